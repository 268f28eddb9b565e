"""Stage 3 - placement: where an object stands in the real scene, and why.

A candidate is a random point of an allowed surface (by label) with valid depth. Around it
the local ground is fitted (robust least squares), the object is stood on it and oriented,
and the candidate must pass, in order: the ground fit, the footprint lying on allowed
labels, the whole object being inside the image, no overlap with objects already placed,
and the paper's two-stage intersection check against the scene's points - a lenient
axis-aligned pre-filter over all points, then the strict oriented-box test on the suspects.
Every rejection is counted by reason.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from .camera import Camera
from .geometry import PointCloud
from .labels import label_id

#: default allowed surfaces per Cityscapes class
ALLOWED_SURFACES: dict[str, tuple[str, ...]] = {
    "car": ("road",), "truck": ("road",), "bus": ("road",), "motorcycle": ("road",),
    "bicycle": ("road",), "rider": ("road",), "caravan": ("road",), "trailer": ("road",),
    "person": ("sidewalk",), "traffic sign": ("sidewalk",), "traffic light": ("sidewalk",),
    "pole": ("sidewalk",),
}
#: default orientation rule per class: along the road, facing the camera, or random
ORIENTATION: dict[str, str] = {"person": "random", "traffic sign": "face-camera", "traffic light": "face-camera"}


@dataclass(frozen=True)
class PlacementRules:
    distance: tuple[float, float] = (6.0, 45.0)  # ground distance from the camera, metres
    max_attempts: int = 200
    yaw_jitter_deg: float = 5.0
    clearance: float = 0.12  # scene points lower than this above the ground are not obstacles, metres
    margin: float = 0.10  # the collision box is this much larger than the object, metres
    min_collision_points: int = 3  # fewer points inside the box count as depth noise
    min_footprint_allowed: float = 0.9  # share of the visible footprint on allowed labels
    max_ground_rms: float = 0.05  # metres
    max_ground_tilt_deg: float = 12.0
    min_ground_points: int = 30


@dataclass(frozen=True)
class Placement:
    """An accepted pose. Frames: vehicle V (ISO 8855) and optical S (see camera.py)."""

    class_name: str
    extents: tuple[float, float, float]  # object length, width, height, metres
    vehicle_from_object: tuple[tuple[float, ...], ...]  # (4, 4), object frame O -> V
    yaw: float  # radians about V's z, 0 = facing +x (driving direction)
    ground_normal: tuple[float, float, float]
    ground_rms: float  # metres
    distance: float  # ground distance from the camera, metres
    pixel: tuple[int, int]  # (row, column) of the chosen ground point

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.vehicle_from_object)

    @property
    def position(self) -> np.ndarray:
        """Ground contact point (centre of the footprint) in V."""
        return self.matrix[:3, 3]

    def box_corners(self) -> np.ndarray:
        """(8, 3) corners of the object's box in V."""
        l, w, h = self.extents
        local = np.array([[sx * l / 2, sy * w / 2, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0, h)])
        m = self.matrix
        return local @ m[:3, :3].T + m[:3, 3]


@dataclass(frozen=True)
class PlacementResult:
    placement: Placement | None
    attempts: int
    rejections: dict[str, int] = field(default_factory=dict)


def _yaw_for(orientation: str, rng: np.random.Generator, jitter: float, point: np.ndarray,
             camera: Camera) -> float:
    if orientation == "random":
        return float(rng.uniform(-math.pi, math.pi))
    if orientation == "face-camera":
        to_cam = camera.position[:2] - point[:2]
        return math.atan2(to_cam[1], to_cam[0]) + float(rng.normal(0.0, jitter))
    # along the road: the driving direction of the ego vehicle, either way
    base = 0.0 if rng.random() < 0.5 else math.pi
    return base + float(rng.uniform(-jitter, jitter))


