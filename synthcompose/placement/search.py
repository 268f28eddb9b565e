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

from synthcompose.geometry.depth import Frame, back_project, nearest_in_row, pinhole
from synthcompose.labels import label_id

from .boxes import footprint_corners, pose_matrix
from .poses import PoseTests, check_pose
from .rules import (
    GROUND_LEVEL,
    ORIENTATIONS,
    UPRIGHT,
    Placement,
    PlacementResult,
    PlacementRules,
    Rejection,
    label_mask,
    orientation_for,
    surfaces_for,
)
from .traffic import TRAFFIC_ORIENTATIONS, hand_of, person_spot, sign_spot, street_of, traffic_candidates, vehicle_spot

UP = np.array([0.0, 0.0, 1.0])
#: candidates are drawn among every STRIDE-th pixel of each row and column
STRIDE = 2
#: a candidate whose object's top leaves the image even this much further away (metres) is
#: not drawn when truncation is off (its point may move that far before the pose is tested)
TOP_SLACK = 1.0


def candidates(frame: Frame, allowed_ids: np.ndarray, distance: tuple[float, float]) -> "_Candidates":
    """The frame's candidate pixels for one surface and distance range (cached on the frame)."""
    key = ("candidates", tuple(int(i) for i in allowed_ids), tuple(float(d) for d in distance))
    return frame.derived(key, lambda: _Candidates(frame, allowed_ids, distance))


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
        self.xy = np.column_stack([ground_x[keep] + np.float32(cam.x), ground_y[keep] + np.float32(cam.y)])
        self.ground_z = (x * m[2, 0] + y * m[2, 1] + z * m[2, 2] + m[2, 3])[keep]
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
        return self.subset(self.room >= 0.9 * self.camera.fx * half_size / self.z)

    def top_in_image(self, frame: Frame, height: float) -> np.ndarray:
        """(N,) bool: the candidates whose top, ``height`` metres over them, is seen below the
        image's top row even TOP_SLACK metres further from the camera (a candidate is moved to
        its lane's centre or the kerb before it is posed): a box whose top leaves the image is
        not fully inside it."""
        cam = self.camera
        away = self.xy - np.array([cam.x, cam.y], np.float32)
        away *= (TOP_SLACK / np.maximum(np.hypot(away[:, 0], away[:, 1]), 1e-3))[:, None]
        top = np.column_stack([self.xy + away, self.ground_z + np.float32(height)]).astype(np.float64)
        return cam.project(frame.to_optical(top))[:, 1] >= 0

    def subset(self, keep: np.ndarray) -> "_Candidates":
        """The candidates where ``keep`` (N,) holds; the same pool when none or all do."""
        if not keep.any() or keep.all():
            return self
        sub = object.__new__(_Candidates)
        sub.camera, sub.depth = self.camera, self.depth
        sub.rows, sub.cols, sub.z, sub.room, sub.weight, sub.xy, sub.ground_z = (
            a[keep] for a in (self.rows, self.cols, self.z, self.room, self.weight, self.xy, self.ground_z))
        sub.cdf = np.cumsum(sub.weight)
        return sub

    def draw(self, rng: np.random.Generator) -> int:
        return int(np.searchsorted(self.cdf, rng.random() * self.cdf[-1], side="right"))

    def point(self, idx: int) -> np.ndarray:
        """(3,) vehicle-frame point of candidate ``idx``."""
        return back_project(self.depth, self.camera, self.rows[idx:idx + 1], self.cols[idx:idx + 1])[1][0]


def no_ground(frame: Frame, class_name: str, allowed: Sequence[str] | None, rules: PlacementRules) -> str | None:
    """Why an object of ``class_name`` can stand nowhere in the frame before any candidate is
    drawn (the frame shows none of its surfaces with valid depth in the distance range), or
    None. The search's own first test; the cast draws no such object (stages/place.py)."""
    allowed = surfaces_for(class_name, allowed)
    if len(candidates(frame, np.array([label_id(n) for n in allowed]), rules.distance)):
        return None
    lo, hi = rules.distance
    return f"no {'/'.join(allowed)} pixel with valid depth within {lo}-{hi} m"


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


