"""The local ground: a robust plane through the real ground points around a spot, in metres.

The fit works on a metric neighbourhood (a square of the ground plan around the spot, found
through the pixel grid), never on pixel-to-pixel differences: real stereo is too noisy for
per-pixel normals (at 7-40 m only half of the road's 2-px normals are within 24 degrees of up),
but a plane through a few hundred points of a few square metres is steady. Its tolerances are
the larger of a fixed value and the stereo noise band at the spot's depth (noise.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.geometry.depth import Frame

from .rules import INLIER_BAND, label_mask


@dataclass(frozen=True)
class GroundFit:
    """The robust plane z = a x + b y + c of the allowed ground around a point (V, metres)."""

    coef: tuple[float, float, float]
    rms: float
    normal: np.ndarray  # (3,) unit, z > 0
    points: int = 0  # ground points the fit saw
    inliers: int = 0  # of those, within the inlier band of the plane

    def height(self, x, y):
        a, b, c = self.coef
        return a * x + b * y + c


def _plane(p: np.ndarray) -> np.ndarray | None:
    """Least-squares z = a x + b y + c through (N, 3) points, by the 3x3 normal equations about
    the points' mean (well conditioned, and far cheaper than a general solver); None when the
    points are collinear."""
    mean = p.mean(axis=0)
    q = p - mean
    xx, xy, yy = (q[:, 0] * q[:, 0]).sum(), (q[:, 0] * q[:, 1]).sum(), (q[:, 1] * q[:, 1]).sum()
    xz, yz = (q[:, 0] * q[:, 2]).sum(), (q[:, 1] * q[:, 2]).sum()
    det = xx * yy - xy * xy
    if det <= 1e-12 * max(xx * yy, 1e-12):
        return None
    a = (xz * yy - yz * xy) / det
    b = (yz * xx - xz * xy) / det
    return np.array([a, b, mean[2] - a * mean[0] - b * mean[1]])


def fit_ground(points: np.ndarray, centre: np.ndarray | None = None, iterations: int = 4,
               band: float = 0.08, inlier_band: float = INLIER_BAND) -> tuple[np.ndarray, float, int] | None:
    """Robust plane z = a x + b y + c through (N, 3) points (metres, V).

    Starts from a level plane at the median height of the points nearest ``centre`` (so a
    kerb face or a lower road next to a sidewalk cannot pull the plane), keeps the points
    within ``band`` of it, then alternates least squares and trimming at 3 robust sigmas.
    Returns ((a, b, c), rms of the kept points in metres, count of points within
    ``inlier_band`` of the plane), or None if too few points.
    """
    if len(points) < 3:
        return None
    if centre is None:
        centre = np.median(points, axis=0)
    d2 = (points[:, 0] - centre[0]) ** 2 + (points[:, 1] - centre[1]) ** 2
    nearest = np.argpartition(d2, min(len(d2) - 1, max(10, len(points) // 5)))[: max(10, len(points) // 5)]
    coef = np.array([0.0, 0.0, float(np.median(points[nearest, 2]))])
    keep = np.abs(points[:, 2] - coef[2]) < band
    floor = max(0.02, inlier_band / 2)
    for _ in range(iterations):
        p = points[keep]
        if len(p) < 3:
            return None
        coef = _plane(p)
        if coef is None:
            return None
        res = points[:, 2] - (points[:, 0] * coef[0] + points[:, 1] * coef[1] + coef[2])
        mad = np.median(np.abs(res[keep]))
        keep = np.abs(res) < max(3.0 * 1.4826 * mad, floor)
    p = points[keep]
    if len(p) < 3:
        return None
    res = p[:, 2] - (p[:, 0] * coef[0] + p[:, 1] * coef[1] + coef[2])
    all_res = points[:, 2] - (points[:, 0] * coef[0] + points[:, 1] * coef[1] + coef[2])
    return coef, float(np.sqrt(np.mean(res ** 2))), int((np.abs(all_res) <= inlier_band).sum())


def ground_points(frame: Frame, point: np.ndarray, reach: float, allowed_ids=None, dz: float = 0.3,
                  max_points: int = 4000) -> np.ndarray:
    """(N, 3) real points (V) of ``allowed_ids`` labels (all labels when None) whose ground-plan
    position is within the square of half-side ``reach`` around ``point``, found through the
    pixel grid (the square, ``dz`` above and below ``point``, projected). Near the camera such
    a square covers a hundred thousand pixels: an even subsample of ``max_points`` is kept,
    the same each time for the same spot."""
    square = point + np.array([[sx * reach, sy * reach, d] for sx in (-1, 1) for sy in (-1, 1)
                               for d in (-dz, dz)])
    rect = frame.box_rect(square)
    if rect is None:
        return np.empty((0, 3))
    only = None if allowed_ids is None or not len(allowed_ids) else label_mask(allowed_ids)
    r0, r1, c0, c1 = rect
    area = max(1, (min(r1, frame.shape[0]) - max(r0, 0)) * (min(c1, frame.shape[1]) - max(c0, 0)))
    stride = max(1, int(math.sqrt(area / (2.5 * max_points))))
    pts, _ = frame.rect_points(r0, r1, c0, c1, only=only, stride=stride)
    sel = (np.abs(pts[:, 0] - point[0]) <= reach) & (np.abs(pts[:, 1] - point[1]) <= reach)
    return pts[sel]


def local_ground(frame: Frame, point: np.ndarray, reach: float, allowed_ids, noise, dz: float = 0.3,
                 ) -> GroundFit | None:
    """The robust plane of the allowed ground around ``point``; None when it has under 3 points.
    Bands follow the stereo noise (``noise``, a StereoNoise) at the spot's depth."""
    pts = ground_points(frame, point, reach, allowed_ids, dz)
    if len(pts) < 3:
        return GroundFit((0.0, 0.0, float(point[2])), float("inf"), np.array([0.0, 0.0, 1.0]), len(pts), 0) \
            if len(pts) else None
    z = float(frame.to_optical(point[None])[0, 2])
    inlier_band = float(noise.height_band(z, INLIER_BAND))
    fit = fit_ground(pts, point, band=max(0.08, 2 * inlier_band), inlier_band=inlier_band)
    if fit is None:
        return None
    (a, b, c), rms, inliers = fit
    normal = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
    return GroundFit((float(a), float(b), float(c)), rms, normal, len(pts), inliers)
