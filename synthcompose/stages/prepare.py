"""Stages 1-2: read the image set and its geometry -> :class:`Prepared`; and the photo's light
(the light estimate, the camera's blur, noise and tones) -> :class:`PhotoLight`, measured only
for a frame where something was placed (:func:`measure_light`)."""
from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from synthcompose.geometry.depth import Frame, disparity_to_depth
from synthcompose.io.dataset import ImageSet, ImageSetId, read_image_set
from synthcompose.io.files import read_input_bytes
from synthcompose.lighting import CameraMatch, LightEstimate, camera_noise_seed, estimate_lighting
from synthcompose.lighting.camera_match import ToneReference
from synthcompose.lighting.plan import completed_labels
from synthcompose.lighting.solar import SunSite
from synthcompose.placement.surfaces import Surfaces, frame_for

from .options import ReadOptions
from .timing import Timings, timed


def image_set_rng(seed: int, ident: ImageSetId) -> np.random.Generator:
    """Randomness of one image set: a function of (seed, image-set id) only, never of order."""
    return np.random.default_rng([seed, zlib.crc32(ident.key.encode())])


@dataclass(frozen=True, eq=False)
class Prepared:
    """What depends on the photo alone (read, geometry, lighting): made ahead on a thread."""

    ident: ImageSetId
    image_set: ImageSet
    camera_json: bytes
    depth: np.ndarray  # (H, W) float32 metres, inf where unknown
    frame: Frame
    surfaces: Surfaces | None  # unlabelled image sets: the road and sidewalk found (placement/surfaces.py)
    rng: np.random.Generator  # the image set's randomness, after the geometry's draws
    vehicle_json: bytes | None = None  # the vehicle file as read, written with the outputs


@dataclass(frozen=True, eq=False)
class PhotoLight:
    """The photo's light and camera, as the objects are shaded to match them."""

    estimate: LightEstimate | None  # lighting "estimate" mode
    match: CameraMatch | None  # lighting "camera_match"
    reference: ToneReference | None  # with camera_match: the tones of the frame's own objects
    labels: np.ndarray | None = None  # (H, W) the labels the light was measured on: a frame without
    # labels has its found surfaces completed with the level ground and what stands (lighting.plan)


def prepare(o: ReadOptions, ident: ImageSetId, timings: Timings) -> Prepared:
    """What the placement needs: the image set read, its depth and frame."""
    with timed(timings, "read"):
        image_set = read_image_set(o.dataset, ident, right=o.right_view)
        camera_json = read_input_bytes(ident.path(o.dataset, "camera"), 1 << 20)
        vehicle_json = None if image_set.vehicle is None else read_input_bytes(ident.path(o.dataset, "vehicle"), 1 << 20)
    with timed(timings, "geometry"):
        cam = image_set.camera
        depth = disparity_to_depth(image_set.disparity, cam)
        rng = image_set_rng(o.seed, ident)
        # no labels (test split): road and sidewalk found from the disparity and the photo
        frame, surfaces = frame_for(image_set, depth)
    return Prepared(ident, image_set, camera_json, depth, frame, surfaces, rng, vehicle_json)


def measure_light(o: ReadOptions, prep: Prepared, timings: Timings) -> PhotoLight:
    """The photo's own light, and its camera's blur, noise and tones (what the manifest asks for)."""
    image_set, frame = prep.image_set, prep.frame
    with timed(timings, "lighting"):
        estimate = match = reference = labels = None
        if o.estimate_light:
            labels = frame.label_ids if frame.labelled else completed_labels(frame.label_ids, prep.depth,
                                                                              image_set.camera)
            estimate = estimate_lighting(image_set.rgb, frame.label_ids, prep.depth, image_set.camera,
                                         labelled=frame.labelled, completed=labels,
                                         site=SunSite.of(image_set.vehicle))
        if o.camera_match:
            match = CameraMatch.measure(image_set.rgb, camera_noise_seed(o.seed, prep.ident.key))
            reference = ToneReference.measure(image_set.rgb, image_set.instance_ids if image_set.labelled else None,
                                              frame.label_ids)
    return PhotoLight(estimate, match, reference, labels)
