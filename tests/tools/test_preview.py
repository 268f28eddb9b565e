"""`synthcompose preview`: the window (under Xvfb: keys, mouse, overlay), the placement rules'
verdict on moved poses, the PLY export and saved placements."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.io.dataset import read_image_set
from synthcompose.manifest import load_manifest
from synthcompose.placement import RULE_OF
from synthcompose.placement.saved_poses import placement_path, read_saved
from synthcompose.preview import PASSES, Overlay, PlacementRefused, PreviewSession
from synthcompose.synthetic import make_sample

from ..helpers import write_manifest
from ..tolerances import (
    CHANGED_PIXEL_8BIT,
    OVERLAY_TEXT_CHANGED_MIN,
    PASS_CHANGE_MIN_SHARE,
    PREVIEW_MOVE_M,
    PREVIEW_PAN_REL,
    SAVED_MATRIX_ABS,
    VIEW_CHANGE_MIN_SHARE,
    WINDOW_MAX_SHARE,
    WINDOW_MEAN_8BIT,
    WINDOW_PIXEL_8BIT,
)

W, H = 640, 320
#: a place on the generated street's left footway, 7 m left of the camera (vehicle frame y, metres):
#: the sample's road reaches about 5 m to each side
OFF_ROAD_Y = 7.0


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("cityscapes")
    return root, make_sample(root, count=2, width=W, height=H, seed=1)


@pytest.fixture
def manifest(dataset, tmp_path):
    root, _ = dataset
    return write_manifest(tmp_path / "m.json", root, tmp_path / "out")


def test_headless_modules_never_import_a_window_toolkit():
    code = ("import sys, synthcompose.cli, synthcompose.run.pipeline, synthcompose.run.batch, synthcompose.preview.session;"
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


@contextmanager
def _loaded(m, frame: str):
    """A preview session (no window) with its first view loaded; closed afterwards."""
    s = PreviewSession(m, frame)
    try:
        s.load()
        yield s
    finally:
        s.close()


@pytest.mark.slow
def test_saved_placement_is_used_by_a_later_batch(dataset, manifest, tmp_path):
    root, ids = dataset
    m = load_manifest(manifest)
    with _loaded(m, ids[0].name) as s:
        before = s.view.objects[0].placement.matrix
        for dx in (0.5, -0.5):  # moved by hand, as the arrow and Q keys do: on, or back where on fails
            s.move(dx=dx, dyaw_deg=10.0)
            if s.view.verdict.ok:
                break
            s.move(dx=-dx, dyaw_deg=-10.0)
        assert s.view.source == "moved" and s.view.verdict.ok
        moved = s.view.objects[0].placement.matrix
        assert np.hypot(*(moved[:2, 3] - before[:2, 3])) == pytest.approx(0.5, abs=PREVIEW_MOVE_M)
        path = s.save()
    assert path == placement_path(m.output, ids[0]) and path.is_file()
    saved = read_saved(m.output, ids[0])
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    rec = json.loads(ids[0].path(m.output, "record").read_text())
    assert rec["placement_file"]["sha256"] == saved.sha256
    assert [o["name"] for o in rec["objects"]] == [o.name for o in saved.objects]
    for obj, so in zip(rec["objects"], saved.objects):
        assert obj["placement_source"] == "saved"
        assert obj["placement_check"] == {"ok": True}  # the pose S saved passes the batch's rules
        assert np.allclose(obj["pose"]["vehicle"]["matrix"], so.matrix, atol=SAVED_MATRIX_ABS)
    other = json.loads(ids[1].path(m.output, "record").read_text())
    assert "placement_file" not in other and all(o["placement_source"] == "random" for o in other["objects"])
    # the window shows the saved placement next time
    with _loaded(m, ids[0].name) as s:
        assert s.view.source == "saved"
        assert np.allclose(s.view.objects[0].placement.matrix, moved, atol=SAVED_MATRIX_ABS)
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


def test_moved_pose_gets_the_placement_rules_verdict_and_save_refuses_a_failing_one(dataset, manifest):
    root, ids = dataset
    m = load_manifest(manifest)
    with _loaded(m, ids[0].name) as s:
        assert s.view.verdict.ok and str(s.view.verdict) == "placement OK"  # the batch accepted it
        start = s.view.objects[0].placement.matrix
        away = OFF_ROAD_Y - start[1, 3]
        s.move(dy=away)  # to the left, off the road: onto the sidewalk
        verdict = s.view.verdict
        assert not verdict.ok
        i, name, why = verdict.failures[0]
        assert (i, name) == (0, s.view.objects[0].name) and why.rule in RULE_OF.values()
        assert str(verdict).startswith(f"FAILS {name} #1 - {why.rule}: {why.reason}")
        assert why.rule in s.status_line()
        with pytest.raises(PlacementRefused, match=f"not saved: .*{why.rule}.*Shift\\+S"):
            s.save()
        assert not s.placement_file.exists()
        s.move(dy=-away)  # back where it was: the rules hold again
        assert s.view.verdict.ok, str(s.view.verdict)
        assert np.allclose(s.view.objects[0].placement.matrix[:2, 3], start[:2, 3], atol=PREVIEW_MOVE_M)
        path = s.save()
        assert path.is_file()
        saved = read_saved(m.output, ids[0])
        assert np.allclose(saved.objects[0].matrix, s.view.objects[0].placement.matrix, atol=SAVED_MATRIX_ABS)
        # into a collision: the first object 1 m ahead of the second, where they stand on one surface
        same = [k for k, o in enumerate(s.view.objects) if o.allowed == s.view.objects[0].allowed]
        if len(same) > 1:
            a, b = (s.view.objects[k].placement.matrix for k in same[:2])
            target = b[:3, 3] + b[:3, 0]
            s.selected = same[0]
            s.move(dx=target[0] - a[0, 3], dy=target[1] - a[1, 3])
            assert any(w.rule == "collision" for _, _, w in s.view.verdict.failures), str(s.view.verdict)
            with pytest.raises(PlacementRefused):
                s.save()
            assert s.save(force=True) == path  # the explicit override writes it anyway
            assert not np.allclose(read_saved(m.output, ids[0]).objects[0].matrix, saved.objects[0].matrix)


def test_batch_records_that_a_force_saved_pose_breaks_a_rule(dataset, manifest):
    root, ids = dataset
    m = load_manifest(manifest)
    with _loaded(m, ids[0].name) as s:
        s.move(dy=OFF_ROAD_Y - s.view.objects[0].placement.matrix[1, 3])  # off the road
        why = s.view.verdict.failures[0][2]
        s.save(force=True)  # Shift+S
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    rec = json.loads(ids[0].path(m.output, "record").read_text())
    obj = rec["objects"][0]
    assert obj["placement_source"] == "saved"  # used as saved, and the record says what it breaks
    assert obj["placement_check"]["ok"] is False
    assert (obj["placement_check"]["rule"], obj["placement_check"]["reason"]) == (why.rule, why.reason)


def test_overlay_picture_has_the_text_on_panels_and_is_clear_elsewhere():
    ov = Overlay((("1: composed | train/a/a_000000_000001 (1/1)", (255, 255, 255)), ("placement OK", (0, 255, 0))),
                 legend=(((255, 0, 0), "x3 intersects the scene"),))
    img = ov.render(640, 320)
    assert img.shape == (320, 640, 4) and img.dtype == np.uint8
    alpha = img[..., 3]
    assert 0.02 < (alpha > 0).mean() < 0.3  # a top panel and a legend panel, the rest clear
    assert (alpha[:40] > 0).any() and (alpha[-40:] > 0).any() and not (alpha[120:200] > 0).any()
    red = (img[..., 0] == 255) & (img[..., 1] == 0) & (img[..., 3] == 255)
    assert red[-40:].sum() > 20  # the legend's swatch
    helped = Overlay(ov.lines, help=("1-9\tpass", "Esc\tquit")).render(640, 320)
    assert (helped[..., 3] > 0).sum() > (Overlay(ov.lines[:1]).render(640, 320)[..., 3] > 0).sum()
    long = Overlay((("word " * 200, (255, 255, 255)),)).render(320, 160)  # wrapped, never past the picture
    assert (long[..., 3] > 0).any() and long.shape == (160, 320, 4)


# ------------------------------------------------------------------------- the window
_WINDOW_SCRIPT = r"""
import json, os, sys, time
import numpy as np
import glfw
from PIL import ImageGrab
from synthcompose.manifest import load_manifest
from synthcompose.preview import PreviewWindow
from synthcompose.render.transforms import look_at

