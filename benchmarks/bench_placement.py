"""Placement time per object at full size, on a Cityscapes root (real frames first) and on
generated scenes in the same run.

    python benchmarks/bench_placement.py ROOT [--generated 4] [--objects 3] [--repeat 3] [--seed 7]

For each image set the frame is built as the pipeline builds it (its own labels, or the surfaces
found without them: timed apart, as "surfaces"), then the bundled manifest's objects are drawn
and placed one after the other as the batch places them. The time per object includes the
frame's set-up for placement (stereo noise, kerb lines, candidate pixels, road lines), which the
first object of a frame pays; the models are loaded before the clock starts. Each frame is
placed ``--repeat`` times on a fresh frame (empty caches) and the fastest run counts, so the
machine's noise does not. Prints per image set and the totals; real and generated in one run.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.geometry.depth import disparity_to_depth, make_frame  # noqa: E402
from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.models import load_model  # noqa: E402
from synthcompose.placement import place_object  # noqa: E402
from synthcompose.placement.surfaces import frame_for  # noqa: E402


def bench_root(root: Path, manifest, objects: int, repeat: int, seed: int, label: str) -> dict:
    specs = manifest.objects
    weights = np.array([s.weight for s in specs], float)
    weights /= weights.sum()
    models = {s.name: load_model(s.model, s.size, s.up, s.forward) for s in specs}
    print(f"\n== {label}: {root}")
    print(f"{'image set':<44}{'surfaces ms':>12}{'placed':>8}{'ms/object':>11}")
    total_ms, total_objects, total_placed, surf = 0.0, 0, 0, []
    for ident in find_image_sets(root):
        image_set = read_image_set(root, ident)
        depth = disparity_to_depth(image_set.disparity, image_set.camera)
        t0 = time.perf_counter()
        frame, _ = frame_for(image_set, depth)
        surf_ms = 1000 * (time.perf_counter() - t0)
        best, placed = float("inf"), 0
        for _ in range(repeat):
            fresh = make_frame(frame.depth, frame.label_ids, frame.camera, frame.labelled, frame.photo)
            rng = np.random.default_rng([seed, zlib.crc32(ident.key.encode())])
            done = []
            t0 = time.perf_counter()
            for _ in range(objects):
                spec = specs[int(rng.choice(len(specs), p=weights))]
                result = place_object(fresh, spec.class_name, models[spec.name].extents, rng, manifest.rules,
                                      spec.allowed_surfaces, spec.orientation, done)
                if result.placement is not None:
                    done.append(result.placement)
            best = min(best, time.perf_counter() - t0)
            placed = len(done)
        ms = 1000 * best / objects
        print(f"{ident.key:<44}{surf_ms if not image_set.labelled else 0.0:>12.0f}{placed:>5}/{objects:<2}{ms:>11.1f}")
        total_ms += 1000 * best
        total_objects += objects
        total_placed += placed
        if not image_set.labelled:
            surf.append(surf_ms)
    per = total_ms / max(total_objects, 1)
    print(f"totals: {total_placed}/{total_objects} placed, {per:.1f} ms per object"
          + (f", surfaces {np.mean(surf):.0f} ms per frame" if surf else ""))
    return {"ms_per_object": per, "placed": total_placed, "asked": total_objects,
            "surfaces_ms_per_frame": float(np.mean(surf)) if surf else None}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="Cityscapes root (real frames)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated 2048x1024 scenes, same run")
    ap.add_argument("--objects", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--json", type=Path, help="write the totals here")
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    manifest = load_manifest(REPO / "assets" / "demo" / "manifest.json")
    results = {}
    with tempfile.TemporaryDirectory(prefix="synthcompose-bench-") as tmp:
        if a.root is not None:
            results["real"] = bench_root(a.root.resolve(), manifest, a.objects, a.repeat, a.seed, "real")
        if a.generated:
            from synthcompose.synthetic import make_sample

            gen = Path(tmp) / "generated"
            make_sample(gen, count=a.generated, width=2048, height=1024, seed=a.seed)
            results["generated"] = bench_root(gen, manifest, a.objects, a.repeat, a.seed, "generated")
    if len(results) == 2:
        r, g = results["real"], results["generated"]
        print(f"\nreal vs generated: {r['ms_per_object']:.1f} vs {g['ms_per_object']:.1f} ms per object "
              f"(ratio {r['ms_per_object'] / g['ms_per_object']:.2f})")
    if a.json:
        a.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
