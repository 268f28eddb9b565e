"""Every bad input gets a clear, early answer (issue 32): unreadable places, selections that match
nothing, JSON the reader cannot use, models nothing of which would be seen, manifest values
that are not what they say, worker counts, stopping by SIGTERM, saved poses that cannot be, and
make-sample sizes. Each refusal names the file (and the field) and ends with exit status 2 when
it comes before any work, or fails only the image set it concerns; none is a traceback, an
"internal error" or an exit status of 0 for a run that did nothing."""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import unicodedata
from pathlib import Path

import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.errors import InputError, ManifestError
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import MAX_JSON_DEPTH, read_json
from synthcompose.manifest import load_manifest
from synthcompose.run.selection import select_image_sets
from synthcompose.synthetic import make_sample

from ..helpers import ASSETS, OUT_KINDS, assert_resume_matches, box_manifest, with_reference_run

W, H = 320, 160
INPUT_KINDS = ("rgb", "right", "labelIds", "instanceIds", "color", "disparity", "camera")


@pytest.fixture(scope="module")
def sample(tmp_path_factory) -> tuple[Path, list[ImageSetId]]:
    """Three generated image sets, never changed by a test (copy it to break it)."""
    root = tmp_path_factory.mktemp("cs")
    return root, make_sample(root, count=3, width=W, height=H, seed=2)


def copy_of(sample, tmp_path: Path) -> tuple[Path, list[ImageSetId]]:
    root, ids = sample
    shutil.copytree(root, tmp_path / "cs")
    return tmp_path / "cs", ids


def move_set(root: Path, ident: ImageSetId, city: str) -> ImageSetId:
    """Move every file of an image set to another city (folder and file names)."""
    moved = ImageSetId(ident.split, city, ident.seq, ident.frame)
    for kind in INPUT_KINDS:
        src = ident.path(root, kind)
        if src.exists():
            moved.path(root, kind).parent.mkdir(parents=True, exist_ok=True)
            src.rename(moved.path(root, kind))
    return moved


