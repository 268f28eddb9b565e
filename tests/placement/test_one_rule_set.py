"""One rule set: every pose a batch places passes check-placement --strict, measured again from
the record alone (its rules, the objects placed before it, where it said it stands in
traffic), on generated streets and on real frames (SYNTHCOMPOSE_REAL_ROOT; skipped without)."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.io.dataset import find_image_sets
from synthcompose.record import RECORD_VERSION, read_record
from synthcompose.synthetic import make_sample
from synthcompose.tools.check import check_output, check_record

from ..real_root import REAL, needs_real

DEMO = Path(__file__).resolve().parents[2] / "assets" / "demo" / "manifest.json"


def demo_manifest(path: Path, dataset: Path, output: Path, objects: int = 3, **extra) -> Path:
    """The bundled demo's cast (the street cast: cars, a bus, a lorry, posed people, signs) on
    ``dataset``."""
    m = json.loads(DEMO.read_text())
    for obj in m.get("objects", []):
        if not obj["model"].startswith("builtin:"):
            obj["model"] = str((DEMO.parent / obj["model"]).resolve())
    splits = sorted({i.split for i in find_image_sets(dataset)})
    m.update(dataset=str(dataset), output=str(output), splits=splits, objects_per_image=objects,
             render={"right_view": False}, **extra)
    path.write_text(json.dumps(m))
    return path


def _no_disagreement(out: Path) -> int:
    checks = check_output(out)
    bad = [(c.image_set, c.index, c.name, c.failures, c.rule) for c in checks if c.failures]
    assert not bad, bad
    for path in (out / "synthcompose").rglob("*_synthcompose.json"):
        record = read_record(path)
        assert record.record_version == RECORD_VERSION
        if record.done:
            assert record.placement_rules is not None and record.street is not None
            for obj in record.objects:
                assert obj.traffic is not None and obj.traffic["role"] in (
                    "moving", "parked", "walking", "standing", "sign")
                if obj.class_name == "person":
                    # the person was posed as it was placed (the pose decided first)
                    assert obj.traffic["pose_hint"] in ("walking", "standing")
                    assert obj.appearance["pose"]["pose"] == obj.traffic["pose_hint"] == obj.traffic["role"]
    return len(checks)


def test_placement_and_check_agree_on_generated_streets(tmp_path):
    root = tmp_path / "cs"
    make_sample(root, count=5, width=1024, height=512, seed=3, streets="traffic")
    out = tmp_path / "out"
    assert main(["batch", str(demo_manifest(tmp_path / "m.json", root, out, seed=2)), "--no-progress"]) == 0
    assert _no_disagreement(out) >= 10
    # the checker sees a wrong-way vehicle: the same record with a car turned round fails
    for path in sorted((out / "synthcompose").rglob("*_synthcompose.json")):
        record = read_record(path)
        cars = [o for o in record.objects if o.traffic and o.traffic["role"] == "moving"]
        if cars:
            break
    else:
        pytest.fail("no moving vehicle placed")
    car = cars[0]
    m = np.array(car.pose.vehicle)
    m[:3, :2] = -m[:3, :2]  # turned by 180 degrees about its up axis, same place
    turned = replace(car, pose=replace(car.pose, vehicle=tuple(map(tuple, m))))
    bad = record.with_(objects=tuple(turned if o is car else o for o in record.objects))
    check = next(c for c in check_record(bad) if c.index == car.index)
    assert "rules" in check.failures and "against its lane" in check.rule and check.yaw_to_road_deg > 170


@needs_real
def test_placement_and_check_agree_on_real_frames(tmp_path):
    out = tmp_path / "out"
    assert main(["batch", str(demo_manifest(tmp_path / "m.json", Path(REAL), out, seed=7)), "--no-progress"]) == 0
    assert _no_disagreement(out) >= 1
