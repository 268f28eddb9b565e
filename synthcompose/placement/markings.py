"""Road markings in the photo, put on the road plane: lane lines and zebra crossings.

A lane line is a bright thin stripe on the road (0.12-0.25 m wide, white): along an image row
(a cut across the road at one depth) its pixels are brighter than the road a quarter metre to
both sides. The probe is in metres on the ground, so it is ``MARK_PROBE * fx / z`` pixels at
depth ``z`` (from the disparity: the road plane, whatever its slope). A zebra crossing is a
row of wide stripes (0.5 m, 0.5 m apart) along the road: bright against the road half a
metre to both sides, and bright a fifth of a metre to both sides too (wider than a line).

The marking pixels are put on the ground plan (vehicle frame V, metres) through the depth;
``street.py`` finds the lines among them. Everything is done at half resolution on the road's
pixels, once per frame (cached).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .rules import label_mask

#: a line's pixel is brighter than the road this far (metres, on the ground) to both sides
MARK_PROBE = 0.25
#: a zebra stripe's pixel: brighter than the road this far to both sides, and not thinner
#: than a line (bright at ZEBRA_INNER to both sides)
ZEBRA_PROBE, ZEBRA_INNER = 0.5, 0.15
#: a zebra stripe is this many times brighter than three quarters of the road
ZEBRA_BRIGHT = 1.5
#: brighter by at least this many grey levels and this share of the road's grey
MIN_CONTRAST, MIN_RATIO = 8.0, 0.25
#: the road's surfaces markings are painted on
MARKED = ("road", "parking")


@dataclass(frozen=True)
class Markings:
    """Marking pixels of one frame on the ground plan (V, metres): ``lines`` (N, 2) of lane
    lines, ``zebra`` (M, 2) of zebra stripes."""

    lines: np.ndarray
    zebra: np.ndarray


def find_markings(frame: Frame) -> Markings:
    """The frame's markings (cached on the frame); none without a photo."""
    key = ("markings",)
    return frame.derived(key, lambda: _find(frame))


def _find(frame: Frame) -> Markings:
    empty = Markings(np.empty((0, 2)), np.empty((0, 2)))
    if frame.photo is None:
        return empty
    grey = cv2.cvtColor(np.ascontiguousarray(frame.photo[::2, ::2]), cv2.COLOR_RGB2GRAY)
    grey = cv2.GaussianBlur(grey, (3, 3), 0.8).astype(np.float32)
    depth = frame.depth[::2, ::2]
    road = label_mask([label_id(n) for n in MARKED])[frame.label_ids[::2, ::2]] & np.isfinite(depth)
    v, u = np.nonzero(road)
    if not len(v):
        return empty
    h, w = grey.shape
    z = depth[v, u]
    per_m = frame.camera.fx / 2 / z  # half-resolution pixels per metre across the road at that depth

    def probe(metres: float) -> tuple[np.ndarray, np.ndarray]:
        k = np.rint(metres * per_m).astype(np.int32)
        return grey[v, np.clip(u - k, 0, w - 1)], grey[v, np.clip(u + k, 0, w - 1)]

    centre = grey[v, u]
    usable = (MARK_PROBE * per_m >= 1.0) & (ZEBRA_PROBE * per_m < w / 8)
    left, right = probe(MARK_PROBE)
    side = np.maximum(left, right)
    line = usable & (centre - side > np.maximum(MIN_CONTRAST, MIN_RATIO * side))
    left, right = probe(ZEBRA_PROBE)
    side = np.maximum(left, right)
    wide = usable & ~line & (centre - side > np.maximum(MIN_CONTRAST, MIN_RATIO * side))
    left, right = probe(ZEBRA_INNER)
    wide &= np.minimum(left, right) - side > np.maximum(MIN_CONTRAST, MIN_RATIO * side)
    # paint, not a sunlit gap between shadows: far brighter than most of the road
    wide &= centre >= ZEBRA_BRIGHT * np.percentile(centre, 75)
    return Markings(ground_(frame, v[line] * 2, u[line] * 2), ground_(frame, v[wide] * 2, u[wide] * 2))


def ground_(frame: Frame, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(N, 2) ground-plan points (V) of full-resolution pixels."""
    if not len(v):
        return np.empty((0, 2))
    cam = frame.camera
    z = frame.depth[v, u].astype(np.float64)
    optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
    m = cam.vehicle_from_optical
    return (optical @ m[:3, :3].T + m[:3, 3])[:, :2]
