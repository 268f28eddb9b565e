"""Disparity and photo statistics of real Cityscapes frames side by side with generated ones.

    python benchmarks/stereo_stats.py ROOT [--generated 4] [--seed 0] [--stereo realistic|exact]
                                      [--photo realistic|clean]
    python benchmarks/stereo_stats.py --generated 4      # generated scenes only

ROOT: a Cityscapes root (leftImg8bit/, disparity/, camera/, and gtFine/ for the road figures;
an unlabelled root gives the label-free figures only). --generated N renders N 2048x1024
scenes in the same run, frame i from ``random_scene(default_rng([seed, i]))`` as
``make_sample`` draws them. Prints each frame's figures, then per figure the range (min..max)
over the real and the generated frames. The figures are defined in
``evaluation/stereo_stats.py`` and ``photo_stats.py``. Nothing is written (real
frames may not be redistributed).
"""
from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from evaluation.photo_stats import photo_stats  # noqa: E402
from evaluation.stereo_stats import BANDS, stereo_stats  # noqa: E402
from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.synthetic import PHOTO_MODES, STEREO_MODES, random_scene, render_scene  # noqa: E402

ROWS = [("valid", "valid share", "{:.1%}"), ("left_band_valid", "valid share, left 100 columns", "{:.1%}"),
        ("residual_med", "road plane residual 31x31, median px", "{:.2f}"),
        ("residual_p90", "road plane residual 31x31, p90 px", "{:.2f}"),
        ("normals_up", "road 7-40 m, 2-px normal within 24 deg of up", "{:.1%}"),
        ("sigma_d", "sigma_d (placement.noise), px", "{:.2f}")]
for lo, hi in BANDS:
    ROWS.append((f"height_{lo:g}_{hi:g}", f"road height {lo:g}-{hi:g} m, median m", "{:+.3f}"))
    ROWS.append((f"height_mad_{lo:g}_{hi:g}", f"road height {lo:g}-{hi:g} m, MAD m", "{:.3f}"))
ROWS += [("fatten_right", "fattening right of objects, px", "{:.1f}"),
         ("fatten_left", "fattening left of objects, px", "{:.1f}"),
         ("invalid_left", "invalid in 8 px left of objects", "{:.0%}"),
         ("invalid_right", "invalid in 8 px right of objects", "{:.0%}"),
         ("v_median", "photo: brightness V, median (0-255)", "{:.0f}"),
         ("v_p5", "photo: brightness V, 5th percentile", "{:.0f}"),
         ("v_p95", "photo: brightness V, 95th percentile", "{:.0f}"),
         ("s_median", "photo: saturation S, median", "{:.0f}"),
         ("s_p90", "photo: saturation S, 90th percentile", "{:.0f}"),
         ("road_v", "photo: road brightness V, median", "{:.0f}"),
         ("sky_v", "photo: sky brightness V, median", "{:.0f}"),
         ("road_green", "photo: road green / mean(red, blue)", "{:.2f}"),
         ("noise", "photo: noise (Immerkaer, 8-bit levels)", "{:.2f}")]


def _range(values: list[float], fmt: str) -> str:
    v = [x for x in values if x is not None and not math.isnan(x)]
    if not v:
        return "-"
    lo, hi = min(v), max(v)
    return fmt.format(lo) if lo == hi else f"{fmt.format(lo)}..{fmt.format(hi)}"


def real_stats(root: Path) -> list[dict]:
    out = []
    for ident in find_image_sets(root):
        s = read_image_set(root, ident)
        labels = s.label_ids if s.labelled else None
        st = stereo_stats(s.disparity, s.camera, labels) | photo_stats(s.rgb, labels)
        out.append(st)
        print(f"real {ident.name}: " + ", ".join(f"{k} {v:.3g}" for k, v in st.items()))
    return out


def generated_stats(n: int, seed: int, stereo: str, photo: str) -> list[dict]:
    out = []
    for i in range(n):
        scene = random_scene(np.random.default_rng([seed, i]), 2048, 1024)
        a = render_scene(scene, stereo=stereo, photo=photo)
        st = stereo_stats(a["disparity"], scene.camera, a["label_ids"]) | photo_stats(a["rgb"], a["label_ids"])
        out.append(st)
        print(f"generated {i}: " + ", ".join(f"{k} {v:.3g}" for k, v in st.items()))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="Cityscapes root (real frames)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated scenes, 2048x1024")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--stereo", choices=STEREO_MODES, default="realistic")
    ap.add_argument("--photo", choices=PHOTO_MODES, default="realistic")
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    warnings.filterwarnings("ignore", category=RuntimeWarning)  # all-NaN medians at sparse edges
    columns = {}
    if a.root is not None:
        columns[f"real ({a.root.name})"] = real_stats(a.root)
    if a.generated:
        columns[f"generated ({a.stereo} stereo, {a.photo} photo)"] = generated_stats(a.generated, a.seed, a.stereo,
                                                                                   a.photo)
    names = list(columns)
    print()
    print("| figure | " + " | ".join(f"{n}, {len(columns[n])} frames" for n in names) + " |")
    print("|---|" + "---|" * len(names))
    for key, title, fmt in ROWS:
        print(f"| {title} | " + " | ".join(_range([s.get(key) for s in columns[n]], fmt) for n in names) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
