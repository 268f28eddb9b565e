"""Number plates: each vehicle's own registration, drawn seeded, imaged like a plate and rendered
on the model's plate parts (synthcompose/look/plates.py, models/mesh.py, render/lit.py)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from synthcompose.look.appearance import appearance_rng, draw_appearance
from synthcompose.look.plates import draw_registration, plate_image
from synthcompose.models import NEUTRAL_PLATE, load_model
from synthcompose.placement import pose_matrix
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera

CAR = str(Path(__file__).resolve().parents[2] / "assets" / "models" / "openmaterial_car" / "vehicle_example.gltf")
REGISTRATION = re.compile(r"^[A-Z]{1,3} [A-Z]{1,2} [1-9][0-9]{0,3}$")


def test_registrations_are_german_style_seeded_and_varied():
    drawn = [draw_registration(np.random.default_rng(k)) for k in range(200)]
    assert drawn == [draw_registration(np.random.default_rng(k)) for k in range(200)]
    for text in drawn:
        assert REGISTRATION.match(text), text
        assert len(text.replace(" ", "")) <= 8, text
    assert len(set(drawn)) >= 195
    # most numbers have three or four digits, as on the road
    assert np.mean([len(t.split()[-1]) >= 3 for t in drawn]) > 0.6


def test_the_plate_image_is_dark_characters_on_white_with_the_blue_band():
    img = plate_image("K AB 1234", (521, 113))  # drawn 110 px high, at the texture's aspect
    assert img.shape == (110, 507, 4) and img.dtype == np.uint8 and (img[..., 3] == 255).all()
    band = img[20:90, 10:40, :3].astype(int)
    assert np.median(band[..., 2]) > 2 * np.median(band[..., 0])  # blue
    text = img[10:100, 60:497, :3].min(axis=2)
    dark, white = (text < 60).mean(), (text > 230).mean()
    assert 0.1 < dark < 0.45 and white > 0.45
    assert not np.array_equal(img, plate_image("K AB 1235", (521, 113)))
    # any texture size: the same height, its aspect within 1 .. 10
    assert plate_image("K AB 1234", (8, 2)).shape == (110, 440, 4)
    assert plate_image("K AB 1234", (4096, 100)).shape == (110, 1100, 4)


def test_the_car_model_has_plate_parts_and_each_car_draws_its_registration():
    car = load_model(CAR, (("length", 4.4),), "+y", "+x")
    plates = [p for p in car.parts if p.plate is not None]
    assert len(plates) == 2  # front and rear
    for p in plates:
        assert p.plate == (521, 113) and p.texture is None  # the file's "OpenMaterial" is never drawn
        assert np.allclose(p.colors[:, :3], NEUTRAL_PLATE[:3])
        assert p.uvs.min() > -0.01 and p.uvs.max() < 1.01 and np.ptp(p.uvs, axis=0).min() > 0.9
    looks = [draw_appearance(car, "car", appearance_rng(3, "train/x/x_000000_000000", k)) for k in range(20)]
    assert all(REGISTRATION.match(a.plate) for a in looks)
    assert len({a.plate for a in looks}) == 20
    assert looks[0].to_dict()["plate"] == looks[0].plate
    # a class without plates, and a model without plate parts, draw none
    assert draw_appearance(car, "person", appearance_rng(3, "x", 0)).plate is None
    assert draw_appearance(load_model("builtin:box", (("length", 2.0),)), "car", appearance_rng(3, "x", 0)).plate is None


def test_the_plate_is_rendered_on_the_car_and_only_there(gl_clean):
    car = load_model(CAR, (("length", 4.4),), "+y", "+x")
    cam = make_camera()
    pose = pose_matrix(np.array([7.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), 0.0)
    renderer = Renderer(gl_clean)
    out = {}
    for text in (None, "K AB 1234", "HH X 99"):
        passes = renderer.render(cam, [RenderObject(car, pose, (0.2, 0.2, 0.2), plate=text)], Lighting.daylight())
        out[text] = passes.read("irpv")[..., :3].copy(), passes.read("id").copy()
        renderer.release(passes)
    blank, ids = out[None]
    plated = out["K AB 1234"][0]
    changed = np.abs(plated - blank).max(axis=2) > 1e-4
    rows, cols = np.nonzero(changed)
    assert len(rows) > 200
    # a plate-shaped patch on the car: wider than high, a small part of the car, darker (the characters)
    assert (ids[changed] == 1).all()
    height, width = np.ptp(rows) + 1, np.ptp(cols) + 1
    assert 3 < width / height < 7 and changed.sum() < 0.1 * (ids == 1).sum()
    assert plated[changed].mean() < blank[changed].mean()
    assert not np.array_equal(plated, out["HH X 99"][0])


def test_the_characters_have_the_standard_plates_proportions():
    """DIN 74069: characters 75 mm high on the 110 mm plate, condensed (a letter about 40 mm of
    ink in its 47.5 mm), one dark shape per character, the zero unslashed: what real German
    plates show (the earlier wide, short font read as a foreign sticker next to real cars)."""
    import cv2

    for text in ("K AB 1234", "HRO WX 2000"):
        img = plate_image(text, (520, 110))[..., :3]
        dark = (img.max(axis=2) < 90).astype(np.uint8)
        dark[:, :60], dark[:4], dark[-4:], dark[:, -4:] = 0, 0, 0, 0  # the band and the rim
        n, _, stats, _ = cv2.connectedComponentsWithStats(dark)
        shapes = stats[1:][stats[1:, 4] > 30]
        assert len(shapes) == len(text.replace(" ", "")), text  # a slashed zero would be two shapes
        heights, widths = shapes[:, 3] / 110, shapes[:, 2] / shapes[:, 3]
        assert np.all(np.abs(heights - 75 / 110) < 0.03), heights
        assert np.all(widths < 0.62) and np.median(widths) > 0.35, widths