def refused(argv: list[str], capsys) -> str:
    """Run the command line; it must end with exit status 2 and one error line (no traceback)."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "synthcompose: error:" in err and "Traceback" not in err
    return err


def failures(out: Path) -> dict[str, str]:
    summary = json.loads((out / "summary.json").read_text())
    return {p["image_set"]: p["reason"] for p in summary["problems"] if p["status"] == "failed"}


# ------------------------------------------------------------------------------ unreadable places
def test_a_city_folder_that_cannot_be_listed_is_reported(sample, tmp_path, capsys, monkeypatch):
    import synthcompose.io.dataset as dataset

    root, ids = sample
    city = root / "leftImg8bit" / "train" / ids[0].city
    real = os.scandir

    def denied(path):
        if Path(path) == city:
            raise PermissionError(13, "Permission denied", str(path))
        return real(path)

    monkeypatch.setattr(dataset.os, "scandir", denied)
    out = tmp_path / "out"
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, out)), "--no-progress"], capsys)
    assert f"{city}: folder cannot be listed (Permission denied)" in err
    assert not out.exists()  # refused before the output root is made


@pytest.mark.skipif(os.geteuid() == 0, reason="root lists any folder")
def test_a_city_folder_without_read_permission_is_reported(sample, tmp_path, capsys):
    root, ids = copy_of(sample, tmp_path)
    city = root / "leftImg8bit" / "train" / ids[0].city
    city.chmod(0o300)
    try:
        err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, tmp_path / "out"))], capsys)
    finally:
        city.chmod(0o755)
    assert f"{city}: folder cannot be listed" in err


@pytest.mark.parametrize("where", ["city", "split"])
def test_a_link_loop_in_the_dataset_tree_is_reported(sample, tmp_path, capsys, where):
    root, _ = copy_of(sample, tmp_path)
    link = root / "leftImg8bit" / "train" / "loop" if where == "city" else root / "leftImg8bit" / "loop"
    link.symlink_to(link.name)  # a link to itself
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, tmp_path / "out"))], capsys)
    assert f"{link}: cannot be followed (Too many levels of symbolic links)" in err
    # a selection that leaves the loop out is not stopped by it
    assert select_image_sets(load_manifest(box_manifest(tmp_path / "n.json", root, tmp_path / "out", splits=["train"],
                                                        cities=["synthtown"])))


def test_city_names_with_spaces_and_letters_of_any_script_are_selectable(sample, tmp_path):
    root, ids = copy_of(sample, tmp_path)
    spaced = move_set(root, ids[0], "bad homburg")
    composed = move_set(root, ids[1], unicodedata.normalize("NFD", "münchen"))  # as a Mac writes it
    manifest = box_manifest(tmp_path / "m.json", root, tmp_path / "out", cities=["bad homburg", "münchen"])
    assert select_image_sets(load_manifest(manifest)) == sorted([spaced, composed])
    out = tmp_path / "out"
    assert main(["batch", str(manifest), "--no-progress", "--limit", "1"]) == 0
    assert spaced.path(out, "record").is_file()


@pytest.mark.parametrize("name", ["..", ".", "a/b", "a\\b", " padded", "tab\t", "line\n", ""])
def test_path_tricks_in_city_names_are_still_refused(tmp_path, name):
    with pytest.raises(ManifestError, match="field 'cities/0'"):
        load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", cities=[name]))


# ------------------------------------------------------------------- selections that match nothing
@pytest.mark.parametrize("selector, says, hint", [
    ({"splits": ["trian"]}, "field 'splits': 'trian' matches no split folder", "did you mean 'train'?"),
    ({"cities": ["synthtwon"]}, "field 'cities': 'synthtwon' matches no city folder", "did you mean 'synthtown'?"),
    ({"frames": ["synthtown_000000_00001"]}, "field 'frames': 'synthtown_000000_00001' matches no image set",
     "did you mean 'synthtown_000000_000001'"),
    ({"frames": ["synthtown_000000_000001", "synthtown_000000_000099"]}, "'synthtown_000000_000099' matches no",
     "did you mean"),
    ({"cities": []}, "field 'cities': an empty list selects no image set", ""),
    ({"frames": []}, "field 'frames': an empty list selects no image set", ""),
])
def test_a_selector_that_matches_nothing_is_named_with_near_matches(sample, tmp_path, capsys, selector, says, hint):
    root, _ = sample
    out = tmp_path / "out"
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, out, **selector)), "--no-progress"], capsys)
    assert says in err and hint in err
    assert not out.exists()


def test_an_empty_dataset_is_refused(tmp_path, capsys):
    (tmp_path / "cs" / "leftImg8bit" / "train").mkdir(parents=True)
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", tmp_path / "cs", tmp_path / "out"))], capsys)
    assert "selects no image set" in err
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", tmp_path / "none", tmp_path / "out"))], capsys)
    assert f"{tmp_path / 'none'}: dataset root is missing" in err


def test_a_frame_whose_left_photo_is_missing_is_named(sample, tmp_path, capsys):
    root, ids = copy_of(sample, tmp_path)
    ids[1].path(root, "rgb").unlink()  # its camera, disparity and labels are there
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, tmp_path / "out", frames=[ids[1].name]))],
                  capsys)
    assert f"has no left photo ({ids[1].path(root, 'rgb')} is missing)" in err


def test_a_frame_outside_the_cities_selected_is_explained(sample, tmp_path, capsys):
    root, ids = copy_of(sample, tmp_path)
    moved = move_set(root, ids[0], "elsewhere")
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", root, tmp_path / "out", cities=["synthtown"],
                                             frames=[moved.name]))], capsys)
    assert f"'{moved.name}' is in city 'elsewhere', which field 'cities' leaves out" in err


# ---------------------------------------------------------------------------- JSON inputs
def _camera(edit):
    def apply(root, ident):
        path = ident.path(root, "camera")
        path.write_text(edit(path.read_text()))
        return path
    return apply


def _number(field: str, text: str):
    """Replace the camera's ``field`` value by ``text`` (JSON as written)."""
    def edit(raw: str) -> str:
        data = json.loads(raw)
        block = "intrinsic" if field in data["intrinsic"] else "extrinsic"
        data[block][field] = "@@"
        return json.dumps(data).replace('"@@"', text)
    return _camera(edit)


def _polygons(text: str):
    def apply(root, ident):
        path = ident.path(root, "polygons")
        path.write_text(text)
        return path
    return apply


