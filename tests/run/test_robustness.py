"""Robustness: bad input of every kind, faults, and long runs. Each bad image set gives a
clear error naming the file and the problem, and the rest of the batch completes."""
from __future__ import annotations

import errno
import functools
import json
import os
import random
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import synthcompose.io.files as fileio
from synthcompose.camera import Camera
from synthcompose.cli import main
from synthcompose.errors import InputError, ManifestError, SynthComposeError
from synthcompose.manifest import parse_manifest
from synthcompose.run import engines
from synthcompose.synthetic import make_sample

from ..helpers import ASSETS, OUT_KINDS, assert_resume_matches, crashing_worker, with_reference_run, write_manifest
from ..tolerances import RSS_GROWTH_MB

W, H = 320, 160


def _camera_edit(edit):
    def apply(root, ident):
        p = ident.path(root, "camera")
        cam = json.loads(p.read_text())
        edit(cam)
        p.write_text(json.dumps(cam))
        return p
    return apply


def _png(kind, make):
    def apply(root, ident):
        p = ident.path(root, kind)
        p.parent.mkdir(parents=True, exist_ok=True)  # the right view: a folder of its own
        assert cv2.imwrite(str(p), make())
        return p
    return apply


def _bytes(kind, data: bytes):
    def apply(root, ident):
        p = ident.path(root, kind)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
        return p
    return apply


def _raw(kind, data):
    def apply(root, ident):
        p = ident.path(root, kind)
        p.write_bytes(data(p.read_bytes()))
        return p
    return apply


def _delete(kind):
    def apply(root, ident):
        p = ident.path(root, kind)
        p.unlink()
        return p
    return apply


def _json(where, text: str):
    """Give the image set an input JSON file (``where(root, ident)`` -> its path) holding ``text``."""
    def apply(root, ident):
        p = where(root, ident)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
        return p
    return apply


def _polygons(root, ident):
    return ident.path(root, "polygons")


def _boxes(root, ident):
    from synthcompose.write.annotations import bbox3d_path
    return bbox3d_path(root, ident)


