"""Accuracy of the light estimate (lighting.py) on generated sunny and overcast scenes with a
known light: how often the sun is detected, and the sun azimuth error when it is.

    python benchmarks/eval_lighting.py --count 60 --size 1024x512

Not a test (it takes minutes): prints a table, and one line per scene with --verbose. The
table is broken down by the share of the ground in view (pixels of lighting.GROUND_IDS) that
the sun really reaches (the generator's own sun visibility): where that ground is in shadow,
an object placed on it gets ambient light only, whatever the sun's direction.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from synthcompose.geometry.depth import disparity_to_depth
from synthcompose.lighting import GROUND_IDS, estimate_lighting
from synthcompose.synthetic import SceneLight, random_scene, render_scene, render_scene_sunlit

BUILDING_IDS = (11, 12)  # building, wall
#: bins of the ground's sunlit share: (name, low, high), low < share <= high
BINS = (("0", -1.0, 0.0), ("(0, 10%]", 0.0, 0.10), ("(10, 50%]", 0.10, 0.50), ("> 50%", 0.50, 1.0))


def azimuth_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=40, help="sunny scenes (and a quarter as many overcast)")
    ap.add_argument("--size", default="1024x512", help="WxH")
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--work-width", type=int, default=700, help="estimate_lighting's working grid width")
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    rng = np.random.default_rng(args.seed)
    errors, detected, times = [], 0, []
    rows = []  # (ground sunlit share, found, azimuth error, walls' sunlit share) per sunny scene
    for i in range(args.count):
        az, el = float(rng.uniform(-180, 180)), float(rng.uniform(20, 65))
        frac = float(rng.uniform(0.5, 0.75))
        light = SceneLight(sun_azimuth_deg=az, sun_elevation_deg=el, sun_fraction=frac)
        scene = random_scene(np.random.default_rng(args.seed + i), w, h, light=light)
        arrays, sunlit = render_scene_sunlit(scene, stereo="exact", photo="clean")
        ground = np.isin(arrays["label_ids"], GROUND_IDS)
        walls = np.isin(arrays["label_ids"], BUILDING_IDS)
        g_lit = float(sunlit[ground].mean()) if ground.any() else 0.0
        b_lit = float(sunlit[walls].mean()) if walls.any() else float("nan")
        depth = disparity_to_depth(arrays["disparity"], scene.camera)
        t0 = time.perf_counter()
        est = estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera, args.work_width)
        times.append(time.perf_counter() - t0)
        err = azimuth_error(est.sun_azimuth_deg, az)
        if est.sunny:
            detected += 1
            errors.append(err)
        rows.append((g_lit, est.sunny, err, b_lit))
        if args.verbose:
            c = est.cues
            print(f"seed {args.seed + i:5d} az {az:7.1f} el {el:4.1f} frac {frac:.2f} -> sunny {est.sunny!s:5} "
                  f"az {est.sun_azimuth_deg:6.1f} el {est.sun_elevation_deg:4.1f} err {err:5.1f} "
                  f"gain {c.get('ground_two_levels_gain', 0):.3f} delta {c.get('ground_shadow_log_ratio', 0):.2f} "
                  f"share {c.get('ground_shadow_share', 0):.2f} sd {c.get('shadow_agreement', 0):.2f} "
                  f"sh {c.get('shading_gain', 0):.3f} pairs {c.get('shading_pairs', 0)} "
                  f"lit ground {100 * g_lit:3.0f}% walls {100 * b_lit:3.0f}%", flush=True)
    overcast_sunny = 0
    n_over = max(1, args.count // 4)
    for i in range(n_over):
        scene = random_scene(np.random.default_rng(args.seed + 5000 + i), w, h,
                             light=SceneLight(sun_fraction=0.0))
        arrays = render_scene(scene, stereo="exact", photo="clean")
        depth = disparity_to_depth(arrays["disparity"], scene.camera)
        overcast_sunny += estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera,
                                             args.work_width).sunny
    e = np.array(errors) if errors else np.array([np.nan])
    print(f"size {w}x{h} (working grid {args.work_width} wide), {args.count} sunny scenes "
          f"(sun azimuth uniform, elevation 20-65 deg), {n_over} overcast")
    print(f"sun detected          : {detected}/{args.count} ({100 * detected / args.count:.0f}%)")
    print(f"azimuth within 20 deg : {int((e <= 20).sum())}/{detected} detected "
          f"({100 * np.mean(e <= 20):.0f}%), {100 * (e <= 20).sum() / args.count:.0f}% of all sunny")
    print(f"azimuth error, deg    : median {np.median(e):.1f}, p90 {np.quantile(e, 0.9):.1f}")
    print(f"overcast called sunny : {overcast_sunny}/{n_over}")
    print("by the share of the ground in view that the sun reaches (generator's truth):")
    print(f"  {'ground sunlit':13s} {'scenes':>6s} {'found':>6s} {'within 20':>11s} {'median err':>10s} "
          f"{'walls sunlit':>12s}")
    for name, lo, hi in BINS + (("> 10% (all)", 0.10, 1.0),):
        sel = [r for r in rows if lo < r[0] <= hi]
        found = [r for r in sel if r[1]]
        good = sum(r[2] <= 20.0 for r in found)
        med = f"{np.median([r[2] for r in found]):.1f}" if found else "-"
        share = f" ({100 * good / len(sel):.0f}%)" if sel else ""
        walls = f"{100 * np.nanmean([r[3] for r in sel]):.0f}%" if sel else "-"
        print(f"  {name:13s} {len(sel):6d} {len(found):6d} {good:4d}{share:>7s} {med:>10s} {walls:>12s}")
    print(f"estimate time         : {1000 * np.mean(times):.0f} ms mean")


if __name__ == "__main__":
    main()