manifest, frame, out = sys.argv[1:4]
w = PreviewWindow(load_manifest(manifest), frame, quiet=True)
got = {}

def shot():
    for _ in range(3):
        glfw.poll_events()
        w.dirty = True
        w.frame()
    time.sleep(0.2)
    x, y = glfw.get_window_pos(w.window)
    fw, fh = glfw.get_framebuffer_size(w.window)
    return np.asarray(ImageGrab.grab(bbox=(x, y, x + fw, y + fh), xdisplay=os.environ['DISPLAY']))[..., :3]

def key(k, mods=0):
    w.on_key(w.window, k, 0, glfw.PRESS, mods)
    w.on_key(w.window, k, 0, glfw.RELEASE, mods)

def read():
    w.draw()
    return w.read_framebuffer()

def orbit():
    o = w.orbit
    return np.array([o.yaw, o.pitch, o.distance, *o.target])

def drag(button, dx, dy):
    x0, y0 = glfw.get_cursor_pos(w.window)
    w.on_mouse_button(w.window, button, glfw.PRESS, 0)
    w.on_cursor(w.window, x0 + dx / 2, y0 + dy / 2)
    w.on_cursor(w.window, x0 + dx, y0 + dy)
    w.on_mouse_button(w.window, button, glfw.RELEASE, 0)

