"""Issue 29's outline measure on exact shadows: what a physically right shadow reads.

    python benchmarks/outline_reference.py [--distances 10 15 20 26] [--yaws 0 30 90] [--sun 40 30]

A box car (body, cabin, four wheels; 0.18 m under the sills, 0.32-0.36 m under the bumpers)
stands on a flat grey road seen from a Cityscapes camera (2048x1024, f 2262 px, 1.22 m up).
Its shadow is worked out exactly, not rendered (:mod:`evaluation.exact_shadow`): for each point
of the road, the share of the sky's light that reaches it past the car (a CIE overcast sky,
1 + 2 cos(zenith), over 2,048 directions) and, with ``--sun``, the share of the sun's disc (0.53
degrees, 64 directions) it sees. The output is the road's grey times that (8-bit sRGB, as
written), the car's pixels its own grey. Then :func:`evaluation.shadowlook.outline` measures it
exactly as ``eval_sun.py`` does.

Per case: the car's distance and yaw (0: seen from behind, 90: side on), its width in pixels,
the outline in the overcast sky alone and, with a sun (azimuth from the camera's forward axis,
elevation; the sunlit road 3 times as bright as the shade, as on a clear day), the
outline with the sun. Over 0.2 counts against issue 29's 5 % target. Pure NumPy; a minute or
two.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from evaluation import shadowlook  # noqa: E402
from evaluation.exact_shadow import light_grid, picture  # noqa: E402


def _f(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--distances", type=float, nargs="+", default=[10, 15, 20, 26])
    ap.add_argument("--yaws", type=float, nargs="+", default=[0, 30, 90])
    ap.add_argument("--sun", type=float, nargs=2, metavar=("AZIMUTH", "ELEVATION"), default=None,
                    help="also a sun at this azimuth (degrees from the view's forward axis, "
                         "towards the right) and elevation")
    a = ap.parse_args(argv)
    print(f"{'distance':>8} {'yaw':>4} {'width':>5} {'under':>5} {'edge':>5} {'sky outline':>11} {'with sun':>8}")
    over = total = 0
    for yaw in a.yaws:
        sky, sun = light_grid(yaw, None if a.sun is None else tuple(a.sun))
        for d in a.distances:
            src, out, out_sun, car = picture(d, yaw, sky, sun)
            width = int(np.ptp(np.nonzero(car.any(axis=0))[0]) + 1)
            line = shadowlook.outline(src, out, [car])[0]
            under = shadowlook.under(out, car, ~car)
            edge = shadowlook.under_edge(out, car, ~car)
            with_sun = "-"
            if out_sun is not None:
                with_sun = shadowlook.outline(src, out_sun, [car])[0]
                over += with_sun > 0.2
                with_sun = f"{with_sun:.2f}"
            over += line > 0.2
            total += 1 + (sun is not None)
            print(f"{d:8.1f} {yaw:4.0f} {width:5d} {_f(under):>5} {_f(edge, 3):>5} {line:11.2f} {with_sun:>8}",
                  flush=True)
    print(f"over 0.2: {over}/{total}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
