"""The outputs read by the field's own tools: cityscapesScripts' converters and evaluations,
and pycocotools.

Used by the tests and by ``benchmarks/eval_ecosystem.py`` (figures in docs/ecosystem.md). Each
check takes an output root (or a batch's image sets in it) and returns plain numbers.

cityscapesScripts 2.3.0 (its latest release) predates NumPy 2.4 and Pillow 13 in places:

* ``evalPixelLevelSemanticLabeling`` and ``evalInstanceLevelSemanticLabeling`` call
  ``numpy.in1d``, which NumPy 2.4 removed: :func:`numpy_in1d` puts it back as ``numpy.isin``
  (the same function) while they run;
* their JSON exports (``args.JSONOutput``, and the ``matches.json`` that the instance
  evaluation's ``evaluateImgLists`` always writes into the working folder) fail on NumPy
  integers; the checks here run the evaluations' steps themselves and export nothing;
* the converters (``json2labelImg``, ``json2instanceImg``, ``csCreateTrainIdLabelImgs``) and
  the 3D box helpers run unchanged.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from synthcompose.io.dataset import ImageSetId


def _train_ids() -> np.ndarray:
    """(256,) uint8: labelIds value -> Cityscapes train id (255: ignored in training)."""
    from cityscapesscripts.helpers.labels import labels
    lut = np.full(256, 255, np.uint8)
    for label in labels:
        if 0 <= label.id < 256 and 0 <= label.trainId < 255:
            lut[label.id] = label.trainId
    return lut


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """cityscapesScripts and pycocotools print their progress: not into our output."""
    with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink):
        yield


@contextlib.contextmanager
def numpy_in1d() -> Iterator[None]:
    """``numpy.in1d`` as ``numpy.isin`` while cityscapesScripts' evaluations run (NumPy >= 2.4)."""
    had = "in1d" in np.__dict__
    if not had:
        np.in1d = np.isin  # type: ignore[attr-defined]
    try:
        yield
    finally:
        if not had:
            del np.in1d  # type: ignore[attr-defined]