def _vehicle(text: str):
    """Give the image set a vehicle file holding ``text``."""
    def apply(root, ident):
        path = ident.path(root, "vehicle")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        return path
    return apply


#: how to break an image set's JSON -> text its failure must hold after the file's name
JSON_BREAKAGES = {
    "a vehicle file whose heading is text": (_vehicle('{"gpsHeading": "east", "gpsLatitude": 51, "gpsLongitude": 7}'),
                                             "gpsHeading is 'east': a number is needed"),
    "a vehicle file at latitude 151": (_vehicle('{"gpsHeading": 90, "gpsLatitude": 151, "gpsLongitude": 7}'),
                                       "gpsLatitude is 151: outside -90..90 degrees"),
    "a vehicle file with a longitude of true": (_vehicle('{"gpsHeading": 9, "gpsLatitude": 51, "gpsLongitude": true}'),
                                                "gpsLongitude is True: a number is needed"),
    "a vehicle file that is a list": (_vehicle("[1, 2]"), "is not a JSON object"),
    "integer too large for a float": (_number("fx", "1" + "0" * 400), "number at 'intrinsic/fx' is too large"),
    "exponent beyond a float": (_number("baseline", "1e999"), "number at 'extrinsic/baseline' is beyond the range"),
    "arrays thousands deep": (_number("u0", "[" * 5000 + "]" * 5000), "is nested more than 64 levels deep"),
    "arrays a hundred deep": (_number("v0", "[" * 100 + "]" * 100), "is nested more than 64 levels deep"),
    "numbers as strings": (_number("fy", '"2262.5"'),
                           "camera JSON 'intrinsic.fy' must be a finite number, found '2262.5' (a string)"),
    "a key twice": (_camera(lambda raw: raw.replace('"fx":', '"fx": 1, "fx":', 1)),
                    "gives the key 'fx' twice in the object at 'intrinsic'"),
    "a focal length of 1e-300": (_number("fx", "1e-300"), "camera JSON 'fx' is 1e-300 px, outside"),
    "a principal point 1e300 away": (_number("u0", "1e300"), "camera JSON 'u0' is 1e+300 px, outside"),
    "a camera 1 km up": (_number("z", "1000"), "camera JSON 'z' is 1000 m, outside"),
    "polygons with a huge number": (_polygons('{"imgWidth": %d, "imgHeight": %d, "objects": [{"label": "car", '
                                              '"polygon": [[0, 0], [1%s, 4]]}]}' % (W, H, "0" * 400)),
                                    "number at 'objects/0/polygon/1/0' is too large"),
}


