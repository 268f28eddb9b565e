"""The cast-shadow measure of eval_sun.py (``evaluation.shadowlook.cast_shadow_fit``) against a sun
whose direction is known: a batch with a fixed light (the manifest's ``sun_azimuth_deg``,
``sun_elevation_deg``, ``sun_fraction`` 0.6) and its twin with the sun's share given to the sky
(``sun_fraction`` 0), two cars a set; per car within the ground plan's reach (20 m), the
direction and length fitted against the direction the sun throws shadows (azimuth + 180).

    python benchmarks/check_cast_fit.py ROOT --sun AZ EL [--frames NAME ...] [--limit N]
    python benchmarks/check_cast_fit.py --generated 4 --sun 90 30

Never commit outputs made from real frames (Cityscapes' licence forbids redistribution).
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench_cost import dataset, manifest_for  # noqa: E402
from eval_real import done_outputs  # noqa: E402

from evaluation import shadowlook  # noqa: E402
from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.io.dataset import read_image_set  # noqa: E402
from synthcompose.io.files import decode_rle  # noqa: E402
from synthcompose.lighting import plansun  # noqa: E402
from synthcompose.lighting.plan import completed_labels  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.placement.boxes import footprint_corners  # noqa: E402
from synthcompose.placement.surfaces import frame_for  # noqa: E402
from synthcompose.run.batch import run_batch  # noqa: E402


def check(root: Path, azimuth: float, elevation: float, base: Path, frames: list[str], limit: int) -> list:
    """(image set, car, distance, fitted (azimuth, length, IoU) or None) of every car placed."""
    outs = {}
    select = {"frames": frames} if frames else {"limit": limit}
    for fraction in (0.6, 0.0):
        out = base / f"out_{fraction}"
        light = {"sun_azimuth_deg": azimuth, "sun_elevation_deg": elevation, "sun_fraction": fraction}
        m = manifest_for(root, out, base, objects=2, render={"right_view": False}, lighting=light, **select)
        run_batch(load_manifest(m), workers=1, progress=False, resume=False)
        outs[fraction] = out
    rows = []
    for ident, rec, src, res in done_outputs(root, outs[0.6]):
        twin = read_image_set(outs[0.0], ident)
        depth = disparity_to_depth(src.disparity, src.camera)
        frame, _ = frame_for(src, depth)
        labels = frame.label_ids if frame.labelled else completed_labels(frame.label_ids, depth, src.camera)
        _, plan, _ = plansun.measure(src.rgb, labels, depth, src.camera, frame.labelled)
        masks = [shadowlook.annotated(decode_rle(o["mask_rle"])) for o in rec["objects"]]
        feet = [footprint_corners(np.array(o["pose"]["vehicle"]["matrix"]), o["extents_m"]) for o in rec["objects"]]
        fits = shadowlook.cast_shadow_fit(twin.rgb, res.rgb, masks, feet, plan)
        rows += [(ident.name, k, obj["distance_m"], fit) for k, (obj, fit) in enumerate(zip(rec["objects"], fits))]
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="a Cityscapes root")
    ap.add_argument("--generated", type=int, default=0, help="N generated image sets instead, 2048x1024")
    ap.add_argument("--sun", type=float, nargs=2, required=True, metavar=("AZ", "EL"), help="degrees, vehicle frame")
    ap.add_argument("--frames", nargs="*", default=[], help="frame names (city_seq_frame)")
    ap.add_argument("--limit", type=int, default=4)
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT or --generated N")
    root = a.root.resolve() if a.root is not None else dataset(a.generated, 2048, 1024)
    azimuth, elevation = a.sun
    thrown = (azimuth + 180.0) % 360.0
    with tempfile.TemporaryDirectory(prefix="synthcompose-castfit-") as tmp:
        rows = check(root, azimuth, elevation, Path(tmp), a.frames, a.limit if a.root is not None else a.generated)
    print(f"sun {azimuth:.0f}/{elevation:.0f}: shadows thrown to {thrown:.0f}, a 1.5 m box's "
          f"{1.5 / math.tan(math.radians(elevation)):.1f} m long")
    print(f"{'image set':<28}{'car':>4}{'dist m':>8}{'fitted':>8}{'length':>8}{'IoU':>6}{'off':>6}")
    offs = []
    for name, k, dist, fit in rows:
        if fit is None:
            print(f"{name:<28}{k:>4}{dist:>8.1f}       -")
            continue
        off = abs((fit[0] - thrown + 180.0) % 360.0 - 180.0)
        offs.append(off)
        print(f"{name:<28}{k:>4}{dist:>8.1f}{fit[0]:>8.0f}{fit[1]:>8.2f}{fit[2]:>6.2f}{off:>6.0f}")
    if offs:
        print(f"fitted within 15 degrees: {sum(o <= 15 for o in offs)}/{len(offs)}, median off {np.median(offs):.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
