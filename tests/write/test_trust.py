"""Outputs a training job can trust (issue: never touch inputs, clean only what the tool wrote,
no output outliving its record, resume that notices changed inputs and models, a damaged
record that does not stop the batch, files other users can read)."""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
from pathlib import Path

import cv2
import pytest

from synthcompose.cli import main
from synthcompose.io.files import dumps_json, write_bytes_atomic
from synthcompose.synthetic import make_sample
from synthcompose.write.outputs import output_paths

from ..helpers import ASSETS, write_manifest

W, H = 320, 160


@pytest.fixture()
def data(tmp_path):
    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=W, height=H, seed=4)
    return root, ids


def _digest(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("how", ["same", "link", "inside"])
def test_an_output_root_on_the_inputs_is_refused_and_nothing_is_touched(data, tmp_path, capsys, how):
    root, _ = data
    before = _digest(root)
    out = {"same": root, "inside": root / "leftImg8bit" / "out"}.get(how)
    if how == "link":
        out = tmp_path / "alias"
        out.symlink_to(root)
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 2
    assert "would overwrite the inputs" in capsys.readouterr().err
    assert _digest(root) == before


def test_clean_up_removes_only_its_own_partial_files(data, tmp_path):
    root, ids = data
    out = tmp_path / "out"
    folder = ids[0].path(out, "rgb").parent
    folder.mkdir(parents=True)
    ours = folder / ".x_leftImg8bit.png.synthcompose-abc.part"
    theirs = folder / ".download.part"  # another program's
    nested = out / "nested" / "leftImg8bit" / ".y.png.synthcompose-def.part"  # a batch writing in a sub-root
    nested.parent.mkdir(parents=True)
    for p in (ours, theirs, nested):
        p.write_bytes(b"partial")
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 0
    assert not ours.exists() and theirs.exists() and nested.exists()


def test_a_failed_or_skipped_set_leaves_no_outputs_of_an_earlier_run(data, tmp_path):
    root, ids = data
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 0
    assert all(p.exists() for p in output_paths(out, ids[0])[:5])
    # another seed, and one input broken: that set fails; its earlier files must not stay
    ids[0].path(root, "disparity").write_bytes(b"not a png")
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out, seed=77)), "--no-progress"]) == 1
    assert not any(p.exists() for p in output_paths(out, ids[0]))
    # nothing can be placed any more: the set is skipped, its record says so, no images stay
    assert main(["batch", str(write_manifest(tmp_path / "m2.json", root, out, seed=78,
                                             placement={"distance": [300, 301]})), "--no-progress"]) in (0, 1)
    paths = output_paths(out, ids[1])
    assert not any(p.exists() for p in paths[:-1])
    assert json.loads(paths[-1].read_text())["status"] == "no valid placement"


def test_resume_redoes_a_set_whose_input_or_model_changed(data, tmp_path):
    root, ids = data
    out = tmp_path / "out"
    model = tmp_path / "car"
    shutil.copytree(ASSETS / "openmaterial_car", model)
    manifest = write_manifest(tmp_path / "m.json", root, out)
    spec = json.loads(manifest.read_text())
    spec["objects"][0]["model"] = str(model / "vehicle_example.gltf")
    manifest.write_text(json.dumps(spec))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["resumed"] == len(ids)
    # a new photo for one set (same size): that set is redone, the other kept
    rgb = cv2.imread(str(ids[0].path(root, "rgb")))
    cv2.imwrite(str(ids[0].path(root, "rgb")), 255 - rgb)
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["resumed"] == len(ids) - 1
    # the model's buffer changes: everything is redone
    buf = model / "vehicle_example.bin"
    data = bytearray(buf.read_bytes())
    data[8] ^= 0x01  # the lowest bits of a float of the first accessor: a changed model, still valid
    buf.write_bytes(bytes(data))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    assert json.loads((out / "summary.json").read_text())["resumed"] == 0


def test_a_malformed_record_does_not_stop_the_batch(data, tmp_path):
    root, ids = data
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out)
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    stray = out / "synthcompose" / "train" / "elsewhere" / "elsewhere_000000_000000_synthcompose.json"
    stray.parent.mkdir(parents=True)
    stray.write_text(json.dumps({"status": "done", "image": "no", "objects": [{"mask_rle": 1}]}))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["done"] == len(ids)
    coco = json.loads((out / "coco_instances.json").read_text())
    assert len(coco["images"]) == len(ids)


