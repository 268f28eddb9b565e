"""The cast: the catalogue, the manifest's pools and built-in street cast, the per-object draws,
the people's posing hook, the German traffic signs and their labels (docs/cast.md)."""
from __future__ import annotations

import json
import shutil
import sys
import types
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from cityscapesscripts.helpers.annotation import Annotation
from cityscapesscripts.preparation.json2labelImg import createLabelImage

from synthcompose.cast import (
    CAST_PREFIX,
    STREET,
    cast_model,
    cast_rng,
    cast_root,
    draw_entry,
    load_catalogue,
    mounted_higher,
    posed_person,
)
from synthcompose.cli import main
from synthcompose.errors import ManifestError, ModelError
from synthcompose.io.dataset import read_image_set
from synthcompose.io.files import decode_rle
from synthcompose.labels import label_id
from synthcompose.manifest import load_manifest, parse_manifest
from synthcompose.models import load_model
from synthcompose.models.signs import POLE_RADIUS, Plate, sign_model
from synthcompose.synthetic import make_sample

from ..tolerances import LABELS_DRAWN_BACK

REPO = Path(__file__).resolve().parents[2]
W, H = 640, 320


def manifest_data(tmp_path: Path, **extra) -> dict:
    return {"dataset": str(tmp_path / "cs"), "output": str(tmp_path / "out"), **extra}


# ------------------------------------------------------------------ the catalogue
def test_the_installed_catalogue_is_valid_and_its_signs_are_german():
    cat = load_catalogue()
    assert cat.root == cast_root() and cat.entries
    assert len({e.id for e in cat.entries}) == len(cat.entries)
    for e in cat.entries:
        assert (e.folder / "entry.json").is_file() and e.folder.name == e.id
        assert any(e.folder.glob("LICENSE*")) and (e.folder / "SOURCE.txt").is_file(), e.id
        if e.sign is None:
            assert Path(e.model).is_file() and e.size is not None
    signs = cat.pool("traffic sign")
    assert len({e.kind for e in signs}) >= 10 and all(e.kind.startswith("de-") for e in signs)
    for e in signs:  # VwV-StVO size 2: round 600 mm (a bus stop 450), triangles 900 a side, stop 900
        assert 0.44 <= e.sign.width_m <= 0.9 and e.sign.lower_edge_m[0] >= 2.0
    assert cat.get("de-206").sign.width_m == pytest.approx(0.9)
    assert cat.get("de-274-30").sign.width_m == pytest.approx(0.6)


def _tmp_root(tmp_path: Path, *entries: str) -> Path:
    root = tmp_path / "cast"
    for entry in entries:
        group = "signs" if entry.startswith("de-") else "vehicles"
        shutil.copytree(cast_root() / group / entry, root / group / entry)
    return root


def test_a_bad_entry_is_an_error_naming_its_file(tmp_path):
    root = _tmp_root(tmp_path, "de-206")
    path = root / "signs" / "de-206" / "entry.json"
    entry = json.loads(path.read_text())
    for bad, says in [({"weight": -1}, "field 'weight'"), ({"class": "tree-ish"}, "field 'class'"),
                      ({"id": "other"}, "must be the name of its folder"),
                      ({"model": "missing.glb"}, "'size' is a required property"),
                      ({"sign": entry["sign"] | {"face": "nope.png"}}, "field 'sign/face'"),
                      ({"sign": entry["sign"] | {"below": [{"id": "de-999", "p": 0.5}]}}, "field 'sign/below'")]:
        path.write_text(json.dumps(entry | bad))
        load_catalogue.cache_clear()
        with pytest.raises(ModelError, match=says) as err:
            load_catalogue(root)
        assert str(path) in str(err.value)
    load_catalogue.cache_clear()


