"""The rules of one pose, cheapest first: in view, footprint support, local ground, visibility,
other objects, the scene inside the box. :func:`place_object` (search.py) runs them on its
candidates, :func:`check_pose` on a pose given outright (an object moved by hand in the preview).

Every comparison of a pose with the real depth allows the stereo noise at that depth
(noise.py): depth bands grow with z², height bands with z.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .boxes import (
    box_corners,
    box_samples,
    footprint_corners,
    footprint_grid,
    footprints_overlap,
    hides_others,
    penetration,
    rays_hit_box,
    strict_inside,
    visibility_of,
)
from .ground import GroundFit, local_ground
from .noise import StereoNoise, stereo_noise
from .road import surface_edges

if TYPE_CHECKING:
    from .claim import Traffic
from .rules import (
    GROUND_LEVEL,
    KERB_CLEARANCE,
    MAX_PENETRATION,
    POSE_GROUND_SEARCH,
    SUPPORT_BAND,
    Placement,
    PlacementRules,
    Rejection,
    label_mask,
    standing_footprint,
    surfaces_for,
)

#: a footprint sample is seen when the real depth there is not nearer than the sample by more
#: than this (relative, absolute) or the stereo band
SEEN_TOL_REL, SEEN_TOL_ABS = 0.02, 0.05
#: a real point nearer than a footprint sample but lower than this above the pose's plane is
#: ground (a kerb, a raised sidewalk), not an occluder: it counts as seen and unsupported
STEP_HEIGHT = 0.3
#: the scene test samples the box's pixel rectangle at about this spacing, metres
SCENE_SPACING = 0.03
#: people stand at least this far apart (unless the object gap asks for more), metres
PEOPLE_GAP = 0.5
#: a sign's plate is never hidden behind an inserted object beyond this share of it
SIGN_HIDDEN = 0.1
#: a sign's plate: the top of its box, this share of its height (the cast's plates hang from
#: 2.0-2.2 m on poles 2.6-2.9 m tall); its pole may stand behind a car, as real poles do
SIGN_PLATE = 0.3
SIGNS = ("traffic sign", "traffic light")


def frame_noise(frame: Frame) -> StereoNoise:
    """The frame's stereo noise, measured on all of its ground-level labels."""
    return stereo_noise(frame, [label_id(n) for n in GROUND_LEVEL])


def footprint_support(frame: Frame, m: np.ndarray, local: np.ndarray, allowed_ids: np.ndarray,
                      noise: StereoNoise, band_floor: float = SUPPORT_BAND) -> dict[str, np.ndarray] | None:
    """For footprint samples ``local`` ((N, 3), object frame, z = 0) of the pose ``m``: which
    are on screen, seen (not behind something nearer that is not ground), on allowed labels,
    and on the pose's plane (real point within the height band). None when none is on screen.
    The placement and the checker share this definition."""
    cam, depth = frame.camera, frame.depth
    H, W = frame.shape
    foot_o = frame.to_optical(local @ m[:3, :3].T + m[:3, 3])
    with np.errstate(invalid="ignore"):
        fuv = np.rint(cam.project(foot_o)).astype(int)
    on_screen = (foot_o[:, 2] > 0.1) & (fuv[:, 0] >= 0) & (fuv[:, 0] < W) & (fuv[:, 1] >= 0) & (fuv[:, 1] < H)
    if not on_screen.any():
        return None
    fu, fv, foot_d = fuv[on_screen, 0], fuv[on_screen, 1], foot_o[on_screen, 2]
    scene_d = depth[fv, fu].astype(np.float64)
    finite = np.isfinite(scene_d)
    # the real point at each sample's pixel, and its height above the pose's plane
    z = np.where(finite, scene_d, 0.0)
    real_o = np.column_stack([(fu - cam.u0) * z / cam.fx, (fv - cam.v0) * z / cam.fy, z])
    real_v = real_o @ cam.vehicle_from_optical[:3, :3].T + cam.vehicle_from_optical[:3, 3]
    height = (real_v - m[:3, 3]) @ m[:3, 2]
    tol = noise.depth_band(foot_d, SEEN_TOL_REL * foot_d + SEEN_TOL_ABS)
    seen = finite & ((scene_d >= foot_d - tol) | (height < STEP_HEIGHT))
    allowed = label_mask(allowed_ids)[frame.label_ids[fv, fu]]
    # supported: the real ground at the sample is on the pose's plane, and there (at its
    # depth): ground of the same height farther away is no support (a footprint floating over
    # a lower road towards a sidewalk behind it)
    # (along the ray, the ground seen at a grazing angle moves by the height band's worth)
    band = noise.height_band(foot_d, band_floor)
    at_foot = np.abs(z - foot_d) <= np.maximum(tol, 1.5 * band * foot_d / noise.camera_height)
    on_plane = finite & at_foot & (np.abs(height) <= band)
    return {"on_screen": on_screen, "seen": seen, "allowed": allowed, "on_plane": on_plane}


