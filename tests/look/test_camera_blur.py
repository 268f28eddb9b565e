"""The camera match's blur on real renders: the objects' edges, as :func:`estimate_blur` reads
them, come out as sharp as the renderer's (:data:`RENDER_BLUR_SIGMA`) without the match, and as
blurred as the photo's with it (an inserted car crisper than the photo's own is a tell)."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.lighting.camera_match import BOX_EDGE_SIGMA, RENDER_BLUR_SIGMA, estimate_blur
from synthcompose.synthetic import make_sample

from ..helpers import write_manifest
from ..tolerances import OBJECT_EDGE_BLUR_PX

W, H = 2048, 1024


def _object_blur(out, ident) -> tuple[float, dict | None]:
    """(the objects' edges' blur, the record's camera match) in an output image set."""
    rgb = cv2.cvtColor(cv2.imread(str(ident.path(out, "rgb"))), cv2.COLOR_BGR2RGB)
    record = json.loads(ident.path(out, "record").read_text())
    ids = cv2.imread(str(ident.path(out, "instanceIds")), cv2.IMREAD_UNCHANGED)
    mask = np.isin(ids, [o["instance_id"] for o in record["objects"]]).astype(np.uint8)
    inner = cv2.erode(mask, np.ones((5, 5), np.uint8)) > 0  # the object's own edges, not the photo's
    return estimate_blur(rgb, counted=inner), record.get("camera_match")


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    root = tmp_path_factory.mktemp("blur") / "cs"
    return root, make_sample(root, count=1, width=W, height=H, seed=4)


@pytest.mark.slow
@pytest.mark.parametrize("match", [False, True])
def test_inserted_cars_edges_are_as_sharp_as_the_photos(sample, tmp_path, match):
    root, ids = sample
    out = tmp_path / "out"
    objects = [{"name": "car", "model": "cast:car", "class": "car"}]
    manifest = write_manifest(tmp_path / "m.json", root, out, seed=2, objects=objects, objects_per_image=2,
                              placement={"distance": [6, 14]}, lighting={"camera_match": match},
                              render={"right_view": False})
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    for ident in ids:
        found, camera = _object_blur(out, ident)
        if match:
            # as blurred as the photo's own edges
            assert found == pytest.approx(camera["blur_sigma_px"], abs=OBJECT_EDGE_BLUR_PX), (ident.key, found, camera)
        else:
            # the renderer's own edges: about RENDER_BLUR_SIGMA (0.62-0.72 on real frames, a little
            # more on the generated scenes' smaller cars), never blurrier than an ideal box edge
            assert RENDER_BLUR_SIGMA - OBJECT_EDGE_BLUR_PX <= found <= BOX_EDGE_SIGMA, (ident.key, found)
