"""The batch engine: worker processes, Ray, resume, the output lock, interrupted runs."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import pytest

from synthcompose.cli import main
from synthcompose.run.batch import LOCK_NAME, OutputLock
from synthcompose.synthetic import make_sample

from ..helpers import OUT_KINDS, write_manifest

W, H = 640, 320


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("cs")
    ids = make_sample(root, count=4, width=W, height=H, seed=21)
    work = tmp_path_factory.mktemp("ref")
    manifest = write_manifest(work / "m.json", root, work / "out")
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    return root, ids, work / "out"


def _files(out: Path, ids) -> dict[str, bytes]:
    return {f"{i.key}:{k}": i.path(out, k).read_bytes() for i in ids for k in OUT_KINDS}


@pytest.mark.slow
def test_two_workers_give_byte_identical_outputs(data, tmp_path):
    root, ids, ref = data
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--workers", "2", "--no-progress"]) == 0
    assert _files(out, ids) == _files(ref, ids)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["engine"] == "process" and summary["workers"] == 2 and summary["done"] == len(ids)


@pytest.mark.slow
def test_ray_actors_give_the_same_outputs(data, tmp_path):
    pytest.importorskip("ray")
    root, ids, ref = data
    out = tmp_path / "out"
    code = main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--ray", "--workers", "2",
                 "--no-progress"])
    assert code == 0
    assert _files(out, ids) == _files(ref, ids)
    assert json.loads((out / "summary.json").read_text())["engine"] == "ray"


@pytest.mark.slow
def test_resume_redoes_only_what_is_missing(data, tmp_path):
    root, ids, ref = data
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out)
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    first = {k: os.stat(ids[0].path(out, k)).st_mtime_ns for k in OUT_KINDS}
    ids[2].path(out, "record").unlink()  # as if killed before its record was written
    ids[2].path(out, "rgb").unlink()
    (ids[1].path(out, "rgb").parent / ".stale_leftImg8bit.png.synthcompose-abc.part").write_bytes(b"partial")
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed"] == len(ids) - 1 and summary["done"] == len(ids)
    assert {k: os.stat(ids[0].path(out, k)).st_mtime_ns for k in OUT_KINDS} == first  # untouched
    assert _files(out, ids) == _files(ref, ids)
    assert not list(out.rglob("*.part"))
    # another configuration (seed) in the same output root: everything is redone
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out, seed=99)), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["resumed"] == 0


def test_second_batch_on_the_same_output_is_refused(data, tmp_path, capsys):
    root, ids, _ = data
    out = tmp_path / "out"
    with OutputLock(out):
        assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "another batch is writing to this output root" in err and str(out) in err
    assert not (out / "summary.json").exists()
    assert (out / LOCK_NAME).exists()


@pytest.mark.slow
@pytest.mark.parametrize("delay", [1.5, 3.0])
def test_kill_9_then_resume_gives_the_uninterrupted_result(data, tmp_path, delay):
    root, ids, ref = data
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out)
    cmd = [sys.executable, "-m", "synthcompose", "batch", str(manifest), "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(delay)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    # whatever exists under a final name is complete
    for ident in ids:
        for kind in ("rgb", "labelIds", "instanceIds", "color", "disparity"):
            p = ident.path(out, kind)
            if p.exists():
                assert cv2.imread(str(p), cv2.IMREAD_UNCHANGED) is not None, p
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert _files(out, ids) == _files(ref, ids)
