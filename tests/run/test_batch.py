"""End to end: `synthcompose batch` over generated image sets, and bad input in a batch."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.io.dataset import ImageSetId, read_image_set
from synthcompose.labels import HAS_INSTANCES, INSTANCE_FACTOR
from synthcompose.stages.place import stands_like
from synthcompose.synthetic import make_sample

from ..helpers import OUT_KINDS, H, W, write_manifest
from ..tolerances import OBJECT_PIXELS_CHANGED_MIN, PHOTO_CHANGE_COLS_PX, PHOTO_CHANGE_ROWS_PX


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> tuple[Path, list[ImageSetId]]:
    root = tmp_path_factory.mktemp("cityscapes")
    return root, make_sample(root, count=3, width=W, height=H, seed=1)


@pytest.fixture(scope="module")
def batch(dataset, tmp_path_factory):
    root, ids = dataset
    work = tmp_path_factory.mktemp("batch")
    code = main(["batch", str(write_manifest(work / "m.json", root, work / "out")), "--no-progress"])
    return work / "out", code


def test_every_output_file_in_cityscapes_layout(batch, dataset):
    out, code = batch
    root, ids = dataset
    assert code == 0
    for ident in ids:
        for kind in OUT_KINDS:
            assert ident.path(out, kind).is_file(), (ident, kind)
        result = read_image_set(out, ident)  # loads with the same checks as an input set
        assert result.size == (W, H)
        color = cv2.imread(str(ident.path(out, "color")), cv2.IMREAD_UNCHANGED)
        assert color.shape == (H, W, 4)
        assert ident.path(out, "camera").read_bytes() == ident.path(root, "camera").read_bytes()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["done"] == len(ids) and summary["failed"] == 0


def test_labels_instances_and_disparity_change_exactly_on_the_objects(batch, dataset):
    out, _ = batch
    root, ids = dataset
    for ident in ids:
        src, res = read_image_set(root, ident), read_image_set(out, ident)
        record = json.loads(ident.path(out, "record").read_text())
        assert record["status"] == "done" and record["objects"]
        union = np.zeros((H, W), bool)
        new_ids = []
        for obj in record["objects"]:
            cls, inst = obj["label_id"], obj["instance_id"]
            new_ids.append(inst)
            mask = (res.instance_ids == inst) & (src.instance_ids != inst)
            # classes without instances share their plain id: compare with all objects of it
            same = [o for o in record["objects"] if o["instance_id"] == inst]
            assert mask.sum() == sum(o["visible_pixels"] for o in same) > 0
            assert (res.label_ids[mask] == cls).all()
            if len(same) == 1:
                ys, xs = np.nonzero(mask)
                assert obj["bbox_2d"] == [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]
            # instance ids: class*1000+k above the frame's own instances of that class
            if HAS_INSTANCES[cls]:
                assert inst // INSTANCE_FACTOR == cls
                existing = src.instance_ids[src.instance_ids // INSTANCE_FACTOR == cls]
                assert inst > (existing.max() if existing.size else -1)
            else:
                assert inst == cls
            # the object is in front where it is seen: larger disparity than the scene had
            assert (res.disparity[mask] >= src.disparity[mask]).all() or (src.disparity[mask] == 0).any()
            union |= mask
        instance_ids = [i for i in new_ids if i >= INSTANCE_FACTOR]
        assert len(set(instance_ids)) == len(instance_ids)
        assert (res.label_ids[~union] == src.label_ids[~union]).all()
        assert (res.instance_ids[~union] == src.instance_ids[~union]).all()
        assert (res.disparity[~union] == src.disparity[~union]).all()
        # the photo changes around the objects (object + shadow) and nowhere far from them
        changed = np.any(res.rgb != src.rgb, axis=2)
        assert changed[union].mean() > OBJECT_PIXELS_CHANGED_MIN
        ys, xs = np.nonzero(union)
        far = np.ones((H, W), bool)
        dr, dc = PHOTO_CHANGE_ROWS_PX, PHOTO_CHANGE_COLS_PX
        far[max(ys.min() - dr, 0): ys.max() + dr, max(xs.min() - dc, 0): xs.max() + dc] = False
        assert not changed[far].any()


def test_same_seed_gives_byte_identical_outputs(batch, dataset, tmp_path):
    out, _ = batch
    root, ids = dataset
    again = tmp_path / "again"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, again)), "--no-progress"]) == 0
    for ident in ids:
        for kind in OUT_KINDS:
            assert ident.path(out, kind).read_bytes() == ident.path(again, kind).read_bytes(), (ident, kind)


def test_other_seed_gives_other_placements(batch, dataset, tmp_path):
    out, _ = batch
    root, ids = dataset
    other = tmp_path / "other"
    main(["batch", str(write_manifest(tmp_path / "m.json", root, other, seed=6)), "--no-progress"])
    assert any(ident.path(out, "rgb").read_bytes() != ident.path(other, "rgb").read_bytes() for ident in ids)


def test_no_road_anywhere_is_reported_not_crashed(dataset, tmp_path):
    root, ids = dataset
    manifest = write_manifest(tmp_path / "m.json", root, tmp_path / "out",
                              objects=[{"model": "builtin:box", "class": "car", "size": {"length": 4.0},
                                        "allowed_surfaces": ["terrain"]}])
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["skipped"] == len(ids) and summary["done"] == 0
    assert all("no valid placement" in p["reason"] for p in summary["problems"])
    record = json.loads(ids[0].path(tmp_path / "out", "record").read_text())
    assert record["status"] == "no valid placement" and record["not_placed"]
    assert not ids[0].path(tmp_path / "out", "rgb").exists()
    # the photo's light is not measured where nothing was placed (the lighting stage never runs)
    from synthcompose.manifest import load_manifest
    from synthcompose.run.pipeline import Pipeline
    with Pipeline(load_manifest(manifest)) as pipe:
        outcome = pipe.process(ids[0])
    assert outcome.status == "skipped" and "placement" in outcome.timings and "lighting" not in outcome.timings


def _break(root: Path, ident: ImageSetId, how: str) -> str:
    """Damage one image set; returns text the error must contain."""
    if how == "missing":
        ident.path(root, "disparity").unlink()
        return f"{ident.path(root, 'disparity')}: file is missing"
    if how == "corrupt":
        p = ident.path(root, "rgb")
        p.write_bytes(p.read_bytes()[:200])
        return f"{p}: PNG data is corrupt or truncated"
    if how == "size":
        p = ident.path(root, "labelIds")
        cv2.imwrite(str(p), np.zeros((H // 2, W // 2), np.uint8))
        return f"{p}: image is {W // 2}x{H // 2} but"
    if how == "no-fx":
        p = ident.path(root, "camera")
        cam = json.loads(p.read_text())
        del cam["intrinsic"]["fx"]
        p.write_text(json.dumps(cam))
        return f"{p}: camera JSON 'intrinsic' has no 'fx'"
    raise ValueError(how)


def test_bad_image_sets_are_reported_and_the_rest_completes(tmp_path, capsys):
    root = tmp_path / "cs"
    ids = make_sample(root, count=5, width=W, height=H, seed=2)
    expected = {ids[i].key: _break(root, ids[i], how) for i, how in enumerate(["missing", "corrupt", "size", "no-fx"])}
    out = tmp_path / "out"
    code = main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"])
    assert code != 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed"] == 4 and summary["done"] == 1
    reasons = {p["image_set"]: p["reason"] for p in summary["problems"]}
    for key, text in expected.items():
        assert text in reasons[key]
        assert text in printed
    for ident in ids[:4]:
        assert not any(ident.path(out, k).exists() for k in OUT_KINDS)
    assert all(ids[4].path(out, k).is_file() for k in OUT_KINDS)
    assert not list(out.rglob("*.part"))


@pytest.mark.parametrize("change, field", [
    ({"seed": "x"}, "seed"),
    ({"objects": []}, "objects"),
    ({"colour": 1}, "colour"),
    ({"objects": [{"model": "m.glb", "class": "spaceship", "size": {"length": 1}}]}, "objects/0/class"),
])
def test_bad_manifest_names_the_field(tmp_path, capsys, change, field):
    manifest = write_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", **change)
    assert main(["batch", str(manifest)]) == 2
    err = capsys.readouterr().err
    assert str(manifest) in err and field in err


@pytest.mark.slow
def test_stream_overlapping_reads_and_writes_matches_one_at_a_time(tmp_path, monkeypatch):
    """Pipeline.stream (read ahead, write behind, on threads) gives the outcomes in order and
    the same bytes as processing each image set alone; a read failure and a write failure
    fail only their own image set. While it streams, OpenCV's own functions run on one thread
    and the PNG codec on the threads OpenCV had; both are restored after."""
    from threadpoolctl import threadpool_info

    from synthcompose.io.files import codec_thread_count
    from synthcompose.manifest import load_manifest
    from synthcompose.run.pipeline import Pipeline
    from synthcompose.stages import write as write_stage

    root = tmp_path / "cs"
    ids = make_sample(root, count=4, width=W, height=H, seed=9)
    _break(root, ids[1], "missing")
    outs, blas, opencv = {}, [], []

    def begin(ident) -> None:  # NumPy's BLAS and OpenCV on one thread while streaming, the codec on 3
        blas.extend(pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas")
        opencv.append((cv2.getNumThreads(), codec_thread_count()))

    threads = cv2.getNumThreads()
    cv2.setNumThreads(3)
    try:
        for way in ("alone", "stream"):
            manifest = load_manifest(write_manifest(tmp_path / f"{way}.json", root, tmp_path / way))
            with Pipeline(manifest) as pipe:
                outs[way] = [pipe.process(i) for i in ids] if way == "alone" else list(pipe.stream(ids, on_begin=begin))
        assert (cv2.getNumThreads(), codec_thread_count()) == (3, 3)
    finally:
        cv2.setNumThreads(threads)
    assert blas and set(blas) == {1}
    assert opencv and set(opencv) == {(1, 3)}
    assert [o.key for o in outs["stream"]] == [i.key for i in ids]
    assert [o.status for o in outs["stream"]] == [o.status for o in outs["alone"]]
    assert outs["stream"][1].status == "failed" and "file is missing" in outs["stream"][1].reason
    assert all(o.status in ("done", "skipped") for k, o in enumerate(outs["stream"]) if k != 1)
    for ident in ids[2:] + ids[:1]:
        for kind in OUT_KINDS:
            alone, streamed = ident.path(tmp_path / "alone", kind), ident.path(tmp_path / "stream", kind)
            if kind == "record":
                a, b = json.loads(alone.read_text()), json.loads(streamed.read_text())
                assert a["objects"] == b["objects"] and a["lighting"] == b["lighting"]
            else:
                assert alone.read_bytes() == streamed.read_bytes(), (ident.key, kind)
        assert set(outs["stream"][ids.index(ident)].timings) >= {"read", "geometry", "write"}

    # a write that fails (on the writer thread) fails that image set alone
    real = write_stage.write_outputs

    def full_disk(out_root, ident, *args):
        if ident.key == ids[2].key:
            raise OSError(28, "No space left on device")
        return real(out_root, ident, *args)

    monkeypatch.setattr(write_stage, "write_outputs", full_disk)
    manifest = load_manifest(write_manifest(tmp_path / "w.json", root, tmp_path / "w"))
    with Pipeline(manifest) as pipe:
        got = list(pipe.stream(ids))
    assert [o.key for o in got] == [i.key for i in ids]
    assert got[2].status == "failed" and "No space left" in got[2].reason
    assert not ids[2].path(tmp_path / "w", "record").exists()
    assert ids[3].path(tmp_path / "w", "record").is_file() and ids[0].path(tmp_path / "w", "record").is_file()


def _sign_or(car: dict) -> list[dict]:
    """A manifest's objects: ``car``, drawn for nearly every slot, and a sign at the kerb."""
    return [car | {"name": "car", "model": "builtin:box", "class": "car", "weight": 1e6},
            {"name": "sign", "model": "builtin:traffic-sign", "class": "traffic sign", "size": {"height": 2.5},
             "orientation": "face-camera", "weight": 1e-3}]


