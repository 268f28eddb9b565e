"""One synthetic frame's arrays: :func:`render_scene` ray-casts, shades, adds image noise and
encodes the disparity.
"""
from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from synthcompose.geometry.depth import depth_to_disparity
from synthcompose.labels import label_id

from .photo import NOISE_SHARE, PHOTO_MODES, camera_look
from .raycast import (
    PID_EGO,
    PID_FIRST_OBJECT,
    PID_KERB,
    PID_ROAD,
    PID_SIDEWALK,
    PID_SKY,
    Buffers,
    cast_box,
    cast_ground,
    cast_pole,
    ego_mask,
    street_rays,
)
from .scene import StreetScene
from .shading import shade
from .stereo import STEREO_MODES, sgm_disparity

#: fraction of valid pixels whose disparity is set to 0 (stereo holes, ``stereo="exact"``)
HOLE_FRACTION = 0.02

_ROAD, _SIDEWALK, _SKY, _EGO = (label_id(n) for n in ("road", "sidewalk", "sky", "ego vehicle"))
_POLE = label_id("pole")


def render_scene(scene: StreetScene, stereo: str = "realistic", photo: str = "realistic",
                 right: bool = False) -> dict[str, np.ndarray]:
    """Ray-cast a scene. Returns (H, W from ``scene.camera``):

    rgb          : (H, W, 3) uint8 sRGB, shaded with image noise. ``photo="realistic"``
                   (default): as Cityscapes' camera records it (dark, a wide range between
                   street and sky, greenish, little noise; see :mod:`.camera`); ``"clean"``:
                   the shading as it is, with more noise
    label_ids    : (H, W) uint8 Cityscapes label ids
    instance_ids : (H, W) uint16, label_id*1000+k for cars/persons, plain label id elsewhere
    depth        : (H, W) float32 exact optical-frame depth in metres; inf on sky and ego vehicle
                   (the stereo holes of ``disparity`` keep their true depth here)
    disparity    : (H, W) uint16 Cityscapes disparity. ``stereo="realistic"`` (default): as
                   semi-global matching measures it (noise, fattening, holes; see
                   :mod:`.stereo`); ``"exact"``: the encoding of ``depth``, 0 on sky, ego
                   and ~2 % random holes
    right_rgb    : with ``right``: (H, W, 3) uint8, the scene seen by the right camera of the
                   pair (``Camera.right_camera``), shaded and recorded as the left photo (the
                   same clouds and camera look; its own image noise)
    The labels and depth are the same bytes in every mode; the photo does not depend on
    ``stereo``, the exact disparity not on ``photo``, the left arrays not on ``right``.
    """
    arrays = _render(scene, stereo=stereo, photo=photo)
    if right:
        view = replace(scene, camera=scene.camera.right_camera())
        buf, ego = _cast(view)
        # the same draws for the clouds as the left photo, then noise of its own sensor
        arrays["right_rgb"] = _photo(view, buf, ego, np.random.default_rng(scene.noise_seed), None, photo,
                                     np.random.default_rng([scene.noise_seed, 1]))
    return arrays


