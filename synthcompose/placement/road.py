"""The road's direction: kerb lines where the allowed surface meets other ground, fitted by RANSAC."""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.geometry.depth import Frame, nearest_in_row
from synthcompose.labels import label_id

from .rules import GROUND_LEVEL, label_mask


@dataclass(frozen=True)
class RoadLine:
    """A kerb line near a candidate: direction angle in V (radians, in (-pi/2, pi/2]), the
    candidate's signed lateral offset from it (metres) and its support (inlier points)."""

    angle: float
    offset: float
    inliers: int
    ambiguous: bool = False  # another strong kerb line crosses it (a junction)
    centre: tuple[float, float] = (0.0, 0.0)  # a point of the line (mean of its inliers)

    def offset_of(self, point) -> float:
        """Signed lateral offset of a ground-plan ``point`` from the line, metres."""
        return float(self.offsets(np.asarray(point, float)[None, :2])[0])

    def offsets(self, xy: np.ndarray) -> np.ndarray:
        """(N,) signed lateral offsets of ground-plan points (N, 2) from the line, metres."""
        return (xy[:, 0] - self.centre[0]) * -math.sin(self.angle) + (xy[:, 1] - self.centre[1]) * math.cos(self.angle)


#: road lines are fitted once per cell of this size (metres) of the ground plan
LINE_CELL = 2.5
#: kerb points within this ground distance of a cell's centre make its line, metres
LINE_RADIUS = 15.0
#: at most this many kerb points go into one RANSAC (an even subsample)
LINE_POINTS = 800
#: a kerb seen across a strip of no found ground at most this wide (metres): its stones and a
#: gutter, neither road nor footway on a frame without labels
GUTTER = 0.8


def road_line(frame: Frame, surface_ids: np.ndarray, point: np.ndarray) -> RoadLine | None:
    """The kerb line of the surface near ``point``, fitted once per LINE_CELL cell around the
    cell's centre (cached on the frame), with the offset of ``point`` itself. The placement
    and the checker both ask here, so they agree on the road's direction."""
    edges = surface_edges(frame, surface_ids)
    if not len(edges):
        return None
    cell = (int(math.floor(point[0] / LINE_CELL)), int(math.floor(point[1] / LINE_CELL)))
    key = ("road_line", tuple(int(i) for i in surface_ids), cell)

    def fit():
        centre = (np.array(cell, float) + 0.5) * LINE_CELL
        rng = np.random.default_rng([cell[0] & 0xFFFF, cell[1] & 0xFFFF])
        # far away a kerb is seen sparsely: look twice as far before falling back on the
        # ego vehicle's heading (a turned street is not along it)
        return fit_road_line(edges, centre, rng) or fit_road_line(edges, centre, rng, radius=2 * LINE_RADIUS)
    line = frame.derived(key, fit)
    return None if line is None else RoadLine(line.angle, line.offset_of(point), line.inliers, line.ambiguous,
                                              line.centre)


def surface_edges(frame: Frame, surface_ids: np.ndarray) -> np.ndarray:
    """(N, 2) ground-plan points (V) where a surface (e.g. road) meets another ground-level
    surface (e.g. sidewalk): the kerb lines. Cached on the frame per surface."""
    key = ("surface_edges", tuple(int(i) for i in surface_ids))
    return frame.derived(key, lambda: _surface_edges(frame, surface_ids))


