"""The outputs in the field's own tools: cityscapesScripts' converters (json2labelImg,
json2instanceImg, csCreateTrainIdLabelImgs) and evaluations (pixel-level, instance-level), and
pycocotools' COCOeval, on a batch whose first image set has its own polygons file and whose
others have none (the whole frame is then described)."""
from __future__ import annotations

import numpy as np

from evaluation import ecosystem

from ..tolerances import INSTANCES_DRAWN_BACK, LABELS_DRAWN_BACK


def test_polygons_draw_back_with_json2labelimg_and_json2instanceimg(annotated_batch):
    _, out, ids = annotated_batch
    for ident in ids:
        back = ecosystem.drawn_back(out, ident)
        assert back["labels"] >= LABELS_DRAWN_BACK and back["instances"] >= INSTANCES_DRAWN_BACK, (ident, back)


def test_cscreatetrainidlabelimgs_ignores_only_what_the_labelids_ignore(annotated_batch):
    _, out, ids = annotated_batch
    result = ecosystem.train_id_ignore(out, ids)
    assert set(result) == {i.key for i in ids}
    for key, r in result.items():
        assert r["extra"] == 0, (key, r)  # not a pixel more ignored than the labelIds say
        assert r["missing"] <= 0.0005 * r["pixels"], (key, r)
        assert r["different"] <= (1 - LABELS_DRAWN_BACK) * r["pixels"], (key, r)


def test_cityscapes_evaluations_read_the_outputs(annotated_batch):
    _, out, ids = annotated_batch
    assert ecosystem.pixel_level_iou(out, ids) >= 0.99
    assert ecosystem.instance_level_ap(out, ids) == 1.0
    assert not hasattr(np, "in1d") or "in1d" in np.__dict__  # the NumPy 2.4 shim is taken away again


def test_cocoeval_scores_the_coco_file_against_itself(annotated_batch):
    _, out, _ = annotated_batch
    assert ecosystem.coco_ap(out) == {"bbox": 1.0, "segm": 1.0}