#: name -> (how to break one image set, text the error must contain after the file name)
BREAKAGES = {
    "missing camera": (_delete("camera"), "file is missing"),
    "missing instanceIds": (_delete("instanceIds"), "file is missing"),
    "truncated png": (_raw("disparity", lambda b: b[: len(b) // 3]), "corrupt or truncated"),
    "not a png": (_raw("labelIds", lambda b: b"GIF89a" + b[6:]), "is not a PNG file"),
    "8-bit disparity": (_png("disparity", lambda: np.full((H, W), 40, np.uint8)), "expected a 16-bit"),
    "16-bit labels": (_png("labelIds", lambda: np.full((H, W), 7, np.uint16)), "expected a 8-bit"),
    "rgb as gray": (_png("rgb", lambda: np.zeros((H, W), np.uint8)), "expected an 8-bit RGB image"),
    "sizes differ": (_png("instanceIds", lambda: np.zeros((H, W + 8), np.uint16)), f"is {W + 8}x{H} but"),
    "camera without fx": (_camera_edit(lambda c: c["intrinsic"].pop("fx")), "has no 'fx'"),
    "camera NaN focal": (_camera_edit(lambda c: c["intrinsic"].update(fy=float("nan"))),
                         "NaN is not a number JSON allows"),
    "camera zero focal": (_camera_edit(lambda c: c["intrinsic"].update(fx=0)), "must be positive"),
    "camera negative baseline": (_camera_edit(lambda c: c["extrinsic"].update(baseline=-0.2)), "must be positive"),
    "camera not json": (_raw("camera", lambda b: b"intrinsic: {fx: 2262}"), "is not valid JSON"),
    "camera a list": (_raw("camera", lambda b: b"[1, 2, 3]"), "must be an object"),
    "disparity all zero": (_png("disparity", lambda: np.zeros((H, W), np.uint16)), "no valid pixel"),
    "impossible disparity": (_png("disparity", lambda: np.full((H, W), 65000, np.uint16)), "exceed half the image width"),
    "unknown label ids": (_png("labelIds", lambda: np.full((H, W), 200, np.uint8)), "does not define: 200"),
    "polygons not json": (_json(_polygons, "{objects: []"), "is not valid JSON"),
    "polygons a list": (_json(_polygons, "[]"), "must be an object with an 'objects' list"),
    "polygons label a list": (_json(_polygons, json.dumps({"imgWidth": W, "imgHeight": H, "objects": [
        {"label": ["car"], "polygon": [[0, 0], [4, 0], [4, 4]]}]})), "entry 0 has no 'label' string"),
    "polygons without polygon": (_json(_polygons, json.dumps({"imgWidth": W, "imgHeight": H, "objects": [
        {"label": "car", "polygon": [[0, 0, 1]]}]})), "entry 0 ('car') has no 'polygon' list"),
    "polygons of another size": (_json(_polygons, json.dumps({"imgWidth": W * 2, "imgHeight": H, "objects": []})),
                                 f"is for {W * 2}x{H}"),
    "3d boxes ignore a number": (_json(_boxes, json.dumps({"objects": [], "ignore": 3})), "'ignore' lists"),
    "right photo of another size": (_png("right", lambda: np.zeros((H, W + 8, 3), np.uint8)), f"is {W + 8}x{H} but"),
    "right photo not a png": (_bytes("right", b"GIF89a" + bytes(64)), "is not a PNG file"),
}


def test_every_kind_of_bad_image_set_is_reported_and_the_rest_completes(tmp_path, capsys):
    root = tmp_path / "cs"
    ids = make_sample(root, count=len(BREAKAGES) + 1, width=W, height=H, seed=5)
    expected = {}
    for ident, (name, (apply, text)) in zip(ids, BREAKAGES.items()):
        expected[ident.key] = (name, f"{apply(root, ident)}: ", text)
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out, objects=[
        {"model": "builtin:box", "class": "car", "size": {"width": 1.8}}], placement={"distance": [5, 30]})
    assert main(["batch", str(manifest), "--no-progress"]) == 1
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    reasons = {p["image_set"]: p["reason"] for p in summary["problems"] if p["status"] == "failed"}
    assert summary["failed"] == len(BREAKAGES)
    for key, (name, where, text) in expected.items():
        assert where in reasons[key] and text in reasons[key], (name, reasons.get(key))
        assert "internal error" not in reasons[key]
        assert reasons[key] in printed
    good = ids[-1]
    assert summary["done"] + summary["skipped"] == 1
    assert good.path(out, "record").is_file()
    assert not list(out.rglob("*.part"))


def test_missing_texture_loads_with_a_warning(tmp_path):
    src = ASSETS / "kenney_vehicles"
    dst = tmp_path / "truck"
    dst.mkdir()
    (dst / "vehicle-truck-red.glb").write_bytes((src / "vehicle-truck-red.glb").read_bytes())  # no Textures/
    from synthcompose.models import load_model

    model = load_model(str(dst / "vehicle-truck-red.glb"), (("length", 6.0),), "+y", "+z")
    assert model.triangles > 0 and all(p.texture is None for p in model.parts)


def test_enormous_model_is_refused_not_rendered(tmp_path, monkeypatch):
    import synthcompose.models as models
    import synthcompose.models.load as loading

    monkeypatch.setattr(loading, "MAX_TRIANGLES", 1000)
    models.load_model.cache_clear()
    try:
        with pytest.raises(SynthComposeError, match="triangles, more than the limit"):
            models.load_model(str(ASSETS / "openmaterial_car" / "vehicle_example.gltf"), (("length", 4.0),))
    finally:
        models.load_model.cache_clear()


@pytest.mark.parametrize("model, text", [
    ("nothing-here.glb", "model file is missing"),
    ("empty.obj", "model file is empty"),
    ("garbage.glb", "cannot be read as a mesh"),
])
def test_bad_model_stops_the_batch_at_the_start_naming_the_file(tmp_path, capsys, model, text):
    root = tmp_path / "cs"
    make_sample(root, count=1, width=W, height=H, seed=1)
    (tmp_path / "empty.obj").write_bytes(b"")
    (tmp_path / "garbage.glb").write_bytes(os.urandom(300))
    manifest = write_manifest(tmp_path / "m.json", root, tmp_path / "out", objects=[
        {"model": str(tmp_path / model), "class": "car", "size": {"length": 4.0}}])
    assert main(["batch", str(manifest), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path / model) in err and text in err


@pytest.mark.parametrize("change, text", [
    ({"cities": ["../../etc"]}, "cities/0"),
    ({"splits": ["train/../../x"]}, "splits/0"),
    ({"frames": ["a_000000_000001", "a_000000_000001"]}, "non-unique"),
    ({"objects_per_image": "2"}, "objects_per_image"),
    ({"placement": {"distance": [30, 5]}}, "placement/distance"),
])
def test_manifest_path_tricks_and_duplicates_are_refused(tmp_path, capsys, change, text):
    manifest = write_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", **change)
    assert main(["batch", str(manifest)]) == 2
    assert text in capsys.readouterr().err


def test_output_root_that_cannot_be_created(tmp_path, capsys):
    root = tmp_path / "cs"
    make_sample(root, count=1, width=W, height=H, seed=1)
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, blocker / "out")), "--no-progress"]) == 2
    assert "output root is not writable" in capsys.readouterr().err


