"""Golden end-to-end images: a tiny deterministic batch (one generated 256 x 128 image set per
case, the builtin box and traffic sign, `synthcompose batch` as a user runs it) whose labelIds
and instanceIds must equal the stored ones but for a few pixels on an object's outline (another
CPU's rounding moves an outline by a pixel: GOLDEN_LABEL_EDGE_PIXELS) and whose photo must stay within the named
tolerances of the stored one (tests/tolerances.py, GOLDEN_RGB_*: drivers round and filter a
little differently, so a few pixels may move by a few levels; a change to the light, the
shadows, the tone, the noise or the blur moves hundreds).

The goldens are tests/golden/<case>_{rgb,labelIds,instanceIds}.png, generated scenes only.
The lit pass is shaded once per pixel on every driver ("render": {"shading": "pixel"}), so that
a GPU runs the same code path as llvmpipe, where the goldens were made.

On a failure the test writes <case>_<kind>_diff.png into its pytest tmp dir - golden, output
and their difference side by side (differing pixels red) - and prints the path.

Regenerating: when a change is meant to change the outputs, run

    SYNTHCOMPOSE_UPDATE_GOLDEN=1 .venv/bin/python -m pytest -q -p no:cacheprovider tests/compose/test_golden.py

which rewrites the goldens from this machine's run (those tests then skip, naming the files);
look at the new images and commit them with the change that made them.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.synthetic import make_sample

from ..helpers import write_manifest
from ..tolerances import GOLDEN_LABEL_EDGE_PIXELS, GOLDEN_RGB_MAX_8BIT, GOLDEN_RGB_MAX_SHARE, GOLDEN_RGB_PIXEL_8BIT

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
UPDATE = os.environ.get("SYNTHCOMPOSE_UPDATE_GOLDEN") == "1"
W, H = 256, 128
OBJECTS = [
    {"name": "box", "model": "builtin:box", "class": "car", "size": {"width": 1.8}, "weight": 2},  # a lane holds it
    {"name": "sign", "model": "builtin:traffic-sign", "class": "traffic sign", "size": {"height": 2.5}},
]
#: case -> make_sample seed: the batch puts a box and a sign (a class with instances, one
#: without) into seed 1's frame, two boxes into seed 10's (its sign finds no place at the kerb
#: and a box takes its slot)
CASES = {"box-and-sign": 1, "two-boxes": 10}
KINDS = ("rgb", "labelIds", "instanceIds")


def golden_path(case: str, kind: str) -> Path:
    return GOLDEN / f"{case}_{kind}.png"


@pytest.fixture(scope="module", params=sorted(CASES))
def outputs(request, tmp_path_factory) -> tuple[str, dict[str, np.ndarray]]:
    case = request.param
    work = tmp_path_factory.mktemp(case)
    (ident,) = make_sample(work / "cityscapes", count=1, width=W, height=H, seed=CASES[case])
    manifest = write_manifest(work / "m.json", work / "cityscapes", work / "out", seed=5, objects=OBJECTS,
                              render={"shading": "pixel"})
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    record = json.loads(ident.path(work / "out", "record").read_text())
    assert record["status"] == "done" and record["objects"]
    images = {kind: cv2.imread(str(ident.path(work / "out", kind)), cv2.IMREAD_UNCHANGED) for kind in KINDS}
    if UPDATE:
        GOLDEN.mkdir(exist_ok=True)
        for kind, image in images.items():
            assert cv2.imwrite(str(golden_path(case, kind)), image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return case, images


def _golden(case: str, kind: str) -> np.ndarray:
    if UPDATE:
        pytest.skip(f"golden rewritten: {golden_path(case, kind)}")
    path = golden_path(case, kind)
    assert path.is_file(), f"{path} is missing: SYNTHCOMPOSE_UPDATE_GOLDEN=1 writes it (see this module's docstring)"
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def _write_diff(directory: Path, case: str, kind: str, golden: np.ndarray, got: np.ndarray,
                differs: np.ndarray, diff: np.ndarray) -> Path:
    """golden | output | difference (grey: the difference x16, red: the pixels that differ)."""
    def bgr(a: np.ndarray) -> np.ndarray:
        if a.ndim == 3:
            return a
        a = a.astype(np.int64)
        return cv2.cvtColor(((a * 97 + (a // 1000) * 53) % 256).astype(np.uint8), cv2.COLOR_GRAY2BGR)

    panel = cv2.cvtColor(np.clip(diff * 16, 0, 255).astype(np.uint8), cv2.COLOR_GRAY2BGR)
    panel[differs] = (0, 0, 255)
    path = directory / f"{case}_{kind}_diff.png"
    cv2.imwrite(str(path), np.hstack([bgr(golden), bgr(got), panel]))
    print(f"diff image: {path}")
    return path


@pytest.mark.parametrize("kind", ["labelIds", "instanceIds"])
def test_labels_and_instances_equal_the_golden(outputs, kind, tmp_path):
    case, images = outputs
    golden, got = _golden(case, kind), images[kind]
    assert got.shape == golden.shape and got.dtype == golden.dtype, (got.shape, got.dtype, golden.dtype)
    differs = got != golden
    # another CPU's rounding (OpenBLAS picks its kernels by CPU) may move an outline by a pixel:
    # such pixels lie on an edge of the golden's labels, and there are few of them
    stray = differs & ~_edges(golden)
    if stray.any() or differs.sum() > GOLDEN_LABEL_EDGE_PIXELS:
        ys, xs = np.nonzero(differs)
        diff = np.where(differs, 255, 0)
        path = _write_diff(tmp_path, case, kind, golden, got, differs, diff)
        pytest.fail(f"{case} {kind}: {differs.sum()} pixels differ from {golden_path(case, kind)}, "
                    f"{stray.sum()} of them off its labels' edges (allowed: {GOLDEN_LABEL_EDGE_PIXELS} on "
                    f"the edges) (rows {ys.min()}-{ys.max()}, columns {xs.min()}-{xs.max()}); see {path}")


def _edges(labels: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels within one pixel of a pixel of another label."""
    edge = np.zeros(labels.shape, bool)
    edge[1:] |= labels[1:] != labels[:-1]
    edge[:-1] |= labels[1:] != labels[:-1]
    edge[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edge[:, :-1] |= labels[:, 1:] != labels[:, :-1]
    return cv2.dilate(edge.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def test_rgb_is_within_tolerance_of_the_golden(outputs, tmp_path):
    case, images = outputs
    golden, got = _golden(case, "rgb"), images["rgb"]
    assert got.shape == golden.shape == (H, W, 3)
    diff = np.abs(got.astype(np.int16) - golden.astype(np.int16)).max(axis=2)
    differs = diff > GOLDEN_RGB_PIXEL_8BIT
    share = float(differs.mean())
    if diff.max() > GOLDEN_RGB_MAX_8BIT or share > GOLDEN_RGB_MAX_SHARE:
        path = _write_diff(tmp_path, case, "rgb", golden, got, differs, diff)
        pytest.fail(f"{case} rgb vs {golden_path(case, 'rgb')}: max difference {diff.max()} levels "
                    f"(allowed {GOLDEN_RGB_MAX_8BIT}), {share:.3%} of the pixels off by more than "
                    f"{GOLDEN_RGB_PIXEL_8BIT} levels (allowed {GOLDEN_RGB_MAX_SHARE:.3%}); see {path}")


def test_goldens_are_small():
    for case in CASES:
        for kind in KINDS:
            path = golden_path(case, kind)
            if path.is_file():
                assert path.stat().st_size < 100_000, path
