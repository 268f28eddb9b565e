"""Stages 4-5 for the right view: the objects shaded for the left photo, with the same light,
ground planes, real shadows, camera tones, blur and noise level, rendered from the right camera
of the stereo pair and composed into the right photo (:func:`shade_right`). The real scene in
front of them is the left view's, carried to the right camera (:mod:`synthcompose.geometry.right_view`),
so that the pair stays a stereo pair: an object's pixels lie ``fx * baseline / z`` apart in the
two photos, the disparity the left view writes for them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from synthcompose.compose import FRONT_LABELS, Composer, SceneLayers
from synthcompose.geometry.right_view import carry_to_right
from synthcompose.labels import labels_in
from synthcompose.lighting import CameraMatch
from synthcompose.lighting.light import Lighting
from synthcompose.render import Renderer, RenderObject
from synthcompose.render.values import roi_for

from .prepare import Prepared


def right_noise_seed(seed: int) -> int:
    """The right camera's noise seed, from the left one's: its own sensor, the same level."""
    return int(np.random.SeedSequence([int(seed), 1]).generate_state(1, np.uint64)[0] >> 1)


@dataclass(frozen=True, eq=False)
class LeftShading:
    """How the left view shaded its objects; the right view shades them the same way."""

    objects: Sequence[RenderObject]
    lighting: Lighting
    sun_mask: np.ndarray | None  # where the sun reaches the real ground
    scene: SceneLayers  # the left frame's layers
    classes: Sequence[int]  # label id of each object
    instances: Sequence[int]  # instance id of each object
    match: CameraMatch | None  # the camera's blur and noise
    tones: Sequence[tuple[float, float]] | None  # (gain, saturation) of each object


def shade_right(renderer: Renderer, composer: Composer, prep: Prepared, left_shading: LeftShading) -> np.ndarray:
    """(H, W, 3) uint8: the right photo with the left view's objects in it (shaded as the left
    view shaded them); unchanged where nothing of them is in the right camera's view."""
    objects, lighting, sun_mask, scene = (left_shading.objects, left_shading.lighting, left_shading.sun_mask,
                                          left_shading.scene)
    classes, instances, match, tones = (left_shading.classes, left_shading.instances, left_shading.match,
                                        left_shading.tones)
    photo = prep.image_set.right_rgb
    left = prep.image_set.camera
    cam = left.right_camera()
    roi = roi_for(cam, objects, lighting)
    if roi is None:
        return photo
    rows, cols = roi.slices
    # the colour-only compose reads the labels (what is in front), not the instance ids or disparity
    layers = {"label_ids": scene.label_ids}
    if scene.ground is not None:
        layers["ground"] = scene.ground
    if sun_mask is not None:
        layers["sun"] = np.asarray(sun_mask, np.float32)
    carried = carry_to_right(scene.depth, left, rows, cols, layers, keep=labels_in(scene.label_ids, FRONT_LABELS))
    passes = renderer.render(cam, objects, lighting, photo=photo, roi=roi, sun_mask=carried.get("sun"),
                             eye=(left, prep.image_set.rgb), scene_depth=carried["depth"])
    if passes is None:
        return photo
    try:
        unread = np.broadcast_to(np.uint16(0), carried["label_ids"].shape)  # (no memory)
        right = SceneLayers(photo, carried["label_ids"], unread, unread, carried["depth"], scene.disparity_scale,
                            ground=carried.get("ground"), ground_band=scene.ground_band)
        match = None if match is None else replace(match, seed=right_noise_seed(match.seed))
        rgb = photo.copy()  # composed into its region
        composer.compose_roi(passes, right, classes, instances, match, tones, rgb_only=True, into={"rgb": rgb[rows, cols]})
    finally:
        renderer.release(passes)
    return rgb