def test_an_object_without_a_place_is_replaced_by_one_that_stands_elsewhere(dataset, tmp_path):
    """A car 60 m long fits no lane: drawn for every slot, each is replaced by a sign, which
    stands at the kerb, and the record says which it replaced."""
    root, ids = dataset
    out = tmp_path / "out"
    manifest = write_manifest(tmp_path / "m.json", root, out, objects=_sign_or({"size": {"length": 60.0}}))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    signs = 0
    for ident in ids:
        record = json.loads(ident.path(out, "record").read_text())
        missed = record["not_placed"]
        assert [m["class"] for m in missed] == ["car", "car"]  # both slots drew the car
        assert all(o["class"] == "traffic sign" for o in record["objects"])
        assert sum(m.get("replaced_by") == "sign" for m in missed) == len(record["objects"])
        assert "not_drawn" not in record  # the car had road to try
        signs += len(record["objects"])
    assert signs >= len(ids)  # the frames have footway for a sign


def test_an_object_whose_ground_the_frame_lacks_is_not_drawn(dataset, tmp_path):
    """A car allowed only on grass, where the generated frames have none, could stand nowhere:
    it is not drawn (the record says why) and the slots get signs. With ``redraw_unplaced``
    false (each object as drawn) it is drawn for both slots, which stay empty."""
    root, ids = dataset
    objects = _sign_or({"size": {"length": 4.0}, "allowed_surfaces": ["terrain"]})
    out = tmp_path / "out"
    assert main(["batch", str(write_manifest(tmp_path / "m.json", root, out, objects=objects)), "--no-progress"]) == 0
    for ident in ids:
        record = json.loads(ident.path(out, "record").read_text())
        assert list(record["not_drawn"]) == ["car"]
        assert record["not_drawn"]["car"].startswith("no terrain pixel with valid depth within")
        assert all(m["class"] == "traffic sign" for m in record["not_placed"])
        assert record["objects"] and all(o["class"] == "traffic sign" for o in record["objects"])
    none = tmp_path / "none"
    manifest = write_manifest(tmp_path / "n.json", root, none, objects=objects, redraw_unplaced=False)
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    for ident in ids:
        record = json.loads(ident.path(none, "record").read_text())
        assert record["objects"] == [] and [m["class"] for m in record["not_placed"]] == ["car", "car"]
        assert "not_drawn" not in record


def test_a_car_may_stand_in_for_a_bus_that_found_no_lane_not_the_other_way():
    """The redraw's rule: a substitute must need something else than what failed; a car needs
    less road than a bus or a lorry, so it may replace one; a bus may not replace a car, nor a
    person a person."""
    assert not stands_like("car", "bus") and not stands_like("car", "truck")
    assert stands_like("bus", "car") and stands_like("car", "car") and stands_like("truck", "bus")
    assert stands_like("person", "person") and not stands_like("person", "car")
    assert not stands_like("traffic sign", "person")