def test_json_the_reader_cannot_use_fails_its_image_set_naming_file_and_field(tmp_path):
    root = tmp_path / "cs"
    ids = make_sample(root, count=len(JSON_BREAKAGES) + 1, width=W, height=H, seed=4)
    expected = {ident.key: (name, f"{apply(root, ident)}: {text}")
                for ident, (name, (apply, text)) in zip(ids, JSON_BREAKAGES.items())}
    out = tmp_path / "out"
    assert main(["batch", str(box_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 1
    reasons = failures(out)
    assert len(reasons) == len(JSON_BREAKAGES)
    for key, (name, text) in expected.items():
        assert text in reasons[key] and "internal error" not in reasons[key], (name, reasons[key])


@pytest.mark.parametrize("text, says", [
    ('{"a": 1, "b": {"c": 2, "c": 3}}', "gives the key 'c' twice in the object at 'b'"),
    ('{"a": [' + "1" * 5000 + "]}", "holds an integer of more than 4300 digits"),
    ("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1), "is nested more than 64 levels deep"),
    ('{"a": [1, -1e400]}', "number at 'a/1' is beyond the range of a 64-bit float"),
])
def test_every_json_input_is_checked_the_same_way(tmp_path, text, says):
    path = tmp_path / "x.json"
    path.write_text(text)
    with pytest.raises(InputError, match=says) as exc:
        read_json(path)
    assert str(exc.value).startswith(f"{path}: ")


def test_json_with_a_byte_order_mark_and_deep_but_allowed_nesting_is_read(tmp_path):
    path = tmp_path / "x.json"
    nested = "[" * (MAX_JSON_DEPTH - 1) + "]" * (MAX_JSON_DEPTH - 1)
    path.write_bytes(b"\xef\xbb\xbf" + f'{{"a": 1e300, "s": "[[[\\"{"[" * 80}", "n": {nested}}}'.encode())
    data = read_json(path)
    assert data["a"] == 1e300 and data["s"].startswith("[[[")


# ---------------------------------------------------------------------------------- models
def _obj(path: Path, text: str) -> str:
    path.write_text(text)
    return str(path)


def _gltf_with_index(path: Path, index: int) -> str:
    import base64

    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, index], np.uint16)
    blob = pos.tobytes() + idx.tobytes()
    path.write_text(json.dumps({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," +
                     base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0],
                       "max": [1, 1, 1]}, {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}))
    return str(path)


def _truncated_texture(folder: Path) -> str:
    src = ASSETS / "kenney_vehicles"
    (folder / "Textures").mkdir(parents=True)
    shutil.copy(src / "vehicle-truck-red.glb", folder)
    (folder / "Textures" / "colormap.png").write_bytes((src / "Textures" / "colormap.png").read_bytes()[:300])
    return str(folder / "vehicle-truck-red.glb")


@pytest.mark.parametrize("make, says", [
    (lambda d: _obj(d / "flat.obj", "v 0 0 0\nv 4 0 0\nv 0 0 2\nv 4 0 2\nf 1 2 3\nf 2 4 3\n"), "is flat: its height is 0"),
    (lambda d: _obj(d / "zero.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 1\nf 1 2 3\nf 1 1 4\n"),
     "has no surface: all its 2 triangles have zero area"),
    (lambda d: _gltf_with_index(d / "indices.gltf", 9), "has a face index 9 out of range: its mesh has 4 vertices"),
    (lambda d: _truncated_texture(d / "truck"), "has a texture that cannot be decoded (image file is truncated"),
    (lambda d: str(d), "is a folder, not a model file"),
])
def test_a_model_nothing_of_which_would_be_seen_is_refused_at_the_start(sample, tmp_path, capsys, make, says):
    from synthcompose.models import load_model

    models = tmp_path / "models"
    models.mkdir()
    model = make(models)
    out = tmp_path / "out"
    manifest = box_manifest(tmp_path / "m.json", sample[0], out, objects=[
        {"model": model, "class": "car", "size": {"length": 4.0}}])
    load_model.cache_clear()
    err = refused(["batch", str(manifest), "--no-progress"], capsys)
    assert f"{model}: {says}" in err
    assert not out.exists()


def test_an_object_with_no_visible_pixel_is_never_written(sample, tmp_path):
    from synthcompose.placement.saved_poses import write_saved

    root, ids = sample
    out = tmp_path / "out"
    far = np.eye(4)
    far[0, 3] = 900.0  # in view, 900 m ahead: smaller than a pixel
    write_saved(out, ids[0], [("box", far)])
    assert main(["batch", str(box_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 1
    assert "has 0 visible pixels once rendered" in failures(out)[ids[0].key]
    assert not any(ids[0].path(out, kind).exists() for kind in OUT_KINDS)
    assert all(ids[1].path(out, kind).exists() for kind in OUT_KINDS)


# -------------------------------------------------------------------------------- manifest
@pytest.mark.parametrize("name", ["sky", "ego vehicle", "unlabeled", "road", "building", "polegroup", "license plate",
                                  "rectification border", "dynamic"])
def test_an_object_class_that_is_not_a_thing_is_refused(tmp_path, name):
    with pytest.raises(ManifestError, match=f"field 'objects/0/class': '{name}' is"):
        load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", objects=[
            {"model": "builtin:box", "class": name, "size": {"length": 4.0}}]))


@pytest.mark.parametrize("name", ["person", "rider", "car", "truck", "bus", "caravan", "trailer", "train",
                                  "motorcycle", "bicycle", "pole", "traffic light", "traffic sign"])
def test_every_thing_class_is_accepted(tmp_path, name):
    load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", objects=[
        {"model": "builtin:box", "class": name, "size": {"length": 4.0}}]))


def test_a_surface_that_is_not_ground_is_refused(tmp_path):
    with pytest.raises(ManifestError, match="field 'objects/0/allowed_surfaces': 'sky' is not a ground"):
        load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", objects=[
            {"model": "builtin:box", "class": "car", "size": {"length": 4.0}, "allowed_surfaces": ["sky"]}]))


