"""The search: candidates drawn among the allowed ground pixels, each run through the rules.

For each object, candidates are drawn at random among pixels of an allowed surface (by label)
with valid depth, weighted so distances spread over the allowed range, and only where the
object can fit: along the pixel's row the allowed surface (or something standing on it) must
reach at least the object's smallest half-size on both sides, inside the image (a necessary
condition for any yaw: it only spares attempts on spots every rule would reject). A candidate is
oriented (along the local road direction, towards the camera, or at random), then must pass,
cheapest first (poses.py):

1. on a provisional level pose: the object in front of the camera and inside the image (or
   truncated, if allowed), its footprint on seen, allowed ground;
2. a robust plane fit of the allowed ground around it over a metric neighbourhood (the object
   stands on that plane: contact, pitch and roll follow it), rejected when too few points, a
   step, rough or steep for the stereo noise at its depth; the candidate point on that plane;
3. the image tests on the final pose, now with the real ground's height under the footprint;
   the visibility rules (visible pixels, occluded share) estimated against the real depth;
4. no overlap with objects already placed in the frame;
5. no scene point inside its box: the pixel grid is the spatial index (every point inside
   the box projects inside the box's image rectangle), then the strict oriented-box test.

No rule looks at pixel-to-pixel differences of the depth: real stereo is too noisy for them.
Every rejection is counted by reason and returned with the result.
"""
from __future__ import annotations

import math
from collections import Counter
from typing import Sequence

import numpy as np

from ..geometry import Frame, back_project, nearest_in_row, pinhole
from ..labels import label_id
from .boxes import footprint_corners, pose_matrix
from .poses import PoseTests
from .road import road_line
from .rules import (GROUND_LEVEL, ORIENTATIONS, Placement, PlacementResult,
                    PlacementRules, Rejection, label_mask, orientation_for, surfaces_for)

UP = np.array([0.0, 0.0, 1.0])
#: candidates are drawn among every STRIDE-th pixel of each row and column
STRIDE = 2


def candidates(frame: Frame, allowed_ids: np.ndarray, distance: tuple[float, float]) -> "_Candidates":
    """The frame's candidate pixels for one surface and distance range (cached on the frame)."""
    key = ("candidates", tuple(int(i) for i in allowed_ids), tuple(float(d) for d in distance))
    if key not in frame.cache:
        frame.cache[key] = _Candidates(frame, allowed_ids, distance)
    return frame.cache[key]


