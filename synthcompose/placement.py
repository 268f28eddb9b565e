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
#: a footprint sample is on the real ground when |scene depth - its depth| <= REL * depth + ABS
#: (a 15 cm kerb drop seen from 1.2 m moves the ground ~14% further away)
SUPPORT_TOL_REL = 0.02
SUPPORT_TOL_ABS = 0.05
#: a ground point is on the fitted plane when within this height of it, metres
INLIER_BAND = 0.04
#: default orientation rule per class: along the road, facing the camera, or random
ORIENTATION: dict[str, str] = {"person": "random", "traffic sign": "face-camera", "traffic light": "face-camera"}


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
    # near ground covers far more pixels than far ground: weight pixels by depth^2 so that
    # distances come out roughly evenly spread over the allowed range
    cdf = np.cumsum(cloud.optical[candidates, 2].astype(np.float64) ** 2)
    allowed_pts = cloud.vehicle[on_allowed]
    jitter = math.radians(rules.yaw_jitter_deg)
    min_up = math.cos(math.radians(2 * rules.max_ground_tilt_deg))
    l, w, h = extents
    reach = math.hypot(l, w) / 2 + 0.5
    other_prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]
    H, W = label_ids.shape
    opt_from_v = camera.optical_from_vehicle
    fm = rules.footprint_margin
    gx, gy = np.meshgrid(np.linspace(-l / 2 - fm, l / 2 + fm, 9), np.linspace(-w / 2 - fm, w / 2 + fm, 5))
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])

    corners = np.array([[sx * l / 2, sy * w / 2, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0, h)])

    def image_check(m: np.ndarray) -> str | None:
        """Cheap tests in the image: whole object on screen, footprint on seen allowed ground."""
        corners_o = corners @ (opt_from_v @ m)[:3, :3].T + (opt_from_v @ m)[:3, 3]
        if (corners_o[:, 2] <= 1.0).any():
            return "partly behind the camera"
        uv = camera.project(corners_o)
        if (uv[:, 0] < 0).any() or (uv[:, 0] > W - 1).any() or (uv[:, 1] < 0).any() or (uv[:, 1] > H - 1).any():
            return "not fully inside the image"
        foot_o = grid @ (opt_from_v @ m)[:3, :3].T + (opt_from_v @ m)[:3, 3]
        fuv = np.rint(camera.project(foot_o)).astype(int)
        fu, fv = np.clip(fuv[:, 0], 0, W - 1), np.clip(fuv[:, 1], 0, H - 1)
        scene_d, foot_d = depth[fv, fu], foot_o[:, 2]
        tol = SUPPORT_TOL_REL * foot_d + SUPPORT_TOL_ABS
        seen = scene_d >= foot_d - tol  # not hidden behind something nearer
        if seen.sum() < 0.3 * len(seen):
            return "footprint hidden"
        # a seen sample is supported when the real ground is there: allowed label, same
        # depth, and a ground-like surface (not the face of a kerb)
        supported = np.isin(label_ids[fv, fu], allowed_ids) & (scene_d <= foot_d + tol)
        supported &= surface_normals(depth, camera, fv, fu)[:, 2] >= min_up
        if supported[seen].mean() < rules.min_footprint_allowed:
            return "footprint off the allowed surface"
        return None

    for attempt in range(1, rules.max_attempts + 1):
        idx = candidates[np.searchsorted(cdf, rng.random() * cdf[-1], side="right")]
        point = cloud.vehicle[idx].astype(float)
        # 1. the candidate pixel must be ground-like, not a kerb face or a wall
        n_here = surface_normals(depth, camera, cloud.pixels[idx:idx + 1, 0], cloud.pixels[idx:idx + 1, 1])[0]
        if not n_here[2] >= min_up:  # NaN-safe
            rejections["candidate surface not horizontal"] += 1
            continue
        yaw = _yaw_for(orientation, rng, jitter, point, camera)
        # 2. cheap image-space tests on a provisional pose (the pixel's own normal)
        why = image_check(pose_matrix(point, n_here, yaw))
        if why:
            rejections[why] += 1
            continue
        # 3. the local ground: robust plane through the allowed points around the candidate
        near = allowed_pts[(np.abs(allowed_pts[:, 0] - point[0]) <= reach)
                           & (np.abs(allowed_pts[:, 1] - point[1]) <= reach)]
        fit = fit_ground(near.astype(float), point) if len(near) >= rules.min_ground_points else None
        if fit is None:
            rejections["too few ground points"] += 1
            continue
        (a, b, c), rms, inliers = fit
        normal = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
        ground_z = a * point[0] + b * point[1] + c
        why = None
        if inliers < rules.min_ground_inliers * len(near):
            why = "ground not planar (step or kerb)"
        elif rms > rules.max_ground_rms:
            why = "ground not flat (rms too high)"
        elif math.degrees(math.acos(normal[2])) > rules.max_ground_tilt_deg:
            why = "ground too steep"
        elif abs(point[2] - ground_z) > rules.max_ground_rms + 0.02:
            why = "candidate point is off the fitted ground (kerb face, noise)"
        if why:
            rejections[why] += 1
            continue
        position = np.array([point[0], point[1], ground_z])
        m = pose_matrix(position, normal, yaw)
        why = image_check(m)  # again, on the final pose
        if why:
            rejections[why] += 1
            continue
        # 4. other objects of this frame
        mine = footprint_corners(m, extents, rules.object_gap / 2)
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