def test_files_get_the_umasks_mode_and_are_complete(tmp_path):
    old = os.umask(0o022)
    try:
        path = tmp_path / "a" / "f.bin"
        write_bytes_atomic(path, b"x" * 1000)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    assert path.read_bytes() == b"x" * 1000
    assert not list(path.parent.glob("*.part"))


# ------------------------------------------------------------------ clear refusals on the command line
@pytest.mark.parametrize("argv, says", [
    (["batch", "m.json", "--limit", "0"], "--limit: 0 is below 1"),
    (["batch", "m.json", "--limit", "-1"], "--limit: -1 is below 1"),
    (["batch", "m.json", "--workers", "-3"], "--workers: -3 is below 0"),
    (["make-sample", "x", "--count", "two"], "--count: 'two' is not an integer"),
])
def test_numbers_the_code_cannot_use_are_refused(argv, says, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and says in capsys.readouterr().err


@pytest.mark.parametrize("command", ["report", "check-placement"])
def test_report_and_check_on_a_missing_folder_refuse_and_create_nothing(command, tmp_path, capsys):
    missing = tmp_path / "nowhere"
    assert main([command, str(missing)]) == 2
    assert "no such output root" in capsys.readouterr().err and not missing.exists()


def test_version_and_verbose_after_the_command(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith("synthcompose ")
    assert main(["make-sample", str(tmp_path / "s"), "--count", "1", "--size", "64x32", "-v"]) == 0


def test_ctrl_c_is_one_line_without_a_traceback(monkeypatch, capsys):
    import synthcompose.synthetic as synthetic

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(synthetic, "make_sample", interrupted)
    assert main(["make-sample", "x", "--count", "1"]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "Traceback" not in err


# ------------------------------------------------------------------ inputs that are not regular files
def test_pipes_devices_and_bombs_are_refused_before_reading(tmp_path, capsys):
    root = tmp_path / "cs"
    ids = make_sample(root, count=4, width=W, height=H, seed=6)
    fifo = ids[0].path(root, "disparity")
    fifo.unlink()
    os.mkfifo(fifo)  # nobody writes: reading it would block forever
    dev = ids[1].path(root, "camera")
    dev.unlink()
    dev.symlink_to("/dev/zero")  # reading it would never end
    bomb = ids[2].path(root, "labelIds")  # a header declaring 100000 x 100000 pixels
    data = bytearray(bomb.read_bytes())
    data[16:24] = (100000).to_bytes(4, "big") * 2
    bomb.write_bytes(bytes(data))
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    reasons = {p["image_set"]: p["reason"] for p in summary["problems"]}
    assert "is not a regular file" in reasons[ids[0].key] and str(fifo) in reasons[ids[0].key]
    assert "is not a regular file" in reasons[ids[1].key]
    assert "declares 100000x100000 pixels" in reasons[ids[2].key]
    assert summary["done"] == 1


def test_nan_and_infinity_in_json_are_refused(tmp_path):
    from synthcompose.errors import InputError
    from synthcompose.io.files import read_json

    path = tmp_path / "c.json"
    path.write_text('{"fx": NaN}')
    with pytest.raises(InputError, match="NaN is not a number JSON allows"):
        read_json(path)


@pytest.mark.parametrize("field, value, says", [
    ("objects_per_image", 2.0, None), ("seed", 5.0, None),
    ("weight", 1e300, "field 'objects/0/weight'"), ("size", {"length": 1e9}, "field 'objects/0/size/length'"),
])
def test_numbers_the_schema_lets_through_are_made_usable_or_refused(data, tmp_path, field, value, says):
    from synthcompose.errors import ManifestError
    from synthcompose.manifest import load_manifest

    root, ids = data
    path = write_manifest(tmp_path / "m.json", root, tmp_path / "out")
    spec = json.loads(path.read_text())
    if field in ("weight", "size"):
        spec["objects"][0][field] = value
    else:
        spec[field] = value
    path.write_text(json.dumps(spec))
    if says:
        with pytest.raises(ManifestError, match=says):
            load_manifest(path)
        return
    m = load_manifest(path)
    assert isinstance(m.objects_per_image, int) and isinstance(m.seed, int)
    assert main(["batch", str(path), "--no-progress"]) == 0


# ------------------------------------------------------------------ the wheel alone
@pytest.mark.slow
def test_the_wheel_alone_runs_make_sample_and_the_demo_manifest(tmp_path):
    """The wheel (no checkout: its shaders and built-in models inside it) in a fresh venv; the
    third-party packages come from this environment (a .pth file), not the checkout."""
    import subprocess
    import sys
    import sysconfig
    import venv

    repo = Path(__file__).resolve().parents[2]
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(wheels), str(repo)], check=True, cwd=tmp_path)
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    wheel = next(wheels.glob("synthcompose-*.whl"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site), str(wheel)],
                   check=True, cwd=tmp_path)
    where = subprocess.run([str(py), "-c", "import synthcompose; print(synthcompose.__file__)"], check=True,
                           capture_output=True, text=True, cwd=tmp_path).stdout
    assert str(site) in where  # the wheel's copy, not the checkout's
    sample = tmp_path / "cityscapes"
    subprocess.run([str(py), "-m", "synthcompose", "make-sample", str(sample), "--count", "1", "--size", "320x160"],
                   check=True, cwd=tmp_path)
    demo = json.loads((repo / "assets" / "demo" / "manifest.json").read_text())
    assert demo.get("cast") == "street"  # the built-in cast: its catalogue must be in the wheel
    for obj in demo.get("objects", []):
        if not obj["model"].startswith("builtin:"):
            obj["model"] = str((repo / "assets" / "demo" / obj["model"]).resolve())
    demo.update(dataset=str(sample), output=str(tmp_path / "out"))
    (tmp_path / "demo.json").write_text(json.dumps(demo))
    run = subprocess.run([str(py), "-m", "synthcompose", "batch", str(tmp_path / "demo.json"), "--no-progress"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "1 done" in run.stdout
    (record,) = (tmp_path / "out" / "synthcompose").rglob("*_synthcompose.json")
    objects = json.loads(record.read_text())["objects"]
    assert objects and all(o["model"] == "cast:" + o["appearance"]["model"] for o in objects)
    listed = subprocess.run([str(py), "-c", "from synthcompose.cast import load_catalogue as c; "
                             "print(c().root, len(c().entries))"], check=True, capture_output=True, text=True,
                            cwd=tmp_path).stdout.split()
    assert listed[0].startswith(str(site)) and int(listed[1]) == len(list((repo / "assets" / "cast").glob("*/*/entry.json")))


@pytest.mark.slow
def test_sigterm_with_workers_prints_no_traceback(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    root = tmp_path / "cs"
    make_sample(root, count=8, width=W, height=H, seed=8)
    manifest = write_manifest(tmp_path / "m.json", root, tmp_path / "out")
    proc = subprocess.Popen([sys.executable, "-m", "synthcompose", "batch", str(manifest), "--workers", "2",
                             "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            cwd=tmp_path)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list((tmp_path / "out").rglob("*_synthcompose.json")):
        time.sleep(0.1)  # the workers are at work: a set is done, others in flight
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    time.sleep(1.0)  # the workers notice their parent is gone
    assert "Traceback" not in err, err[-3000:]


@pytest.mark.parametrize("doc", [
    {"imgHeight": 4, "imgWidth": 8, "objects": [{"label": "car", "polygon": [[0, 0], [4.5, 0], [4, 3]]},
                                                {"label": "road", "polygon": []}]},
    {"a": [1, [2, [3]]], "b": {}, "c": [], "d": "é\"\n", "e": None, True: False, 3: [{"x": 1}], 2.5: (1, 2)},
    [], {}, 7, "text", [[1, 2], [3, [4]]],
])
def test_json_outputs_load_as_written_and_keep_number_lists_on_one_line(doc):
    text = dumps_json(doc).decode("utf-8")
    assert json.loads(text) == json.loads(json.dumps(doc))
    assert text.endswith("\n")
    if isinstance(doc, dict) and "objects" in doc:
        assert '"polygon": [[0, 0], [4.5, 0], [4, 3]]' in text
        assert text.startswith('{\n  "imgHeight": 4,')
    with pytest.raises(ValueError):
        dumps_json({"x": [float("nan")]})