def _surface_edges(frame: Frame, road_ids: np.ndarray, stride: int = 2) -> np.ndarray:
    """Kerb points on every ``stride``-th row and column (the lines are metres long)."""
    lab = frame.label_ids[::stride, ::stride]
    road = label_mask(road_ids)[lab]
    side = label_mask([label_id(n) for n in GROUND_LEVEL])[lab] & ~road
    near_side = cv2.dilate(side.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    edge = (road & near_side | _across_gutter(lab, road, side, frame.depth[::stride, ::stride],
                                             frame.camera.fx / stride)) & np.isfinite(frame.depth[::stride, ::stride])
    v, u = np.nonzero(edge)
    v, u = v * stride, u * stride
    z = frame.depth[v, u].astype(np.float64)
    cam = frame.camera
    optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
    m = cam.vehicle_from_optical
    return (optical @ m[:3, :3].T + m[:3, 3])[:, :2]


def _across_gutter(lab: np.ndarray, road: np.ndarray, side: np.ndarray, depth: np.ndarray, fx: float) -> np.ndarray:
    """Road pixels at the road's edge along their row where the ground beyond is found only past
    a strip of nothing (label 0) at most :data:`GUTTER` metres wide (``fx``: the focal length in
    these pixels): on frames without labels a kerb's stones, and a gutter under leaves, are often
    found as neither road nor footway."""
    H, W = lab.shape
    void = lab == 0
    left, right = nearest_in_row(~void)  # the nearest found pixel at or left / right of each pixel
    out = np.zeros((H, W), bool)
    for step, nearest in ((1, right), (-1, left)):  # rightwards, then leftwards
        # road pixels whose neighbour on that side is void (at the frame's edge: itself, not void)
        nxt = np.clip(np.arange(W) + step, 0, W - 1)
        r, c = np.nonzero(road & void[:, nxt])
        # the first found pixel past the void (none found: the frame's last column on that side)
        beyond = np.clip(nearest[r, nxt[c]], 0, W - 1)
        with np.errstate(invalid="ignore"):
            narrow = np.abs(beyond - c) * depth[r, c] / fx <= GUTTER
        out[r, c] |= side[r, beyond] & narrow
    return out


def _ransac_line(pts: np.ndarray, rng: np.random.Generator, iterations: int, band: float,
                 away_from: float | None = None) -> tuple[np.ndarray, np.ndarray, float] | None:
    """Best line through (N, 2) points: (a point on it, unit normal, score). ``away_from``: only
    lines at more than 30 degrees from that angle. All hypotheses are scored at once."""
    if len(pts) < 2:
        return None
    i, j = rng.integers(len(pts), size=(2, iterations))
    d = pts[j] - pts[i]
    length = np.hypot(d[:, 0], d[:, 1])
    ok = length >= 1.0
    d = d[ok] / length[ok, None]
    i = i[ok]
    if away_from is not None:
        ok = np.abs(d[:, 0] * math.sin(away_from) - d[:, 1] * math.cos(away_from)) >= 0.5
        d, i = d[ok], i[ok]
    if not len(i):
        return None
    n = np.column_stack([-d[:, 1], d[:, 0]])
    rel = pts[None, :, :] - pts[i][:, None, :]  # (K, N, 2)
    near = np.abs(np.einsum("knc,kc->kn", rel, n)) < band
    along = np.einsum("knc,kc->kn", rel, d)
    # score by the length of line covered (0.5 m bins), not by the point count: seen from a
    # car, ground far away is sampled densely across the view and sparsely along it, so
    # counting points would favour any kerb that crosses the view; for the same reason prefer
    # lines along the view, as streets ahead mostly run
    bins = np.floor(along / 0.5).astype(np.int64)
    lo = bins.min()
    width = int(bins.max() - lo + 1)
    flat = (np.arange(len(i))[:, None] * width + (bins - lo))[near]
    covered = (np.bincount(flat, minlength=len(i) * width).reshape(len(i), width) > 0).sum(axis=1)
    score = covered * (0.5 + 0.5 * d[:, 0] ** 2)
    best = int(np.argmax(score))
    if score[best] <= 0:
        return None
    return pts[i[best]], n[best], float(score[best])


def line_through(pts: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares line through (N, 2) ground-plan points: (their mean, its direction angle
    in (-pi/2, pi/2])."""
    centre = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
    angle = math.atan2(vt[0][1], vt[0][0])
    if angle <= -math.pi / 2:
        angle += math.pi
    elif angle > math.pi / 2:
        angle -= math.pi
    return centre, angle


def fit_road_line(edges: np.ndarray, point: np.ndarray, rng: np.random.Generator | None = None,
                  radius: float = LINE_RADIUS, iterations: int = 80, band: float = 0.15) -> RoadLine | None:
    """RANSAC kerb line through the edge points within ``radius`` of ``point`` (ground plan);
    flagged ambiguous where a second strong line crosses it (a junction)."""
    near = edges[np.hypot(edges[:, 0] - point[0], edges[:, 1] - point[1]) <= radius]
    if rng is None:
        rng = np.random.default_rng(0)
    if len(near) > LINE_POINTS:
        near = near[:: int(math.ceil(len(near) / LINE_POINTS))]
    if len(near) < 20:
        return None
    found = _ransac_line(near, rng, iterations, band)
    if found is None or found[2] < 6:
        return None
    p0, n, score = found
    on_line = np.abs((near - p0) @ n) < band
    inl = near[on_line]
    centre, angle = line_through(inl)
    normal = np.array([-math.sin(angle), math.cos(angle)])
    rival = _ransac_line(near[~on_line], rng, iterations, band, away_from=angle)
    ambiguous = rival is not None and rival[2] > 0.5 * score
    return RoadLine(angle, float((point[:2] - centre) @ normal), len(inl), bool(ambiguous),
                    (float(centre[0]), float(centre[1])))
