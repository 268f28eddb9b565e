"""Stage 3 - placement: where an object stands in the real scene, and why.

For each object, candidates are drawn at random among ground-like pixels of an allowed
surface (by label) with valid depth, weighted so distances spread over the allowed range.
A candidate is oriented (along the local road direction, towards the camera, or at random),
then must pass, cheapest first:

1. a ground-like surface at the pixel (not a kerb face or a wall);
2. on a provisional pose: the object in front of the camera and inside the image (or
   truncated, if allowed), its footprint on seen, supported, allowed ground;
3. a robust plane fit of the allowed ground around it (the object stands on that plane:
   contact, pitch and roll follow it), rejected when too few points, a step, rough or steep;
4. the same image tests on the final pose, and the visibility rules (visible pixels,
   occluded share) estimated against the real depth;
5. no overlap with objects already placed in the frame;
6. no scene point inside its box: the pixel grid is the spatial index (every point inside
   the box projects inside the box's image rectangle), then the strict oriented-box test.
   :func:`prefilter` is the paper's lenient all-points pre-filter, kept for comparison.

Every rejection is counted by reason and returned with the result. Steps 1-6 (less the
candidate's own tests) are the methods of :class:`PoseTests`; :func:`check_pose` runs them on
a pose given outright (an object moved by hand in the preview) and names the rule it breaks.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Sequence

import cv2
import numpy as np

from .camera import Camera
from .geometry import Frame, back_project, pinhole
from .labels import label_id

#: default allowed surfaces per Cityscapes class
ALLOWED_SURFACES: dict[str, tuple[str, ...]] = {
    "car": ("road",), "truck": ("road",), "bus": ("road",), "motorcycle": ("road",),
    "bicycle": ("road",), "rider": ("road",), "caravan": ("road",), "trailer": ("road",),
    "person": ("sidewalk",), "traffic sign": ("sidewalk",), "traffic light": ("sidewalk",),
    "pole": ("sidewalk",),
}
#: default orientation rule per class (others: along-road)
ORIENTATION: dict[str, str] = {"person": "random", "traffic sign": "face-camera", "traffic light": "face-camera"}
ORIENTATIONS = ("along-road", "parked", "face-camera", "random")
#: ground-level labels: where an allowed surface meets another of these there is a kerb line
GROUND_LEVEL = ("road", "sidewalk", "parking", "rail track", "terrain", "ground")
#: the footprint must stay this far from a kerb line of its own surface, metres
KERB_CLEARANCE = 0.2
#: a footprint sample is on the real ground when |scene depth - its depth| <= REL * depth + ABS
#: (a 15 cm kerb drop seen from 1.2 m moves the ground ~14% further away)
SUPPORT_TOL_REL = 0.02
SUPPORT_TOL_ABS = 0.05
#: a ground point is on the fitted plane when within this height of it, metres
INLIER_BAND = 0.04
#: a point of the object is hidden when the real depth is nearer by more than this
OCCLUSION_TOL_REL = 0.01
OCCLUSION_TOL_ABS = 0.05


@dataclass(frozen=True)
class PlacementRules:
    distance: tuple[float, float] = (6.0, 45.0)  # ground distance from the camera, metres
    max_attempts: int = 200
    yaw_jitter_deg: float = 5.0
    clearance: float = 0.12  # scene points lower than this above the ground are not obstacles, metres
    margin: float = 0.10  # the collision box is this much larger than the object, metres
    object_gap: float = 0.6  # least ground distance between two inserted objects, metres
    min_collision_points: int = 3  # fewer points inside the box count as depth noise
    min_footprint_allowed: float = 0.97  # share of the visible footprint on allowed labels
    footprint_margin: float = 0.15  # the supporting ground must reach this far beyond the footprint, metres
    max_ground_rms: float = 0.05  # metres
    max_ground_tilt_deg: float = 12.0
    min_ground_points: int = 30
    min_ground_inliers: float = 0.6  # share of the local ground points on the fitted plane
    min_visible_pixels: int = 150
    max_occluded_fraction: float = 0.7
    allow_truncation: bool = False  # objects may be cut by the image border
    parked_kerb_gap: float = 0.8  # parked: most distance from the kerb line to the car's side, metres


@dataclass(frozen=True)
class Placement:
    """An accepted pose. Frames: vehicle V (ISO 8855) and optical S (see camera.py)."""

    class_name: str
    extents: tuple[float, float, float]  # object length, width, height, metres
    vehicle_from_object: tuple[tuple[float, ...], ...]  # (4, 4), object frame O -> V
    yaw: float  # radians about V's z, 0 = facing +x (driving direction)
    road_yaw: float | None  # local road direction estimated from the kerb lines, radians (mod pi)
    ground_normal: tuple[float, float, float]
    ground_rms: float  # metres
    distance: float  # ground distance from the camera, metres
    pixel: tuple[int, int]  # (row, column) of the chosen ground point
    occluded_estimate: float  # share of the object hidden by the real scene (box samples)
    truncated: bool  # the object crosses the image border

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.vehicle_from_object)

    @property
    def position(self) -> np.ndarray:
        """Ground contact point (centre of the footprint) in V."""
        return self.matrix[:3, 3]

    def box_corners(self, grow: float = 0.0) -> np.ndarray:
        """(8, 3) corners of the object's box in V (grown by ``grow`` metres, not below z = 0)."""
        return box_corners(self.matrix, self.extents, grow)