@pytest.mark.parametrize("seed", ["-1", "1.5", "true", '"7"', "1e30", "9223372036854775808", "1" + "0" * 400])
def test_seeds_that_are_huge_negative_or_not_whole_are_refused(tmp_path, capsys, seed):
    path = box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", seed=0)
    path.write_text(path.read_text().replace('"seed": 0', f'"seed": {seed}'))
    err = refused(["batch", str(path)], capsys)
    assert str(path) in err
    assert "field 'seed'" in err and "the seed is a whole number from 0 to 2**63 - 1" in err or \
        "number at 'seed' is too large" in err


def test_a_manifest_key_given_twice_is_refused_naming_it(tmp_path, capsys):
    path = box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", seed=1)
    path.write_text(path.read_text().replace('"seed": 1', '"seed": 1, "seed": 2'))
    assert "gives the key 'seed' twice" in refused(["batch", str(path)], capsys)


@pytest.mark.parametrize("field, value", [("yaw_jitter_deg", 1e300), ("clearance", 1e300), ("object_gap", 1e300),
                                          ("parked_kerb_gap", 1e300), ("min_visible_pixels", 0)])
def test_placement_numbers_without_a_bound_before_are_bounded(tmp_path, field, value):
    with pytest.raises(ManifestError, match=f"field 'placement/{field}'"):
        load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", placement={field: value}))


# ---------------------------------------------------------------------------------- workers
def test_worker_counts_are_one_per_core_for_0_and_capped_by_cores_and_memory(monkeypatch):
    import synthcompose.run.engines as engines

    monkeypatch.setattr(engines, "usable_cores", lambda: 4)
    monkeypatch.setattr(engines, "available_memory", lambda: 64 << 30)
    assert engines.worker_count(0) == (4, "--workers 0: one per core, 4")
    assert engines.worker_count(3) == (3, None)
    n, note = engines.worker_count(6)
    assert n == 6 and "more workers than the 4 cores" in note  # they run, sharing the cores
    n, note = engines.worker_count(10**9)
    assert n == 16 and "4 cores, 4 each" in note
    monkeypatch.setattr(engines, "available_memory", lambda: int(2.5 * 2**30))
    n, note = engines.worker_count(4)
    assert n == 2 and "2.5 GiB free" in note
    monkeypatch.setattr(engines, "available_memory", lambda: 1 << 20)
    assert engines.worker_count(4)[0] == 1  # never none