def fit_ground(points: np.ndarray, iterations: int = 3) -> tuple[np.ndarray, float, int] | None:
    """Robust plane z = a x + b y + c through (N, 3) points: least squares with outlier trimming.

    Returns ((a, b, c), rms of the inliers in metres, inlier count), or None if too few points.
    """
    keep = np.ones(len(points), bool)
    coef = None
    for _ in range(iterations):
        p = points[keep]
        if len(p) < 3:
            return None
        A = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
        coef, *_ = np.linalg.lstsq(A, p[:, 2], rcond=None)
        res = points[:, 2] - (points[:, 0] * coef[0] + points[:, 1] * coef[1] + coef[2])
        mad = np.median(np.abs(res[keep])) + 1e-3
        keep = np.abs(res) < 3.0 * 1.4826 * mad + 0.01
    p = points[keep]
    res = p[:, 2] - (p[:, 0] * coef[0] + p[:, 1] * coef[1] + coef[2])
    return coef, float(np.sqrt(np.mean(res ** 2))), int(keep.sum())


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
    """Lenient pass over all (N, 3) points: indices inside the box's bounding axis-aligned box."""
    l, w, h = extents
    r = math.hypot(l / 2 + margin, w / 2 + margin)
    c = m[:3, 3]
    zlo, zhi = c[2] + min(clearance, 0.0) - 0.5, c[2] + h + margin + 0.5
    sel = (np.abs(points[:, 0] - c[0]) <= r) & (np.abs(points[:, 1] - c[1]) <= r)
    sel &= (points[:, 2] >= zlo) & (points[:, 2] <= zhi)
    return np.flatnonzero(sel)


def strict_inside(points: np.ndarray, m: np.ndarray, extents, clearance: float, margin: float) -> np.ndarray:
    """Strict oriented-box test: bool mask of the (N, 3) points inside the object's box."""
    l, w, h = extents
    local = (points - m[:3, 3]) @ m[:3, :3]
    return ((np.abs(local[:, 0]) <= l / 2 + margin) & (np.abs(local[:, 1]) <= w / 2 + margin)
            & (local[:, 2] >= clearance) & (local[:, 2] <= h + margin))


def _footprint_2d(m: np.ndarray, extents) -> np.ndarray:
    l, w, _ = extents
    local = np.array([[l / 2, w / 2, 0], [-l / 2, w / 2, 0], [-l / 2, -w / 2, 0], [l / 2, -w / 2, 0]])
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


