"""Measure the placements of a finished batch against the real scene they were put in.

For every inserted object of every record under an output root, from the input image set
the record names:

* footprint_on_allowed : share of the footprint (dense grid) seen on the allowed labels
* ground_gap_m         : largest height difference between the footprint's corners and a
                         robust plane fitted to the real allowed ground around the object
* penetration_m        : deepest a real scene point reaches into the object's box (above
                         the clearance band that the ground itself occupies)
* occluded_fraction    : share of the rendered object hidden by the real scene (exact, from
                         the record)
* yaw_to_road_deg      : angle between the object's heading and its lane's direction (0-180:
                         a vehicle facing against its lane reads 180), for vehicles placed with
                         traffic sense; the local kerb direction (either way, 0-90) for others
                         aligned along the road
* rule                 : the first placement rule the pose breaks, checked with the rules the
                         record was placed by (``placement.check_pose``: the placement's own
                         tests, the objects placed before it, and where it said it stands in
                         traffic); None when it passes - the placement runs the same test on
                         every pose it returns, so a disagreement is a bug
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from synthcompose.geometry.depth import make_frame
from synthcompose.io.dataset import ImageSetId, labelled_twin, read_image_set
from synthcompose.io.files import write_json
from synthcompose.labels import label_id
from synthcompose.placement import (
    FOOTPRINT_SAMPLES,
    MAX_PENETRATION,
    PlacementRules,
    check_pose,
    footprint_grid,
    footprint_support,
    frame_noise,
    local_ground,
    road_line,
    scene_clearance,
)
from synthcompose.placement.claim import Traffic
from synthcompose.placement.poses import deepest_scene_point
from synthcompose.placement.rules import UPRIGHT, rules_from, standing_footprint
from synthcompose.placement.saved_poses import placement_from_pose
from synthcompose.placement.surfaces import frame_for
from synthcompose.placement.verdict import lane_yaw_error
from synthcompose.record import ImageSetRecord, read_record

#: what the checks require (issue: placement a dataset can trust)
LIMITS = {"footprint_on_allowed": 0.95, "ground_gap_m": 0.05, "penetration_m": MAX_PENETRATION,
          "yaw_to_road_deg": 10.0}


@dataclass(frozen=True)
class ObjectCheck:
    image_set: str
    index: int
    name: str
    footprint_on_allowed: float
    ground_gap_m: float
    penetration_m: float
    occluded_fraction: float
    yaw_to_road_deg: float | None
    distance_m: float = float("nan")
    footprint_on_truth: float | None = None  # unlabelled sets with a labelled twin: share on the true labels
    rule: str | None = None  # the placement rule the pose breaks (None: it passes them all)
    role: str | None = None  # traffic role (moving, parked, walking, standing, sign)
    direction: str | None = None  # with / against the ego vehicle

    @property
    def failures(self) -> list[str]:
        out = []
        if self.footprint_on_allowed < LIMITS["footprint_on_allowed"]:
            out.append("footprint")
        if self.ground_gap_m > LIMITS["ground_gap_m"]:
            out.append("ground gap")
        if self.penetration_m > LIMITS["penetration_m"]:
            out.append("penetration")
        if self.yaw_to_road_deg is not None and self.yaw_to_road_deg > LIMITS["yaw_to_road_deg"]:
            out.append("yaw")
        if self.rule is not None:
            out.append("rules")
        return out


def ground_gap(fit, matrix: np.ndarray, grid: np.ndarray, class_name: str) -> float:
    """How far the object's footing is from the robust local ground plane ``fit`` (metres; nan
    without a plane): the corners of its footprint ``grid`` (placement's samples, object frame).
    A person or a pole stands plumb (placement/search.py), so on a slope it touches the ground
    at its foot, not at its box's corners (a slope of 8 degrees lifts them 5-6 cm): its foot."""
    if fit is None or not np.isfinite(fit.rms):
        return float("nan")
    rows = grid.reshape(FOOTPRINT_SAMPLES[1], FOOTPRINT_SAMPLES[0], 3)
    at = matrix[:3, 3][None] if class_name in UPRIGHT else \
        rows[[0, 0, -1, -1], [0, -1, 0, -1]] @ matrix[:3, :3].T + matrix[:3, 3]
    return float(np.abs(at[:, 2] - fit.height(at[:, 0], at[:, 1])).max())


def _ident_from_record(record: ImageSetRecord) -> tuple[Path, ImageSetId]:
    rgb = Path(record.source["rgb"])
    split, city = record.image_set.split("/")[:2]
    _, seq, frame = record.image_set.split("/")[2].rsplit("_", 2)
    return rgb.parents[3], ImageSetId(split, city, seq, frame)


def check_record(record: ImageSetRecord, rules: PlacementRules = PlacementRules(),
                 truth_root: Path | None = None) -> list[ObjectCheck]:
    """The figures of every object of one record, measured on its input image set with the
    placement's own definitions (footprint support, local ground, clearance, road line); the
    frame is built as the pipeline built it (surfaces found where the set has no labels).
    ``truth_root``: a labelled Cityscapes root holding the same frame (the development set's
    twin), to measure unlabelled placements against the true labels too."""
    root, ident = _ident_from_record(record)
    image_set = read_image_set(root, ident)
    cam = image_set.camera
    frame, _ = frame_for(image_set)
    truth = None
    if truth_root is not None and not image_set.labelled:
        twin = labelled_twin(truth_root, ident)
        if twin is not None:
            t = read_image_set(truth_root, twin)
            truth = make_frame(frame.depth, t.label_ids, cam)
    noise = frame_noise(frame)
    rules = rules_from(record.placement_rules) if record.placement_rules is not None else rules
    out = []
    before: list = []
    for obj in record.objects:
        m = np.array(obj.pose.vehicle, float)
        l, w, h = obj.extents_m
        allowed = np.array([label_id(s) for s in obj.allowed_surfaces])
        grid = footprint_grid(*standing_footprint(obj.class_name, (l, w, h)))

        def share_on(f):
            sup = footprint_support(f, m, grid, allowed, noise)
            if sup is None or not sup["seen"].any():
                return 0.0
            return float(sup["allowed"][sup["seen"]].mean())

        share = share_on(frame)
        fit = local_ground(frame, m[:3, 3], math.hypot(l, w) / 2 + 0.5, allowed, noise)
        gap = ground_gap(fit, m, grid, obj.class_name)
        # penetration of scene points into the box (above the ground's noise band)
        z = float(frame.to_optical(m[:3, 3][None])[0, 2])
        pen = deepest_scene_point(frame, m, (l, w, h), scene_clearance(noise, z, rules.clearance))
        # heading against the lane's direction (traffic sense) or the local kerb line
        claim = Traffic.from_dict(obj.traffic)
        yaw_err = None
        if claim is not None and claim.role in ("moving", "parked"):
            yaw_err = lane_yaw_error(frame, (l, w, h), m, rules.traffic)
        elif obj.orientation in ("along-road", "parked", "moving"):
            line = road_line(frame, allowed, m[:3, 3])
            if line is not None:
                diff = math.atan2(m[1, 0], m[0, 0]) - line.angle
                yaw_err = math.degrees(abs(math.asin(max(-1.0, min(1.0, math.sin(diff))))))
        why = check_pose(frame, obj.class_name, (l, w, h), m, rules, obj.allowed_surfaces, before, obj.orientation,
                         claim)
        before.append(placement_from_pose(frame, obj.class_name, (l, w, h), m))
        dist = float(math.hypot(m[0, 3] - cam.x, m[1, 3] - cam.y))
        out.append(ObjectCheck(record.image_set, obj.index, obj.name, round(share, 4), round(gap, 4),
                               round(pen, 4), obj.occluded_fraction,
                               None if yaw_err is None else round(yaw_err, 2), round(dist, 2),
                               None if truth is None else round(share_on(truth), 4),
                               None if why is None else str(why), None if claim is None else claim.role,
                               None if claim is None else claim.direction))
    return out


def check_output(out_root: Path, truth_root: Path | None = None) -> list[ObjectCheck]:
    """Check every record under ``out_root/synthcompose``; writes ``placement_check.json``."""
    results: list[ObjectCheck] = []
    for path in sorted((Path(out_root) / "synthcompose").rglob("*_synthcompose.json")):
        record = read_record(path)
        if record.done:
            results.extend(check_record(record, truth_root=truth_root))
    write_json(Path(out_root) / "placement_check.json",
               {"limits": LIMITS, "objects": [asdict(r) | {"failures": r.failures} for r in results]})
    return results


def format_table(results: list[ObjectCheck]) -> str:
    head = (f"{'image set':<44}{'#':>3} {'object':<12}{'foot':>6}{'gap m':>8}{'pen m':>7}{'occl':>6}{'yaw°':>7}"
            f"  {'traffic':<18} verdict")
    lines = [head]
    for r in results:
        yaw = "-" if r.yaw_to_road_deg is None else f"{r.yaw_to_road_deg:.1f}"
        verdict = "ok" if not r.failures else "FAIL: " + ", ".join(r.failures)
        traffic = f"{r.role or '-'}/{r.direction or '-'}"
        lines.append(f"{r.image_set:<44}{r.index:>3} {r.name[:12]:<12}{r.footprint_on_allowed:>6.2f}"
                     f"{r.ground_gap_m:>8.3f}{r.penetration_m:>7.3f}{r.occluded_fraction:>6.2f}{yaw:>7}"
                     f"  {traffic:<18} {verdict}" + (f" ({r.rule})" if r.rule else ""))
    bad = sum(bool(r.failures) for r in results)
    lines.append(f"{len(results)} objects checked, {bad} outside the limits {LIMITS}")
    return "\n".join(lines)
