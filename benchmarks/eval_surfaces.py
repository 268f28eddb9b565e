"""The label-free surface finder (``synthcompose.surfaces``) against the truth of labelled frames.

    python benchmarks/eval_surfaces.py <labelled root> [--generated 4 --streets traffic] [--seed 7]

Each labelled image set is read as a frame without labels would be (its disparity and photo
only; gtFine is the truth): road and sidewalk precision and recall per frame; the footway
precision, the found sidewalk's share on paved ground a person walks on (sidewalk, parking,
ground: Cityscapes labels a paved strip or square beyond a kerb "ground" where it is no
sidewalk along the road); its share on ground a person can stand on (those and terrain); the
found sidewalk's share of the frame, the true sidewalk's recall per distance band (where the
finder loses it), the found grass verges (terrain: where a sign may stand) and the share of
them on ground beside the carriageway (sidewalk, parking, ground, terrain, vegetation), and the
finder's CPU seconds. ``--generated N``: the same on N generated scenes
(2048x1024, ``make-sample``), in the same run. Nothing is written; never commit real pixels.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.labels import label_id  # noqa: E402
from synthcompose.placement.surfaces import ROAD, SIDEWALK, TERRAIN, find_surfaces  # noqa: E402

WALKABLE = [label_id(n) for n in ("sidewalk", "parking", "ground", "terrain")]
#: a footway: paved ground a person walks on (Cityscapes' "ground" holds the paved squares and
#: strips beyond a kerb that are not labelled sidewalk); grass verges (terrain) are left out
FOOTWAY = [label_id(n) for n in ("sidewalk", "parking", "ground")]
#: where a sign may stand: off the carriageway, on ground beside it (a verge holds vegetation too)
SIGN_GROUND = WALKABLE + [label_id("vegetation")]
#: distance bands of the sidewalk's recall, metres
BANDS = ((0, 10), (10, 20), (20, 40), (40, 80))


def _ratio(a: int, b: int) -> float | None:
    return a / b if b else None


def measure(ident, root: Path) -> dict:
    """Figures of one labelled image set's found surfaces against its gtFine."""
    s = read_image_set(root, ident)
    t0 = time.process_time()
    found = find_surfaces(s.disparity, s.rgb, s.camera).labels
    cpu = time.process_time() - t0
    truth = s.label_ids
    fig = {"cpu_s": cpu}
    for name, lid in (("road", ROAD), ("sidewalk", SIDEWALK)):
        f, g = found == lid, truth == lid
        fig[f"{name}_P"] = _ratio(int((f & g).sum()), int(f.sum()))
        fig[f"{name}_R"] = _ratio(int((f & g).sum()), int(g.sum()))
    side = found == SIDEWALK
    fig["footway_P"] = float(np.isin(truth[side], FOOTWAY).mean()) if side.any() else None
    fig["walkable"] = float(np.isin(truth[side], WALKABLE).mean()) if side.any() else None
    fig["share"] = float(side.mean())
    verge = found == TERRAIN  # a sign's place: off the carriageway, on ground beside it
    fig["verge_n"] = int(verge.sum())
    fig["verge_ok"] = float(np.isin(truth[verge], SIGN_GROUND).mean()) if verge.any() else None
    z = disparity_to_depth(s.disparity, s.camera)
    gs = truth == SIDEWALK
    for lo, hi in BANDS:
        band = gs & (z >= lo) & (z < hi)
        fig[f"R{lo}-{hi}"] = _ratio(int((band & side).sum()), int(band.sum())) if band.sum() >= 200 else None
    return fig


def report(root: Path, label: str) -> list[dict]:
    idents = [i for i in find_image_sets(root) if i.path(root, "labelIds").exists()]
    if not idents:
        raise SystemExit(f"{root}: no labelled image set (gtFine) to measure against")
    cols = ["road_P", "road_R", "sidewalk_P", "sidewalk_R", "footway_P", "walkable", "share"] \
        + [f"R{lo}-{hi}" for lo, hi in BANDS] + ["verge_n", "verge_ok"]
    print(f"\n== {label}: {root}")
    print(f"{'image set':<34}" + "".join(f"{c:>11}" for c in cols) + f"{'cpu s':>7}")
    rows = []
    for ident in idents:
        fig = measure(ident, root)
        rows.append(fig)
        spec = {"share": ".4f", "verge_n": "d"}
        cells = "".join(f"{'-' if fig[c] is None else format(fig[c], spec.get(c, '.3f')):>11}" for c in cols)
        print(f"{ident.key.split('/')[-1][:33]:<34}{cells}{fig['cpu_s']:>7.2f}")
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="a labelled Cityscapes root (real frames)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated scenes, same run")
    ap.add_argument("--streets", choices=("plain", "traffic"), default="traffic")
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    if a.root is not None:
        report(a.root.resolve(), "real")
    if a.generated:
        from synthcompose.synthetic import make_sample

        with tempfile.TemporaryDirectory(prefix="synthcompose-surfaces-") as tmp:
            make_sample(Path(tmp), count=a.generated, width=2048, height=1024, seed=a.seed,
                        streets=None if a.streets == "plain" else a.streets)
            report(Path(tmp), "generated")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
