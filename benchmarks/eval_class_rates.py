"""How often each class finds a place on a frame by itself: the placement's own rate, without
the batch's draws.

    python benchmarks/eval_class_rates.py <root> [<root> ...] [--seeds 3] [--classes person,traffic sign,car]

For every image set of each root (its labels where it has them, else the surfaces found without
labels: ``placement/surfaces.py``), one object of each class is placed alone (the test suite's
sizes, placement's default rules at 7-40 m) with seeds 0..N-1; prints placed / asked per frame
and class, then the totals. The batch's own per-draw figures (``eval_traffic.py``) move with
what was drawn before each object; these do not. Nothing is written; never commit real pixels.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.placement.rules import PlacementRules  # noqa: E402
from synthcompose.placement.search import place_object  # noqa: E402
from synthcompose.placement.surfaces import frame_for  # noqa: E402

#: each class's extents (length, width, height, metres): the test suite's (tests/helpers.py)
SIZES = {"car": (4.4, 1.85, 1.48), "person": (0.5, 0.6, 1.75), "traffic sign": (0.2, 0.8, 2.5)}
DISTANCE = (7.0, 40.0)


def rates(root: Path, classes: list[str], seeds: int) -> dict[str, int]:
    """Placed counts per class over the root's image sets (``seeds`` tries each); prints a row a frame."""
    print(f"\n== {root}\n{'image set':<34}" + "".join(f"{c:>14}" for c in classes))
    placed = dict.fromkeys(classes, 0)
    for ident in find_image_sets(root):
        frame, _ = frame_for(read_image_set(root, ident))
        row = []
        for cls in classes:
            n = sum(place_object(frame, cls, SIZES[cls], np.random.default_rng(seed),
                                 PlacementRules(distance=DISTANCE)).placement is not None for seed in range(seeds))
            placed[cls] += n
            row.append(f"{n}/{seeds}")
        print(f"{ident.key.split('/')[-1][:33]:<34}" + "".join(f"{r:>14}" for r in row), flush=True)
    return placed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("roots", nargs="+", type=Path)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--classes", default="person,traffic sign,car")
    a = ap.parse_args(argv)
    classes = [c.strip() for c in a.classes.split(",")]
    unknown = [c for c in classes if c not in SIZES]
    if unknown:
        ap.error(f"--classes: no size for {unknown} (known: {', '.join(SIZES)})")
    for root in a.roots:
        n = len(find_image_sets(root))
        placed = rates(root.resolve(), classes, a.seeds)
        print("totals: " + ", ".join(f"{c} {placed[c]}/{n * a.seeds} ({placed[c] / max(n * a.seeds, 1):.0%})"
                                     for c in classes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