def _seen_ground(frame: Frame, point: np.ndarray, allowed_ids: np.ndarray, noise, floor: float = 0.3
                 ) -> np.ndarray | None:
    """The real ground point (V) seen at ``point``'s place on the ground plan (a candidate moved
    to its place in traffic): the pixel it projects to, its real point's height taken and the
    projection done again (the ground there may be higher or lower than where it was drawn).
    None when that pixel is not allowed ground or its real point stays farther away on the
    ground plan than the stereo's depth band there (at least ``floor`` metres): the place is
    hidden, or across a kerb (15 cm at a grazing angle moves the ground seen by metres)."""
    cam = frame.camera
    H, W = frame.shape
    lut = label_mask(allowed_ids)
    p = np.array(point, float)
    for _ in range(3):
        uv = cam.project(frame.to_optical(p[None]))[0]
        if not np.isfinite(uv).all():
            return None
        u, v = int(round(uv[0])), int(round(uv[1]))
        if not (0 <= u < W and 0 <= v < H) or not np.isfinite(frame.depth[v, u]) or not lut[frame.label_ids[v, u]]:
            return None
        real = back_project(frame.depth, cam, np.array([v]), np.array([u]))[1][0].astype(float)
        tol = float(noise.depth_band(float(frame.depth[v, u]), floor))
        if math.hypot(real[0] - p[0], real[1] - p[1]) <= tol:
            return np.array([p[0], p[1], real[2]])
        p[2] = real[2]
    return None


def _turned(frame: Frame, street, point: np.ndarray, orientation: str, extents, rng: np.random.Generator,
            jitter: float, hand: int, pose_hint: str | None, allowed_ids: np.ndarray, noise):
    """A candidate's place and heading: (point, yaw, road yaw or None, traffic claim or None), or
    the Rejection. With traffic sense the candidate moves to its place in the lane or at the kerb
    (traffic.py); without, it is turned towards the camera or at random."""
    if orientation == "random":
        return point, float(rng.uniform(-math.pi, math.pi)), None, None
    if orientation == "face-camera":
        to_cam = frame.camera.position[:2] - point[:2]
        return point, math.atan2(to_cam[1], to_cam[0]) + float(rng.normal(0.0, jitter)), None, None
    if orientation == "pedestrian":
        spot = person_spot(frame, street, point, rng, hand, pose_hint)
    elif orientation == "facing-traffic":
        spot = sign_spot(frame, street, point, extents, rng, jitter, hand, pose_hint)
    else:
        spot = vehicle_spot(frame, street, point, extents, orientation, rng, jitter, hand)
    if isinstance(spot, Rejection):
        return spot
    moved, yaw, claim = spot
    seen = _seen_ground(frame, moved, allowed_ids, noise)
    if seen is None:
        return Rejection("its place in traffic is not seen on the ground")
    return seen, yaw, math.radians(claim.heading_deg), claim


def _posed(frame: Frame, tests: PoseTests, point: np.ndarray, yaw: float, rules: PlacementRules, class_name: str,
           extents, allowed, orientation: str, claim, others: Sequence[Placement], other_prints: list):
    """The candidate's pose on its local ground through every test: (matrix, position, ground,
    share in the image, hidden share), or the first Rejection."""
    # 1. cheap image tests on a provisional level pose: in view, footprint on allowed ground
    why = tests.image(pose_matrix(point, UP, yaw), heights=False)
    if why:
        return why
    # 2. the local ground: robust plane through the allowed points around the candidate
    ground, why = tests.ground(point)
    if why is None and tests.off_ground(point, ground, rules.max_ground_rms + 0.02) is not None:
        why = Rejection("candidate point is off the fitted ground (kerb face, noise)")
    if why:
        return why
    position = np.array([point[0], point[1], ground.height(point[0], point[1])])
    # vehicles lie on the ground's plane; a pole and a person stand plumb (gravity), on a slope too
    m = pose_matrix(position, UP if class_name in UPRIGHT else ground.normal, yaw)
    # 3. the image tests on the final pose (with heights), then the visibility rules
    why = tests.image(m)
    if why:
        return why
    why, in_image, hidden = tests.visibility(m, others)
    if why:
        return why
    # 4. other objects of this frame; 5. scene points inside the box; 6. the pose as the
    # checker sees it: the same rules on the pose given outright, traffic included (one
    # rule set: what placement returns, check-placement --strict accepts)
    why = tests.overlap(m, other_prints, others) or tests.scene(m) \
        or check_pose(frame, class_name, extents, m, rules, allowed, others, orientation, claim)
    if why:
        return why
    return m, position, ground, in_image, hidden