@dataclass(frozen=True, eq=False)
class PoseTests:
    """The placement rules for poses of one object (``extents``, l, w, h metres) in one frame,
    cheapest first. Each returns a :class:`Rejection` or None."""

    frame: Frame
    extents: tuple[float, float, float]
    rules: PlacementRules
    allowed: tuple[str, ...]
    allowed_ids: np.ndarray
    edges: np.ndarray  # (N, 2) kerb-line points of the allowed surface (ground plan)
    grid: np.ndarray  # (2N, 3) footprint samples (object frame): the checker's N, then N reaching
    # footprint_margin beyond
    reach: float  # half-side of the square searched for ground points, metres
    noise: StereoNoise
    class_name: str = ""

    @classmethod
    def of(cls, frame: Frame, extents, rules: PlacementRules, allowed: Sequence[str],
           class_name: str = "") -> "PoseTests":
        allowed_ids = np.array([label_id(n) for n in allowed])
        l, w, _ = extents
        fl, fw = standing_footprint(class_name, extents)
        grid = np.concatenate([footprint_grid(fl, fw), footprint_grid(fl, fw, rules.footprint_margin)])
        return cls(frame, extents, rules, tuple(allowed), allowed_ids, surface_edges(frame, allowed_ids), grid,
                   math.hypot(l, w) / 2 + 0.5, frame_noise(frame), class_name)

    def depth_of(self, point: np.ndarray) -> float:
        return float(self.frame.to_optical(np.asarray(point, float)[None])[0, 2])

    def image(self, m: np.ndarray, heights: bool = True) -> Rejection | None:
        """Tests in the image: object on screen, footprint on seen, allowed ground (and, with
        ``heights``, on the pose's plane: no step or kerb under it), no kerb line under it."""
        frame, rules, camera = self.frame, self.rules, self.frame.camera
        H, W = frame.shape
        corners_o = frame.to_optical(box_corners(m, self.extents))
        if (corners_o[:, 2] <= 1.0).any():
            return Rejection("partly behind the camera", f"a corner {corners_o[:, 2].min():.2f} m in front of it")
        uv = camera.project(corners_o)
        out = (uv[:, 0] < 0).any() or (uv[:, 0] > W - 1).any() or (uv[:, 1] < 0).any() or (uv[:, 1] > H - 1).any()
        if out and not rules.allow_truncation:
            return Rejection("not fully inside the image", "the box crosses the image border and truncation is off")
        s = footprint_support(frame, m, self.grid, self.allowed_ids, self.noise)
        if s is None or s["on_screen"].mean() < 0.5:
            share = 0.0 if s is None else s["on_screen"].mean()
            return Rejection("footprint outside the image", f"{share:.0%} of it on screen, needs 50%")
        seen = s["seen"]
        if seen.sum() < 0.3 * len(seen):
            return Rejection("footprint hidden", f"{seen.mean():.0%} of it seen, needs 30%")
        # on the footprint itself (the checker's grid) and with the margin around it
        inner = np.arange(len(seen)) < len(self.grid) // 2
        share = min(s["allowed"][seen].mean(), s["allowed"][seen & inner].mean() if (seen & inner).any() else 0.0)
        if share < rules.min_footprint_allowed:
            return Rejection("footprint off the allowed surface",
                             f"{share:.0%} of the seen footprint on {'/'.join(self.allowed)}, "
                             f"needs {rules.min_footprint_allowed:.0%}")
        if heights:
            level = s["on_plane"][seen].mean()
            if level < rules.min_footprint_allowed:
                return Rejection("footprint off the ground plane (step or kerb)",
                                 f"{level:.0%} of the seen footprint on the pose's plane, "
                                 f"needs {rules.min_footprint_allowed:.0%}")
            # on the final pose only (the search's first, level pose would ask it again)
            if (why := self._along_the_ray(m)) is not None:
                return why
        # no kerb line of the surface under the part that stands on the ground
        fl, fw = standing_footprint(self.class_name, self.extents)
        c, edges, reach = m[:3, 3], self.edges, self.reach
        close = edges[(np.abs(edges[:, 0] - c[0]) <= reach + 1) & (np.abs(edges[:, 1] - c[1]) <= reach + 1)]
        if len(close):
            local = (close - c[:2]) @ m[:2, :2]
            if ((np.abs(local[:, 0]) <= fl / 2 + KERB_CLEARANCE) & (np.abs(local[:, 1]) <= fw / 2 + KERB_CLEARANCE)).any():
                return Rejection("footprint crosses a kerb line", f"a kerb within {KERB_CLEARANCE} m of the footprint")
        return None

    def _along_the_ray(self, m: np.ndarray) -> Rejection | None:
        """A footprint shorter along the camera's ray than the stereo's depth band at its
        distance (a person or a pole far away) is judged as that long: there its own pixels
        and those of the ground a band nearer or farther are one, and a footprint just in front
        of a kerb across the view (a cross street's far side) is seen on the footway beyond it.
        The allowed share over that stretch, as over the footprint."""
        fl, fw = standing_footprint(self.class_name, self.extents)
        c = m[:3, 3]
        band = float(self.noise.depth_band(self.depth_of(c), 0.0))
        ray = c[:2] - self.frame.camera.position[:2]
        ray = ray / max(float(np.hypot(*ray)), 1e-6)
        cos, sin = abs(float(m[:2, 0] @ ray)), abs(float(m[:2, 1] @ ray))
        along_half, across_half = fl / 2 * cos + fw / 2 * sin, fl / 2 * sin + fw / 2 * cos
        if along_half >= band:
            return None
        a, b = np.meshgrid(np.linspace(-band, band, 21), np.linspace(-across_half, across_half, 5))
        offsets = a.ravel()[:, None] * ray + b.ravel()[:, None] * np.array([-ray[1], ray[0]])
        local = np.column_stack([offsets @ m[:2, :2], np.zeros(len(offsets))])
        s = footprint_support(self.frame, m, local, self.allowed_ids, self.noise)
        if s is None or not s["seen"].any():
            return None
        share = float(s["allowed"][s["seen"]].mean())
        if share < self.rules.min_footprint_allowed:
            return Rejection("footprint off the allowed surface",
                             f"{share:.0%} of the ground within the depth band ({band:.1f} m) along the view "
                             f"on {'/'.join(self.allowed)}")
        return None

    def ground(self, point: np.ndarray, dz: float = 0.3) -> tuple[GroundFit | None, Rejection | None]:
        """Robust plane through the allowed points around ``point`` (V): a metric neighbourhood,
        tolerances that follow the stereo noise at its depth."""
        rules = self.rules
        ground = local_ground(self.frame, point, self.reach, self.allowed_ids, self.noise, dz)
        n = 0 if ground is None else ground.points
        if ground is None or n < rules.min_ground_points:
            return None, Rejection("too few ground points",
                                   f"{n} {'/'.join(self.allowed)} points around it, needs {rules.min_ground_points}")
        if ground.inliers < rules.min_ground_inliers * n:
            return ground, Rejection("ground not planar (step or kerb)",
                                     f"{ground.inliers / n:.0%} of the ground points on one plane, "
                                     f"needs {rules.min_ground_inliers:.0%}")
        z = self.depth_of(point)
        limit = float(self.noise.height_band(z, rules.max_ground_rms))
        if ground.rms > limit:
            return ground, Rejection("ground not flat (rms too high)", f"rms {ground.rms:.3f} m > {limit:.3f} m")
        tilt = math.degrees(math.acos(min(1.0, ground.normal[2])))
        if tilt > rules.max_ground_tilt_deg:
            return ground, Rejection("ground too steep", f"{tilt:.1f} deg > {rules.max_ground_tilt_deg} deg")
        return ground, None

    def off_ground(self, point: np.ndarray, ground: GroundFit, floor: float) -> float | None:
        """How far ``point`` is from the plane when beyond the band at its depth, else None."""
        gap = abs(float(point[2]) - float(ground.height(point[0], point[1])))
        return gap if gap > float(self.noise.height_band(self.depth_of(point), floor)) else None

    def visibility(self, m: np.ndarray, others: Sequence[Placement] = ()) -> tuple[Rejection | None, float, float]:
        """The visibility rules against the real depth and ``others`` placed before; also
        returns (share of the object inside the image, share hidden)."""
        rules = self.rules
        in_image, hidden, area = visibility_of(self.frame, m, self.extents, others, self.noise)
        if hidden > rules.max_occluded_fraction:
            why = Rejection("too much hidden by the scene",
                            f"{hidden:.0%} hidden, at most {rules.max_occluded_fraction:.0%}")
            return why, in_image, hidden
        visible = area * in_image * (1.0 - hidden)
        if visible < rules.min_visible_pixels:
            why = Rejection("too few visible pixels", f"about {visible:.0f} seen, needs {rules.min_visible_pixels}")
            return why, in_image, hidden
        if others and hides_others(self.frame, m, self.extents, others, rules, self.noise):
            why = Rejection("would hide an object placed before",
                            f"it would leave one more than {rules.max_occluded_fraction:.0%} hidden")
            return why, in_image, hidden
        return self._signs_seen(m, others), in_image, hidden

    def _signs_seen(self, m: np.ndarray, others: Sequence[Placement]) -> Rejection | None:
        """A sign's plate is never hidden behind an inserted object: neither this one's behind
        those placed before, nor the plate of one placed before behind this one (beyond
        SIGN_HIDDEN of it). A pole may be: a driver reads the plate over a car in front of it."""
        cam = self.frame.camera.position
        if self.class_name in SIGNS and others:
            samples = plate_samples(m, self.extents)
            behind = np.zeros(len(samples), bool)
            for o in others:
                behind |= rays_hit_box(cam, samples, o.matrix, o.extents)
            if behind.mean() > SIGN_HIDDEN:
                return Rejection("sign hidden behind an inserted object", f"{behind.mean():.0%} of it")
        for o in others:
            if o.class_name in SIGNS:
                newly = rays_hit_box(cam, plate_samples(o.matrix, o.extents), m, self.extents).mean()
                if newly > SIGN_HIDDEN:
                    return Rejection("would hide a sign placed before", f"{newly:.0%} of it")
        return None

    def overlap(self, m: np.ndarray, other_prints: Sequence[np.ndarray],
                others: Sequence[Placement] = ()) -> Rejection | None:
        """No overlap with the footprints (grown by half the object gap) of objects placed
        before; people keep at least PEOPLE_GAP apart."""
        gap = self.rules.object_gap
        mine = footprint_corners(m, self.extents, gap / 2)
        if any(footprints_overlap(mine, o) for o in other_prints):
            return Rejection("overlaps another inserted object", f"closer than {gap} m")
        if self.class_name == "person" and gap < PEOPLE_GAP:
            mine = footprint_corners(m, self.extents, PEOPLE_GAP / 2)
            for o in others:
                if o.class_name == "person" and footprints_overlap(mine, footprint_corners(o.matrix, o.extents,
                                                                                           PEOPLE_GAP / 2)):
                    return Rejection("overlaps another inserted object", f"people closer than {PEOPLE_GAP} m")
        return None

    def scene(self, m: np.ndarray) -> Rejection | None:
        """No scene point inside the box (above the ground's noise band): the pixel grid as
        index, then the strict test; and none deeper inside than MAX_PENETRATION."""
        frame, rules = self.frame, self.rules
        rect = frame.box_rect(box_corners(m, self.extents, rules.margin))
        z = self.depth_of(m[:3, 3])
        # every pixel would be a few millimetres apart near the camera: sample the box's
        # rectangle every SCENE_SPACING metres (at the object's depth), never sparser than 4 px
        stride = int(np.clip(SCENE_SPACING * frame.camera.fx / max(z, 0.1), 1, 4))
        pts, _ = frame.rect_points(*rect, stride=stride) if rect else (np.empty((0, 3)), None)
        clearance = scene_clearance(self.noise, z, rules.clearance)
        inside = int(strict_inside(pts, m, self.extents, clearance, rules.margin).sum())
        if inside >= rules.min_collision_points:
            return Rejection("intersects the scene", f"{inside} scene points inside the box")
        deepest = penetration(pts, m, self.extents, clearance)
        if deepest <= MAX_PENETRATION and stride > 1:
            # check-placement measures every pixel of the box: a pole or a branch between the
            # samples counts there, so it counts here (the samples passed: once per pose)
            deepest = deepest_scene_point(frame, m, self.extents, clearance)
        if deepest > MAX_PENETRATION:
            return Rejection("intersects the scene", f"a scene point {deepest:.2f} m inside the box")
        return None


