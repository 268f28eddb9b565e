"""`synthcompose preview`: the window (under Xvfb), the PLY export and saved placements."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.dataset import read_image_set
from synthcompose.manifest import load_manifest
from synthcompose.placements import placement_path, read_saved
from synthcompose.preview_state import PASSES, PreviewSession
from synthcompose.sample import make_sample

from .test_batch import write_manifest

W, H = 640, 320


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("cityscapes")
    return root, make_sample(root, count=2, width=W, height=H, seed=1)


@pytest.fixture
def manifest(dataset, tmp_path):
    root, _ = dataset
    return write_manifest(tmp_path / "m.json", root, tmp_path / "out")


def test_headless_modules_never_import_a_window_toolkit():
    code = ("import sys, synthcompose.cli, synthcompose.pipeline, synthcompose.batch, synthcompose.preview_state;"
            "bad = [m for m in ('glfw', 'pyglet', 'moderngl_window') if m in sys.modules]; assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_export_ply_headless_loads_in_trimesh(dataset, manifest, tmp_path, capsys):
    trimesh = pytest.importorskip("trimesh")
    root, ids = dataset
    out = tmp_path / "cloud.ply"
    assert main(["preview", str(manifest), "--frame", ids[0].name, "--export-ply", str(out)]) == 0
    assert "written" in capsys.readouterr().out
    mesh = trimesh.load(out, process=False)
    disparity = read_image_set(root, ids[0]).disparity
    points = int((disparity > 1).sum())  # valid depth: p > 1 (p = 1 is infinitely far)
    record_objects = len(PreviewSession(load_manifest(manifest), ids[0].name).load().objects)
    assert record_objects >= 1
    assert len(mesh.vertices) == points + 12 * record_objects  # cloud + per object 8 box + 4 plane corners
    assert len(mesh.faces) == 14 * record_objects
    box = mesh.vertices[points:points + 8]
    assert np.ptp(box, axis=0).max() > 3.0  # a car-sized box (length 4.4 m)
    colours = mesh.visual.vertex_colors[points:points + 8, :3]
    assert (colours == [255, 0, 0]).all()


def test_every_pass_image_is_full_frame_and_not_blank(manifest):
    s = PreviewSession(load_manifest(manifest))
    try:
        s.load()
        for name in PASSES:
            img = s.pass_image(name)
            assert img.shape == (H, W, 3) and img.dtype == np.uint8
            assert img.any(), name
        assert (s.pass_image("id") != s.pass_image("composed")).any()
    finally:
        s.close()


def test_saved_placement_is_used_by_a_later_batch(dataset, manifest, tmp_path):
    root, ids = dataset
    m = load_manifest(manifest)
    s = PreviewSession(m, ids[0].name)
    try:
        s.load()
        before = s.view.objects[0].placement.matrix
        s.move(dx=0.5, dyaw_deg=10.0)  # moved by hand, as the arrow and Q keys do
        assert s.view.source == "moved"
        moved = s.view.objects[0].placement.matrix
        assert np.hypot(*(moved[:2, 3] - before[:2, 3])) == pytest.approx(0.5, abs=1e-6)
        path = s.save()
    finally:
        s.close()
    assert path == placement_path(m.output, ids[0]) and path.is_file()
    saved = read_saved(m.output, ids[0])
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    rec = json.loads(ids[0].path(m.output, "record").read_text())
    assert rec["placement_file"]["sha256"] == saved.sha256
    assert [o["name"] for o in rec["objects"]] == [o.name for o in saved.objects]
    for obj, so in zip(rec["objects"], saved.objects):
        assert obj["placement_source"] == "saved"
        assert np.allclose(obj["pose"]["vehicle"]["matrix"], so.matrix, atol=1e-5)
    other = json.loads(ids[1].path(m.output, "record").read_text())
    assert "placement_file" not in other and all(o["placement_source"] == "random" for o in other["objects"])
    # the window shows the saved placement next time
    s = PreviewSession(m, ids[0].name)
    try:
        assert s.load().source == "saved"
        assert np.allclose(s.view.objects[0].placement.matrix, moved, atol=1e-5)
    finally:
        s.close()
    # resume keeps it while the file is unchanged, redoes the set when the file changes
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    summary = json.loads((m.output / "summary.json").read_text())
    assert summary["resumed"] == 2
    data = json.loads(path.read_text())
    data["objects"] = data["objects"][:1]
    path.write_text(json.dumps(data))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert json.loads((m.output / "summary.json").read_text())["resumed"] == 1
    rec = json.loads(ids[0].path(m.output, "record").read_text())
    assert len(rec["objects"]) == 1 and rec["objects"][0]["placement_source"] == "saved"


def test_bad_saved_placement_fails_that_set_naming_the_file(dataset, manifest):
    root, ids = dataset
    m = load_manifest(manifest)
    path = placement_path(m.output, ids[0])
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"format": "synthcompose-placement/1", "image_set": ids[0].key,
                                "objects": [{"name": "no such object", "matrix": np.eye(4).tolist()}]}))
    assert main(["batch", str(manifest), "--no-progress"]) == 1
    summary = json.loads((m.output / "summary.json").read_text())
    failed = [o for o in summary["problems"] if o["status"] == "failed"]
    assert len(failed) == 1 and str(path) in failed[0]["reason"]


# ------------------------------------------------------------------------- the window
_WINDOW_SCRIPT = r"""
import json, os, sys, time
import numpy as np
import glfw
from PIL import ImageGrab
from synthcompose.manifest import load_manifest
from synthcompose.preview import PreviewWindow

