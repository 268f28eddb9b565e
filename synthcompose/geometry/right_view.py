"""Stage 2 for the right view - the left frame's layers carried to the right camera of the pair.

A left pixel (u, v) at depth z is seen by the right camera at (u - fx*B/z, v) (rectified pair,
``Camera.right_camera``); at infinite depth it stays where it is. To hide an inserted object
behind the real scene in the right photo as in the left one, the compose stage needs, in the
right view, the real scene's depth, labels, ground and sun. They are carried from the left view:

* each left pixel goes to its nearest right column; where several land on one pixel the nearest
  surface (largest disparity) wins, as a camera sees it;
* a right pixel that no left pixel reaches (background the left camera does not see, right of
  a near object; a surface stretched between two columns) takes the layers of the farther of its
  nearest reached neighbours along the row: the background, the same conservative rule as the
  left view's own holes (:func:`synthcompose.geometry.depth.occluder_depth`);
* labels that belong to the image and not to the scene (our own car, the rectification border:
  ``compose.FRONT_LABELS``) stay where they are in the left image.

The depth carried is the one the left compose tests against (its holes already filled), so that
the same real surface hides the same part of an object in both views.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from synthcompose.camera import Camera

from .depth import nearest_in_row

#: disparity fixed-point steps per pixel in the nearest-surface test
_STEPS = 256
#: rows carried at once: the carry's index arrays take about 90 bytes a pixel of a block of rows
#: (a near car's right region of 2048 x 800 pixels at once: 150 MB; 64 rows: 12 MB)
ROWS_AT_ONCE = 64


def carry_to_right(depth: np.ndarray, camera: Camera, rows: slice, cols: slice,
                   layers: Mapping[str, np.ndarray], keep: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The left view's ``depth`` (H, W float32, inf where unknown) and ``layers`` (each (H, W),
    any dtype) as the right camera sees them, inside the right image's ``rows`` x ``cols``
    (step 1); returns full-frame arrays (``depth`` included) that are filled there only (depth
    inf, layers 0 elsewhere). ``keep`` (H, W) bool: left pixels whose layers stay in place in
    the right view (labels of the image, not of the scene). Each row is carried on its own (a
    pair's rows are its epipolar lines): :data:`ROWS_AT_ONCE` rows at a time."""
    H, W = depth.shape
    r0, r1 = rows.indices(H)[:2]
    c0, c1 = cols.indices(W)[:2]
    out = {"depth": np.full((H, W), np.inf, np.float32)} | {k: np.zeros((H, W), v.dtype) for k, v in layers.items()}
    if r1 <= r0 or c1 <= c0:
        return out
    for a in range(r0, r1, ROWS_AT_ONCE):
        _carry_rows(depth, camera, slice(a, min(a + ROWS_AT_ONCE, r1)), c0, c1, layers, keep, out)
    return out


def _carry_rows(depth: np.ndarray, camera: Camera, rows: slice, c0: int, c1: int, layers: Mapping[str, np.ndarray],
                keep: np.ndarray | None, out: dict[str, np.ndarray]) -> None:
    """:func:`carry_to_right` for the right image's ``rows`` x [c0, c1), into ``out``."""
    src = depth[rows, c0:]  # disparity >= 0: a right pixel is seen by a left one at or right of it
    h, w = src.shape
    cw = c1 - c0
    # disparity, 0 at infinite depth; the right column within the block
    d = np.where(np.isfinite(src) & (src > 0), camera.fx * camera.baseline / np.maximum(src, 1e-6), 0.0)
    target = np.rint(np.arange(w, dtype=np.float64)[None, :] - d).astype(np.int64)
    at = np.flatnonzero((target >= 0) & (target < cw))  # the source pixels (flat) that land in the block
    # nearest surface wins: the largest disparity, then the source's flat index (within a row:
    # its column)
    key = (np.rint(d.ravel()[at] * _STEPS).astype(np.int64) << 32) | at
    del d
    best = np.full(h * cw, -1, np.int64)
    np.maximum.at(best, at // w * cw + target.ravel()[at], key)
    del target, at, key
    best = best.reshape(h, cw)
    reached = best >= 0
    source = best & 0xFFFFFFFF  # the source's flat index (unreached: 0)
    source[~reached] = 0
    del best
    # unreached pixels: the farther of the nearest reached ones along the row
    left, right = nearest_in_row(reached)
    rows_ = np.arange(h)[:, None]
    src_depth = src.ravel()
    zl = np.where(left >= 0, src_depth[source[rows_, np.maximum(left, 0)]], -np.inf)
    zr = np.where(right < cw, src_depth[source[rows_, np.minimum(right, cw - 1)]], -np.inf)
    take = np.where(zl >= zr, np.maximum(left, 0), np.minimum(right, cw - 1))
    neither = (left < 0) & (right >= cw)
    filled = np.where(reached, source, source[rows_, take])
    out["depth"][rows, c0:c1] = np.where(neither, np.inf, src_depth[filled])
    stay = None if keep is None else keep[rows, c0:c1]
    for name, layer in layers.items():
        block = layer[rows, c0:].ravel()[filled]
        if stay is not None:
            block = np.where(stay, layer[rows, c0:c1], block)
        out[name][rows, c0:c1] = np.where(neither, 0, block)