def deepest_scene_point(frame: Frame, m: np.ndarray, extents, clearance: float) -> float:
    """How deep the deepest real scene point (every pixel of the box's rectangle) reaches into
    the object's box above ``clearance``, metres: placement's last scene test and
    check-placement's ``penetration_m``."""
    rect = frame.box_rect(box_corners(m, extents))
    if rect is None:
        return 0.0
    pts, _ = frame.rect_points(*rect)
    return penetration(pts, m, extents, clearance)


def scene_clearance(noise: StereoNoise, z: float, floor: float) -> float:
    """Scene points lower than this above an object's ground plane are ground, not obstacles:
    the rules' clearance or the stereo height band at the object's depth (checker and placement)."""
    return float(noise.height_band(z, floor))


def check_pose(frame: Frame, class_name: str, extents, matrix: np.ndarray, rules: PlacementRules,
               allowed: Sequence[str] | None = None, others: Sequence[Placement] = (),
               orientation: str | None = None, claim: "Traffic | None" = None) -> Rejection | None:
    """The batch's placement rules on a pose given outright (moved by hand in the preview,
    saved, or recorded by a batch: check-placement): the first rule it breaks, or None when
    the batch would accept it. ``others``: the objects placed before it. ``claim``: where the
    placement said the object stands in traffic (traffic.py); its traffic rules are checked
    too (verdict.py). Without a claim (a pose moved by hand) the traffic rules are the user's
    choice and not checked. The placement runs this on every pose it returns."""
    from .verdict import check_traffic

    tests = PoseTests.of(frame, extents, rules, surfaces_for(class_name, allowed), class_name)
    m = np.asarray(matrix, float)
    # the distance on the ground plan, as the placement draws and records it (a candidate moved
    # to its lane's centre or the kerb may leave the range it was drawn in)
    d = math.hypot(m[0, 3] - frame.camera.x, m[1, 3] - frame.camera.y)
    if not rules.distance[0] <= d <= rules.distance[1]:
        return Rejection("outside the distance range", f"{d:.2f} m, the range {rules.distance[0]:g}-{rules.distance[1]:g} m")
    why = tests.image(m, heights=False)
    if why:
        return why
    ground, why = tests.ground(m[:3, 3], dz=POSE_GROUND_SEARCH)
    if why:
        return why
    foot = box_corners(m, extents)[::2]  # the 4 bottom corners
    if any(tests.off_ground(c, ground, rules.max_ground_rms + 0.02) is not None for c in foot):
        gap = float(np.abs(foot[:, 2] - ground.height(foot[:, 0], foot[:, 1])).max())
        return Rejection("object is off the fitted ground", f"a footprint corner {gap:.2f} m from the ground plane")
    why = tests.image(m)
    if why:
        return why
    prints = [footprint_corners(o.matrix, o.extents, rules.object_gap / 2) for o in others]
    # collisions before visibility (the batch's order is the other way round): an object moved
    # onto another is said to collide, not to be hidden by it
    return tests.overlap(m, prints, others) or tests.scene(m) or tests.visibility(m, others)[0] \
        or check_traffic(frame, extents, m, orientation or "", claim, rules.traffic)


def plate_samples(m: np.ndarray, extents) -> np.ndarray:
    """(N, 3) V points over the plate of a sign posed by ``m``: the box's samples in the top
    SIGN_PLATE of its height."""
    return box_samples(m, extents, above=1.0 - SIGN_PLATE)