got["before"] = shot()
got["title_before"], got["mask_before"] = w.title, w.overlay_pixels[..., 3] > 0
key(glfw.KEY_2)  # a key press: show the Irpv pass
got["after"] = shot()
got["title"], got["pass_name"], got["mask"] = w.title, w.pass_name, w.overlay_pixels[..., 3] > 0
got["overlay_lines"] = [t for t, _ in w.overlay().lines]
got["framebuffer"] = read()
key(glfw.KEY_O)  # overlay off
got["after_no_overlay"], got["framebuffer_no_overlay"] = shot(), read()
key(glfw.KEY_O)
key(glfw.KEY_H)  # help on screen
read()
got["mask_help"] = w.overlay_pixels[..., 3] > 0
key(glfw.KEY_H)
# the 3D view and the mouse: orbit (left drag), pan (right drag), zoom (wheel)
key(glfw.KEY_V)
got["view3d"], got["orbit0"], got["mask_3d"] = read(), orbit(), w.overlay_pixels[..., 3] > 0
got["legend"] = [t for _, t in w.overlay().legend]
drag(glfw.MOUSE_BUTTON_LEFT, 60, 25)
got["view_orbit"], got["orbit1"] = read(), orbit()
drag(glfw.MOUSE_BUTTON_RIGHT, 40, 30)
got["view_pan"], got["orbit2"] = read(), orbit()
camera = look_at(w.orbit.eye, w.orbit.target)  # rows 0, 1: the camera's right and up (the pan keeps them)
got["pan_right"], got["pan_up"] = camera[0, :3], camera[1, :3]
w.on_scroll(w.window, 0.0, 2.0)  # wheel up twice
got["view_zoom"], got["orbit3"] = read(), orbit()
key(glfw.KEY_V)
# save with the keys: refused off the road, Shift+S saves anyway, back on the road S saves
path = w.session.placement_file
steps = 0
while w.session.view.verdict.ok and steps < 12:  # 1 m to the left each, until off the road
    key(glfw.KEY_LEFT, glfw.MOD_SHIFT)
    steps += 1
got["verdict_moved"], got["title_moved"] = str(w.session.view.verdict), w.title
key(glfw.KEY_S)
got["refused_message"], got["refused_exists"] = w.message, path.exists()
got["refused_overlay"] = [t for t, _ in w.overlay().lines]
key(glfw.KEY_S, glfw.MOD_SHIFT)
got["anyway_message"], got["anyway_exists"] = w.message, path.exists()
for _ in range(steps):
    key(glfw.KEY_RIGHT, glfw.MOD_SHIFT)
got["verdict_back"] = str(w.session.view.verdict)
key(glfw.KEY_S)
got["saved_message"] = w.message
got["saved_matrix"] = np.array(json.loads(path.read_text())["objects"][w.session.selected]["matrix"])
got["shown_matrix"] = w.session.view.objects[w.session.selected].placement.matrix
np.savez(out, **got)
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