@dataclass(frozen=True)
class PlacementResult:
    placement: Placement | None
    attempts: int
    rejections: dict[str, int] = field(default_factory=dict)


# ------------------------------------------------------------------------ geometry helpers
def label_mask(ids) -> np.ndarray:
    """(256,) bool lookup table of label ids: ``label_mask(ids)[labels]`` is a fast np.isin."""
    lut = np.zeros(256, bool)
    lut[np.asarray(ids, int)] = True
    return lut



def box_corners(m: np.ndarray, extents, grow: float = 0.0) -> np.ndarray:
    """(8, 3) vehicle-frame corners of an object's box, its sides pushed out by ``grow``."""
    l, w, h = extents[0] / 2 + grow, extents[1] / 2 + grow, extents[2] + grow
    local = np.array([[sx * l, sy * w, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, h)])
    return local @ m[:3, :3].T + m[:3, 3]


def fit_ground(points: np.ndarray, centre: np.ndarray | None = None, iterations: int = 4,
               band: float = 0.08) -> tuple[np.ndarray, float, int] | None:
    """Robust plane z = a x + b y + c through (N, 3) points (metres, V).

    Starts from a level plane at the median height of the points nearest ``centre`` (so a
    kerb face or a lower road next to a sidewalk cannot pull the plane), keeps the points
    within ``band`` of it, then alternates least squares and trimming at 3 robust sigmas.
    Returns ((a, b, c), rms of the kept points in metres, count of points within
    :data:`INLIER_BAND` of the plane), or None if too few points.
    """
    if len(points) < 3:
        return None
    if centre is None:
        centre = np.median(points, axis=0)
    d2 = (points[:, 0] - centre[0]) ** 2 + (points[:, 1] - centre[1]) ** 2
    nearest = np.argsort(d2)[: max(10, len(points) // 5)]
    coef = np.array([0.0, 0.0, float(np.median(points[nearest, 2]))])
    keep = np.abs(points[:, 2] - coef[2]) < band
    for _ in range(iterations):
        p = points[keep]
        if len(p) < 3:
            return None
        A = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
        coef, *_ = np.linalg.lstsq(A, p[:, 2], rcond=None)
        res = points[:, 2] - (points[:, 0] * coef[0] + points[:, 1] * coef[1] + coef[2])
        mad = np.median(np.abs(res[keep]))
        keep = np.abs(res) < max(3.0 * 1.4826 * mad, 0.02)
    p = points[keep]
    if len(p) < 3:
        return None
    res = p[:, 2] - (p[:, 0] * coef[0] + p[:, 1] * coef[1] + coef[2])
    all_res = points[:, 2] - (points[:, 0] * coef[0] + points[:, 1] * coef[1] + coef[2])
    return coef, float(np.sqrt(np.mean(res ** 2))), int((np.abs(all_res) <= INLIER_BAND).sum())


def surface_normals(depth: np.ndarray, camera: Camera, rows: np.ndarray, cols: np.ndarray,
                    step: int = 2) -> np.ndarray:
    """(N, 3) unit normals (V frame, z >= 0) of the real surface at pixels (rows, cols), from
    the 3D points ``step`` pixels above/below and left/right; NaN where depth is missing."""
    H, W = depth.shape
    rows, cols = np.asarray(rows), np.asarray(cols)
    r0, r1 = np.clip(rows - step, 0, H - 1), np.clip(rows + step, 0, H - 1)
    c0, c1 = np.clip(cols - step, 0, W - 1), np.clip(cols + step, 0, W - 1)
    m = camera.vehicle_from_optical[:3, :3]

    def point(r, c):
        z = depth[r, c]
        return np.column_stack([(c - camera.u0) * z / camera.fx, (r - camera.v0) * z / camera.fy, z]) @ m.T

    with np.errstate(invalid="ignore", divide="ignore"):  # inf depth gives NaN normals
        n = np.cross(point(rows, c1) - point(rows, c0), point(r1, cols) - point(r0, cols))
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(n[:, 2:3] < 0, -n, n)


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


# ------------------------------------------------------------------------- road direction
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


def fit_road_line(edges: np.ndarray, point: np.ndarray, rng: np.random.Generator, radius: float = 15.0,
                  iterations: int = 80, band: float = 0.15) -> RoadLine | None:
    """RANSAC kerb line through the edge points within ``radius`` of ``point`` (ground plan);
    flagged ambiguous where a second strong line crosses it (a junction)."""
    near = edges[np.hypot(edges[:, 0] - point[0], edges[:, 1] - point[1]) <= radius]
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


# ------------------------------------------------------------------------------- placing
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


def _box_samples(m: np.ndarray, extents) -> np.ndarray:
    l, w, h = extents
    g = np.stack(np.meshgrid(np.linspace(-0.5, 0.5, 7) * l, np.linspace(-0.5, 0.5, 5) * w,
                             np.linspace(0.05, 1.0, 6) * h), -1).reshape(-1, 3)
    return g @ m[:3, :3].T + m[:3, 3]


def _visibility(frame: Frame, m: np.ndarray, extents, others: Sequence[Placement] = ()) -> tuple[float, float, float]:
    """(share of box samples inside the image, share of those hidden by the real scene or by
    the ``others`` already placed, projected area of the box in pixels)."""
    samples = _box_samples(m, extents)
    opt = frame.to_optical(samples)
    uv = frame.camera.project(opt)
    H, W = frame.shape
    inside = (uv[:, 0] >= 0) & (uv[:, 0] <= W - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= H - 1)
    if not inside.any():
        return 0.0, 1.0, 0.0
    u, v, z = np.rint(uv[inside, 0]).astype(int), np.rint(uv[inside, 1]).astype(int), opt[inside, 2]
    hidden = frame.depth[v, u] < z - (OCCLUSION_TOL_ABS + OCCLUSION_TOL_REL * z)
    for o in others:
        hidden |= rays_hit_box(frame.camera.position, samples[inside], o.matrix, o.extents)
    cuv = frame.camera.project(frame.to_optical(box_corners(m, extents)))
    area = float(cv2.contourArea(cv2.convexHull(cuv.astype(np.float32))))
    return float(inside.mean()), float(hidden.mean()), area


def _hides_others(frame: Frame, m: np.ndarray, extents, others: Sequence[Placement], rules: PlacementRules) -> bool:
    """True when the new box would leave an earlier object more hidden than the rules allow."""
    for i, o in enumerate(others):
        rest = [p for j, p in enumerate(others) if j != i]
        _, before, _ = _visibility(frame, o.matrix, o.extents, rest)
        samples = _box_samples(o.matrix, o.extents)
        newly = rays_hit_box(frame.camera.position, samples, m, extents).mean()
        if min(1.0, before + newly) > rules.max_occluded_fraction:
            return True
    return False


class _Candidates:
    """Allowed-surface pixels of one frame with known depth in the distance range, sampled with
    weight depth^2 (near ground covers far more pixels than far ground: this spreads distances
    evenly). Only the ground distance of each pixel is worked out here (an image's road is
    most of a million pixels); a drawn pixel is back-projected when drawn.

    rows, cols (N,) the pixels; cdf (N,) cumulative weights."""

    def __init__(self, frame: Frame, allowed_ids: np.ndarray, distance: tuple[float, float]) -> None:
        lo, hi = distance
        cam = self.camera = frame.camera
        self.depth = frame.depth
        v, u = np.nonzero(label_mask(allowed_ids)[frame.label_ids] & np.isfinite(frame.depth))
        x, y, z = pinhole(frame.depth, cam, v, u)
        m = cam.vehicle_from_optical.astype(np.float32)
        ground_x = x * m[0, 0] + y * m[0, 1] + z * m[0, 2] + (m[0, 3] - np.float32(cam.x))
        ground_y = x * m[1, 0] + y * m[1, 1] + z * m[1, 2] + (m[1, 3] - np.float32(cam.y))
        dist = np.hypot(ground_x, ground_y)
        keep = (dist >= lo) & (dist <= hi)
        self.rows, self.cols = v[keep], u[keep]
        self.cdf = np.cumsum(np.square(z[keep], dtype=np.float64))

    def __len__(self) -> int:
        return len(self.rows)

    def draw(self, rng: np.random.Generator) -> int:
        return int(np.searchsorted(self.cdf, rng.random() * self.cdf[-1], side="right"))

    def point(self, idx: int) -> np.ndarray:
        """(3,) vehicle-frame point of candidate ``idx``."""
        return back_project(self.depth, self.camera, self.rows[idx:idx + 1], self.cols[idx:idx + 1])[1][0]


class _TracedCounter(Counter):
    """Rejection counter that also lists (candidate point in V, reason) for the preview."""

    def __init__(self, trace: list) -> None:
        super().__init__()
        self.trace, self.point = trace, None

    def __setitem__(self, key, value) -> None:
        if value > self.get(key, 0) and self.point is not None:
            self.trace.append((self.point, key))
        super().__setitem__(key, value)


# ------------------------------------------------------------------- the rules of one pose
#: the placement rule each rejection reason belongs to (the preview names it)
RULE_OF: dict[str, str] = {
    "partly behind the camera": "in view",
    "not fully inside the image": "truncation",
    "footprint outside the image": "ground support",
    "footprint hidden": "ground support",
    "footprint off the allowed surface": "ground support",
    "footprint crosses a kerb line": "ground support",
    "too few ground points": "ground plane",
    "ground not planar (step or kerb)": "ground plane",
    "ground not flat (rms too high)": "ground plane",
    "ground too steep": "ground plane",
    "candidate point is off the fitted ground (kerb face, noise)": "ground plane",
    "object is off the fitted ground": "ground plane",
    "too much hidden by the scene": "max occluded share",
    "too few visible pixels": "min visible pixels",
    "would hide an object placed before": "max occluded share",
    "overlaps another inserted object": "collision",
    "intersects the scene": "collision",
}
#: a pose given outright may be this far above or below the ground it is checked against, metres
POSE_GROUND_SEARCH = 2.0


@dataclass(frozen=True)
class Rejection:
    """Why a pose breaks a placement rule: ``reason`` as the record counts it, ``detail`` the
    measurement behind it (for people; empty where there is nothing to add)."""

    reason: str
    detail: str = ""

    @property
    def rule(self) -> str:
        return RULE_OF.get(self.reason, "placement")

    def __str__(self) -> str:
        return f"{self.rule}: {self.reason}" + (f" ({self.detail})" if self.detail else "")


@dataclass(frozen=True)
class GroundFit:
    """The robust plane z = a x + b y + c of the allowed ground around a point (V, metres)."""

    coef: tuple[float, float, float]
    rms: float
    normal: np.ndarray  # (3,) unit, z > 0

    def height(self, x, y):
        a, b, c = self.coef
        return a * x + b * y + c


@dataclass(frozen=True, eq=False)
class PoseTests:
    """The placement rules for poses of one object (``extents``, l, w, h metres) in one frame,
    cheapest first: :func:`place_object` runs them on its candidates, :func:`check_pose` on a
    pose given outright (the preview's hand-moved objects). Each returns a :class:`Rejection`
    or None."""

    frame: Frame
    extents: tuple[float, float, float]
    rules: PlacementRules
    allowed: tuple[str, ...]
    allowed_ids: np.ndarray
    edges: np.ndarray  # (N, 2) kerb-line points of the allowed surface (ground plan)
    grid: np.ndarray  # (45, 3) footprint samples in the object frame, footprint_margin beyond it
    reach: float  # half-side of the square searched for ground points, metres
    min_up: float  # least z of a ground-like surface normal

    @classmethod
    def of(cls, frame: Frame, extents, rules: PlacementRules, allowed: Sequence[str]) -> "PoseTests":
        allowed_ids = np.array([label_id(n) for n in allowed])
        l, w, _ = extents
        fm = rules.footprint_margin
        gx, gy = np.meshgrid(np.linspace(-l / 2 - fm, l / 2 + fm, 9), np.linspace(-w / 2 - fm, w / 2 + fm, 5))
        grid = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])
        return cls(frame, extents, rules, tuple(allowed), allowed_ids, surface_edges(frame, allowed_ids), grid,
                   math.hypot(l, w) / 2 + 0.5, math.cos(math.radians(2 * rules.max_ground_tilt_deg)))

    def image(self, m: np.ndarray) -> Rejection | None:
        """Cheap tests in the image: object on screen, footprint on seen, supported, allowed ground."""
        frame, rules, camera, depth = self.frame, self.rules, self.frame.camera, self.frame.depth
        l, w, _ = self.extents
        H, W = frame.label_ids.shape
        corners_o = frame.to_optical(box_corners(m, self.extents))
        if (corners_o[:, 2] <= 1.0).any():
            return Rejection("partly behind the camera", f"a corner {corners_o[:, 2].min():.2f} m in front of it")
        uv = camera.project(corners_o)
        out = (uv[:, 0] < 0).any() or (uv[:, 0] > W - 1).any() or (uv[:, 1] < 0).any() or (uv[:, 1] > H - 1).any()
        if out and not rules.allow_truncation:
            return Rejection("not fully inside the image", "the box crosses the image border and truncation is off")
        foot_o = frame.to_optical(self.grid @ m[:3, :3].T + m[:3, 3])
        fuv = np.rint(camera.project(foot_o)).astype(int)
        on_screen = (fuv[:, 0] >= 0) & (fuv[:, 0] < W) & (fuv[:, 1] >= 0) & (fuv[:, 1] < H)
        if on_screen.mean() < 0.5:
            return Rejection("footprint outside the image", f"{on_screen.mean():.0%} of it on screen, needs 50%")
        fu, fv, foot_d = fuv[on_screen, 0], fuv[on_screen, 1], foot_o[on_screen, 2]
        scene_d = depth[fv, fu]
        tol = SUPPORT_TOL_REL * foot_d + SUPPORT_TOL_ABS
        # seen: known depth (disparity holes say nothing) and not behind something nearer
        seen = np.isfinite(scene_d) & (scene_d >= foot_d - tol)
        if seen.sum() < 0.3 * len(seen):
            return Rejection("footprint hidden", f"{seen.mean():.0%} of it seen, needs 30%")
        # a seen sample is supported when the real ground is there: allowed label, same
        # depth, and a ground-like surface (not the face of a kerb; unknown next to a hole)
        supported = np.isin(frame.label_ids[fv, fu], self.allowed_ids) & (scene_d <= foot_d + tol)
        up = surface_normals(depth, camera, fv, fu)[:, 2]
        supported &= ~(up < self.min_up)  # NaN (a hole nearby) does not count against
        share = supported[seen].mean()
        if share < rules.min_footprint_allowed:
            return Rejection("footprint off the allowed surface",
                             f"{share:.0%} of the seen footprint on level {'/'.join(self.allowed)} ground at its "
                             f"height, needs {rules.min_footprint_allowed:.0%}")
        # no kerb line of the surface under the footprint (also where its face is unresolved)
        c, edges, reach = m[:3, 3], self.edges, self.reach
        close = edges[(np.abs(edges[:, 0] - c[0]) <= reach + 1) & (np.abs(edges[:, 1] - c[1]) <= reach + 1)]
        if len(close):
            local = (close - c[:2]) @ m[:2, :2]
            if ((np.abs(local[:, 0]) <= l / 2 + KERB_CLEARANCE) & (np.abs(local[:, 1]) <= w / 2 + KERB_CLEARANCE)).any():
                return Rejection("footprint crosses a kerb line", f"a kerb within {KERB_CLEARANCE} m of the footprint")
        return None

    def ground(self, point: np.ndarray, dz: float = 0.3) -> tuple[GroundFit | None, Rejection | None]:
        """Robust plane through the allowed, ground-like points around ``point`` (V), found through
        the pixel grid (the square of side 2 * reach, ``dz`` above and below it, projected)."""
        frame, rules, reach = self.frame, self.rules, self.reach
        square = point + np.array([[sx * reach, sy * reach, d] for sx in (-1, 1) for sy in (-1, 1)
                                   for d in (-dz, dz)])
        rect = frame.box_rect(square)
        near = np.empty((0, 3))
        if rect is not None:
            pts, _, rr, cc = frame.rect_points(*rect, with_pixels=True, only=label_mask(self.allowed_ids))
            sel = np.flatnonzero((np.abs(pts[:, 0] - point[0]) <= reach) & (np.abs(pts[:, 1] - point[1]) <= reach))
            # only ground-like surfaces: kerb faces and walls of an allowed label do not count
            sel = sel[surface_normals(frame.depth, frame.camera, rr[sel], cc[sel])[:, 2] >= self.min_up]
            near = pts[sel]
        fit = fit_ground(near, point) if len(near) >= rules.min_ground_points else None
        if fit is None:
            return None, Rejection("too few ground points",
                                   f"{len(near)} {'/'.join(self.allowed)} points around it, needs {rules.min_ground_points}")
        (a, b, c), rms, inliers = fit
        normal = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
        ground = GroundFit((a, b, c), rms, normal)
        if inliers < rules.min_ground_inliers * len(near):
            return ground, Rejection("ground not planar (step or kerb)",
                                     f"{inliers / len(near):.0%} of the ground points on one plane, "
                                     f"needs {rules.min_ground_inliers:.0%}")
        if rms > rules.max_ground_rms:
            return ground, Rejection("ground not flat (rms too high)", f"rms {rms:.3f} m > {rules.max_ground_rms} m")
        tilt = math.degrees(math.acos(normal[2]))
        if tilt > rules.max_ground_tilt_deg:
            return ground, Rejection("ground too steep", f"{tilt:.1f} deg > {rules.max_ground_tilt_deg} deg")
        return ground, None

    def visibility(self, m: np.ndarray, others: Sequence[Placement] = ()) -> tuple[Rejection | None, float, float]:
        """The visibility rules against the real depth and ``others`` placed before; also
        returns (share of the object inside the image, share hidden)."""
        rules = self.rules
        in_image, hidden, area = _visibility(self.frame, m, self.extents, others)
        if hidden > rules.max_occluded_fraction:
            why = Rejection("too much hidden by the scene",
                            f"{hidden:.0%} hidden, at most {rules.max_occluded_fraction:.0%}")
            return why, in_image, hidden
        visible = area * in_image * (1.0 - hidden)
        if visible < rules.min_visible_pixels:
            why = Rejection("too few visible pixels", f"about {visible:.0f} seen, needs {rules.min_visible_pixels}")
            return why, in_image, hidden
        if others and _hides_others(self.frame, m, self.extents, others, rules):
            why = Rejection("would hide an object placed before",
                            f"it would leave one more than {rules.max_occluded_fraction:.0%} hidden")
            return why, in_image, hidden
        return None, in_image, hidden

    def overlap(self, m: np.ndarray, other_prints: Sequence[np.ndarray]) -> Rejection | None:
        """No overlap with the footprints (grown by half the object gap) of objects placed before."""
        mine = footprint_corners(m, self.extents, self.rules.object_gap / 2)
        if any(footprints_overlap(mine, o) for o in other_prints):
            return Rejection("overlaps another inserted object", f"closer than {self.rules.object_gap} m")
        return None

    def scene(self, m: np.ndarray) -> Rejection | None:
        """No scene point inside the box: the pixel grid as index, then the strict test."""
        frame, rules = self.frame, self.rules
        rect = frame.box_rect(box_corners(m, self.extents, rules.margin))
        pts, _ = frame.rect_points(*rect) if rect else (np.empty((0, 3)), None)
        inside = int(strict_inside(pts, m, self.extents, rules.clearance, rules.margin).sum())
        if inside >= rules.min_collision_points:
            return Rejection("intersects the scene", f"{inside} scene points inside the box")
        return None