# ------------------------------------------------------------------ the manifest
def test_the_street_cast_stands_for_its_pools_and_objects_add_to_it(tmp_path):
    m = parse_manifest(manifest_data(tmp_path, cast="street"), tmp_path / "m.json")
    cat = load_catalogue()
    assert [o.name for o in m.objects] == [n for n, sel, _ in STREET if cat.pool(sel)]
    for o in m.objects:
        assert o.model.startswith(CAST_PREFIX) and o.cast and o.size == ()
        assert {e.class_name for e in o.cast} == {o.class_name}
    sign = next(o for o in m.objects if o.class_name == "traffic sign")
    assert sign.allowed_surfaces == ("sidewalk", "terrain") and sign.orientation == "facing-traffic"  # traffic sense
    more = parse_manifest(manifest_data(tmp_path, cast="street", objects=[
        {"model": "cast:de-206", "weight": 5, "size": {"height": 3.0}},
        {"model": "builtin:box", "class": "car", "size": {"length": 4.0}}]), tmp_path / "m.json")
    assert len(more.objects) == len(m.objects) + 2
    stop = more.objects[-2]
    assert stop.class_name == "traffic sign" and stop.size == (("height", 3.0),) and stop.weight == 5
    demo = load_manifest(REPO / "assets" / "demo" / "manifest.json")
    assert demo.raw["cast"] == "street" and "objects" not in demo.raw and demo.objects


@pytest.mark.parametrize("objects, says", [
    ([{"model": "cast:unicorn"}], "no cast entry matches 'unicorn'"),
    ([{"model": "cast:traffic sign", "class": "car"}], "field 'objects/0/class'"),
    ([{"model": "builtin:box", "class": "car"}], "'size' is a required property"),
])
def test_a_bad_pool_is_an_error_naming_the_field(tmp_path, objects, says):
    with pytest.raises(ManifestError, match=says):
        parse_manifest(manifest_data(tmp_path, objects=objects), tmp_path / "m.json")
    with pytest.raises(ManifestError, match="objects|cast"):  # neither objects nor a cast
        parse_manifest(manifest_data(tmp_path), tmp_path / "m.json")


def test_the_config_hash_follows_the_cast_files(tmp_path, monkeypatch):
    root = _tmp_root(tmp_path, "de-206")
    monkeypatch.setattr("synthcompose.cast.catalogue.cast_root", lambda: root)
    load_catalogue.cache_clear()
    try:
        data = manifest_data(tmp_path, objects=[{"model": "cast:traffic sign"}])
        before = parse_manifest(data, tmp_path / "m.json").config_hash
        assert parse_manifest(data, tmp_path / "m.json").config_hash == before
        face = root / "signs" / "de-206" / "face.png"
        face.write_bytes(face.read_bytes() + b"\0")
        assert parse_manifest(data, tmp_path / "m.json").config_hash != before
    finally:
        load_catalogue.cache_clear()


# ------------------------------------------------------------------ the draws
def test_draws_depend_on_seed_image_set_and_index_only():
    signs = load_catalogue().pool("traffic sign")
    first = [draw_entry(signs, cast_rng(3, "train/a/a_000000_000001", k)).id for k in range(40)]
    assert first == [draw_entry(signs, cast_rng(3, "train/a/a_000000_000001", k)).id for k in range(40)]
    assert len(set(first)) >= 10  # the index varies the draw
    assert first != [draw_entry(signs, cast_rng(4, "train/a/a_000000_000001", k)).id for k in range(40)]
    # the share of each entry follows its weight
    n = 4000
    counts = {}
    for k in range(n):
        e = draw_entry(signs, cast_rng(0, "x", k))
        counts[e.id] = counts.get(e.id, 0) + 1
    total = sum(e.weight for e in signs)
    for e in signs:
        assert abs(counts.get(e.id, 0) / n - e.weight / total) < 0.02


def test_a_person_is_posed_by_the_skinning_hook_when_it_is_there(monkeypatch):
    person = next(e for e in load_catalogue().entries if e.group == "people")
    mannequin = replace(person, rig=None)  # an entry without a rig: loaded as saved
    box = load_model("builtin:box", (("height", 1.7),))
    calls = []

    def posed_model(path, size, up, forward, rng, pose=None):
        calls.append((path, size, up, forward, pose, float(rng.random())))
        return box, {"pose": "walking", "phase": 0.25}

    fake = types.ModuleType("synthcompose.models.skinning")
    fake.posed_model = posed_model
    monkeypatch.setitem(sys.modules, "synthcompose.models.skinning", fake)
    rigged = replace(mannequin, rig="makehuman-default")
    model, pose = posed_person(rigged, rigged.size, np.random.default_rng(1))
    assert model is box and pose == {"pose": "walking", "phase": 0.25}
    assert calls[0][:5] == (rigged.model, rigged.size, rigged.up, rigged.forward, None)
    _, drawn = cast_model(rigged, None, np.random.default_rng(2))
    assert drawn.appearance == {"model": rigged.id, "body": rigged.body_dict, "pose": {"pose": "walking", "phase": 0.25}}
    # an entry without a rig, or no skinning module: the file as saved, its rest pose
    model, pose = posed_person(mannequin, mannequin.size, np.random.default_rng(1))
    assert pose == {"pose": "rest"} and model.extents[2] == pytest.approx(mannequin.size[0][1], rel=1e-4)
    monkeypatch.setitem(sys.modules, "synthcompose.models.skinning", None)  # import fails
    assert posed_person(rigged, rigged.size, np.random.default_rng(1))[1] == {"pose": "rest"}


