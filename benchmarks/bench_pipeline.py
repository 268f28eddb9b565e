"""End-to-end batch speed at Cityscapes size, next to the PNG codec floor.

    python benchmarks/bench_pipeline.py [--count N] [--size 2048x1024] [--workers 1,2] [--scale 10,100]

Generates N synthetic image sets with one car each to insert (cached under out/bench/), then
in one run measures:

* the codec floor: decoding the inputs and encoding the outputs of the same image sets with
  the same settings and nothing else, one file after the other and side by side on OpenCV's
  threads as the pipeline does (one process);
* the whole batch (`synthcompose batch`, fresh output root) with each worker count: wall time
  per image set, throughput against one worker, mean time per stage, peak RSS per worker;
* with --scale, the one-worker wall time for each batch size, to check it grows linearly.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.io.files import encode_png, map_threads  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_cost import dataset, run_batch  # noqa: E402


def codec_floor(root: Path, count: int, threaded: bool) -> float:
    """Mean seconds per image set to decode its 4 input PNGs and encode 5 output PNGs: one after
    the other, or (``threaded``) side by side as the pipeline codes them (fileio.map_threads)."""
    import cv2

    cv2.setNumThreads(0 if not threaded else -1)  # 0: map_threads runs a plain loop
    times = []
    try:
        for ident in find_image_sets(root)[:count]:
            t0 = time.perf_counter()
            s = read_image_set(root, ident)
            outputs = (lambda: s.rgb, lambda: s.label_ids, lambda: s.instance_ids.astype("uint16"),
                       lambda: colorize(s.label_ids), lambda: s.disparity)
            map_threads(lambda make: encode_png(make()), outputs)
            times.append(time.perf_counter() - t0)
    finally:
        cv2.setNumThreads(-1)
    return statistics.mean(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=10)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--workers", default="1,2", help="worker counts to measure")
    ap.add_argument("--scale", default="", help="batch sizes for the linearity check, e.g. 10,100")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    sizes = [int(v) for v in args.scale.split(",") if v]
    data = dataset(max([args.count] + sizes), width, height)
    n = args.count
    floor_seq = codec_floor(data, n, threaded=False)
    floor = codec_floor(data, n, threaded=True)
    print(f"\n{n} image sets at {width}x{height}, one car each\n")
    print(f"PNG codec floor (decode 4 inputs + encode 5 outputs), one after the other: {floor_seq * 1000:.0f} ms "
          f"per image set; side by side as the pipeline codes them: {floor * 1000:.0f} ms (the 'x floor' below)\n")
    rows, base = [], None
    for workers in [int(v) for v in args.workers.split(",")]:
        r = run_batch(data, workers, n)
        per = r["wall_s"] / n
        base = base or per
        peak = r["rss_self_mb"] if workers == 1 else r["rss_children_mb"]
        rows.append((workers, per, base / per, per / floor, per / floor_seq, peak, r["summary"]))
    print(f"{'workers':>8}{'ms/set':>9}{'speed-up':>10}{'x floor':>9}{'x floor one by one':>20}"
          f"{'peak RSS/worker MB':>20}")
    for workers, per, speed, xf, xs, peak, _ in rows:
        print(f"{workers:>8}{per * 1000:>9.0f}{speed:>10.2f}{xf:>9.2f}{xs:>20.2f}{peak:>20.0f}")
    print("\nmean time per stage (ms), one worker (the stages of three image sets overlap: "
          "Pipeline.stream):")
    for stage, v in rows[0][6]["mean_stage_s"].items():
        print(f"  {stage:<10}{v * 1000:>7.0f}")
    if sizes:
        print("\nlinearity, one worker (wall includes start-up):")
        for size in sizes:
            r = run_batch(data, 1, size)
            print(f"  {size:>5} image sets: {r['wall_s']:7.1f} s, {r['wall_s'] / size * 1000:6.0f} ms per set")
    return 0


if __name__ == "__main__":
    sys.exit(main())
