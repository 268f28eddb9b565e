"""PNG encoding of one image set's outputs with each zlib strategy (OpenCV), at the level the
writer uses: time and size per file.

    python benchmarks/bench_png.py [--size 2048x1024]

Uses the first generated image set of the benchmarks' generated data (`bench_cost.dataset`) (made when missing).
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
from synthcompose.io.files import PNG_COMPRESSION, PNG_STRATEGY  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402

STRATEGIES = {"default": cv2.IMWRITE_PNG_STRATEGY_DEFAULT, "filtered": cv2.IMWRITE_PNG_STRATEGY_FILTERED,
              "huffman": cv2.IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY, "rle": cv2.IMWRITE_PNG_STRATEGY_RLE,
              "fixed": cv2.IMWRITE_PNG_STRATEGY_FIXED}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--repeat", type=int, default=5, help="best of this many encodings")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    data = dataset(10, width, height)
    s = read_image_set(data, find_image_sets(data)[0])
    cv2.setNumThreads(1)
    images = {"rgb": cv2.cvtColor(s.rgb, cv2.COLOR_RGB2BGR), "labelIds": s.label_ids,
              "instanceIds": s.instance_ids.astype(np.uint16),
              "color": cv2.cvtColor(colorize(s.label_ids), cv2.COLOR_RGBA2BGRA), "disparity": s.disparity}
    used = next(k for k, v in STRATEGIES.items() if v == PNG_STRATEGY)
    print(f"{width}x{height}, zlib level {PNG_COMPRESSION}, one thread; the writer uses '{used}'")
    print(f"{'file':<12}" + "".join(f"{k:>20}" for k in STRATEGIES))
    totals = dict.fromkeys(STRATEGIES, 0.0)
    for name, img in images.items():
        cells = []
        for key, strategy in STRATEGIES.items():
            best, size = float("inf"), 0
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                _, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESSION,
                                                    cv2.IMWRITE_PNG_STRATEGY, strategy])
                best, size = min(best, time.perf_counter() - t0), len(buf)
            totals[key] += best
            cells.append(f"{best * 1000:6.0f} ms {size / 1e6:6.2f} MB")
        print(f"{name:<12}" + "".join(f"{c:>20}" for c in cells))
    print(f"{'all':<12}" + "".join(f"{totals[k] * 1000:>12.0f} ms     " for k in STRATEGIES))
    return 0


if __name__ == "__main__":
    sys.exit(main())