@pytest.mark.slow
def test_a_huge_worker_count_runs_with_what_the_machine_allows(sample, tmp_path, caplog):
    import logging

    from synthcompose.run.engines import worker_count

    root, ids = sample
    out = tmp_path / "out"
    with caplog.at_level(logging.INFO, logger="synthcompose"):
        assert main(["batch", str(box_manifest(tmp_path / "m.json", root, out, frames=[ids[0].name])),
                     "--workers", "100000", "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["workers"] == worker_count(100000)[0] < 100000
    assert "--workers 100000: " in caplog.text


# ---------------------------------------------------------------------------------- stopping
@pytest.mark.slow
@pytest.mark.parametrize("to", ["parent", "group"])
def test_sigterm_with_workers_stops_as_ctrl_c_does_and_the_resume_is_byte_identical(tmp_path, to):
    ids, manifest, out, ref = with_reference_run(tmp_path, box_manifest)
    proc = subprocess.Popen([sys.executable, "-m", "synthcompose", "batch", str(manifest), "--workers", "2",
                             "--no-progress"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(out.rglob("*_synthcompose.json")):
        time.sleep(0.05)  # one set done, others in the works
    (os.killpg if to == "group" else os.kill)(proc.pid, signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err[-2000:]
    assert err.strip().splitlines()[-1] == "synthcompose: interrupted (a rerun resumes where this one stopped)"
    assert "Traceback" not in err
    assert_resume_matches(ids, manifest, out, ref)


# --------------------------------------------------------------------------- saved placements
def _pose(x: float = 15.0, y: float = 0.0, mirror: bool = False) -> list[list]:
    m = np.eye(4)
    m[:3, 3] = (x, y, 0.0)
    if mirror:
        m[1, 1] = -1.0
    return m.tolist()


#: a saved pose that cannot be -> text the image set's failure must hold after the file's name
SAVED = {
    "mirrored": (_pose(mirror=True), "'matrix' mirrors the object (its rotation's determinant is -1)"),
    "behind the camera": (_pose(x=-15.0), "saved placement object 0 ('box') is behind the camera"),
    "outside the view": (_pose(y=300.0), "saved placement object 0 ('box') is outside the camera's view"),
    "numbers as strings": ([[str(v) for v in r] for r in _pose()], "needs a 'name' string and a 4x4 'matrix' of numbers"),
    "a million km away": (_pose(x=1e9), "puts the object 1e+09 m away"),
}


def test_a_saved_pose_that_cannot_be_fails_its_image_set_naming_the_file(tmp_path):
    from synthcompose.placement.saved_poses import FORMAT, placement_path

    root = tmp_path / "cs"
    ids = make_sample(root, count=len(SAVED) + 1, width=W, height=H, seed=3)
    out = tmp_path / "out"
    for ident, (matrix, _) in zip(ids, SAVED.values()):
        path = placement_path(out, ident)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"format": FORMAT, "image_set": ident.key,
                                    "objects": [{"name": "box", "matrix": matrix}]}))
    assert main(["batch", str(box_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 1
    reasons = failures(out)
    assert len(reasons) == len(SAVED)
    for ident, (name, (_, text)) in zip(ids, SAVED.items()):
        assert f"{placement_path(out, ident)}: " in reasons[ident.key] and text in reasons[ident.key], (name, reasons)


# ------------------------------------------------------------------------- make-sample arguments
@pytest.mark.parametrize("size, says", [
    ("0x0", "0x0: the width must be 64 to 8192"), ("abc", "'abc' is not WIDTHxHEIGHT"),
    ("100000x100000", "the width must be 64 to 8192"), ("8192x8192", "more than the 16777216"),
    ("64x32x3", "is not WIDTHxHEIGHT"), ("-64x32", "is not WIDTHxHEIGHT"), ("2048x", "is not WIDTHxHEIGHT"),
])
def test_make_sample_sizes_that_cannot_be_are_usage_errors(tmp_path, capsys, size, says):
    with pytest.raises(SystemExit) as exc:
        main(["make-sample", str(tmp_path / "s"), f"--size={size}"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --size: " in err and says in err
    assert not (tmp_path / "s").exists()


# ------------------------------------------------------------------------------ beyond the list
def test_an_output_root_that_is_a_file_is_refused(sample, tmp_path, capsys):
    (tmp_path / "out").write_text("a file")
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", sample[0], tmp_path / "out"))], capsys)
    assert "output root is a file, not a folder" in err


def test_a_read_only_output_root_is_refused_before_any_work(sample, tmp_path, capsys, monkeypatch):
    import errno

    import synthcompose.run.batch as batch

    real = batch.os.open

    def read_only(path, *args, **kwargs):
        if str(path).endswith(batch.LOCK_NAME):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch.os, "open", read_only)
    err = refused(["batch", str(box_manifest(tmp_path / "m.json", sample[0], tmp_path / "out"))], capsys)
    assert "output root is not writable (Read-only file system)" in err


def test_a_frame_whose_instance_ids_are_all_taken_is_named(tmp_path):
    import cv2

    root = tmp_path / "cs"
    ident = make_sample(root, count=1, width=W, height=H, seed=2)[0]
    path = ident.path(root, "instanceIds")
    ids = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    ids[0, 0] = 26999  # car number 999: the last a frame may have
    cv2.imwrite(str(path), ids)
    out = tmp_path / "out"
    assert main(["batch", str(box_manifest(tmp_path / "m.json", root, out)), "--no-progress"]) == 1
    assert failures(out)[ident.key].startswith(f"{path}: holds instance 26999 of class 26 already")


def test_an_object_smaller_than_a_centimetre_is_refused(tmp_path):
    with pytest.raises(ManifestError, match="field 'objects/0/size/length'"):
        load_manifest(box_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", objects=[
            {"model": "builtin:box", "class": "car", "size": {"length": 1e-9}}]))