def check_pose(frame: Frame, class_name: str, extents, matrix: np.ndarray, rules: PlacementRules,
               allowed: Sequence[str] | None = None, others: Sequence[Placement] = ()) -> Rejection | None:
    """The batch's placement rules on a pose given outright (moved by hand in the preview, or
    saved): the first rule it breaks, or None when the batch would have accepted it. ``others``:
    the objects placed before it. Orientation rules (road direction, parked, junctions) are
    about drawing candidates and are not checked."""
    tests = PoseTests.of(frame, extents, rules, tuple(allowed or ALLOWED_SURFACES.get(class_name, ("road",))))
    m = np.asarray(matrix, float)
    why = tests.image(m)
    if why:
        return why
    ground, why = tests.ground(m[:3, 3], dz=POSE_GROUND_SEARCH)
    if why:
        return why
    foot = box_corners(m, extents)[::2]  # the 4 bottom corners
    gap = float(np.abs(foot[:, 2] - ground.height(foot[:, 0], foot[:, 1])).max())
    if gap > rules.max_ground_rms + 0.02:
        return Rejection("object is off the fitted ground", f"a footprint corner {gap:.2f} m from the ground plane")
    prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]
    # collisions before visibility (the batch's order is the other way round): an object moved
    # onto another is said to collide, not to be hidden by it
    return tests.overlap(m, prints) or tests.scene(m) or tests.visibility(m, others)[0]


