"""The cast's vehicles (assets/cast/vehicles, built by scripts/build_vehicles.py; docs/vehicles.md):
every entry is complete and licensed, its model loads at its real size with the material roles
the renderer reads (paint, transparent glass, tyres, lamps, plates at the front and the rear), and
it stands on its wheels."""
import json
from pathlib import Path

import numpy as np
import pytest

from synthcompose.look.appearance import draw_appearance, recolourable
from synthcompose.models import load_model

VEHICLES = Path(__file__).resolve().parents[2] / "assets" / "cast" / "vehicles"
ENTRIES = sorted(VEHICLES.glob("*/entry.json"))
KINDS = {"compact", "saloon", "estate", "suv", "van", "bus", "lorry", "classic"}


def _entry(path: Path) -> dict:
    return json.loads(path.read_text())


def _model(path: Path):
    e = _entry(path)
    return e, load_model(str(path.parent / e["model"]), tuple(e["size"].items()), e["up"], e["forward"])


def _parts(model, name: str):
    return [p for p in model.parts if p.name == name]


def test_the_cast_has_its_vehicles():
    entries = [_entry(p) for p in ENTRIES]
    cars = [e for e in entries if e["class"] == "car" and e["kind"] != "classic"]
    assert len(cars) >= 5
    assert {e["class"] for e in entries} >= {"car", "bus", "truck"}
    assert any(e["kind"] == "van" for e in entries) and any(e["kind"] == "lorry" for e in entries)


@pytest.mark.parametrize("path", ENTRIES, ids=lambda p: p.parent.name)
def test_an_entry_is_complete_and_licensed(path):
    e = _entry(path)
    assert e["id"] == path.parent.name
    assert e["kind"] in KINDS and e["class"] in {"car", "truck", "bus"}
    assert len(e["size"]) == 1 and e["weight"] > 0
    model = path.parent / e["model"]
    assert model.is_file() and model.stat().st_size < 5_000_000
    assert (path.parent / "LICENSE").stat().st_size > 500
    source = (path.parent / "SOURCE.txt").read_text()
    assert e["source"].split("@")[1].split()[0] in source  # the commit


@pytest.mark.parametrize("path", ENTRIES, ids=lambda p: p.parent.name)
def test_a_vehicle_loads_with_the_roles_the_renderer_reads(path):
    e, model = _model(path)
    assert 10_000 <= model.triangles <= 200_000
    # transparent glass, rubber tyres, red tail lamps, a plate at each end with UVs over it
    glass = [p for p in model.parts if p.name.startswith("glass")]
    assert glass and all(0.3 < p.transmission < 0.9 for p in glass)
    assert _parts(model, "tyre") and _parts(model, "light_red")
    assert all(p.colors[:, :3].max() < 0.05 for p in _parts(model, "tyre"))
    plates = [p for p in model.parts if p.plate]
    assert plates
    pos = np.concatenate([p.positions for p in plates])
    assert pos[:, 0].max() > 0.4 * model.extents[0] and pos[:, 0].min() < -0.4 * model.extents[0]
    uvs = np.concatenate([p.uvs for p in plates])
    assert uvs.min() >= -1e-6 and uvs.max() <= 1 + 1e-6


@pytest.mark.parametrize("path", ENTRIES, ids=lambda p: p.parent.name)
def test_a_vehicle_stands_on_its_wheels(path):
    """Every wheel touches the ground (z = 0 is the model's lowest point): the lowest point of
    the tyres in each quarter of the footprint is within 2 cm of it; nothing else is lower."""
    e, model = _model(path)
    tyres = np.concatenate([p.positions for p in _parts(model, "tyre")])
    for sx in (1, -1):
        for sy in (1, -1):
            quarter = tyres[(np.sign(tyres[:, 0]) == sx) & (np.sign(tyres[:, 1]) == sy)]
            assert len(quarter) and quarter[:, 2].min() < 0.02, (sx, sy, quarter[:, 2].min())


@pytest.mark.parametrize("path", ENTRIES, ids=lambda p: p.parent.name)
def test_the_paint_is_drawn_per_object_and_a_livery_is_kept(path):
    e, model = _model(path)
    keys = recolourable(model, e["class"])
    paint = _parts(model, "paint")
    if paint:
        assert keys == [tuple(float(v) for v in np.round(paint[0].colors[0], 4))]
        app = draw_appearance(model, e["class"], np.random.default_rng(0))
        assert app.names and app.plate
    else:
        assert _parts(model, "livery") and keys == []
