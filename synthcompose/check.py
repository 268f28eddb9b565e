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
* yaw_to_road_deg      : angle between the object's heading and the local kerb direction
                         (objects aligned along the road only)
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .dataset import ImageSetId, read_image_set
from .fileio import read_json, write_json
from .geometry import disparity_to_depth, make_frame
from .labels import label_id
from .placement import PlacementRules, fit_ground, fit_road_line, penetration, surface_edges

#: what the checks require (issue: placement a dataset can trust)
LIMITS = {"footprint_on_allowed": 0.95, "ground_gap_m": 0.05, "penetration_m": 0.05, "yaw_to_road_deg": 10.0}


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
        return out


def _ident_from_record(record: dict) -> tuple[Path, ImageSetId]:
    rgb = Path(record["source"]["rgb"])
    split, city = record["image_set"].split("/")[:2]
    _, seq, frame = record["image_set"].split("/")[2].rsplit("_", 2)
    return rgb.parents[3], ImageSetId(split, city, seq, frame)


def check_record(record: dict, rules: PlacementRules = PlacementRules()) -> list[ObjectCheck]:
    root, ident = _ident_from_record(record)
    image_set = read_image_set(root, ident)
    cam = image_set.camera
    frame = make_frame(disparity_to_depth(image_set.disparity, cam), image_set.label_ids, cam)
    H, W = frame.shape
    out = []
    for obj in record.get("objects", []):
        m = np.array(obj["pose"]["vehicle"]["matrix"], float)
        l, w, h = obj["extents_m"]
        allowed = np.array([label_id(s) for s in obj["allowed_surfaces"]])
        # footprint seen on allowed labels
        gx, gy = np.meshgrid(np.linspace(-l / 2, l / 2, 21), np.linspace(-w / 2, w / 2, 11))
        foot = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) @ m[:3, :3].T + m[:3, 3]
        opt = frame.to_optical(foot)
        uv = np.rint(cam.project(opt)).astype(int)
        ok = (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
        u, v, z = uv[ok, 0], uv[ok, 1], opt[ok, 2]
        seen = frame.depth[v, u] >= z * 0.98 - 0.05
        share = float(np.isin(frame.label_ids[v, u][seen], allowed).mean()) if seen.any() else 0.0
        # ground gap: corners of the footprint vs the real ground plane around the object
        reach = math.hypot(l, w) / 2 + 0.5
        square = m[:3, 3] + np.array([[sx * reach, sy * reach, dz] for sx in (-1, 1) for sy in (-1, 1)
                                      for dz in (-0.3, 0.3)])
        rect = frame.box_rect(square)
        gap = float("nan")
        if rect is not None:
            pts, labs = frame.rect_points(*rect)
            c = m[:3, 3]
            near = pts[np.isin(labs, allowed) & (np.abs(pts[:, 0] - c[0]) <= reach) & (np.abs(pts[:, 1] - c[1]) <= reach)]
            fit = fit_ground(near, c)
            if fit is not None:
                (a, b, cc), _, _ = fit
                corners = foot.reshape(11, 21, 3)[[0, 0, -1, -1], [0, -1, 0, -1]]
                gap = float(np.abs(corners[:, 2] - (a * corners[:, 0] + b * corners[:, 1] + cc)).max())
        # penetration of scene points into the box
        grow = np.array([[sx * l / 2, sy * w / 2, zz] for sx in (-1, 1) for sy in (-1, 1) for zz in (0, h)])
        rect = frame.box_rect(grow @ m[:3, :3].T + m[:3, 3])
        pen = 0.0
        if rect is not None:
            pts, _ = frame.rect_points(*rect)
            pen = penetration(pts, m, (l, w, h), rules.clearance)
        # heading against the local road direction
        yaw_err = None
        if obj.get("orientation") in ("along-road", "parked"):
            line = fit_road_line(surface_edges(frame, allowed), m[:3, 3], np.random.default_rng(0))
            if line is not None:
                diff = math.atan2(m[1, 0], m[0, 0]) - line.angle
                yaw_err = math.degrees(abs(math.asin(max(-1.0, min(1.0, math.sin(diff))))))
        out.append(ObjectCheck(record["image_set"], obj["index"], obj["name"], round(share, 4), round(gap, 4),
                               round(pen, 4), obj.get("occluded_fraction", float("nan")),
                               None if yaw_err is None else round(yaw_err, 2)))
    return out


def check_output(out_root: Path) -> list[ObjectCheck]:
    """Check every record under ``out_root/synthcompose``; writes ``placement_check.json``."""
    results: list[ObjectCheck] = []
    for path in sorted((Path(out_root) / "synthcompose").rglob("*_synthcompose.json")):
        record = read_json(path)
        if record.get("status") == "done":
            results.extend(check_record(record))
    write_json(Path(out_root) / "placement_check.json",
               {"limits": LIMITS, "objects": [asdict(r) | {"failures": r.failures} for r in results]})
    return results


def format_table(results: list[ObjectCheck]) -> str:
    head = f"{'image set':<44}{'#':>3} {'object':<12}{'foot':>6}{'gap m':>8}{'pen m':>7}{'occl':>6}{'yaw°':>7}  verdict"
    lines = [head]
    for r in results:
        yaw = "-" if r.yaw_to_road_deg is None else f"{r.yaw_to_road_deg:.1f}"
        verdict = "ok" if not r.failures else "FAIL: " + ", ".join(r.failures)
        lines.append(f"{r.image_set:<44}{r.index:>3} {r.name[:12]:<12}{r.footprint_on_allowed:>6.2f}"
                     f"{r.ground_gap_m:>8.3f}{r.penetration_m:>7.3f}{r.occluded_fraction:>6.2f}{yaw:>7}  {verdict}")
    bad = sum(bool(r.failures) for r in results)
    lines.append(f"{len(results)} objects checked, {bad} outside the limits {LIMITS}")
    return "\n".join(lines)
