"""Shared fixtures: one GL context per test session (EGL; llvmpipe where there is no GPU)."""
from __future__ import annotations

import pytest

from synthcompose.render.gl import GLContext


@pytest.fixture(scope="session")
def gl():
    ctx = GLContext()
    yield ctx
    ctx.release()


@pytest.fixture
def gl_clean(gl):
    """The session context; fails the test if it leaves a GL error behind."""
    gl.activate()  # a batch run by an earlier test made its own context current
    gl.ctx.error  # reset
    yield gl
    gl.activate()
    assert gl.ctx.error == "GL_NO_ERROR"


def pytest_report_header(config):
    try:
        g = GLContext()
        name = g.renderer_name
        g.release()
    except Exception as exc:  # noqa: BLE001 - a header must not fail the run
        name = f"unavailable ({exc})"
    return f"OpenGL: {name}"


@pytest.fixture(scope="module")
def annotated_batch(tmp_path_factory):
    """(input root, output root, ids) of a small batch whose first image set has its own polygons
    and 3D boxes (which must be kept): the annotation and ecosystem tests read it."""
    import json

    from synthcompose.cli import main
    from synthcompose.io.dataset import read_image_set
    from synthcompose.synthetic import make_sample
    from synthcompose.write.annotations import bbox3d_path
    from synthcompose.write.polygons import frame_polygons

    from .helpers import H, W, write_manifest

    root = tmp_path_factory.mktemp("cityscapes")
    ids = make_sample(root, count=3, width=W, height=H, seed=1)
    src = read_image_set(root, ids[0])
    ids[0].path(root, "polygons").write_text(json.dumps(
        {"imgHeight": H, "imgWidth": W, "objects": frame_polygons(src.label_ids, src.instance_ids)}))
    box_file = bbox3d_path(root, ids[0])
    box_file.parent.mkdir(parents=True)
    box_file.write_text(json.dumps({
        "imgWidth": W, "imgHeight": H, "sensor": {},
        "objects": [{"2d": {"modal": [1, 2, 3, 4], "amodal": [1, 2, 3, 5]},
                     "3d": {"center": [30.0, -5.0, 0.8], "dimensions": [4.0, 1.8, 1.5], "rotation": [1.0, 0, 0, 0]},
                     "label": "car", "instanceId": 26000, "score": 1.0}],
        "ignore": [{"2d": [0, 0, 10, 10], "label": "car", "instanceId": -1}]}))
    work = tmp_path_factory.mktemp("batch")
    out = work / "out"
    assert main(["batch", str(write_manifest(work / "m.json", root, out)), "--no-progress"]) == 0
    return root, out, ids