manifest, frame, out = sys.argv[1:4]
w = PreviewWindow(load_manifest(manifest), frame, quiet=True)

def shot():
    for _ in range(3):
        glfw.poll_events()
        w.dirty = True
        w.frame()
    time.sleep(0.2)
    x, y = glfw.get_window_pos(w.window)
    fw, fh = glfw.get_framebuffer_size(w.window)
    return np.asarray(ImageGrab.grab(bbox=(x, y, x + fw, y + fh), xdisplay=os.environ['DISPLAY']))[..., :3]

before = shot()
title_before = w.title
w.on_key(w.window, glfw.KEY_2, 0, glfw.PRESS, 0)  # a key press: show the Irpv pass
w.on_key(w.window, glfw.KEY_2, 0, glfw.RELEASE, 0)
after = shot()
title_after = w.title
w.draw()
framebuffer = w.read_framebuffer()
w.on_key(w.window, glfw.KEY_V, 0, glfw.PRESS, 0)  # the 3D view
w.draw()
view3d = w.read_framebuffer()
np.savez(out, before=before, after=after, framebuffer=framebuffer, view3d=view3d,
         pass_name=w.pass_name, title_before=title_before, title=title_after, title_3d=w.title)
w.close()
"""


@pytest.fixture(scope="module")
def display():
    pytest.importorskip("glfw")
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        if os.environ.get("DISPLAY"):
            yield os.environ["DISPLAY"]
            return
        pytest.skip("Xvfb is not installed (apt-get install xvfb) and no DISPLAY")
    for num in range(99, 120):
        if not Path(f"/tmp/.X11-unix/X{num}").exists() and not Path(f"/tmp/.X{num}-lock").exists():
            break
    proc = subprocess.Popen([xvfb, f":{num}", "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(50):
        if Path(f"/tmp/.X11-unix/X{num}").exists():
            break
        time.sleep(0.1)
    else:
        proc.kill()
        pytest.skip("Xvfb did not start")
    yield f":{num}"
    proc.terminate()
    proc.wait(timeout=10)


def test_window_shows_the_pass_the_keys_choose_as_the_headless_renderer_does(display, dataset, manifest, tmp_path):
    root, ids = dataset
    out = tmp_path / "shots.npz"
    env = dict(os.environ, DISPLAY=display)
    run = subprocess.run([sys.executable, "-c", _WINDOW_SCRIPT, str(manifest), ids[0].name, str(out)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    got = np.load(out)
    assert "1: composed" in str(got["title_before"]) and "2: Irpv" in str(got["title"])
    assert str(got["pass_name"]) == "irpv" and "3D view" in str(got["title_3d"])
    before, after = got["before"], got["after"]
    assert after.shape == (H, W, 3)  # window sized to the image
    assert after.std() > 10 and (after.max(axis=2) > 0).mean() > 0.02  # not blank
    assert (np.abs(after.astype(int) - before).max(axis=2) > 30).mean() > 0.3  # the key changed the pass
    # the same view from the headless renderer (EGL, same pipeline, same seed: same placement)
    s = PreviewSession(load_manifest(manifest), ids[0].name)
    try:
        s.load()
        ref_after, ref_before = s.pass_image("irpv"), s.pass_image("composed")
    finally:
        s.close()
    for img, ref in ((after, ref_after), (before, ref_before), (got["framebuffer"], ref_after)):
        diff = np.abs(img.astype(int) - ref.astype(int)).max(axis=2)
        assert diff.mean() < 1.0 and (diff > 8).mean() < 0.005, (diff.mean(), (diff > 8).mean())
    view3d = got["view3d"]
    assert view3d.std() > 5  # the point cloud is drawn
