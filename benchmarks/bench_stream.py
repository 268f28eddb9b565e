"""One process, the same image sets: stages one after the other (Pipeline.process) against
three image sets in the works (Pipeline.stream), wall and CPU time per image set.

    python benchmarks/bench_stream.py [--count 8] [--repeat 3] [--size 2048x1024]

Uses the benchmarks' generated data (`bench_cost.dataset`) (made when missing); the two ways alternate, and
the best of the repeats is printed with every run's figures.
"""
from __future__ import annotations

import argparse
import json
import resource
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


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--size", default="2048x1024")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    data = dataset(10, width, height) if args.count <= 10 else dataset(args.count, width, height)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.json"
        path.write_text(json.dumps({"dataset": str(data), "output": str(Path(tmp) / "out"), "seed": 1, "objects": [
            {"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}}]}))
        ids = find_image_sets(data)[:args.count]
        runs: dict[str, list[tuple[float, float]]] = {"one after the other": [], "streamed": []}
        with Pipeline(load_manifest(path)) as pipe:
            pipe.process(ids[0])  # warm-up: shaders, the model
            for _ in range(args.repeat):
                for way in runs:
                    t0, c0 = time.perf_counter(), cpu_s()
                    outcomes = list(pipe.stream(ids)) if way == "streamed" else [pipe.process(i) for i in ids]
                    assert all(o.status != "failed" for o in outcomes), [o.reason for o in outcomes]
                    runs[way].append(((time.perf_counter() - t0) / len(ids), (cpu_s() - c0) / len(ids)))
    print(f"{args.count} image sets at {width}x{height}, one car each, one process (best of {args.repeat})")
    for way, figures in runs.items():
        wall, cpu = min(figures)
        print(f"  {way:<20} {wall * 1000:5.0f} ms per set, CPU {cpu * 1000:5.0f} ms per set   "
              f"(all: {', '.join(f'{w * 1000:.0f}' for w, _ in figures)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
