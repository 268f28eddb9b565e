"""Collision test cost on a full 2048x1024 point cloud (~2 M points).

    python benchmarks/bench_collision.py [--repeat N]

For car-sized boxes placed on the road of a generated frame, prints the time of: the
paper's lenient pre-filter over all points, the strict oriented-box test on its suspects,
the strict test on all points, and the pixel-grid index (rectangle lookup + strict test)
that placement uses.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from synthcompose.geometry.depth import disparity_to_depth, make_frame  # noqa: E402
from synthcompose.placement import box_corners, pose_matrix, prefilter, strict_inside  # noqa: E402
from synthcompose.synthetic import random_scene, render_scene  # noqa: E402


def timed(fn, repeat):
    out, times = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times) * 1000


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    scene = random_scene(np.random.default_rng([5, 0]), 2048, 1024)
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera)
    pts = frame.cloud.vehicle
    print(f"point cloud: {len(pts):,} points (2048x1024)")
    ext, clearance, margin = (4.4, 1.85, 1.5), 0.12, 0.1
    rows = []
    for x, y in ((9.0, 1.5), (15.0, -2.0), (25.0, 3.0), (35.0, -3.5)):
        m = pose_matrix(np.array([x, y, 0.0]), np.array([0.0, 0.0, 1.0]), 0.05)
        sus, t_pre = timed(lambda: prefilter(pts, m, ext, clearance, margin), args.repeat)
        hit_s, t_strict_sus = timed(lambda: strict_inside(pts[sus], m, ext, clearance, margin).sum(), args.repeat)
        hit_a, t_strict_all = timed(lambda: strict_inside(pts, m, ext, clearance, margin).sum(), args.repeat)

        def grid():
            rect = frame.box_rect(box_corners(m, ext, margin))
            near, _ = frame.rect_points(*rect)
            return strict_inside(near, m, ext, clearance, margin).sum(), len(near)

        (hit_g, n_rect), t_grid = timed(grid, args.repeat)
        assert hit_s == hit_a == hit_g, (hit_s, hit_a, hit_g)
        rows.append((f"({x:.0f}, {y:+.1f})", len(sus), n_rect, int(hit_a), t_pre, t_strict_sus, t_strict_all, t_grid))
    print(f"\n{'box at':<14}{'suspects':>9}{'in rect':>9}{'inside':>8}{'prefilter':>11}{'strict/sus':>12}"
          f"{'strict/all':>12}{'grid+strict':>13}   (ms, median of {args.repeat})")
    for r in rows:
        print(f"{r[0]:<14}{r[1]:>9}{r[2]:>9}{r[3]:>8}{r[4]:>11.2f}{r[5]:>12.3f}{r[6]:>12.2f}{r[7]:>13.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
