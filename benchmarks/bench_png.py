"""PNG encoding of one image set's outputs: the writer (io.png, each row filter) against OpenCV's
libpng at the cost yardstick's settings (zlib level 1, run-length strategy, libpng's filter
choice per row) and at the writer's former fixed filters; time (one thread, best of --repeat)
and size per file.

    python benchmarks/bench_png.py [--size 2048x1024] [--real <Cityscapes root>]

Uses the first image set of --real, or of the benchmarks' generated data (`bench_cost.dataset`,
made when missing). Nothing is written.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.bench_cost import dataset  # noqa: E402
from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.io.png import PNG_FILTERS, PNG_LEVEL, encode_png  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402
from synthcompose.write.outputs import PNG_FILTER_OF  # noqa: E402

_CV = [cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_RLE]
OPENCV = {"cv-adaptive": [], "cv-paeth": [cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_PAETH],
          "cv-up": [cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_UP]}


def _best(fn, repeat: int) -> tuple[float, int]:
    best, size = float("inf"), 0
    for _ in range(repeat):
        t0 = time.thread_time()
        size = len(fn())
        best = min(best, time.thread_time() - t0)
    return best, size


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="2048x1024", help="of the generated data")
    ap.add_argument("--real", type=Path, help="a Cityscapes root: its first image set instead")
    ap.add_argument("--repeat", type=int, default=5, help="best of this many encodings")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    data = args.real or dataset(10, width, height)
    s = read_image_set(data, find_image_sets(data)[0], right=True)
    cv2.setNumThreads(1)
    images = {"rgb": s.rgb, "labelIds": s.label_ids, "instanceIds": np.asarray(s.instance_ids, np.uint16),
              "color": colorize(s.label_ids), "disparity": s.disparity}
    if s.right_rgb is not None:
        images["right"] = s.right_rgb
    methods = list(OPENCV) + [f"writer-{f}" for f in PNG_FILTERS]
    print(f"{s.rgb.shape[1]}x{s.rgb.shape[0]}, one thread; OpenCV at zlib level 1 (run-length), the writer at ISA-L "
          f"level {PNG_LEVEL}; the writer's filter per file marked *")
    print(f"{'file':<12}" + "".join(f"{k:>22}" for k in methods))
    totals = {k: [0.0, 0] for k in methods + ["writer"]}
    for name, img in images.items():
        bgr = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2BGR if img.shape[2] == 3 else cv2.COLOR_RGBA2BGRA)
        cells = []
        for key in methods:
            if key in OPENCV:
                cost = _best(lambda: cv2.imencode(".png", bgr, _CV + OPENCV[key])[1], args.repeat)
            else:
                cost = _best(lambda: encode_png(img, key.removeprefix("writer-")), args.repeat)
            mine = key == f"writer-{PNG_FILTER_OF[name]}"
            for k in [key] + (["writer"] if mine else []):
                totals[k][0] += cost[0]
                totals[k][1] += cost[1]
            cells.append(f"{cost[0] * 1000:6.1f} ms {cost[1] / 1e6:6.3f} MB{'*' if mine else ' '}")
        print(f"{name:<12}" + "".join(f"{c:>22}" for c in cells))
    print(f"{'all':<12}" + "".join(f"{totals[k][0] * 1000:6.1f} ms {totals[k][1] / 1e6:6.3f} MB " for k in methods))
    w, a = totals["writer"], totals["cv-adaptive"]
    print(f"the writer (its filter per file): {w[0] * 1000:.1f} ms, {w[1] / 1e6:.3f} MB; OpenCV as the yardstick "
          f"{a[0] * 1000:.1f} ms, {a[1] / 1e6:.3f} MB: {a[0] / w[0]:.1f} x less CPU, {w[1] / a[1]:.2f} x the bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