def test_disk_full_midway_loses_nothing(tmp_path, monkeypatch):
    root = tmp_path / "cs"
    ids = make_sample(root, count=3, width=W, height=H, seed=6)
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out)
    real = fileio.tempfile.mkstemp
    calls = {"n": 0}

    def full(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 9:  # the disk fills up during the second image set
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(*args, **kwargs)

    monkeypatch.setattr(fileio.tempfile, "mkstemp", full)
    assert main(["batch", str(manifest), "--no-progress"]) != 0
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else None
    monkeypatch.setattr(fileio.tempfile, "mkstemp", real)
    if summary:
        assert any("No space left on device" in p["reason"] for p in summary["problems"])
    assert not list(out.rglob("*.part"))
    assert main(["batch", str(manifest), "--no-progress"]) == 0  # space back: resume completes
    for ident in ids:
        assert all(ident.path(out, k).is_file() for k in OUT_KINDS)


@pytest.mark.slow
def test_a_worker_that_dies_is_reported_and_replaced(tmp_path, monkeypatch):
    root = tmp_path / "cs"
    ids = make_sample(root, count=4, width=W, height=H, seed=7)
    monkeypatch.setattr(engines, "worker_entry", functools.partial(crashing_worker, ids[1].key))
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--workers", "2",
                 "--no-progress"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed"] == 1 and summary["done"] + summary["skipped"] == 3
    assert "worker process died" in summary["problems"][0]["reason"]
    assert summary["problems"][0]["image_set"] == ids[1].key


def test_no_gl_context_gives_one_clear_message(tmp_path):
    root = tmp_path / "cs"
    make_sample(root, count=1, width=W, height=H, seed=1)
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"} | {"SYNTHCOMPOSE_GL_BACKEND": "x11"}
    res = subprocess.run([sys.executable, "-m", "synthcompose", "batch",
                          str(write_manifest(tmp_path / "m.json", root, tmp_path / "out")), "--no-progress"],
                         capture_output=True, text=True, env=env, timeout=120)
    assert res.returncode == 2
    assert "cannot create an OpenGL context" in res.stderr and "apt-get install" in res.stderr
    assert "Traceback" not in res.stderr


# --------------------------------------------------------------------------------- fuzzing
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
JSONISH = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
                       lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c, max_size=5),
                       max_leaves=20)