# ------------------------------------------------------------------ the signs
def test_a_sign_stands_at_its_real_size_and_height_with_its_pole_labelled():
    cat = load_catalogue()
    main_sign, below = cat.get("de-267").sign, cat.get("de-1022-10").sign
    plates = (Plate("de-267", main_sign.face, main_sign.width_m, main_sign.height_m),
              Plate("de-1022-10", below.face, below.width_m, below.height_m))
    model = sign_model(plates, 2.2)
    faces = [p for p in model.parts if p.texture is not None]
    assert len(faces) == 2
    top, low = faces
    for face, plate in zip(faces, plates):
        ext = face.positions.max(0) - face.positions.min(0)
        assert ext[1] == pytest.approx(plate.width_m, abs=0.01) and ext[2] == pytest.approx(plate.height_m, abs=0.01)
        assert np.allclose(face.normals, [1, 0, 0])  # the face looks along +x
    assert low.positions[:, 2].min() == pytest.approx(2.2, abs=1e-4)  # the lowest plate's lower edge
    assert top.positions[:, 2].min() > low.positions[:, 2].max()
    poles = [p for p in model.parts if p.label == "pole"]
    assert poles and all(p.label in (None, "pole") for p in model.parts)
    pole = max(poles, key=lambda p: np.ptp(p.positions[:, 2]))
    assert pole.positions[:, 2].min() == pytest.approx(0.0, abs=1e-5)
    assert np.ptp(pole.positions[:, 1]) == pytest.approx(2 * POLE_RADIUS, rel=0.02)
    assert pole.positions[:, 0].max() < top.positions[:, 0].min()  # behind the plates
    # the round plate's outline: a circle of the plate's diameter
    centre = np.array([top.positions[:, 1].mean(), (top.positions[:, 2].max() + top.positions[:, 2].min()) / 2])
    r = np.linalg.norm(top.positions[:, 1:] - centre, axis=1)
    assert r.max() == pytest.approx(0.3, abs=0.006) and r.min() > 0.29


def test_a_sign_mounted_lowest_is_the_same_draw_with_its_least_lower_edge_and_nothing_under_it():
    signs = load_catalogue().pool("traffic sign")
    seen_below = seen_high = 0
    for k in range(60):
        entry = draw_entry(signs, cast_rng(5, "x", k))
        model, drawn = cast_model(entry, None, cast_rng(5, "x", k))
        low_model, low = cast_model(entry, None, cast_rng(5, "x", k), lowest=True)
        sign, lowest = drawn.appearance["sign"], low.appearance["sign"]
        assert lowest["code"] == sign["code"] and lowest["below"] == []
        assert lowest["lower_edge_m"] == min(entry.sign.lower_edge_m) <= sign["lower_edge_m"]
        assert not mounted_higher(low)
        higher = bool(sign["below"]) or sign["lower_edge_m"] > lowest["lower_edge_m"]
        assert mounted_higher(drawn) == higher
        if higher:  # lower by what was under it and the difference of the edges
            drop = sign["lower_edge_m"] - lowest["lower_edge_m"]
            assert model.extents[2] - low_model.extents[2] >= drop - 1e-6
            assert low_model.extents[2] < model.extents[2]
        seen_below += bool(sign["below"])
        seen_high += higher
    assert seen_below and seen_high < 60  # both kinds of draw were tried
    assert not mounted_higher(None)


