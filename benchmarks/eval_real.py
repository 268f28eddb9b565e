"""Evaluate the main job on any Cityscapes root (real frames first): one batch with the bundled
manifest's objects, then per image set the objects asked and placed, the rejection reasons,
the check-placement figures and the time per stage, and the totals.

    python benchmarks/eval_real.py ROOT [--truth LABELLED_ROOT] [--objects 3] [--seed 7] [--out DIR]
    python benchmarks/eval_real.py --generated 4      # the same on generated scenes, same run
    python benchmarks/eval_real.py --generated 5 --streets traffic   # streets laid out as traffic uses them

ROOT: a Cityscapes root (leftImg8bit/, disparity/, camera/, gtFine/ when labelled). --truth: a
labelled root holding the same frames, to measure placements on an unlabelled root against the
true labels. Outputs go to a temporary folder unless --out is given (never commit outputs made
from real frames: Cityscapes' licence forbids redistribution).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.labels import label_id  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.run.batch import STAGES, run_batch  # noqa: E402
from synthcompose.tools.check import LIMITS, check_output  # noqa: E402


def write_manifest(root: Path, out: Path, objects: int, seed: int, folder: Path) -> Path:
    """The bundled demo manifest's objects (its street cast; model paths made absolute), on
    ``root``."""
    demo = REPO / "assets" / "demo" / "manifest.json"
    m = json.loads(demo.read_text())
    if "cast" in m:  # the built-in cast as its pools, each with its class (callers weigh them)
        from synthcompose.cast import CASTS, load_catalogue

        catalogue = load_catalogue()
        pools = CASTS[m.pop("cast")]
        m["objects"] = m.get("objects", []) + [
            {"name": name, "model": f"cast:{sel}", "class": catalogue.pool(sel)[0].class_name, "weight": w}
            for name, sel, w in pools if catalogue.pool(sel)]
    for obj in m.get("objects", []):
        if not obj["model"].startswith(("builtin:", "cast:")):
            obj["model"] = str((demo.parent / obj["model"]).resolve())
    splits = sorted({i.split for i in find_image_sets(root)})
    m.update(dataset=str(root), output=str(out), splits=splits, seed=seed, objects_per_image=objects)
    path = folder / "eval_manifest.json"
    path.write_text(json.dumps(m, indent=2))
    return path


def done_outputs(root: Path, out: Path):
    """(ident, record, input image set, output image set) of every image set done under ``out``."""
    for ident in find_image_sets(out):
        rec_path = ident.path(out, "record")
        if not rec_path.is_file():
            continue
        rec = json.loads(rec_path.read_text())
        if rec.get("status") != "done":
            continue
        yield ident, rec, read_image_set(root, ident), read_image_set(out, ident)


def labels_changed_outside(root: Path, out: Path, keys: list[str]) -> int | None:
    """Pixels whose label or instance id differs between input and output outside the inserted
    objects' visible masks, over the done sets of a labelled root (None for unlabelled roots).
    A part labelled apart (a sign's pole, labelled ``pole``) is the object's too: the pixels
    turned ``pole`` in the columns of its box, from its top down."""
    total, seen = 0, False
    for ident in find_image_sets(root):
        if ident.key not in keys:
            continue
        src, res = read_image_set(root, ident), read_image_set(out, ident)
        if not src.labelled:
            continue
        seen = True
        record = json.loads(ident.path(out, "record").read_text())
        union = np.zeros(src.label_ids.shape, bool)
        pole = label_id("pole")
        for obj in record.get("objects", []):
            union |= (res.instance_ids == obj["instance_id"]) & (src.instance_ids != obj["instance_id"])
            box = obj.get("bbox_2d_amodal")
            if box is not None:
                x0, y0, x1, y1 = box
                part = np.zeros_like(union)
                part[y0:, x0:x1] = True  # the plate's box and below it: its pole
                union |= part & (res.label_ids == pole) & (src.label_ids != pole)
        diff = (res.label_ids != src.label_ids) | (res.instance_ids != src.instance_ids)
        total += int((diff & ~union).sum())
    return total if seen else None


def surfaces_against_truth(root: Path, truth: Path) -> list[tuple[str, dict[str, float]]]:
    """Per image set of an unlabelled ``root`` whose labelled twin is under ``truth``: precision
    and recall of the found road and sidewalk against gtFine, the footway precision (the found
    sidewalk's share on paved ground a person walks on: sidewalk, parking, ground) and its share
    on ground a person can stand on (those and terrain)."""
    from eval_surfaces import FOOTWAY, WALKABLE  # benchmarks/ is on the path when run as a script

    from synthcompose.io.dataset import labelled_twin
    from synthcompose.placement.surfaces import ROAD, SIDEWALK, find_surfaces

    out = []
    for ident in find_image_sets(root):
        twin = labelled_twin(truth, ident)
        if twin is None:
            continue
        s, t = read_image_set(root, ident), read_image_set(truth, twin)
        found = find_surfaces(s.disparity, s.rgb, s.camera).labels
        fig = {}
        for name, lid in (("road", ROAD), ("sidewalk", SIDEWALK)):
            f, g = found == lid, t.label_ids == lid
            fig[f"{name}_precision"] = float((f & g).sum() / max(f.sum(), 1))
            fig[f"{name}_recall"] = float((f & g).sum() / max(g.sum(), 1))
        side = found == SIDEWALK
        fig["footway_precision"] = float(np.isin(t.label_ids[side], FOOTWAY).mean()) if side.any() else 0.0
        fig["sidewalk_on_walkable"] = float(np.isin(t.label_ids[side], WALKABLE).mean()) if side.any() else 0.0
        out.append((ident.key, fig))
    return out


def evaluate(root: Path, out: Path, objects: int, seed: int, truth: Path | None, label: str) -> dict:
    manifest = load_manifest(write_manifest(root, out, objects, seed, out.parent))
    summary = run_batch(manifest, workers=1, progress=False, resume=False)
    checks = check_output(out, truth_root=truth)
    by_set: dict[str, list] = {}
    for c in checks:
        by_set.setdefault(c.image_set, []).append(c)
    print(f"\n== {label}: {root}")
    print(f"{'image set':<44}{'asked':>6}{'placed':>7}{'ok':>4}  stage seconds {' '.join(STAGES)}  / rejections")
    asked = placed = ok = 0
    reasons: Counter[str] = Counter()
    for o in sorted(summary.outcomes, key=lambda o: o.key):
        rec_path = next((out / "synthcompose").rglob(f"{o.key.split('/')[-1]}_synthcompose.json"), None)
        rec = json.loads(rec_path.read_text()) if rec_path else {}
        n_placed = len(rec.get("objects", []))
        n_asked = n_placed + len(rec.get("not_placed", []))
        if not n_asked:
            n_asked = objects
        cs = by_set.get(o.key, [])
        n_ok = sum(not c.failures for c in cs)
        asked, placed, ok = asked + n_asked, placed + n_placed, ok + n_ok
        why: Counter[str] = Counter()
        for f in rec.get("not_placed", []):
            why.update(f.get("rejections", {}))
        for r in rec.get("objects", []):
            why.update(r.get("placement", {}).get("rejections", {}))
        reasons.update(why)
        stages = " ".join(f"{o.timings.get(s, 0.0):.2f}" for s in STAGES)
        top = ", ".join(f"{k} x{v}" for k, v in why.most_common(3))
        print(f"{o.key:<44}{n_asked:>6}{n_placed:>7}{n_ok:>4}  {stages}  / {top}")
    changed = labels_changed_outside(root, out, [o.key for o in summary.outcomes if o.status == "done"])
    print(f"{'object':<12}{'dist m':>7}{'foot':>6}{'truth':>6}{'gap m':>7}{'pen m':>7}{'occl':>6}{'yaw°':>6}  verdict")
    for c in checks:
        yaw = "-" if c.yaw_to_road_deg is None else f"{c.yaw_to_road_deg:.1f}"
        tr = "-" if c.footprint_on_truth is None else f"{c.footprint_on_truth:.2f}"
        verdict = "ok" if not c.failures else "FAIL: " + ", ".join(c.failures)
        print(f"{c.name[:12]:<12}{c.distance_m:>7.1f}{c.footprint_on_allowed:>6.2f}{tr:>6}{c.ground_gap_m:>7.3f}"
              f"{c.penetration_m:>7.3f}{c.occluded_fraction:>6.2f}{yaw:>6}  {verdict}")
    means = summary.stage_means()
    per_object = means.get("placement", 0.0) / max(placed / max(summary.count("done"), 1), 1e-9)
    on_truth = [c.footprint_on_truth for c in checks if c.footprint_on_truth is not None]
    result = {
        "asked": asked, "placed": placed, "placed_share": placed / asked if asked else 0.0,
        "pass_strict": ok, "pass_share": ok / placed if placed else 0.0,
        "placement_ms_per_object": 1000 * per_object,
        "stage_mean_s": means, "rejections": dict(reasons.most_common(8)),
        "on_truth_ge_095": (sum(v >= LIMITS["footprint_on_allowed"] for v in on_truth), len(on_truth)),
        "labels_changed_outside_objects_px": changed,
    }
    print(f"totals: {placed}/{asked} placed ({result['placed_share']:.0%}), {ok}/{placed} pass check-placement "
          f"--strict ({result['pass_share']:.0%}), placement {result['placement_ms_per_object']:.0f} ms per object; "
          f"mean stage s: " + ", ".join(f"{k} {v:.2f}" for k, v in means.items()))
    if on_truth:
        print(f"on the true labels: {result['on_truth_ge_095'][0]}/{len(on_truth)} footprints >= 0.95 on the allowed class")
    if changed is not None:
        print(f"label or instance pixels changed outside the inserted objects: {changed}")
    if truth is not None:
        print("surfaces found without labels, against the true labels (precision / recall):")
        for key, f in surfaces_against_truth(root, truth):
            print(f"  {key:<44} road {f['road_precision']:.2f} / {f['road_recall']:.2f}, sidewalk "
                  f"{f['sidewalk_precision']:.2f} / {f['sidewalk_recall']:.2f} "
                  f"(footway precision {f['footway_precision']:.2f}; {f['sidewalk_on_walkable']:.0%} of it on "
                  "walkable ground)")
    print("rejections (all attempts):", ", ".join(f"{k} x{v}" for k, v in reasons.most_common(6)))
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="Cityscapes root (real frames)")
    ap.add_argument("--truth", type=Path, help="labelled root with the same frames (for an unlabelled ROOT)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated scenes, 2048x1024, same run")
    ap.add_argument("--streets", choices=("plain", "traffic"), default="plain",
                    help="the generated scenes' streets (make-sample --streets)")
    ap.add_argument("--objects", type=int, default=3, help="objects asked per image set")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--out", type=Path, help="keep the outputs here (default: a temporary folder)")
    ap.add_argument("--json", type=Path, help="write the totals here")
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    results = {}
    with tempfile.TemporaryDirectory(prefix="synthcompose-eval-") as tmp:
        base = a.out or Path(tmp)
        if a.root is not None:
            (base / "real").mkdir(parents=True, exist_ok=True)
            results["real"] = evaluate(a.root.resolve(), base / "real" / "out", a.objects, a.seed, a.truth, "real")
        if a.generated:
            from synthcompose.synthetic import make_sample

            gen = base / "generated"
            make_sample(gen / "cityscapes", count=a.generated, width=2048, height=1024, seed=a.seed,
                        streets=None if a.streets == "plain" else a.streets)
            results["generated"] = evaluate(gen / "cityscapes", gen / "out", a.objects, a.seed, None, "generated")
    if len(results) == 2:
        r, g = results["real"], results["generated"]
        print(f"\nreal vs generated: placed {r['placed_share']:.0%} vs {g['placed_share']:.0%}, pass "
              f"{r['pass_share']:.0%} vs {g['pass_share']:.0%}, placement {r['placement_ms_per_object']:.0f} vs "
              f"{g['placement_ms_per_object']:.0f} ms per object")
    if a.json:
        a.json.write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
