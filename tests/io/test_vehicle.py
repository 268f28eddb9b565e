"""Cityscapes' vehicle file (optional): read where it is there, its GPS heading and latitude
handed to the light estimate, and written with the outputs as it came (one that is not a
vehicle file fails its image set: test_bad_inputs.JSON_BREAKAGES)."""
from __future__ import annotations

import json

import pytest

from synthcompose.io.dataset import read_image_set
from synthcompose.io.vehicle import Vehicle, read_vehicle
from synthcompose.synthetic import make_sample

FIELDS = {"gpsHeading": 96, "gpsLatitude": 51.0479, "gpsLongitude": 6.9807, "outsideTemperature": 17.5,
          "speed": 6.7, "yawRate": 0.01}


def test_a_vehicle_file_is_read_and_its_absence_or_a_missing_fix_is_none(tmp_path):
    path = tmp_path / "v.json"
    assert read_vehicle(path) is None
    path.write_text(json.dumps(FIELDS))
    assert read_vehicle(path) == Vehicle(96.0, 51.0479, 6.9807)
    path.write_text(json.dumps(dict(FIELDS, gpsLatitude=None)))
    assert read_vehicle(path) is None
    path.write_text(json.dumps(dict(FIELDS, gpsHeading=-90)))
    assert read_vehicle(path).heading == 270.0


def test_an_image_set_reads_its_vehicle_file_and_the_generated_sunny_frames_have_one(tmp_path):
    plain = make_sample(tmp_path / "plain", count=1, width=256, height=128, seed=1)[0]
    assert read_image_set(tmp_path / "plain", plain).vehicle is None
    sunny = make_sample(tmp_path / "sunny", count=1, width=256, height=128, seed=1, light="sunny")[0]
    v = read_image_set(tmp_path / "sunny", sunny).vehicle
    assert v is not None and 47.0 < v.latitude < 55.0


def test_a_batch_writes_the_vehicle_file_with_the_outputs_and_records_where_the_sun_can_stand(tmp_path):
    from synthcompose.cli import main

    from ..helpers import box_manifest

    root, out = tmp_path / "cs", tmp_path / "out"
    ids = make_sample(root, count=2, width=320, height=160, seed=2, light="sunny")
    manifest = box_manifest(tmp_path / "m.json", root, out, lighting={"mode": "estimate"})
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    sunny = 0
    for ident in ids:
        record = json.loads(ident.path(out, "record").read_text())
        assert record["status"] == "done"
        assert ident.path(out, "vehicle").read_bytes() == ident.path(root, "vehicle").read_bytes()
        if record["lighting"]["sunny"]:
            sunny += 1
            assert record["lighting"]["cues"]["site"]["latitude"] == pytest.approx(50.5)
    assert sunny