@pytest.fixture(scope="module")
def window_run(display, dataset, tmp_path_factory):
    """The window under Xvfb, driven by its key, mouse-button, cursor and wheel callbacks; what
    it showed, in a .npz file."""
    root, ids = dataset
    work = tmp_path_factory.mktemp("window")
    manifest = write_manifest(work / "m.json", root, work / "out")
    out = work / "shots.npz"
    env = dict(os.environ, DISPLAY=display)
    run = subprocess.run([sys.executable, "-c", _WINDOW_SCRIPT, str(manifest), ids[0].name, str(out)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    return manifest, ids[0], np.load(out)


def _same(img, ref, where=None):
    diff = np.abs(img.astype(int) - ref.astype(int)).max(axis=2)
    if where is not None:
        diff = diff[where]
    over = (diff > WINDOW_PIXEL_8BIT).mean()
    assert diff.mean() < WINDOW_MEAN_8BIT and over < WINDOW_MAX_SHARE, (diff.mean(), over)


@pytest.mark.slow
def test_window_shows_the_pass_the_keys_choose_as_the_headless_renderer_does(window_run):
    manifest, ident, got = window_run
    assert "1: composed" in str(got["title_before"]) and "2: Irpv" in str(got["title"])
    assert str(got["pass_name"]) == "irpv" and "placement OK" in str(got["title"])
    before, after = got["before"], got["after"]
    assert after.shape == (H, W, 3)  # window sized to the image
    assert after.std() > 10 and (after.max(axis=2) > 0).mean() > 0.02  # not blank
    changed = np.abs(after.astype(int) - before).max(axis=2) > CHANGED_PIXEL_8BIT
    assert changed.mean() > PASS_CHANGE_MIN_SHARE  # the key changed the pass
    # the same view from the headless renderer (EGL, same pipeline, same seed: same placement),
    # everywhere but under the overlay's text panels
    s = PreviewSession(load_manifest(manifest), ident.name)
    try:
        s.load()
        ref_after, ref_before = s.pass_image("irpv"), s.pass_image("composed")
    finally:
        s.close()
    main_area, main_before = ~got["mask"], ~got["mask_before"]
    assert main_area.mean() > 0.6 and main_before.mean() > 0.6
    _same(after, ref_after, main_area)
    _same(before, ref_before, main_before)
    _same(got["framebuffer"], ref_after, main_area)
    _same(got["framebuffer_no_overlay"], ref_after)  # overlay off (O): the whole view
    _same(got["after_no_overlay"], ref_after)


def test_overlay_shows_pass_image_set_and_verdict_over_the_view(window_run):
    manifest, ident, got = window_run
    lines = [str(t) for t in got["overlay_lines"]]
    assert lines[0].startswith("2: Irpv") and ident.key in lines[0]
    assert lines[2] == "placement OK"
    on, off, text = got["after"].astype(int), got["after_no_overlay"].astype(int), got["mask"]
    changed = np.abs(on - off).max(axis=2) > WINDOW_PIXEL_8BIT
    assert changed[text].mean() > OVERLAY_TEXT_CHANGED_MIN  # the screenshot differs where the overlay is...
    assert not changed[~text].any()  # ...and nowhere else
    assert got["mask_help"].sum() > got["mask"].sum()  # H: the keys on screen
    # the 3D view's overlay: the legend of colours at the bottom
    assert got["mask_3d"][-H // 3:].any() and not got["mask"][-H // 3:].any()
    legend = [str(t) for t in got["legend"]]
    assert "accepted position" in legend and "selected object's box" in legend


def test_mouse_orbits_pans_and_zooms_the_3d_view(window_run):
    manifest, ident, got = window_run
    o0, o1, o2, o3 = got["orbit0"], got["orbit1"], got["orbit2"], got["orbit3"]  # yaw, pitch, distance, target xyz
    # left drag of (60, 25) px: yaw and pitch turn by 0.01 rad per pixel, the rest stays
    assert o1[0] == pytest.approx(o0[0] - 0.60) and o1[1] == pytest.approx(min(o0[1] + 0.25, 1.45))
    assert np.allclose(o1[2:], o0[2:])
    # right drag of (40, 30) px: the target moves (against the camera's right, along its up), the angles stay
    assert np.allclose(o2[:3], o1[:3])
    moved = o2[3:] - o1[3:]
    k = o1[2] * 0.0015
    assert np.linalg.norm(moved) == pytest.approx(k * 50.0, rel=PREVIEW_PAN_REL)
    assert moved @ got["pan_right"] == pytest.approx(-40 * k) and moved @ got["pan_up"] == pytest.approx(30 * k)
    # wheel up twice: 10 % closer per step, nothing else changes
    assert o3[2] == pytest.approx(o2[2] * 0.81) and np.allclose(np.delete(o3, 2), np.delete(o2, 2))
    # and the picture follows each of them
    outside = ~got["mask_3d"]
    for a, b in (("view3d", "view_orbit"), ("view_orbit", "view_pan"), ("view_pan", "view_zoom")):
        changed = (np.abs(got[a].astype(int) - got[b]).max(axis=2) > CHANGED_PIXEL_8BIT)[outside].mean()
        assert changed > VIEW_CHANGE_MIN_SHARE, (a, b, changed)
    assert got["view3d"].std() > 5  # the point cloud is drawn


def test_s_key_refuses_a_pose_that_breaks_the_rules_shift_s_saves_anyway(window_run):
    manifest, ident, got = window_run
    moved = str(got["verdict_moved"])
    assert moved.startswith("FAILS") and any(f"{rule}:" in moved for rule in RULE_OF.values())
    assert moved in str(got["title_moved"])
    assert str(got["refused_message"]).startswith("not saved:") and "Shift+S" in str(got["refused_message"])
    assert not got["refused_exists"]
    assert moved in [str(t) for t in got["refused_overlay"]]
    assert str(got["refused_message"]) in [str(t) for t in got["refused_overlay"]]
    assert "anyway" in str(got["anyway_message"]) and got["anyway_exists"]
    assert str(got["verdict_back"]) == "placement OK"
    assert str(got["saved_message"]).startswith("saved placement:") and "anyway" not in str(got["saved_message"])
    assert np.allclose(got["saved_matrix"], got["shown_matrix"], atol=SAVED_MATRIX_ABS)
