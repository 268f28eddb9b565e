"""Models load from every supported format, at the size the manifest asks for."""
from pathlib import Path

import numpy as np
import pytest
import trimesh

from synthcompose.errors import ModelError
from synthcompose.models import load_model

from ..tolerances import FBX_SIZE_REL, MODEL_CENTRED_M, MODEL_NORMAL_UNIT, MODEL_ON_GROUND_M, MODEL_SIZE_REL

ASSETS = Path(__file__).resolve().parents[2] / "assets" / "models"


def _check(model, dim, value):
    axis = {"length": 0, "width": 1, "height": 2}[dim]
    assert model.extents[axis] == pytest.approx(value, rel=MODEL_SIZE_REL)
    pos = np.concatenate([p.positions for p in model.parts])
    assert pos[:, 2].min() == pytest.approx(0.0, abs=MODEL_ON_GROUND_M)  # stands on z = 0
    assert abs(pos[:, 0].max() + pos[:, 0].min()) < MODEL_CENTRED_M  # centred in x
    assert abs(pos[:, 1].max() + pos[:, 1].min()) < MODEL_CENTRED_M  # centred in y
    for p in model.parts:
        assert np.allclose(np.linalg.norm(p.normals, axis=1), 1.0, atol=MODEL_NORMAL_UNIT)
        assert p.indices.max() < len(p.positions)


def test_gltf_car_is_long_along_x_and_scaled():
    car = load_model(str(ASSETS / "openmaterial_car" / "vehicle_example.gltf"), (("length", 4.5),), "+y", "+x")
    _check(car, "length", 4.5)
    length, width, height = car.extents
    assert length > width > 1.5 and 1.2 < height < 1.8
    # its licence-plate texture ("License_Plate") is not drawn: each car's own plate is (test_plates.py)
    assert all(p.texture is None for p in car.parts)


def test_gltf_person_is_upright():
    person = load_model(str(ASSETS / "openmaterial_human" / "human_example.gltf"), (("height", 1.75),), "+y", "+x")
    _check(person, "height", 1.75)
    assert person.extents[2] > person.extents[0]


def test_glb_truck_with_texture_atlas():
    truck = load_model(str(ASSETS / "kenney_vehicles" / "vehicle-truck-red.glb"), (("length", 6.0),), "+y", "+z")
    _check(truck, "length", 6.0)
    assert any(p.texture is not None for p in truck.parts)


def test_builtin_traffic_sign_has_a_pole():
    sign = load_model("builtin:traffic-sign", (("height", 2.5),), "+z", "+x")
    _check(sign, "height", 2.5)
    assert len(sign.parts) == 3  # pole, red plate, white face


def test_obj_and_stl(tmp_path):
    box = trimesh.creation.box(extents=(3.0, 1.0, 2.0))
    for suffix in (".obj", ".stl"):
        path = tmp_path / f"box{suffix}"
        box.export(path)
        m = load_model(str(path), (("width", 0.5),), "+z", "+x")
        _check(m, "width", 0.5)
        assert m.extents[0] == pytest.approx(1.5, rel=MODEL_SIZE_REL)


def test_fbx_through_assimp(tmp_path):
    pyassimp = pytest.importorskip("pyassimp")
    stl = tmp_path / "box.stl"
    trimesh.creation.box(extents=(4.0, 2.0, 1.5)).export(stl, file_type="stl_ascii")
    fbx = tmp_path / "box.fbx"
    with pyassimp.load(str(stl)) as scene:
        pyassimp.export(scene, str(fbx), file_type="fbxa")
    m = load_model(str(fbx), (("length", 4.0),), "+z", "+x")
    _check(m, "length", 4.0)
    assert m.extents[1] == pytest.approx(2.0, rel=FBX_SIZE_REL)


@pytest.mark.parametrize("content, message", [
    (None, "missing"),
    (b"", "empty"),
    (b"this is not a mesh at all" * 10, "cannot be read"),
])
def test_bad_model_files_name_the_file(tmp_path, content, message):
    path = tmp_path / "thing.glb"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(ModelError, match=message) as err:
        load_model(str(path), (("length", 1.0),))
    assert str(path) in str(err.value)


def test_degenerate_model_is_refused(tmp_path):
    flat = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0]], faces=[[0, 1, 2]], process=False)
    path = tmp_path / "flat.stl"
    flat.export(path)
    with pytest.raises(ModelError, match="zero width|degenerate"):
        load_model(str(path), (("width", 1.0),), "+z", "+x")