def _render(scene: StreetScene, sunlit: np.ndarray | None = None, stereo: str = "realistic",
            photo: str = "realistic") -> dict[str, np.ndarray]:
    if stereo not in STEREO_MODES:
        raise ValueError(f"stereo must be one of {STEREO_MODES}, not {stereo!r}")
    if photo not in PHOTO_MODES:
        raise ValueError(f"photo must be one of {PHOTO_MODES}, not {photo!r}")
    cam = scene.camera
    h, w = cam.height, cam.width
    buf, ego = _cast(scene)

    # labels and instances through per-primitive lookup tables
    n_obj = len(scene.boxes) + len(scene.poles)
    lut_label = np.zeros(PID_FIRST_OBJECT + n_obj + 2, np.uint8)
    lut_inst = np.zeros(len(lut_label), np.uint16)
    base = {PID_EGO: _EGO, PID_SKY: _SKY, PID_ROAD: _ROAD, PID_SIDEWALK: _SIDEWALK, PID_KERB: _SIDEWALK}
    for p, lid in base.items():
        lut_label[p], lut_inst[p] = lid, lid  # negative ids index from the end
    for i, box in enumerate(scene.boxes):
        lut_label[PID_FIRST_OBJECT + i] = label_id(box.label)
        lut_inst[PID_FIRST_OBJECT + i] = box.instance_id
    for j in range(len(scene.poles)):
        lut_label[PID_FIRST_OBJECT + len(scene.boxes) + j] = _POLE
        lut_inst[PID_FIRST_OBJECT + len(scene.boxes) + j] = _POLE
    label_ids = lut_label[buf.pid]
    instance_ids = lut_inst[buf.pid]

    rng = np.random.default_rng(scene.noise_seed)
    rgb8 = _photo(scene, buf, ego, rng, sunlit, photo)

    depth = buf.depth
    if stereo == "exact":
        disparity = depth_to_disparity(depth, cam)
        disparity[rng.random((h, w), dtype=np.float32) < HOLE_FRACTION] = 0
    else:
        disparity = sgm_disparity(depth, rgb8, label_ids, cam, scene.noise_seed)
    return {"rgb": rgb8, "label_ids": label_ids, "instance_ids": instance_ids,
            "depth": depth, "disparity": disparity}


def _cast(scene: StreetScene) -> tuple[Buffers, np.ndarray]:
    """The z-buffer of one ray per pixel centre of ``scene.camera``, and the bonnet's mask."""
    cam = scene.camera
    h, w = cam.height, cam.width
    origin, dirs = street_rays(scene)
    v_from_t = None if scene.street_is_vehicle_frame else scene.vehicle_from_street
    buf = Buffers(origin=origin, d=dirs,
                  depth=np.full((h, w), np.inf, np.float32), pid=np.full((h, w), PID_SKY, np.int16),
                  face=np.zeros((h, w), np.int8))
    cast_ground(scene, buf)
    for i, box in enumerate(scene.boxes):
        cast_box(box, PID_FIRST_OBJECT + i, buf, cam, v_from_t)
    for j, pole in enumerate(scene.poles):
        cast_pole(pole, PID_FIRST_OBJECT + len(scene.boxes) + j, buf, cam, v_from_t)
    ego = ego_mask(h, w, scene.ego_rows)
    buf.depth[ego] = np.inf
    buf.pid[ego] = PID_EGO
    return buf, ego


def _photo(scene: StreetScene, buf: Buffers, ego: np.ndarray, rng: np.random.Generator, sunlit: np.ndarray | None,
           photo: str, noise_rng: np.random.Generator | None = None) -> np.ndarray:
    """(H, W, 3) uint8: the z-buffer shaded (``rng``'s draws: the clouds), recorded as the
    camera would (``photo``), blurred, with image noise drawn from ``noise_rng`` (default ``rng``)."""
    h, w = buf.depth.shape
    rgb = shade(scene, buf, ego, rng, sunlit)
    if photo == "realistic":
        rgb = camera_look(rgb, scene.noise_seed)
    sigma = 0.45 * w / 2048 + 0.15
    rgb = cv2.GaussianBlur(rgb, (0, 0), sigma)
    gain = np.float32(NOISE_SHARE if photo == "realistic" else 1.0)
    noise_rng = rng if noise_rng is None else noise_rng
    rgb += noise_rng.standard_normal((h, w, 3), dtype=np.float32) * (np.float32(1.6) * gain)
    rgb += noise_rng.standard_normal((h, w, 1), dtype=np.float32) * (np.float32(1.4) * gain)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def render_scene_sunlit(scene: StreetScene, stereo: str = "realistic",
                        photo: str = "realistic") -> tuple[dict[str, np.ndarray], np.ndarray]:
    """:func:`render_scene`'s arrays (the same bytes) and the ground truth of the sun: (H, W)
    bool, True where the scene light's sun reaches the surface seen (facing it, no box or pole
    in the way); all False without a sun (no :class:`SceneLight`, or ``sun_fraction`` 0)."""
    cam = scene.camera
    sunlit = np.zeros(cam.height * cam.width, bool)
    arrays = _render(scene, sunlit, stereo, photo)
    if scene.light is None or scene.light.sun_fraction <= 0.0:
        sunlit[:] = False
    return arrays, sunlit.reshape(cam.height, cam.width)