@pytest.mark.slow
@FUZZ
@given(data=st.binary(max_size=400), kind=st.sampled_from(["rgb8", "gray8", "gray16"]))
def test_fuzz_png_reader_raises_only_input_errors(tmp_path_factory, data, kind):
    p = tmp_path_factory.mktemp("fuzz") / "x.png"
    for blob in (data, b"\x89PNG\r\n\x1a\n" + data):
        p.write_bytes(blob)
        try:
            fileio.read_png(p, kind)
        except InputError as exc:
            assert str(p) in str(exc)


@pytest.mark.slow
@FUZZ
@given(data=JSONISH)
def test_fuzz_camera_json_raises_only_input_errors(data):
    for blob in (data, {"intrinsic": data, "extrinsic": data}):
        try:
            Camera.from_dict(blob, 64, 32, "cam.json")
        except InputError as exc:
            assert "cam.json" in str(exc)


@pytest.mark.slow
@FUZZ
@given(data=JSONISH, text=st.text(max_size=60))
def test_fuzz_manifest_and_json_raise_only_typed_errors(tmp_path_factory, data, text):
    try:
        parse_manifest(data, Path("m.json"))
    except ManifestError as exc:
        assert "m.json" in str(exc)
    p = tmp_path_factory.mktemp("fuzz") / "f.json"
    p.write_text(text)
    try:
        fileio.read_json(p)
    except InputError as exc:
        assert str(p) in str(exc)


# --------------------------------------------------------------------------- long runs, kills
@pytest.mark.slow
def test_kill_9_at_20_random_moments_then_resume_is_byte_identical(tmp_path):
    ids, manifest, out, ref = with_reference_run(tmp_path, size=(W, H))
    rnd = random.Random(20)
    for _ in range(20):
        proc = subprocess.Popen([sys.executable, "-m", "synthcompose", "batch", str(manifest), "--no-progress"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rnd.uniform(0.2, 3.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        for ident in ids:  # never a partial file under a final name
            for kind in ("rgb", "labelIds", "instanceIds", "color", "disparity"):
                p = ident.path(out, kind)
                assert not p.exists() or cv2.imread(str(p), cv2.IMREAD_UNCHANGED) is not None, p
            rec = ident.path(out, "record")
            assert not rec.exists() or json.loads(rec.read_text())["status"]
    assert_resume_matches(ids, manifest, out, ref)


@pytest.mark.slow
@pytest.mark.parametrize("streamed, count", [(False, 400), (True, 200)])  # 1000 took 5-8 min
def test_memory_threads_and_open_files_stay_flat(tmp_path, streamed, count):
    """Resident memory, threads and open files do not grow with the image sets: one image set
    after the other (Pipeline.process) or three in the works on threads (Pipeline.stream)."""
    import threading

    from synthcompose.manifest import load_manifest
    from synthcompose.run.pipeline import Pipeline

    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=256, height=128, seed=3)
    manifest = load_manifest(write_manifest(tmp_path / "m.json", root, tmp_path / "out",
                                            placement={"distance": [5, 25], "min_visible_pixels": 20},
                                            lighting={"mode": "fixed", "camera_match": False}))

    def rss_mb() -> float:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * resource.getpagesize() / 2**20

    def lasting_threads() -> int:  # not the pools that code one image set's PNGs (fileio.map_threads)
        return sum(not t.name.startswith("synthcompose-io") for t in threading.enumerate())

    samples = []
    threads_before = lasting_threads()
    with Pipeline(manifest) as pipe:
        todo = (ids[i % 2] for i in range(count))
        outcomes = pipe.stream(todo) if streamed else map(pipe.process, todo)
        for i, outcome in enumerate(outcomes):
            assert outcome.status in ("done", "skipped"), outcome.reason
            if i % (count // 10) == count // 10 - 1:
                samples.append((rss_mb(), len(os.listdir("/proc/self/fd")), lasting_threads()))
    rss, fds, threads = zip(*samples)
    assert max(fds) == min(fds) and max(threads) == min(threads), samples
    assert rss[-1] - rss[1] < RSS_GROWTH_MB, rss  # MB, after warm-up: no growth per image set
    assert lasting_threads() == threads_before  # the stream's threads are gone
