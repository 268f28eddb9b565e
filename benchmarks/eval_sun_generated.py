"""The light estimate's sun against the true one, on generated sunny streets (``make-sample
--light sunny``: the sun across the street, through a gap in the houses on its side).

    python benchmarks/eval_sun_generated.py [--count 12] [--seeds 3 5] [--size 2048x1024] [--no-site]

The scenes' vehicle files put the sun where it can stand (``synthetic.light.sunny_vehicle``);
``--no-site`` measures the estimate without them.

Per scene: the true sun (azimuth / elevation, the generator's own draw), the estimate's, whether
it was sure of the side, the angle between their axes (mod 180) and between their directions;
totals last: the axis within 15 degrees, the direction (the side too) within 15 degrees, the
median elevation error where the side is right.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from evaluation.shadowlook import axis_angle  # noqa: E402
from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.lighting import estimate_lighting  # noqa: E402
from synthcompose.lighting.solar import SunSite  # noqa: E402
from synthcompose.placement.surfaces import frame_for  # noqa: E402
from synthcompose.synthetic import make_sample  # noqa: E402
from synthcompose.synthetic.light import sunny_light  # noqa: E402


def run(seed: int, count: int, width: int, height: int, folder: Path, site: bool = True) -> list[tuple]:
    """(name, true az, true el, sunny, az, el, sure, axis off, direction off) per scene;
    ``site``: the estimate knows where the sun can stand (the scenes' vehicle files)."""
    root = folder / f"seed{seed}"
    make_sample(root, count=count, width=width, height=height, seed=seed, light="sunny")
    rows = []
    for i, ident in enumerate(find_image_sets(root)):
        truth = sunny_light(np.random.default_rng([seed, int(ident.frame), 1]))  # make_sample's draw
        s = read_image_set(root, ident)
        depth = disparity_to_depth(s.disparity, s.camera)
        frame, _ = frame_for(s, depth)
        e = estimate_lighting(s.rgb, frame.label_ids, depth, s.camera, labelled=frame.labelled,
                              site=SunSite.of(s.vehicle) if site else None)
        full = abs((e.sun_azimuth_deg - truth.sun_azimuth_deg + 180.0) % 360.0 - 180.0)
        rows.append((ident.name, truth.sun_azimuth_deg, truth.sun_elevation_deg, e.sunny, e.sun_azimuth_deg,
                     e.sun_elevation_deg, bool(e.cues.get("sun_direction_sure")),
                     axis_angle(e.sun_azimuth_deg, truth.sun_azimuth_deg), full))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 5])
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--no-site", action="store_true", help="leave the vehicle files' site unread (the sun anywhere)")
    a = ap.parse_args(argv)
    width, height = (int(v) for v in a.size.split("x"))
    print(f"{'scene':<28}{'true az/el':>12}{'estimate':>12}{'sure':>6}{'axis off':>10}{'dir off':>9}")
    with tempfile.TemporaryDirectory(prefix="synthcompose-sungen-") as tmp:
        for seed in a.seeds:
            rows = run(seed, a.count, width, height, Path(tmp), site=not a.no_site)
            for name, taz, tel, sunny, az, el, sure, axis, full in rows:
                est = f"{az:.0f}/{el:.0f}" if sunny else "overcast"
                print(f"{name:<28}{taz:>7.0f}/{tel:<4.0f}{est:>12}{'yes' if sure else 'no':>6}{axis:>10.0f}{full:>9.0f}")
            called = [r for r in rows if r[3]]
            right = [r for r in called if r[8] <= 15]
            el_err = [abs(r[5] - r[2]) for r in right]
            print(f"seed {seed}: called sunny {len(called)}/{len(rows)}; axis within 15 degrees "
                  f"{sum(r[7] <= 15 for r in called)}/{len(rows)}; direction (the side too) within 15 degrees "
                  f"{len(right)}/{len(rows)}; elevation off where the direction is right: median "
                  f"{np.median(el_err) if el_err else float('nan'):.0f} degrees\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