def test_a_sign_too_tall_for_the_view_is_placed_again_mounted_lowest(tmp_path, monkeypatch):
    """The place stage's retry: a sign drawn higher than its lowest mounting that finds no place
    is placed again mounted lowest, and the record says what was drawn first; a sign drawn
    lowest is not tried twice. (The view here admits no sign taller than the lowest mounting.)"""
    import importlib

    from synthcompose.stages.options import StageOptions
    from synthcompose.stages.prepare import prepare
    from synthcompose.stages.timing import Timings

    stage = importlib.import_module("synthcompose.stages.place")  # the module, not the function
    ids = make_sample(tmp_path / "cs", count=1, width=W, height=H, seed=3)
    real, calls = stage.place_object, []

    def lowest_only(frame, class_name, extents, *args, **kw):
        calls.append(extents[2])
        result = real(frame, class_name, extents, *args, **kw)
        if class_name == "traffic sign" and extents[2] > limit + 1e-6:  # too tall for this view
            return stage.PlacementResult(None, 200, {"not fully inside the image": 200})
        return result

    monkeypatch.setattr(stage, "place_object", lowest_only)
    for seed in range(40):
        m = parse_manifest(manifest_data(tmp_path, seed=seed, objects_per_image=1,
                                         objects=[{"model": "cast:traffic sign"}]), tmp_path / "m.json")
        o = StageOptions.of(m).place
        low, drawn, _ = stage.object_model(seed, o.objects[0], ids[0].key, 0)
        limit = stage.object_model(seed, o.objects[0], ids[0].key, 0, lowest=True)[0].extents[2]
        if not mounted_higher(drawn):
            continue
        calls.clear()
        prep = prepare(StageOptions.of(m).read, ids[0], Timings())
        done = stage._place_one(o, prep, o.objects[0], [], set())
        if isinstance(done, stage.NotPlaced):
            continue  # no footway for any sign in this draw's view: tried with both mountings
        assert calls == [pytest.approx(low.extents[2]), pytest.approx(limit)]
        assert done.model.extents[2] == pytest.approx(limit)
        sign = done.cast.appearance["sign"]
        first = drawn.appearance["sign"]
        assert sign["lowered_from"] == {"below": first["below"], "lower_edge_m": first["lower_edge_m"]}
        assert sign["below"] == [] and sign["code"] == first["code"]
        break
    else:
        pytest.fail("no seed drew a sign mounted higher that the lowest mounting placed")
    # a sign drawn at its lowest is tried once; so is an object that is not a sign
    monkeypatch.setattr(stage, "place_object", lambda *a, **k: calls.append(a[2][2]) or
                        stage.PlacementResult(None, 200, {"footprint hidden": 200}))
    for seed in range(40):
        m = parse_manifest(manifest_data(tmp_path, seed=seed, objects_per_image=1,
                                         objects=[{"model": "cast:traffic sign"}]), tmp_path / "m.json")
        o = StageOptions.of(m).place
        if not mounted_higher(stage.object_model(seed, o.objects[0], ids[0].key, 0)[1]):
            calls.clear()
            done = stage._place_one(o, prepare(StageOptions.of(m).read, ids[0], Timings()), o.objects[0], [], set())
            assert isinstance(done, stage.NotPlaced) and len(calls) == 1 and done.attempts == 200
            break
    else:
        pytest.fail("no seed drew a sign at its lowest mounting")


@pytest.fixture(scope="module")
def sign_batch(tmp_path_factory):
    work = tmp_path_factory.mktemp("signs")
    ids = make_sample(work / "cs", count=2, width=W, height=H, seed=4)
    path = work / "m.json"
    path.write_text(json.dumps({"dataset": str(work / "cs"), "output": str(work / "out"), "seed": 2,
                                "objects_per_image": 2, "objects": [{"model": "cast:traffic sign"}]}))
    assert main(["batch", str(path), "--no-progress"]) == 0
    return work, ids


def test_a_signs_plate_is_labelled_traffic_sign_and_its_pole_pole(sign_batch):
    work, ids = sign_batch
    seen = 0
    for ident in ids:
        record = json.loads(ident.path(work / "out", "record").read_text())
        src, res = read_image_set(work / "cs", ident), read_image_set(work / "out", ident)
        new = res.label_ids != src.label_ids
        for obj in record["objects"]:
            assert obj["model"] == CAST_PREFIX + obj["appearance"]["model"]
            assert obj["appearance"]["sign"]["code"] == obj["appearance"]["model"]
            mask = decode_rle(obj["mask_rle"])
            assert (res.label_ids[mask] == label_id("traffic sign")).all()
            seen += int(mask.sum())
        assert ((res.label_ids == label_id("pole")) & new).sum() > 0  # the poles' pixels
        ann = Annotation()
        ann.fromJsonFile(str(ident.path(work / "out", "polygons")))
        assert (np.array(createLabelImage(ann, "ids")) == res.label_ids).mean() >= LABELS_DRAWN_BACK
    assert seen > 0
