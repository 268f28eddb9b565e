"""Boxes, footprints and visibility: the object's box against the scene and other objects."""
from __future__ import annotations

import math
from typing import Sequence

import cv2
import numpy as np

from synthcompose.geometry.depth import Frame

from .rules import OCCLUSION_TOL_ABS, OCCLUSION_TOL_REL, Placement, PlacementRules, box_corners


def pose_matrix(position: np.ndarray, normal: np.ndarray, yaw: float) -> np.ndarray:
    """(4, 4) V <- O: O's z along the ground normal, O's x along ``yaw`` projected on the ground."""
    n = normal / np.linalg.norm(normal)
    x = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    x = x - x.dot(n) * n
    x /= np.linalg.norm(x)
    y = np.cross(n, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, n, position
    return m


def prefilter(points: np.ndarray, m: np.ndarray, extents, clearance: float, margin: float) -> np.ndarray:
    """The paper's lenient pass over all (N, 3) points: indices of the points inside the
    axis-aligned box that bounds the object's (rotated) box. Never misses a point inside."""
    l, w, h = extents
    r = math.hypot(l / 2 + margin, w / 2 + margin)
    c = m[:3, 3]
    zlo, zhi = c[2] + min(clearance, 0.0) - r * 0.25, c[2] + h + margin + r * 0.25
    sel = (np.abs(points[:, 0] - c[0]) <= r) & (np.abs(points[:, 1] - c[1]) <= r)
    sel &= (points[:, 2] >= zlo) & (points[:, 2] <= zhi)
    return np.flatnonzero(sel)


def strict_inside(points: np.ndarray, m: np.ndarray, extents, clearance: float, margin: float) -> np.ndarray:
    """Strict oriented-box test: bool mask of the (N, 3) points inside the object's box
    (grown by ``margin``, from ``clearance`` above its ground plane to the top)."""
    l, w, h = extents
    local = (points - m[:3, 3]) @ m[:3, :3]
    return ((np.abs(local[:, 0]) <= l / 2 + margin) & (np.abs(local[:, 1]) <= w / 2 + margin)
            & (local[:, 2] >= clearance) & (local[:, 2] <= h + margin))


def penetration(points: np.ndarray, m: np.ndarray, extents, clearance: float) -> float:
    """Deepest penetration of (N, 3) points into the box above ``clearance``: for each point
    inside, its distance to the nearest face; the maximum, metres (0 when none is inside)."""
    l, w, h = extents
    local = (points - m[:3, 3]) @ m[:3, :3]
    depth = np.minimum.reduce([l / 2 - np.abs(local[:, 0]), w / 2 - np.abs(local[:, 1]),
                               local[:, 2] - clearance, h - local[:, 2]])
    return float(max(depth.max(initial=0.0), 0.0))


#: footprint samples along the length and the width: the placement and the checker use the same grid
FOOTPRINT_SAMPLES = (21, 11)


def footprint_grid(l: float, w: float, margin: float = 0.0) -> np.ndarray:
    """(21 * 11, 3) footprint samples in the object frame (z = 0), row-major along the width:
    the footprint's l x w rectangle with ``margin`` metres more on every side. The placement
    asks its support over the footprint and a margin, the checker over the footprint itself."""
    nl, nw = FOOTPRINT_SAMPLES
    gx, gy = np.meshgrid(np.linspace(-l / 2 - margin, l / 2 + margin, nl),
                         np.linspace(-w / 2 - margin, w / 2 + margin, nw))
    return np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])


def footprint_corners(m: np.ndarray, extents, grow: float = 0.0) -> np.ndarray:
    """(4, 2) ground-plan corners of the footprint, each side pushed out by ``grow`` metres."""
    l, w = extents[0] / 2 + grow, extents[1] / 2 + grow
    local = np.array([[l, w, 0], [-l, w, 0], [-l, -w, 0], [l, -w, 0]])
    return (local @ m[:3, :3].T + m[:3, 3])[:, :2]


def footprints_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test of two convex (4, 2) ground footprints."""
    for poly in (a, b):
        for i in range(4):
            edge = poly[(i + 1) % 4] - poly[i]
            axis = np.array([-edge[1], edge[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def rays_hit_box(origin: np.ndarray, targets: np.ndarray, m: np.ndarray, extents) -> np.ndarray:
    """(N,) bool: the segment from ``origin`` to each of (N, 3) ``targets`` (V) passes
    through the object box of pose ``m`` (slab test in the box frame)."""
    l, w, h = extents
    lo, hi = np.array([-l / 2, -w / 2, 0.0]), np.array([l / 2, w / 2, h])
    o = (origin - m[:3, 3]) @ m[:3, :3]
    d = (targets - m[:3, 3]) @ m[:3, :3] - o
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    tmin = np.nanmax(np.minimum(t1, t2), axis=1)
    tmax = np.nanmin(np.maximum(t1, t2), axis=1)
    return (tmax >= np.maximum(tmin, 0.0)) & (tmin <= 1.0)


def box_samples(m: np.ndarray, extents, above: float = 0.0) -> np.ndarray:
    """(N, 3) V points on a grid through the box of pose ``m``: 7 along, 5 across, 6 up (from
    5 % of its height to its top); with ``above``, only the levels at least that share of the
    height up (a sign's plate)."""
    l, w, h = extents
    up = np.linspace(0.05, 1.0, 6)
    g = np.stack(np.meshgrid(np.linspace(-0.5, 0.5, 7) * l, np.linspace(-0.5, 0.5, 5) * w,
                             up[up >= above] * h), -1).reshape(-1, 3)
    return g @ m[:3, :3].T + m[:3, 3]


def visibility_of(frame: Frame, m: np.ndarray, extents, others: Sequence[Placement] = (),
                noise=None) -> tuple[float, float, float]:
    """(share of box samples inside the image, share of those hidden by the real scene or by
    the ``others`` already placed, projected area of the box in pixels). ``noise``: the frame's
    :class:`~.noise.StereoNoise`; a sample is hidden only where the real depth is nearer by
    more than its band too."""
    samples = box_samples(m, extents)
    opt = frame.to_optical(samples)
    uv = frame.camera.project(opt)
    H, W = frame.shape
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= W - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= H - 1)
    if not inside.any():
        return 0.0, 1.0, 0.0
    u, v, z = np.rint(uv[inside, 0]).astype(int), np.rint(uv[inside, 1]).astype(int), opt[inside, 2]
    tol = OCCLUSION_TOL_ABS + OCCLUSION_TOL_REL * z
    if noise is not None:
        tol = noise.depth_band(z, tol)
    hidden = frame.depth[v, u] < z - tol
    for o in others:
        hidden |= rays_hit_box(frame.camera.position, samples[inside], o.matrix, o.extents)
    cuv = frame.camera.project(frame.to_optical(box_corners(m, extents)))
    area = float(cv2.contourArea(cv2.convexHull(cuv.astype(np.float32))))
    return float(inside.mean()), float(hidden.mean()), area


def hides_others(frame: Frame, m: np.ndarray, extents, others: Sequence[Placement], rules: PlacementRules,
                  noise=None) -> bool:
    """True when the new box would leave an earlier object more hidden than the rules allow."""
    for i, o in enumerate(others):
        rest = [p for j, p in enumerate(others) if j != i]
        _, before, _ = visibility_of(frame, o.matrix, o.extents, rest, noise)
        samples = box_samples(o.matrix, o.extents)
        newly = rays_hit_box(frame.camera.position, samples, m, extents).mean()
        if min(1.0, before + newly) > rules.max_occluded_fraction:
            return True
    return False
