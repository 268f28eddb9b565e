"""How varied the default street cast is: distinct car models, people (bodies), poses and sign
types in the records of a batch of the built-in ``"cast": "street"``.

    python benchmarks/cast_stats.py ROOT [ROOT ...] --seeds 1 2 3 [--out out/cast_stats] [--per-image 2]
    python benchmarks/cast_stats.py --records OUT [OUT ...]      # count the records of earlier batches

For each root (a Cityscapes root: its every image set) and each seed, a batch of the demo's
settings with ``"cast": "street"`` (the right view off: the counts do not need it) is run into
``OUT/<root name>-seed<seed>/``; then every record under the outputs is read and counted:

* car models: distinct ``appearance.model`` of the objects of class car (and of the vehicle
  classes truck and bus, counted apart);
* people: distinct ``appearance.model`` of class person (each entry is one body);
* poses: distinct ``pose/variant`` of the people's ``appearance.pose`` (``standing/pockets``,
  ``walking/walk``: the kinds of pose the issue names), the coarse ``pose`` alone, and distinct
  pose descriptions whole;
* sign types: distinct ``appearance.sign.code`` (the main sign of a pole), and the codes hung
  under them.

The issue's target over 100 image sets: at least 5 car models, 8 people, 6 poses, 5 sign
types. Never commit outputs made from real frames.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def run_batches(roots: list[Path], seeds: list[int], out: Path, per_image: int) -> list[Path]:
    demo = json.loads((REPO / "assets" / "demo" / "manifest.json").read_text())
    outputs = []
    for root in roots:
        for seed in seeds:
            dest = out / f"{root.name}-seed{seed}"
            dest.mkdir(parents=True, exist_ok=True)
            manifest = {k: v for k, v in demo.items() if k not in ("splits", "objects")} | {
                "dataset": str(root.resolve()), "output": str(dest.resolve() / "out"), "seed": seed,
                "cast": "street", "objects_per_image": per_image, "render": {"right_view": False}}
            path = dest / "manifest.json"
            path.write_text(json.dumps(manifest, indent=1))
            print(f"batch {root} seed {seed} -> {dest}", flush=True)
            subprocess.run([sys.executable, "-m", "synthcompose", "batch", str(path), "--no-progress"], check=True)
            outputs.append(dest / "out")
    return outputs


def count(outputs: list[Path]) -> dict:
    sets, objects = 0, Counter()
    cars, heavy, people, poses, coarse, whole_poses, signs, below = (Counter() for _ in range(8))
    for out in outputs:
        for path in sorted(Path(out).rglob("*_synthcompose.json")):
            record = json.loads(path.read_text())
            if record.get("status") != "done":
                continue
            sets += 1
            for obj in record["objects"]:
                look, cls = obj.get("appearance", {}), obj["class"]
                objects[cls] += 1
                model = look.get("model", obj["model"])
                if cls == "car":
                    cars[model] += 1
                elif cls in ("truck", "bus"):
                    heavy[model] += 1
                elif cls == "person":
                    people[model] += 1
                    pose = look.get("pose", {})
                    poses[f"{pose.get('pose', '?')}/{pose.get('variant', '?')}"] += 1
                    coarse[pose.get("pose", "?")] += 1
                    whole_poses[json.dumps(pose, sort_keys=True)] += 1
                elif cls == "traffic sign" and "sign" in look:
                    signs[look["sign"]["code"]] += 1
                    below.update(look["sign"].get("below", []))
    return {"image_sets": sets, "objects": dict(objects), "car_models": dict(cars), "bus_lorry_models": dict(heavy),
            "people": dict(people), "poses": dict(poses), "pose_kinds": dict(coarse),
            "distinct_pose_descriptions": len(whole_poses),
            "sign_types": dict(signs), "supplementary_signs": dict(below)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("roots", nargs="*", type=Path, help="Cityscapes roots to run the street cast on")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--out", type=Path, default=REPO / "out" / "cast_stats")
    ap.add_argument("--per-image", type=int, default=2, help="objects per image set (the demo's: 2)")
    ap.add_argument("--records", type=Path, nargs="+", help="count the records under these output roots instead")
    a = ap.parse_args(argv)
    if not a.roots and not a.records:
        ap.error("give ROOTs to run, or --records OUT")
    outputs = a.records or run_batches(a.roots, a.seeds, a.out, a.per_image)
    stats = count(outputs)
    print(json.dumps(stats, indent=1))
    target = {"car_models": 5, "people": 8, "poses": 6, "sign_types": 5}
    print(f"\n{stats['image_sets']} image sets; distinct (target over 100 image sets):")
    for key, want in target.items():
        print(f"  {key:11s} {len(stats[key]):3d}  (>= {want})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