def _read(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise FileNotFoundError(path)
    return img


def drawn_back(out_root: Path, ident: ImageSetId) -> dict[str, float]:
    """Share of pixels where cityscapesScripts' drawing of the polygons file (``json2labelImg``
    / ``json2instanceImg``) equals the written labelIds / instanceIds, and the pixels that differ."""
    from cityscapesscripts.helpers.annotation import Annotation
    from cityscapesscripts.preparation.json2instanceImg import createInstanceImage
    from cityscapesscripts.preparation.json2labelImg import createLabelImage

    ann = Annotation()
    ann.fromJsonFile(str(ident.path(out_root, "polygons")))
    labels = np.asarray(createLabelImage(ann, "ids"))
    instances = np.asarray(createInstanceImage(ann, "ids")).astype(np.int64)
    written_labels = _read(ident.path(out_root, "labelIds"))
    written_instances = _read(ident.path(out_root, "instanceIds")).astype(np.int64)
    return {"labels": float((labels == written_labels).mean()),
            "instances": float((instances == written_instances).mean()),
            "label_pixels_differ": int((labels != written_labels).sum()),
            "instance_pixels_differ": int((instances != written_instances).sum())}


def train_id_ignore(out_root: Path, idents: list[ImageSetId]) -> dict[str, dict[str, int]]:
    """Run ``csCreateTrainIdLabelImgs`` over the image sets' polygons (copied to a scratch root,
    so the output root is not written) and compare its ignore pixels (train id 255) with the
    written labelIds' own: per image set, the pixels it ignores that the labelIds do not
    (``extra``) and the reverse (``missing``), and the pixels whose train ids differ."""
    from cityscapesscripts.preparation import createTrainIdLabelImgs

    result = {}
    with tempfile.TemporaryDirectory() as scratch:
        for ident in idents:
            dst = ident.path(Path(scratch), "polygons")
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(ident.path(out_root, "polygons"), dst)
        before = os.environ.get("CITYSCAPES_DATASET")
        os.environ["CITYSCAPES_DATASET"] = scratch
        try:
            with _quiet():
                createTrainIdLabelImgs.main()
        finally:
            if before is None:
                os.environ.pop("CITYSCAPES_DATASET", None)
            else:
                os.environ["CITYSCAPES_DATASET"] = before
        lut = _train_ids()
        for ident in idents:
            made = _read(Path(str(ident.path(Path(scratch), "polygons")).replace("_polygons.json",
                                                                                 "_labelTrainIds.png")))
            expected = lut[_read(ident.path(out_root, "labelIds"))]
            result[ident.key] = {"extra": int(((made == 255) & (expected != 255)).sum()),
                                 "missing": int(((made != 255) & (expected == 255)).sum()),
                                 "different": int((made != expected).sum()), "pixels": int(made.size)}
    return result


def pixel_level_iou(out_root: Path, idents: list[ImageSetId]) -> float:
    """cityscapesScripts' ``evalPixelLevelSemanticLabeling``: mean class IoU of the labelIds
    that the polygons draw back to (as predictions) against the written labelIds."""
    from cityscapesscripts.evaluation import evalPixelLevelSemanticLabeling as ev
    from cityscapesscripts.helpers.annotation import Annotation
    from cityscapesscripts.preparation.json2labelImg import createLabelImage

    with tempfile.TemporaryDirectory() as scratch, numpy_in1d(), _quiet():
        predictions, truths = [], []
        for ident in idents:
            ann = Annotation()
            ann.fromJsonFile(str(ident.path(out_root, "polygons")))
            pred = Path(scratch) / f"{ident.name}_pred.png"
            createLabelImage(ann, "ids").save(pred)
            predictions.append(str(pred))
            truths.append(str(ident.path(out_root, "labelIds")))
        args = ev.args
        args.quiet, args.JSONOutput, args.evalPixelAccuracy = True, False, False
        return float(ev.evaluateImgLists(predictions, truths, args)["averageScoreClasses"])


def instance_level_ap(out_root: Path, idents: list[ImageSetId]) -> float:
    """cityscapesScripts' ``evalInstanceLevelSemanticLabeling`` (its steps, no exports): AP of
    every instance of the written instanceIds, given as predictions with confidence 1, against
    themselves (1.0 when the instanceIds load as the evaluation expects)."""
    from cityscapesscripts.evaluation import evalInstanceLevelSemanticLabeling as ev

    with tempfile.TemporaryDirectory() as scratch, numpy_in1d(), _quiet():
        predictions, truths = [], []
        for ident in idents:
            truth = ident.path(out_root, "instanceIds")
            ids = _read(truth)
            lines = []
            for value in np.unique(ids[ids >= 1000]):
                mask = f"{ident.name}_{value}.png"
                cv2.imwrite(str(Path(scratch) / mask), (ids == value).astype(np.uint8) * 255)
                lines.append(f"{mask} {value // 1000} 1.0")
            listing = Path(scratch) / f"{ident.name}.txt"
            listing.write_text("".join(line + "\n" for line in lines))
            predictions.append(str(listing))
            truths.append(str(truth))
        args = ev.args
        args.quiet, args.JSONOutput = True, False
        args.gtInstancesFile = str(Path(scratch) / "gtInstances.json")
        args.predictionPath = scratch
        ev.setInstanceLabels(args)
        gt = ev.getGtInstances(truths, args)
        matches = ev.matchGtWithPreds(predictions, truths, gt, args)
        return float(ev.computeAverages(ev.evaluateMatches(matches, args), args)["allAp"])


def coco_ap(out_root: Path) -> dict[str, float]:
    """pycocotools' COCOeval of ``coco_instances.json`` against itself (every annotation as a
    detection with score 1): bbox and segm AP (1.0 when the file is consistent)."""
    from pycocotools.coco import COCO
    from pycocotools.cocoeval import COCOeval

    with _quiet():
        gt = COCO(str(Path(out_root) / "coco_instances.json"))
        scores = {}
        for kind in ("bbox", "segm"):
            dets = [{"image_id": a["image_id"], "category_id": a["category_id"], "score": 1.0,
                     **({"bbox": a["bbox"]} if kind == "bbox" else {"segmentation": a["segmentation"]})}
                    for a in gt.loadAnns(gt.getAnnIds())]
            ev = COCOeval(gt, gt.loadRes(dets), kind)
            ev.evaluate()
            ev.accumulate()
            ev.summarize()
            scores[kind] = float(ev.stats[0])
    return scores