def place_object(frame: Frame, class_name: str, extents: tuple[float, float, float], rng: np.random.Generator,
                 rules: PlacementRules, allowed: Sequence[str] | None = None, orientation: str | None = None,
                 others: Sequence[Placement] = (), trace: list | None = None) -> PlacementResult:
    """Find a pose for one object of ``extents`` (l, w, h metres) in the frame, or say why not.

    ``trace``: when a list, gets (candidate point (3,) in V, rejection reason) per rejected
    candidate (the preview shows them); the result does not depend on it."""
    allowed = tuple(allowed or ALLOWED_SURFACES.get(class_name, ("road",)))
    orientation = orientation or ORIENTATION.get(class_name, "along-road")
    if orientation not in ORIENTATIONS:
        raise ValueError(f"unknown orientation {orientation!r}")
    allowed_ids = np.array([label_id(n) for n in allowed])
    camera, depth = frame.camera, frame.depth
    rejections: Counter[str] = Counter() if trace is None else _TracedCounter(trace)
    candidates = _Candidates(frame, allowed_ids, rules.distance)
    lo, hi = rules.distance
    if len(candidates) == 0:
        rejections[f"no {'/'.join(allowed)} pixel with valid depth within {lo}-{hi} m"] += 1
        return PlacementResult(None, 0, dict(rejections))
    tests = PoseTests.of(frame, extents, rules, allowed)
    edges = tests.edges
    jitter = math.radians(rules.yaw_jitter_deg)
    l, w, h = extents
    other_prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]

    for attempt in range(1, rules.max_attempts + 1):
        idx = candidates.draw(rng)
        point = candidates.point(idx).astype(float)
        row, col = int(candidates.rows[idx]), int(candidates.cols[idx])
        if trace is not None:  # preview: where this candidate was
            rejections.point = point
        # 1. the candidate pixel must be ground-like, not a kerb face or a wall
        n_here = surface_normals(depth, camera, np.array([row]), np.array([col]))[0]
        if not n_here[2] >= tests.min_up:  # NaN-safe
            rejections["candidate surface not horizontal"] += 1
            continue
        # orientation
        road_yaw = None
        if orientation == "random":
            yaw = float(rng.uniform(-math.pi, math.pi))
        elif orientation == "face-camera":
            to_cam = camera.position[:2] - point[:2]
            yaw = math.atan2(to_cam[1], to_cam[0]) + float(rng.normal(0.0, jitter))
        else:
            line = fit_road_line(edges, point, rng) if len(edges) else None
            if line is None:
                if orientation == "parked":
                    rejections["no kerb line nearby (parked)"] += 1
                    continue
                base = 0.0  # no kerb seen: the ego vehicle's heading
            elif line.ambiguous:
                rejections["road direction ambiguous (junction)"] += 1
                continue
            else:
                base = road_yaw = line.angle
                if orientation == "parked" and abs(line.offset) - w / 2 > rules.parked_kerb_gap:
                    rejections["too far from the kerb (parked)"] += 1
                    continue
            yaw = base + (0.0 if rng.random() < 0.5 else math.pi) + float(rng.uniform(-jitter, jitter))
        # 2. cheap image-space tests on a provisional pose (the pixel's own normal)
        why = tests.image(pose_matrix(point, n_here, yaw))
        if why:
            rejections[why.reason] += 1
            continue
        # 3. the local ground: robust plane through the allowed points around the candidate
        ground, why = tests.ground(point)
        if why is None and abs(point[2] - ground.height(point[0], point[1])) > rules.max_ground_rms + 0.02:
            why = Rejection("candidate point is off the fitted ground (kerb face, noise)")
        if why:
            rejections[why.reason] += 1
            continue
        position = np.array([point[0], point[1], ground.height(point[0], point[1])])
        m = pose_matrix(position, ground.normal, yaw)
        # 4. the image tests again on the final pose, then the visibility rules
        why = tests.image(m)
        if why:
            rejections[why.reason] += 1
            continue
        why, in_image, hidden = tests.visibility(m, others)
        if why:
            rejections[why.reason] += 1
            continue
        # 5. other objects of this frame; 6. scene points inside the box
        why = tests.overlap(m, other_prints) or tests.scene(m)
        if why:
            rejections[why.reason] += 1
            continue
        placement = Placement(
            class_name=class_name, extents=tuple(float(e) for e in extents),
            vehicle_from_object=tuple(tuple(float(v) for v in r) for r in m),
            yaw=float(math.atan2(m[1, 0], m[0, 0])), road_yaw=road_yaw,
            ground_normal=tuple(float(v) for v in ground.normal), ground_rms=ground.rms,
            distance=float(math.hypot(position[0] - camera.x, position[1] - camera.y)),
            pixel=(row, col), occluded_estimate=hidden, truncated=in_image < 1.0)
        return PlacementResult(placement, attempt, dict(rejections))
    return PlacementResult(None, rules.max_attempts, dict(rejections))
