"""Does the augmented image set stay a stereo pair? On generated image sets with right photos
(cached under out/bench/) and, with --real, on a real Cityscapes root with rightImg8bit:

* `synthcompose batch` with the right view on and off (child processes): CPU-seconds per set of
  each, their difference, and the right view's own stage time (render + compose, `right`);
* per image set and seed (stereo_check.check_pair, OpenCV StereoSGBM on the augmented pair):
  over the inserted objects' visible pixels, the share the matcher matched, the share of those
  within 1 px of the written disparity (and of those the right camera sees too), the same over
  the pixels whose window has the texture to measure a disparity, and the same figures for the frame's own cars and
  people against the
  input disparity; without a matcher, the mean difference between the left photo and the right
  one read at the written disparity, and 0.5 px off it; elsewhere, the share matched alike on the
  augmented and the input pair; pooled over all sets and seeds, and the range per set.

    python benchmarks/eval_stereo.py [--count 4] [--objects 3] [--seeds 1 2 3] [--repeat 3]
                                     [--real /path/to/cityscapes] [--keep DIR]

Never commit outputs made from real frames.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cost import cpu_s, dataset, run_batch, stage_cpu  # noqa: E402

from evaluation.stereo_check import check_pair  # noqa: E402
from synthcompose.io.dataset import find_image_sets  # noqa: E402
from synthcompose.io.files import encode_png, read_png  # noqa: E402


def right_codec_cpu(data: Path, count: int) -> float:
    """CPU-seconds per set to decode the right photo and encode it once (what its file costs)."""
    idents = find_image_sets(data)[:count]
    t0 = cpu_s()
    for ident in idents:
        encode_png(read_png(ident.path(data, "right"), "rgb8"))
    return (cpu_s() - t0) / max(len(idents), 1)


def report(name: str, data: Path, count: int, objects: int, keep: Path, seeds: list[int], repeat: int) -> None:
    per = lambda r: r["cpu_s"] / r["sets"]  # noqa: E731
    ons, offs, rights, lefts = [], [], [], []
    for k in range(repeat):  # on and off in turn: the machine's drift falls on both
        on = run_batch(data, 1, count, keep=keep / name / f"seed{seeds[0]}" if k == 0 else None,
                       objects_per_image=objects, render={"right_view": True}, seed=seeds[0])
        off = run_batch(data, 1, count, objects_per_image=objects, render={"right_view": False}, seed=seeds[0])
        stages, _ = stage_cpu(data, count, objects, render={"right_view": True}, seed=seeds[0])
        ons.append(per(on))
        offs.append(per(off))
        rights.append(stages.get("right", 0.0))
        lefts.append(stages.get("render", 0.0) + stages.get("compose", 0.0))
    for seed in seeds[1:]:
        run_batch(data, 1, count, keep=keep / name / f"seed{seed}", objects_per_image=objects,
                  render={"right_view": True}, seed=seed)
    med = lambda v: float(np.median(v))  # noqa: E731
    print(f"\n== {name}: {on['sets']} image sets x {len(seeds)} seeds, {objects} objects each, {data}")
    print(f"CPU-s per set (seed {seeds[0]}, median of {repeat} runs): right view on {med(ons):.3f}, off {med(offs):.3f}, "
          f"difference {med(np.subtract(ons, offs)):+.3f} (each run: {', '.join(f'{a - b:+.2f}' for a, b in zip(ons, offs))}); "
          f"the right view's render + compose (stage 'right', the stages one after the other) "
          f"{med(rights):.3f}; the left's {med(lefts):.3f}; "
          f"the right photo's PNG read and written {right_codec_cpu(data, count):.3f}")
    cols = ("object_pixels", "matched", "within_1px", "within_1px_both_views", "matched_measurable",
            "within_1px_measurable", "within_1px_measurable_both_views", "within_1px_one_depth", "real_within_1px",
            "real_within_1px_measurable", "residual_at_written",
            "residual_off_half_px", "elsewhere_same", "right_changed")
    print(f"{'seed':>4} {'image set':<38}" + "".join(f"{c:>15}" for c in (
        "objects px", "matched", "<=1px", "<=1px (both)", "measurable", "<=1px (meas.)", "meas., both", "one depth", "own <=1px",
        "own (meas.)",
        "resid. at d", "resid. d+-0.5", "elsewhere same", "right changed")))
    pooled = {"m": 0, "w": 0.0, "mm": 0, "wm": 0.0}
    shares = []
    for seed in seeds:
        out = keep / name / f"seed{seed}"
        for ident in find_image_sets(data)[:count]:
            if not ident.path(out, "right").is_file():
                continue
            c = check_pair(data, out, ident)
            d = c.to_dict()
            print(f"{seed:>4} {c.key[-38:]:<38}" + "".join(f"{d[k]:>15}" for k in cols))
            if c.matched:
                pooled["m"] += c.matched
                pooled["w"] += c.matched * c.within_1px
                shares.append(c.within_1px)
            if c.matched_measurable:
                pooled["mm"] += c.matched_measurable
                pooled["wm"] += c.matched_measurable * c.within_1px_measurable
    print(f"pooled: within 1 px {pooled['w'] / max(pooled['m'], 1):.3f} of {pooled['m']} matched object pixels; "
          f"{pooled['wm'] / max(pooled['mm'], 1):.3f} of {pooled['mm']} measurable (target >= 0.90); "
          f"per set {min(shares, default=float('nan')):.3f} .. {max(shares, default=float('nan')):.3f}, "
          f"{sum(v >= 0.9 for v in shares)} of {len(shares)} at >= 0.90")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=4)
    ap.add_argument("--objects", type=int, default=3)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1], help="one batch per seed (default: 1)")
    ap.add_argument("--repeat", type=int, default=1, help="CPU cost: the on / off batches this many times in turn")
    ap.add_argument("--real", type=Path, help="a Cityscapes root with rightImg8bit (real frames)")
    ap.add_argument("--keep", type=Path, help="keep the augmented outputs here (default: a temporary folder)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        keep = args.keep or Path(tmp)
        report("generated", dataset(args.count, 2048, 1024, right=True), args.count, args.objects, keep, args.seeds, args.repeat)
        if args.real is not None:
            report("real", args.real, args.count, args.objects, keep, args.seeds, args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
