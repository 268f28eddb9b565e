"""The outputs in the field's own tools, on any Cityscapes root (real frames first) or on an
output root already made:

* per image set: the share of pixels (and the pixel count that differs) where cityscapesScripts' json2labelImg / json2instanceImg
  drawing of the written polygons equals the written labelIds / instanceIds; the pixels that
  csCreateTrainIdLabelImgs marks as ignore (train id 255) where the labelIds do not, and the
  reverse;
* per run: evalPixelLevelSemanticLabeling mean IoU of the drawn labels against the written
  ones, evalInstanceLevelSemanticLabeling AP of the instanceIds against themselves, and
  pycocotools COCOeval AP of coco_instances.json against itself.

    python benchmarks/eval_ecosystem.py ROOT [--seed 1] [--objects 4]   # a batch on ROOT, then the checks
    python benchmarks/eval_ecosystem.py --outputs OUT_ROOT              # the checks on a finished batch

Never commit outputs made from real frames (Cityscapes' licence forbids redistribution).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from evaluation import ecosystem  # noqa: E402
from synthcompose.io.dataset import find_image_sets  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.run.batch import run_batch  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from eval_real import write_manifest  # noqa: E402


def done_sets(out: Path):
    """The image sets of an output root whose record says done."""
    found = []
    for ident in find_image_sets(out):
        record = ident.path(out, "record")
        if record.is_file() and json.loads(record.read_text()).get("status") == "done":
            found.append(ident)
    return found


def report(out: Path) -> int:
    idents = done_sets(out)
    if not idents:
        print(f"{out}: no done image sets")
        return 1
    ignore = ecosystem.train_id_ignore(out, idents)
    print(f"{'image set':44s} {'labels':>8s} {'px':>4s} {'instances':>9s} {'px':>4s} {'ignore+':>8s} {'ignore-':>8s} "
          f"{'trainId!=':>9s}")
    worst = {"labels": 1.0, "instances": 1.0}
    for ident in idents:
        back = ecosystem.drawn_back(out, ident)
        worst = {k: min(worst[k], back[k]) for k in worst}
        ig = ignore[ident.key]
        print(f"{ident.key:44s} {back['labels']:8.5f} {back['label_pixels_differ']:4d} {back['instances']:9.5f} "
              f"{back['instance_pixels_differ']:4d} {ig['extra']:8d} {ig['missing']:8d} {ig['different']:9d}")
    print(f"lowest drawn-back share: labelIds {worst['labels']:.5f}, instanceIds {worst['instances']:.5f}")
    print(f"evalPixelLevelSemanticLabeling mean IoU (drawn vs written): {ecosystem.pixel_level_iou(out, idents):.4f}")
    print(f"evalInstanceLevelSemanticLabeling AP (instanceIds vs themselves): "
          f"{ecosystem.instance_level_ap(out, idents):.4f}")
    coco = ecosystem.coco_ap(out)
    print(f"pycocotools COCOeval AP (coco_instances.json vs itself): bbox {coco['bbox']:.4f}, segm {coco['segm']:.4f}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="a Cityscapes root: run a batch on it first")
    ap.add_argument("--outputs", type=Path, help="an output root already made")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--objects", type=int, default=4)
    args = ap.parse_args()
    if args.outputs is not None:
        return report(args.outputs)
    if args.root is None:
        ap.error("give a Cityscapes root or --outputs")
    with tempfile.TemporaryDirectory() as work:
        out = Path(work) / "out"
        manifest = write_manifest(args.root, out, args.objects, args.seed, Path(work))
        run_batch(load_manifest(manifest), progress=False)
        return report(out)


if __name__ == "__main__":
    sys.exit(main())
