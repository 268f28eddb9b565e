"""The render stage alone: one image set's objects rendered again and again, wall and CPU time
per render (CPU counts every thread of the process: llvmpipe rasterises on threads of its own).

    python benchmarks/bench_render.py [--renders 30] [--set 3] [--repeat 3]

Uses the benchmarks' generated data (`bench_cost.dataset`) (2048x1024, one car per set; made when missing). The
image set is processed once to place its car; then Renderer.render runs --renders times with the
same arguments, its id pass read back each time (which waits for the GL), --repeat times.
Steadier than the end-to-end figures on a shared machine, for comparing two versions of the
renderer or shaders.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.bench_cost import CAR, dataset  # noqa: E402
from synthcompose.io.dataset import find_image_sets  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.run.pipeline import Pipeline  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--renders", type=int, default=30)
    ap.add_argument("--set", type=int, default=3, help="which of the 10 generated image sets")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    data = dataset(10, 2048, 1024)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.json"
        path.write_text(json.dumps({"dataset": str(data), "output": str(Path(tmp) / "out"), "seed": 1, "objects": [
            {"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}}]}))
        with Pipeline(load_manifest(path)) as pipe:
            renderer, render, calls = pipe.renderer, pipe.renderer.render, []
            renderer.render = lambda *a, **k: calls.append((a, k)) or render(*a, **k)
            outcome = pipe.process(find_image_sets(data)[args.set])
            renderer.render = render
            if not calls:
                print(f"image set {args.set}: nothing rendered ({outcome.status}: {outcome.reason})")
                return 1
            a, k = calls[0]
            runs = []
            for _ in range(args.repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                for _ in range(args.renders):
                    passes = render(*a, **k)
                    passes.read("id")
                    roi = passes.roi
                    renderer.release(passes)
                runs.append(((time.perf_counter() - t0) / args.renders, (time.process_time() - c0) / args.renders))
    wall, cpu = min(runs)
    print(f"image set {args.set} ({outcome.key}), ROI {roi.width}x{roi.height}, {args.renders} renders x {args.repeat}")
    print(f"  per render: wall {wall * 1000:.1f} ms, CPU {cpu * 1000:.1f} ms (best run; all: "
          + ", ".join(f"{w * 1000:.0f}/{c * 1000:.0f}" for w, c in runs) + ")")
    return 0


if __name__ == "__main__":
    sys.exit(main())
