"""The look of inserted objects (issue: light, tone, shadow and contact that match each frame), on
generated scenes that measure like real frames (SGM-like disparity, the camera's look): soft
shadows on noisy depth, objects standing on the ground, appearance drawn per object and
recorded, the camera's tone taken from the frame's own objects, the side-by-side view."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.colour import linear_to_srgb
from synthcompose.geometry.depth import disparity_to_depth
from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.io.files import decode_rle
from synthcompose.lighting.camera_match import CameraMatch, ToneReference, estimate_blur, estimate_noise, object_tones
from synthcompose.look import measures as look
from synthcompose.look.appearance import CLOTHES, PAINTS, appearance_rng, draw_appearance, palette_rank, recolourable
from synthcompose.models import load_model
from synthcompose.synthetic import make_sample

from ..tolerances import (
    CONTACT_DEPTH_REL,
    PALETTE_SUM_ABS,
    ROAD_TONE_8BIT,
    SAMPLED_BLUR_PX,
    SAMPLED_NOISE_REL,
    SHADOW_BLOTCHINESS_MAX,
    SHADOW_BLOTCHINESS_MEDIAN,
    TONE_8BIT,
)

ASSETS = Path(__file__).resolve().parents[2] / "assets" / "models"
CAR = str(ASSETS / "openmaterial_car" / "vehicle_example.gltf")
PERSON = str(ASSETS / "openmaterial_human" / "human_example.gltf")
W, H = 2048, 1024  # the measures are in pixels: at the real frames' size
GROUND = (6, 7, 8, 9, 10, 22)


def car_model():
    return load_model(CAR, (("length", 4.4),), "+y", "+x")


# ------------------------------------------------------------------ appearance
def test_palettes_are_distributions_led_by_the_common_paints():
    for palette in (PAINTS, CLOTHES):
        assert sum(p[1] for p in palette) == pytest.approx(1.0, abs=PALETTE_SUM_ABS)
    shares = {name: share for name, share, _ in PAINTS}
    assert shares["white"] + shares["grey"] + shares["black"] + shares["silver"] >= 0.7
    assert palette_rank(PAINTS, "white")[0] > palette_rank(PAINTS, "grey")[0] > palette_rank(PAINTS, "black")[0]
    assert palette_rank(PAINTS, "red")[1] > palette_rank(PAINTS, "grey")[1]


def test_the_car_paint_and_the_clothes_are_found_and_the_models_plate_text_is_not_drawn():
    car = car_model()
    paint = recolourable(car, "car")
    assert len(paint) == 1 and paint[0][0] > 5 * max(paint[0][1], paint[0][2])  # the red body paint
    assert all(p.texture is None for p in car.parts)  # the "OpenMaterial" plate texture is gone (test_plates.py)
    person = load_model(PERSON, (("height", 1.75),), "+y", "+x")
    clothes = recolourable(person, "person")
    assert 2 <= len(clothes) <= 3
    assert recolourable(car, "traffic sign") == []


def test_appearance_draws_are_seeded_and_vary():
    car = car_model()
    first = [draw_appearance(car, "car", appearance_rng(7, "train/x/x_000000_000000", k)) for k in range(40)]
    again = [draw_appearance(car, "car", appearance_rng(7, "train/x/x_000000_000000", k)) for k in range(40)]
    assert first == again
    names = [a.names[0] for a in first]
    assert len(set(names)) >= 4 and names.count("white") + names.count("grey") + names.count("black") >= 15
    assert {"paint", "albedo_linear", "rank"} <= set(first[0].to_dict())


# ------------------------------------------------------------------ the camera's tone
def test_object_tones_reach_their_rank_among_the_frames_objects():
    rng = np.random.default_rng(0)
    # a rendered object: bright, saturated linear colours (what the renderer gives a red car)
    objc = np.zeros((60, 80, 4), np.float32)
    objc[10:50, 10:70, :3] = np.array([0.5, 0.05, 0.04]) * rng.uniform(0.6, 1.2, (40, 60, 1))
    objc[10:50, 10:70, 3] = 1.0
    ids = (objc[..., 3] > 0).astype(np.uint32)
    ref = ToneReference({26: np.column_stack([rng.uniform(40, 80, 9), rng.uniform(30, 55, 9)])})
    (t,) = object_tones(objc, ids, [26], [(0.5, 0.5)], ref)
    assert t["reference"] == "class x9"
    # the tone the compose shader gives it (gain on the saturation-scaled colour)
    c = objc[ids == 1][:, :3].astype(np.float64)
    y = c @ np.array([0.2126, 0.7152, 0.0722])
    toned = t["gain"] * np.maximum(y[:, None] + t["saturation"] * (c - y[:, None]), 0)
    srgb = np.clip(linear_to_srgb(np.clip(toned, 0, 1)), 0, 1)
    v, s = 255 * srgb.max(1), 255 * (srgb.max(1) - srgb.min(1)) / np.maximum(srgb.max(1), 1e-9)
    assert np.median(v) == pytest.approx(np.quantile(ref.tones[26][:, 0], 0.5), abs=TONE_8BIT)
    assert np.median(s) == pytest.approx(np.quantile(ref.tones[26][:, 1], 0.5), abs=TONE_8BIT)
    # no references: the photo's exposure only
    (none,) = object_tones(objc, ids, [26], [(0.5, 0.5)], ToneReference({}), fallback_gain=0.6)
    assert none == {"gain": 0.6, "saturation": 1.0, "reference": "none"}


# ------------------------------------------------------------------ on generated frames
@pytest.fixture(scope="module")
def composed(tmp_path_factory):
    """Two generated image sets (realistic stereo and photo), cars and people inserted."""
    work = tmp_path_factory.mktemp("look")
    root = work / "cityscapes"
    make_sample(root, count=2, width=W, height=H, seed=3)
    manifest = {
        "dataset": str(root), "output": str(work / "out"), "seed": 4, "objects_per_image": 3,
        "objects": [
            {"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}, "weight": 3},
            {"name": "person", "model": PERSON, "class": "person", "size": {"height": 1.75}},
        ],
        "lighting": {"mode": "estimate"},
        # within 30 m: beyond, a car's shadow band at its foot is a few rows, thinner than the
        # measures' smoothing (blotchiness, contact), as a person's always is (below)
        "placement": {"distance": [7, 30]},
    }
    (work / "m.json").write_text(json.dumps(manifest))
    assert main(["batch", str(work / "m.json"), "--no-progress"]) == 0
    return root, work / "out"


def _objects(root: Path, out: Path):
    for ident in find_image_sets(out):
        rec = json.loads(ident.path(out, "record").read_text())
        if rec.get("status") != "done":
            continue
        src, res = read_image_set(root, ident), read_image_set(out, ident)
        masks = []
        for obj in rec["objects"]:
            rle = obj["mask_rle"]
            masks.append((obj, decode_rle(rle)))
        yield src, res, rec, masks


@pytest.mark.slow
def test_shadows_are_soft_and_objects_stand_on_the_ground(composed):
    root, out = composed
    blots, contacts, n = [], [], 0
    for src, res, _, masks in _objects(root, out):
        objects = np.zeros(src.label_ids.shape, bool)
        for _, m in masks:
            objects |= m
        depth = disparity_to_depth(src.disparity, src.camera)
        out_depth = look.decode_depth(res.disparity, src.camera.fx * src.camera.baseline)
        for obj, m in masks:
            n += 1
            b = look.shadow_blotchiness(src.rgb, res.rgb, m, objects)
            if b is not None and obj["class"] == "car":  # a person's shadow is a streak 2-3 px tall
                blots.append(b)  # at 20 m: thinner than the measure's 4 px smoothing, it reads blotchy
            c = look.contact_error(depth, out_depth, m, np.isin(src.label_ids, GROUND) & ~objects)
            if c is not None:
                contacts.append(abs(c))
    assert n >= 4 and len(blots) >= 3 and len(contacts) >= 3
    # a shadow, not the depth's noise
    assert np.median(blots) <= SHADOW_BLOTCHINESS_MEDIAN and max(blots) <= SHADOW_BLOTCHINESS_MAX, blots
    assert max(contacts) <= CONTACT_DEPTH_REL, contacts  # the lowest points on the real ground


def test_the_record_holds_the_appearance_the_camera_look_and_the_light_evidence(composed):
    root, out = composed
    paints = []
    for _, _, rec, _ in _objects(root, out):
        assert rec["lighting"]["evidence"] and not rec["lighting"]["fallback"]
        for obj in rec["objects"]:
            assert set(obj["appearance"]) >= {"albedo_linear", "rank"}
            assert obj["camera_look"]["gain"] > 0
            paints.append(obj["appearance"].get("paint") or tuple(obj["appearance"]["clothes"]))
    assert len(paints) >= 4


def test_side_by_side_view(composed):
    root, out = composed
    src, res, _, masks = next(_objects(root, out))
    obj, m = masks[0]
    panel = look.side_by_side(src.rgb, res.rgb, m, src.instance_ids, obj["label_id"], height=128)
    assert panel.dtype == np.uint8 and panel.shape[0] == 128 + 22 and panel.shape[2] == 3


def test_the_camera_look_measured_on_a_sample_agrees_with_the_whole_frame(composed):
    # noise and blur on a quarter of the frame's tiles, the road's tone on every other row and
    # column, the real objects' tones within their boxes: as measured over the whole frame
    root, _ = composed
    for ident in find_image_sets(root):
        src = read_image_set(root, ident)
        match = CameraMatch.measure(src.rgb)
        whole = estimate_noise(src.rgb)
        assert np.all(np.abs(np.asarray(match.noise_sigma) / whole - 1) <= SAMPLED_NOISE_REL), (match, whole)
        assert abs(match.blur_sigma - estimate_blur(src.rgb)) <= SAMPLED_BLUR_PX
        ref = ToneReference.measure(src.rgb, src.instance_ids, src.label_ids)
        hsv = cv2.cvtColor(src.rgb[src.label_ids == 7][None], cv2.COLOR_RGB2HSV_FULL)[0]
        assert ref.road is not None
        assert abs(ref.road[0] - np.median(hsv[:, 2])) <= ROAD_TONE_8BIT
        assert abs(ref.road[1] - np.median(hsv[:, 1])) <= ROAD_TONE_8BIT
        tones = look.instance_tones(src.rgb, src.instance_ids, None, 50, fallback=False)
        ids = [i for i in np.unique(src.instance_ids) if i >= 1000 and (src.instance_ids == i).sum() >= 50]
        assert tones and len(tones) <= len(ids)
        for inst in ids:
            t = look.tone(src.rgb, src.instance_ids == inst, fallback=False)
            assert tones.get(int(inst)) == t
