"""The road's direction: kerb lines where the allowed surface meets other ground, fitted by RANSAC."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import Frame
from ..labels import label_id
from .rules import GROUND_LEVEL, label_mask


@dataclass(frozen=True)
class RoadLine:
    """A kerb line near a candidate: direction angle in V (radians, in (-pi/2, pi/2]), the
    candidate's signed lateral offset from it (metres) and its support (inlier points)."""

    angle: float
    offset: float
    inliers: int
    ambiguous: bool = False  # another strong kerb line crosses it (a junction)


def surface_edges(frame: Frame, surface_ids: np.ndarray) -> np.ndarray:
    """(N, 2) ground-plan points (V) where a surface (e.g. road) meets another ground-level
    surface (e.g. sidewalk): the kerb lines. Cached on the frame per surface."""
    key = ("surface_edges", tuple(int(i) for i in surface_ids))
    if key not in frame.cache:
        frame.cache[key] = _surface_edges(frame, surface_ids)
    return frame.cache[key]


def _surface_edges(frame: Frame, road_ids: np.ndarray) -> np.ndarray:
    lab = frame.label_ids
    road = label_mask(road_ids)[lab]
    side = label_mask([label_id(n) for n in GROUND_LEVEL])[lab] & ~road
    edge = np.zeros_like(road)
    for dr, dc in ((2, 0), (-2, 0), (0, 2), (0, -2)):
        shifted = np.zeros_like(side)
        rs = slice(max(dr, 0), lab.shape[0] + min(dr, 0))
        rd = slice(max(-dr, 0), lab.shape[0] + min(-dr, 0))
        cs = slice(max(dc, 0), lab.shape[1] + min(dc, 0))
        cd = slice(max(-dc, 0), lab.shape[1] + min(-dc, 0))
        shifted[rd, cd] = side[rs, cs]
        edge |= road & shifted
    edge &= np.isfinite(frame.depth)
    v, u = np.nonzero(edge)
    z = frame.depth[v, u].astype(np.float64)
    cam = frame.camera
    optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
    m = cam.vehicle_from_optical
    return (optical @ m[:3, :3].T + m[:3, 3])[:, :2]


def _ransac_line(pts: np.ndarray, rng: np.random.Generator, iterations: int, band: float,
                 away_from: float | None = None) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Best line through (N, 2) points: (a point on it, unit normal, score). ``away_from``: only
    lines at more than 30 degrees from that angle."""
    best, best_score = None, 0.0
    if len(pts) < 2:
        return None
    for _ in range(iterations):
        i, j = rng.integers(len(pts), size=2)
        d = pts[j] - pts[i]
        length = math.hypot(*d)
        if length < 1.0:
            continue
        d = d / length
        if away_from is not None and abs(d[0] * math.sin(away_from) - d[1] * math.cos(away_from)) < 0.5:
            continue
        n = np.array([-d[1], d[0]])
        rel = pts - pts[i]
        along = rel[np.abs(rel @ n) < band] @ d
        # score by the length of line covered (0.5 m bins), not by the point count: seen
        # from a car, ground far away is sampled densely across the view and sparsely along
        # it, so counting points would favour any kerb that crosses the view; for the same
        # reason prefer lines along the view, as streets ahead mostly run
        score = len(np.unique(np.floor(along / 0.5))) * (0.5 + 0.5 * d[0] ** 2)
        if score > best_score:
            best, best_score = (pts[i], n), score
    return None if best is None else (best[0], best[1], best_score)


def fit_road_line(edges: np.ndarray, point: np.ndarray, rng: np.random.Generator | None = None,
                  radius: float = 15.0, iterations: int = 80, band: float = 0.15) -> RoadLine | None:
    """RANSAC kerb line through the edge points within ``radius`` of ``point`` (ground plan);
    flagged ambiguous where a second strong line crosses it (a junction). Without ``rng`` the
    draw is seeded by the point's position, so the placement and the checker see one line."""
    near = edges[np.hypot(edges[:, 0] - point[0], edges[:, 1] - point[1]) <= radius]
    if rng is None:
        rng = np.random.default_rng([int(abs(point[0]) * 10), int(abs(point[1]) * 10)])
    if len(near) < 20:
        return None
    found = _ransac_line(near, rng, iterations, band)
    if found is None or found[2] < 6:
        return None
    p0, n, score = found
    on_line = np.abs((near - p0) @ n) < band
    inl = near[on_line]
    centre = inl.mean(axis=0)
    _, _, vt = np.linalg.svd(inl - centre, full_matrices=False)
    d = vt[0]
    angle = math.atan2(d[1], d[0])
    if angle <= -math.pi / 2:
        angle += math.pi
    elif angle > math.pi / 2:
        angle -= math.pi
    normal = np.array([-math.sin(angle), math.cos(angle)])
    rival = _ransac_line(near[~on_line], rng, iterations, band, away_from=angle)
    ambiguous = rival is not None and rival[2] > 0.5 * score
    return RoadLine(angle, float((point[:2] - centre) @ normal), len(inl), bool(ambiguous))