def place_object(frame: Frame, class_name: str, extents: tuple[float, float, float], rng: np.random.Generator,
                 rules: PlacementRules, allowed: Sequence[str] | None = None, orientation: str | None = None,
                 others: Sequence[Placement] = (), trace: list | None = None,
                 pose_hint: str | None = None) -> PlacementResult:
    """Find a pose for one object of ``extents`` (l, w, h metres) in the frame, or say why not.
    ``pose_hint``: a person's pose, decided (and its model posed) before the placement
    (``walking`` / ``standing``): the person is placed as that pose stands in traffic; ``away``:
    a sign that shows its back to the ego vehicle's way (the cast's ``faces``: no entry).

    ``trace``: when a list, gets (candidate point (3,) in V, rejection reason) per rejected
    candidate (the preview shows them); the result does not depend on it."""
    allowed = surfaces_for(class_name, allowed)
    orientation = orientation_for(class_name, orientation)
    if orientation not in ORIENTATIONS:
        raise ValueError(f"unknown orientation {orientation!r}")
    allowed_ids = np.array([label_id(n) for n in allowed])
    camera = frame.camera
    rejections: Counter[str] = Counter() if trace is None else _TracedCounter(trace)
    pool = candidates(frame, allowed_ids, rules.distance)
    if len(pool) == 0:
        rejections[no_ground(frame, class_name, allowed, rules)] += 1
        return PlacementResult(None, 0, dict(rejections))
    pool = pool.fitting(min(extents[0], extents[1]) / 2)
    if not rules.allow_truncation:  # a tall sign near the camera leaves the image at the top
        pool = pool.subset(pool.top_in_image(frame, extents[2]))
    tests = PoseTests.of(frame, extents, rules, allowed, class_name)
    jitter = math.radians(rules.yaw_jitter_deg)
    other_prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]

    hand = hand_of(rules.traffic)
    street = street_of(frame, rules.traffic) if orientation in TRAFFIC_ORIENTATIONS else None
    if street is not None:  # only where the object can stand in traffic (a necessary condition)
        pool = pool.subset(traffic_candidates(frame, street, pool.xy, orientation, extents, hand))

    for attempt in range(1, rules.max_attempts + 1):
        idx = pool.draw(rng)
        point = pool.point(idx).astype(float)
        if trace is not None:  # preview: where this candidate was
            rejections.point = point
        turned = _turned(frame, street, point, orientation, extents, rng, jitter, hand, pose_hint, allowed_ids,
                         tests.noise)
        if isinstance(turned, Rejection):
            rejections[turned.reason] += 1
            continue
        point, yaw, road_yaw, claim = turned
        posed = _posed(frame, tests, point, yaw, rules, class_name, extents, allowed, orientation, claim, others,
                       other_prints)
        if isinstance(posed, Rejection):
            rejections[posed.reason] += 1
            continue
        m, position, ground, in_image, hidden = posed
        uv = camera.project(frame.to_optical(position[None]))[0]
        row = int(np.clip(round(uv[1]), 0, frame.shape[0] - 1))
        col = int(np.clip(round(uv[0]), 0, frame.shape[1] - 1))
        placement = Placement(
            class_name=class_name, extents=tuple(float(e) for e in extents),
            vehicle_from_object=tuple(tuple(float(v) for v in r) for r in m),
            yaw=float(math.atan2(m[1, 0], m[0, 0])), road_yaw=road_yaw,
            ground_normal=tuple(float(v) for v in ground.normal), ground_rms=ground.rms,
            distance=float(math.hypot(position[0] - camera.x, position[1] - camera.y)),
            pixel=(row, col), occluded_estimate=hidden, truncated=in_image < 1.0, traffic=claim)
        return PlacementResult(placement, attempt, dict(rejections))
    return PlacementResult(None, rules.max_attempts, dict(rejections))