def place_object(class_name: str, extents: tuple[float, float, float], cloud: PointCloud, depth: np.ndarray,
                 label_ids: np.ndarray, camera: Camera, rng: np.random.Generator, rules: PlacementRules,
                 allowed: tuple[str, ...] | None = None, orientation: str | None = None,
                 others: tuple[Placement, ...] = ()) -> PlacementResult:
    """Find a pose for one object of ``extents`` (l, w, h metres) in the frame, or say why not."""
    allowed = allowed or ALLOWED_SURFACES.get(class_name, ("road",))
    orientation = orientation or ORIENTATION.get(class_name, "along-road")
    allowed_ids = np.array([label_id(n) for n in allowed])
    on_allowed = np.isin(cloud.labels, allowed_ids)
    ground_dist = np.hypot(cloud.vehicle[:, 0] - camera.x, cloud.vehicle[:, 1] - camera.y)
    lo, hi = rules.distance
    candidates = np.flatnonzero(on_allowed & (ground_dist >= lo) & (ground_dist <= hi))
    rejections: Counter[str] = Counter()
    if len(candidates) == 0:
        rejections[f"no {'/'.join(allowed)} pixel with valid depth within {lo}-{hi} m"] += 1
        return PlacementResult(None, 0, dict(rejections))
    allowed_pts = cloud.vehicle[on_allowed]
    jitter = math.radians(rules.yaw_jitter_deg)
    l, w, h = extents
    reach = math.hypot(l, w) / 2 + 0.5
    other_prints = [_footprint_2d(o.matrix, o.extents) for o in others]
    H, W = label_ids.shape
    opt_from_v = camera.optical_from_vehicle
    gx, gy = np.meshgrid(np.linspace(-0.45, 0.45, 7), np.linspace(-0.45, 0.45, 5))
    grid = np.column_stack([gx.ravel() * l, gy.ravel() * w, np.zeros(gx.size)])

    for attempt in range(1, rules.max_attempts + 1):
        idx = candidates[rng.integers(len(candidates))]
        point = cloud.vehicle[idx].astype(float)
        # 1. local ground
        near = allowed_pts[(np.abs(allowed_pts[:, 0] - point[0]) <= reach)
                           & (np.abs(allowed_pts[:, 1] - point[1]) <= reach)]
        if len(near) < rules.min_ground_points:
            rejections["too few ground points"] += 1
            continue
        fit = fit_ground(near.astype(float))
        if fit is None:
            rejections["too few ground points"] += 1
            continue
        (a, b, c), rms, _ = fit
        normal = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
        if rms > rules.max_ground_rms:
            rejections["ground not flat (rms too high)"] += 1
            continue
        if math.degrees(math.acos(normal[2])) > rules.max_ground_tilt_deg:
            rejections["ground too steep"] += 1
            continue
        position = np.array([point[0], point[1], a * point[0] + b * point[1] + c])
        yaw = _yaw_for(orientation, rng, jitter, position, camera)
        m = pose_matrix(position, normal, yaw)
        # 2. whole object inside the image, in front of the camera
        corners = np.array([[sx * l / 2, sy * w / 2, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0, h)])
        corners_v = corners @ m[:3, :3].T + m[:3, 3]
        corners_o = corners_v @ opt_from_v[:3, :3].T + opt_from_v[:3, 3]
        if (corners_o[:, 2] <= 1.0).any():
            rejections["partly behind the camera"] += 1
            continue
        uv = camera.project(corners_o)
        if (uv[:, 0] < 0).any() or (uv[:, 0] > W - 1).any() or (uv[:, 1] < 0).any() or (uv[:, 1] > H - 1).any():
            rejections["not fully inside the image"] += 1
            continue
        # 3. footprint on allowed labels (where the ground there is seen)
        foot_v = grid @ m[:3, :3].T + m[:3, 3]
        foot_o = foot_v @ opt_from_v[:3, :3].T + opt_from_v[:3, 3]
        fuv = np.rint(camera.project(foot_o)).astype(int)
        fu, fv = np.clip(fuv[:, 0], 0, W - 1), np.clip(fuv[:, 1], 0, H - 1)
        seen = depth[fv, fu] >= foot_o[:, 2] * 0.97 - 0.1
        if seen.sum() < 0.3 * len(seen):
            rejections["footprint hidden"] += 1
            continue
        share = np.isin(label_ids[fv, fu][seen], allowed_ids).mean()
        if share < rules.min_footprint_allowed:
            rejections["footprint off the allowed surface"] += 1
            continue
        # 4. other objects of this frame
        mine = _footprint_2d(m, extents)
        if any(footprints_overlap(mine, o) for o in other_prints):
            rejections["overlaps another inserted object"] += 1
            continue
        # 5. scene points: lenient pre-filter, then strict test on the suspects
        suspects = prefilter(cloud.vehicle, m, extents, rules.clearance, rules.margin)
        inside = strict_inside(cloud.vehicle[suspects].astype(float), m, extents, rules.clearance, rules.margin)
        if inside.sum() >= rules.min_collision_points:
            rejections["intersects the scene"] += 1
            continue
        dist = float(math.hypot(position[0] - camera.x, position[1] - camera.y))
        placement = Placement(
            class_name=class_name, extents=tuple(float(e) for e in extents),
            vehicle_from_object=tuple(tuple(float(v) for v in row) for row in m),
            yaw=float(math.atan2(m[1, 0], m[0, 0])), ground_normal=tuple(float(v) for v in normal),
            ground_rms=rms, distance=dist, pixel=(int(cloud.pixels[idx, 0]), int(cloud.pixels[idx, 1])))
        return PlacementResult(placement, attempt, dict(rejections))
    return PlacementResult(None, rules.max_attempts, dict(rejections))
