"""Traffic sense of a finished batch, measured from its records alone (real frames first).

    python benchmarks/eval_traffic.py OUT [OUT ...]            # outputs of eval_real.py --out DIR
    python benchmarks/eval_traffic.py --run ROOT [--truth LABELLED] [--objects 3] [--seed 7] [--out DIR]

For each output root, from each record's objects and its ``street`` (the axis, carriageways,
centre lines and markings placement found):

* placed / asked (the manifest's objects per set), and placed / drawn for people, signs and
  vehicles (an object that found no place is replaced by one of another kind, a draw of its
  own: ``redraw_unplaced``), and per slot's first draw (the kind it was asked as, placed as
  that kind; the substitutes left out); the frames that got no object, and whether
  they had free road or footway at all (a road or sidewalk pixel in the distance range);
* **headings**: each vehicle's lateral position s across the street (from its pose, against the
  recorded axis) and its heading against the street's direction there; on a two-way carriageway
  right of the centre line (right-hand traffic) it must face along the street, left of it
  against; on a one-way carriageway along; on the other half of a dual road by its side; a
  vehicle facing the other way is counted "against its lane". Also the issue's plain measure:
  vehicles within 1.6 m of the camera's line (V's y), ahead of it, facing the camera; and on a
  carriageway recorded one-way (no centre line), vehicles beyond the ego vehicle's own lane on
  the oncoming side, where a two-way street's traffic would come towards us;
* **markings**: a moving vehicle whose footprint spans a recorded lane marking (a boundary of
  the recorded lanes, or any line seen over 6 m there and not under the ego vehicle's own path,
  at its distance along the street) is "across a lane marking"; a shorter line, or one under
  the ego vehicle's path, is counted apart;
* **people** whose footprint centre lies on a carriageway (between its kerbs) and not on a
  recorded crossing, nor past the kerb where the recorded street ends (a T-junction's far
  footway); **overlaps**: two objects' footprints intersecting, people closer than 0.5 m;
* **disagreement**: objects that check-placement --strict (``synthcompose.tools.check``) fails.

``--run`` first runs ``eval_real.py``'s batch on ROOT (its figures printed too) and keeps the
output in ``--out`` (default a temporary folder). Never commit outputs made from real frames.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.placement.boxes import footprint_corners, footprints_overlap  # noqa: E402
from synthcompose.placement.ends import past_recorded_end  # noqa: E402
from synthcompose.placement.street import EGO_HALF_LANE  # noqa: E402
from synthcompose.placement.street_lines import to_road  # noqa: E402
from synthcompose.placement.verdict import LINE_SEEN  # noqa: E402
from synthcompose.record import read_record  # noqa: E402
from synthcompose.tools.check import check_output  # noqa: E402

VEHICLES = ("car", "truck", "bus", "motorcycle", "caravan", "trailer")


def _lane_direction(street: dict, s: float, hand: int = 1) -> int | None:
    """+1 along the street, -1 against, for a vehicle at offset s (None off the carriageways)."""
    for cw in street["carriageways"]:
        if cw["right_m"] - 0.3 <= s <= cw["left_m"] + 0.3:
            if cw["side"] != 0:
                return -hand * cw["side"]
            if cw["centre_m"] is None:
                return 1
            return 1 if hand * (cw["centre_m"] - s) > 0 else -1
    return None


def _beyond_ego_lane(street: dict, s: float, hand: int = 1) -> str | None:
    """Where a vehicle at offset ``s`` stands beyond the ego vehicle's own lane on the oncoming
    side of a carriageway recorded one-way (no centre line), or None."""
    ego_s = street.get("ego_offset_m", 0.0)
    cws = street["carriageways"]
    if not cws or cws[0]["side"] != 0 or cws[0]["centre_m"] is not None:
        return None
    own = [ln for ln in street.get("lanes", []) if ln["carriageway"] == 0 and ln["role"] == "moving"]
    if not own:
        return None
    ego = min(own, key=lambda ln: max(ln["right_m"] - ego_s, ego_s - ln["left_m"], 0.0))
    edge = ego["left_m"] if hand > 0 else ego["right_m"]
    if hand * (s - edge) > 0 and cws[0]["right_m"] <= s <= cws[0]["left_m"]:
        return f"beyond the ego lane of a one-way street (s {s:.2f} m, its edge {edge:.2f} m)"
    return None


def analyse(out: Path) -> dict:
    counts: Counter[str] = Counter()
    asked, placed = Counter(), Counter()
    first_asked, substitutes = Counter(), Counter()  # first draws that found no place; placed substitutes
    empty, findings = [], []
    for path in sorted((out / "synthcompose").rglob("*_synthcompose.json")):
        rec = read_record(path)
        for f in rec.not_placed:
            asked[f["class"]] += 1  # each draw that found no place, a substitute's too
            # an object that got a substitute, and a substitute that failed, leave no slot empty
            # beyond the first failure: count the slot once
            counts["slots left empty"] += not f.get("replaced_by") and not f.get("substitute_for")
            counts["objects replaced by another kind"] += bool(f.get("replaced_by"))
        for obj in rec.objects:
            asked[obj.class_name] += 1
            placed[obj.class_name] += 1
        for name, why in (rec.not_drawn or {}).items():  # it could stand nowhere in the frame
            counts[f"frames where {name!r} was not drawn ({why})"] += 1
        # per slot's first draw (the kind the slot was asked as): a substitute, placed or not, is
        # the batch's retry, not an object of its kind asked (the record names what replaced what)
        named = {obj.name: obj.class_name for obj in rec.objects}
        for f in rec.not_placed:
            if not f.get("substitute_for"):
                first_asked[f["class"]] += 1
            if f.get("replaced_by") in named:
                substitutes[named[f["replaced_by"]]] += 1
        if not rec.objects:
            reasons = Counter()
            for f in rec.not_placed:
                reasons.update(f.get("rejections", {}))
            free = not any(k.startswith("no ") and "pixel with valid depth" in k for k in reasons)
            empty.append((rec.image_set, "has free road/footway" if free else "no free road or footway"))
            continue
        street = rec.street or {"axis": {"b": 0.0, "q": 0.0}, "carriageways": [], "crossings": []}
        b, q = street["axis"]["b"], street["axis"]["q"]
        prints = []
        for obj in rec.objects:
            m = np.array(obj.pose.vehicle, float)
            t = obj.traffic or {}
            a, s = (float(v[0]) for v in to_road(m[None, :2, 3], b, q))
            yaw = math.atan2(m[1, 0], m[0, 0])
            heading = math.atan(b + 2 * q * a)
            along = 1 if math.cos(yaw - heading) > 0 else -1
            prints.append((obj, footprint_corners(m, obj.extents_m)))
            if obj.class_name in VEHICLES:
                counts["vehicles"] += 1
                if abs(m[1, 3]) < 1.6 and m[0, 3] > 0 and math.cos(yaw) < 0:
                    counts["facing the camera in our lane's corridor"] += 1
                    findings.append((rec.image_set, obj.index, obj.name, "in our corridor facing the camera"))
                if t.get("where") == "side street":
                    counts["on a side street"] += 1
                    continue
                want = _lane_direction(street, s)
                if want is None:
                    counts["off the recorded carriageways"] += 1
                elif want != along:
                    counts["against its lane"] += 1
                    findings.append((rec.image_set, obj.index, obj.name, f"against its lane (s {s:.2f} m)"))
                beyond = _beyond_ego_lane(street, s)
                if beyond:
                    # no centre line and the ego vehicle not keeping right: on a two-way street
                    # this would be the oncoming half (the lanes there are untold)
                    counts["beyond the ego lane of a street taken as one-way"] += 1
                    findings.append((rec.image_set, obj.index, obj.name, beyond))
                if t.get("role") == "moving":
                    _, cs = to_road(footprint_corners(m, obj.extents_m), b, q)
                    inside = (cs.min() + 0.05, cs.max() - 0.05)
                    bounds = {round(e, 3) for ln in street.get("lanes", []) for e in (ln["right_m"], ln["left_m"])}
                    for cw in street["carriageways"]:
                        for mk in cw["markings"]:
                            if not (mk["from_m"] - 1 <= a <= mk["to_m"] + 1 and inside[0] < mk["offset_m"] < inside[1]):
                                continue
                            # a lane boundary; or a line the lanes dropped (rails, a stretch of a
                            # double line), counted apart
                            if any(abs(mk["offset_m"] - e) < 0.05 for e in bounds):
                                counts["across a lane marking"] += 1
                                findings.append((rec.image_set, obj.index, obj.name,
                                                 f"across the lane marking at {mk['offset_m']:.2f} m"))
                            elif mk["to_m"] - mk["from_m"] >= LINE_SEEN and \
                                    abs(mk["offset_m"] - street.get("ego_offset_m", 0.0)) > EGO_HALF_LANE:
                                # a line seen along the street that the lanes left out: a lane
                                # line still (verdict._over_a_line)
                                counts["across a lane marking"] += 1
                                findings.append((rec.image_set, obj.index, obj.name,
                                                 f"across a line the lanes left out at {mk['offset_m']:.2f} m"))
                            else:
                                counts["over a short line or one under the ego vehicle's path"] += 1
            elif obj.class_name == "person":
                counts["people"] += 1
                # past the kerb across a street that ends (a T-junction seen head-on) lies the cross
                # street's far footway, not the ego carriageway
                beyond = past_recorded_end(street, m[0, 3], m[1, 3])
                on_road = any(cw["right_m"] <= s <= cw["left_m"] and not (beyond and cw.get("side", 0) == 0)
                              for cw in street["carriageways"])
                crossing = any(c[0] <= a <= c[1] for c in street.get("crossings", []))
                if on_road and not crossing:
                    counts["people on the carriageway outside a crossing"] += 1
                    findings.append((rec.image_set, obj.index, obj.name, f"on the carriageway (s {s:.2f} m)"))
        for i in range(len(prints)):
            for j in range(i + 1, len(prints)):
                (oi, pi), (oj, pj) = prints[i], prints[j]
                if footprints_overlap(pi, pj):
                    counts["objects inside one another"] += 1
                    findings.append((rec.image_set, oi.index, oi.name, f"overlaps #{oj.index}"))
                elif oi.class_name == oj.class_name == "person":
                    gi = footprint_corners(np.array(oi.pose.vehicle), oi.extents_m, 0.25)
                    gj = footprint_corners(np.array(oj.pose.vehicle), oj.extents_m, 0.25)
                    if footprints_overlap(gi, gj):
                        counts["people closer than 0.5 m"] += 1
    checks = check_output(out)
    counts["check-placement --strict failures"] = sum(bool(c.failures) for c in checks)
    for c in checks:
        if c.failures:
            findings.append((c.image_set, c.index, c.name, f"check: {', '.join(c.failures)} {c.rule or ''}"))
    people = ("person",)
    signs = ("traffic sign",)
    vehicles = VEHICLES
    result = {
        "asked": sum(placed.values()) + counts["slots left empty"], "placed": sum(placed.values()),
        "vehicles": (sum(placed[k] for k in vehicles), sum(asked[k] for k in vehicles)),
        "people": (sum(placed[k] for k in people), sum(asked[k] for k in people)),
        "signs": (sum(placed[k] for k in signs), sum(asked[k] for k in signs)),
        "first_draws": {name: (sum(placed[k] - substitutes[k] for k in kinds),
                               sum(placed[k] - substitutes[k] + first_asked[k] for k in kinds))
                        for name, kinds in (("people", people), ("signs", signs), ("vehicles", vehicles))},
        "frames_without_objects": empty, "counts": dict(counts), "findings": findings,
    }
    return result


def report(out: Path, r: dict) -> None:
    share = r["placed"] / max(r["asked"], 1)
    print(f"\n== traffic sense: {out}")
    print(f"placed {r['placed']}/{r['asked']} ({share:.0%}) of the objects asked; of the objects drawn: "
          f"people {r['people'][0]}/{r['people'][1]}, signs {r['signs'][0]}/{r['signs'][1]}, "
          f"vehicles {r['vehicles'][0]}/{r['vehicles'][1]}")
    print("of the slots first drawn as each kind, placed as drawn (substitutes left out): " +
          ", ".join(f"{k} {p}/{n}" for k, (p, n) in r["first_draws"].items()))
    print("frames without objects:", r["frames_without_objects"] or "none")
    for k, v in r["counts"].items():
        print(f"  {k}: {v}")
    for f in r["findings"]:
        print("  -", *f)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("outputs", nargs="*", type=Path, help="output roots of finished batches")
    ap.add_argument("--run", type=Path, help="run eval_real.py's batch on this Cityscapes root first")
    ap.add_argument("--truth", type=Path, help="with --run: the labelled twin of an unlabelled root")
    ap.add_argument("--objects", type=int, default=3)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, help="with --run: keep the outputs here")
    ap.add_argument("--json", type=Path, help="write the figures here")
    a = ap.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory(prefix="synthcompose-traffic-") as tmp:
        outs = list(a.outputs)
        if a.run is not None:
            from eval_real import evaluate  # noqa: E402 (benchmarks/ is on the path when run as a script)

            base = a.out or Path(tmp)
            base.mkdir(parents=True, exist_ok=True)
            evaluate(a.run.resolve(), base / "out", a.objects, a.seed, a.truth, "real")
            outs.append(base / "out")
        if not outs:
            ap.error("give output roots or --run ROOT")
        for out in outs:
            results[str(out)] = r = analyse(out)
            report(out, r)
    if a.json:
        a.json.write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