class _Candidates:
    """Allowed-surface pixels of one frame with known depth in the distance range, sampled with
    weight depth^2 (near ground covers far more pixels than far ground: this spreads distances
    evenly). Only the ground distance of each pixel is worked out here (an image's road is
    most of a million pixels); a drawn pixel is back-projected when drawn.

    rows, cols (N,) the pixels; z (N,) their depth; room (N,) pixels of allowed row around each
    (the nearer side); cdf (N,) cumulative weights."""

    def __init__(self, frame: Frame, allowed_ids: np.ndarray, distance: tuple[float, float]) -> None:
        lo, hi = distance
        cam = self.camera = frame.camera
        self.depth = frame.depth
        # every other row and column: a quarter of the cost, and still far more candidates
        # than any search draws
        v, u = np.nonzero(label_mask(allowed_ids)[frame.label_ids[::STRIDE, ::STRIDE]]
                          & np.isfinite(frame.depth[::STRIDE, ::STRIDE]))
        v, u = v * STRIDE, u * STRIDE
        x, y, z = pinhole(frame.depth, cam, v, u)
        m = cam.vehicle_from_optical.astype(np.float32)
        ground_x = x * m[0, 0] + y * m[0, 1] + z * m[0, 2] + (m[0, 3] - np.float32(cam.x))
        ground_y = x * m[1, 0] + y * m[1, 1] + z * m[1, 2] + (m[1, 3] - np.float32(cam.y))
        dist = np.hypot(ground_x, ground_y)
        keep = (dist >= lo) & (dist <= hi)
        self.rows, self.cols, self.z = v[keep], u[keep], z[keep]
        # room along the row (pixels) to the nearest other ground surface, or the image border
        left, right = _row_room(_blocking(frame.label_ids[::STRIDE, ::STRIDE], frame.labelled, allowed_ids))
        self.room = np.minimum(left, right)[v[keep] // STRIDE, u[keep] // STRIDE] * STRIDE
        self.weight = np.square(z[keep], dtype=np.float64)
        self.cdf = np.cumsum(self.weight)

    def __len__(self) -> int:
        return len(self.rows)

    def fitting(self, half_size: float) -> "_Candidates":
        """The candidates with room for ``half_size`` metres on both sides along their row
        (90 % of it, for the foreshortening of a footprint turned across the view); the same
        pool when none has."""
        fits = self.room >= 0.9 * self.camera.fx * half_size / self.z
        if not fits.any() or fits.all():
            return self
        sub = object.__new__(_Candidates)
        sub.camera, sub.depth = self.camera, self.depth
        sub.rows, sub.cols, sub.z, sub.room, sub.weight = (a[fits] for a in (self.rows, self.cols, self.z,
                                                                            self.room, self.weight))
        sub.cdf = np.cumsum(sub.weight)
        return sub

    def draw(self, rng: np.random.Generator) -> int:
        return int(np.searchsorted(self.cdf, rng.random() * self.cdf[-1], side="right"))

    def point(self, idx: int) -> np.ndarray:
        """(3,) vehicle-frame point of candidate ``idx``."""
        return back_project(self.depth, self.camera, self.rows[idx:idx + 1], self.cols[idx:idx + 1])[1][0]


def _blocking(label_ids: np.ndarray, labelled: bool, allowed_ids: np.ndarray) -> np.ndarray:
    """Bool mask of the pixels of ``label_ids`` a footprint on the allowed surface cannot cover:
    other ground-level surfaces (a footprint sample hidden by something standing there is not
    held against it). A frame without labels knows only its road and sidewalk: everything else
    blocks."""
    if not labelled:
        return ~label_mask(allowed_ids)[label_ids]
    return (label_mask([label_id(n) for n in GROUND_LEVEL]) & ~label_mask(allowed_ids))[label_ids]


def _row_room(blocking: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) distance in pixels from each pixel to the nearest blocking pixel (or the
    image border) along its row."""
    last, first = nearest_in_row(blocking)
    cols = np.arange(blocking.shape[1], dtype=np.int32)
    return cols - last, first - cols


class _TracedCounter(Counter):
    """Rejection counter that also lists (candidate point in V, reason) for the preview."""

    def __init__(self, trace: list) -> None:
        super().__init__()
        self.trace, self.point = trace, None

    def __setitem__(self, key, value) -> None:
        if value > self.get(key, 0) and self.point is not None:
            self.trace.append((self.point, key))
        super().__setitem__(key, value)


def place_object(frame: Frame, class_name: str, extents: tuple[float, float, float], rng: np.random.Generator,
                 rules: PlacementRules, allowed: Sequence[str] | None = None, orientation: str | None = None,
                 others: Sequence[Placement] = (), trace: list | None = None) -> PlacementResult:
    """Find a pose for one object of ``extents`` (l, w, h metres) in the frame, or say why not.

    ``trace``: when a list, gets (candidate point (3,) in V, rejection reason) per rejected
    candidate (the preview shows them); the result does not depend on it."""
    allowed = surfaces_for(class_name, allowed)
    orientation = orientation_for(class_name, orientation)
    if orientation not in ORIENTATIONS:
        raise ValueError(f"unknown orientation {orientation!r}")
    allowed_ids = np.array([label_id(n) for n in allowed])
    camera, depth = frame.camera, frame.depth
    rejections: Counter[str] = Counter() if trace is None else _TracedCounter(trace)
    pool = candidates(frame, allowed_ids, rules.distance)
    lo, hi = rules.distance
    if len(pool) == 0:
        rejections[f"no {'/'.join(allowed)} pixel with valid depth within {lo}-{hi} m"] += 1
        return PlacementResult(None, 0, dict(rejections))
    pool = pool.fitting(min(extents[0], extents[1]) / 2)
    tests = PoseTests.of(frame, extents, rules, allowed)
    jitter = math.radians(rules.yaw_jitter_deg)
    l, w, h = extents
    other_prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]

    for attempt in range(1, rules.max_attempts + 1):
        idx = pool.draw(rng)
        point = pool.point(idx).astype(float)
        row, col = int(pool.rows[idx]), int(pool.cols[idx])
        if trace is not None:  # preview: where this candidate was
            rejections.point = point
        # orientation
        road_yaw = None
        if orientation == "random":
            yaw = float(rng.uniform(-math.pi, math.pi))
        elif orientation == "face-camera":
            to_cam = camera.position[:2] - point[:2]
            yaw = math.atan2(to_cam[1], to_cam[0]) + float(rng.normal(0.0, jitter))
        else:
            line = road_line(frame, allowed_ids, point)
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
        # 1. cheap image tests on a provisional level pose: in view, footprint on allowed ground
        why = tests.image(pose_matrix(point, UP, yaw), heights=False)
        if why:
            rejections[why.reason] += 1
            continue
        # 2. the local ground: robust plane through the allowed points around the candidate
        ground, why = tests.ground(point)
        if why is None and tests.off_ground(point, ground, rules.max_ground_rms + 0.02) is not None:
            why = Rejection("candidate point is off the fitted ground (kerb face, noise)")
        if why:
            rejections[why.reason] += 1
            continue
        position = np.array([point[0], point[1], ground.height(point[0], point[1])])
        m = pose_matrix(position, ground.normal, yaw)
        # 3. the image tests on the final pose (with heights), then the visibility rules
        why = tests.image(m)
        if why:
            rejections[why.reason] += 1
            continue
        why, in_image, hidden = tests.visibility(m, others)
        if why:
            rejections[why.reason] += 1
            continue
        # 4. other objects of this frame; 5. scene points inside the box
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
