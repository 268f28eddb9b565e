"""Writing synthetic frames in the Cityscapes layout: :func:`write_image_set`, :func:`make_sample`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import write_json, write_png
from synthcompose.labels import KNOWN_IDS, colorize

from .frame import render_scene
from .layout import random_scene
from .light import sunny_light, sunny_vehicle
from .scene import StreetScene
from .streets import STREET_KINDS
from .sunlit import open_to_the_sun

#: the light of the frames :func:`make_sample` writes: the default shading (an overcast day),
#: or a sunny day (:func:`~.light.sunny_light`: a sun with cast shadows and their penumbra)
LIGHTS = ("default", "sunny")


def write_image_set(root: Path, ident: ImageSetId, scene: StreetScene, arrays: dict[str, np.ndarray]) -> None:
    """Write the six Cityscapes files of one rendered frame under ``root``.

    leftImg8bit (RGB), gtFine_labelIds (8-bit), gtFine_instanceIds (16-bit), gtFine_color
    (RGBA), disparity (16-bit) and camera JSON (``scene.camera.to_dict()``); and rightImg8bit
    when ``arrays`` has ``right_rgb``.
    """
    cam = scene.camera
    shape = (cam.height, cam.width)
    expected = {"rgb": (np.uint8, shape + (3,)), "label_ids": (np.uint8, shape),
                "instance_ids": (np.uint16, shape), "disparity": (np.uint16, shape)}
    if "right_rgb" in arrays:
        expected["right_rgb"] = (np.uint8, shape + (3,))
    for key, (dtype, shp) in expected.items():
        arr = arrays[key]
        if arr.dtype != dtype or arr.shape != shp:
            raise ValueError(f"{key} must be {np.dtype(dtype).name} {shp}, found {arr.dtype} {arr.shape}")
    if not KNOWN_IDS[arrays["label_ids"]].all():
        raise ValueError("label_ids holds ids that Cityscapes does not define")
    root = Path(root)
    write_png(ident.path(root, "rgb"), arrays["rgb"])
    if "right_rgb" in arrays:
        write_png(ident.path(root, "right"), arrays["right_rgb"])
    write_png(ident.path(root, "labelIds"), arrays["label_ids"])
    write_png(ident.path(root, "instanceIds"), arrays["instance_ids"])
    write_png(ident.path(root, "color"), colorize(arrays["label_ids"]))
    write_png(ident.path(root, "disparity"), arrays["disparity"])
    write_json(ident.path(root, "camera"), cam.to_dict())


def make_sample(out_root: Path, count: int = 3, width: int = 2048, height: int = 1024, seed: int = 0,
                split: str = "train", city: str = "synthtown", stereo: str = "realistic",
                photo: str = "realistic", right: bool = False, light: str = "default",
                streets: str | None = None) -> list[ImageSetId]:
    """Render and write ``count`` image sets ``<city>_000000_<frame:06d>`` under ``out_root``.

    ``stereo``: ``"realistic"`` writes disparity as semi-global matching measures it,
    ``"exact"`` the exact disparity with 2 % holes; ``photo``: ``"realistic"`` the photo as
    Cityscapes' camera records it, ``"clean"`` the shading as it is (see :func:`render_scene`);
    ``right``: the right view of the stereo pair too (rightImg8bit); ``light``: one of
    :data:`LIGHTS` (a sunny frame's light is drawn from its own generator, ``[seed, i, 1]``: the
    layout is the same as the default's but for a gap in the houses on the sun's side,
    :func:`~.sunlit.open_to_the_sun`, drawn from ``[seed, i, 2]``, and a vehicle file whose
    heading and latitude put the sun where it can stand, :func:`~.light.sunny_vehicle`, from
    ``[seed, i, 3]``). ``streets``: None draws the streets as earlier
    versions; ``"traffic"`` lays frame i out as street kind ``i mod 5`` of
    :data:`.streets.STREET_KINDS` (two-way, one-way, angled and perpendicular bays, a zebra).

    Frame i uses ``np.random.default_rng([seed, i])``: the same arguments give byte-identical
    files, and frames do not depend on ``count``. Returns the ids written, in order.
    """
    if count < 0 or seed < 0:
        raise ValueError("count and seed must be non-negative")
    if light not in LIGHTS:
        raise ValueError(f"light must be one of {', '.join(LIGHTS)}, not {light!r}")
    if streets not in (None, "traffic"):
        raise ValueError(f"streets must be None or 'traffic', not {streets!r}")
    out_root = Path(out_root)
    idents: list[ImageSetId] = []
    for i in range(count):
        sun = sunny_light(np.random.default_rng([seed, i, 1])) if light == "sunny" else None
        kind = None if streets is None else STREET_KINDS[i % len(STREET_KINDS)]
        scene = random_scene(np.random.default_rng([seed, i]), width, height, light=sun, street=kind)
        if sun is not None:  # the sun comes in through a gap in the houses (its own numbers)
            scene = open_to_the_sun(scene, np.random.default_rng([seed, i, 2]))
        ident = ImageSetId(split, city, f"{0:06d}", f"{i:06d}")
        write_image_set(out_root, ident, scene, render_scene(scene, stereo=stereo, photo=photo, right=right))
        if sun is not None:  # where the sun stands as it does: its own numbers
            write_json(ident.path(out_root, "vehicle"), sunny_vehicle(sun, np.random.default_rng([seed, i, 3])))
        idents.append(ident)
    return idents
