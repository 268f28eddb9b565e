"""The frame's own parked rows and the parking strips beside them: what is no parked car, and
no strip over the ego vehicle's own path."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from synthcompose.placement import parked
from synthcompose.placement.lanes import _carriageway_lanes
from synthcompose.placement.street import Carriageway
from synthcompose.placement.street_lines import StreetLine


def _car(a0: float, a1: float, s0: float, s1: float) -> tuple[np.ndarray, np.ndarray]:
    """(a, s) points over a vehicle's footprint seen on the ground plan, every 0.1 m."""
    a, s = np.meshgrid(np.arange(a0, a1, 0.1), np.arange(s0, s1, 0.1))
    return a.ravel(), s.ravel()


def _rows(cars, right: float, left: float, monkeypatch) -> dict:
    a = np.concatenate([c[0] for c in cars])
    s = np.concatenate([c[1] for c in cars])
    monkeypatch.setattr(parked, "_vehicle_points", lambda frame, street: (a, s))
    street = SimpleNamespace(ego=SimpleNamespace(right=right, left=left))
    return parked._rows(SimpleNamespace(labelled=True), street)


def _parallel_row(kerb: float) -> list:
    """Three cars parked parallel along the right kerb at ``kerb`` (0.3 m from it, 1.8 m wide)."""
    return [_car(a, a + 4.4, kerb + 0.3, kerb + 2.1) for a in (8.0, 14.0, 20.0)]


def test_a_car_driving_beside_the_parked_row_is_no_part_of_it(monkeypatch):
    # a car and a bus in the lane beside the row, 3-5.7 m from the kerb: the row's depth (the
    # farthest point per metre) took them for bays 5 m deep, and no car could park in the
    # 2.2 m strip the lanes give
    moving = [_car(9.0, 13.4, 0.0, 1.8), _car(14.0, 26.0, 0.2, 2.7)]
    rows = _rows(_parallel_row(-3.0) + moving, -3.0, 3.5, monkeypatch)
    assert rows[-1].layout == "parallel"
    assert rows[-1].depth == pytest.approx(2.1, abs=0.15)


def test_cars_beyond_the_other_kerb_are_no_row_of_this_one(monkeypatch):
    # a car park beyond the left kerb (cars nosed in, 3.7-8.2 m left of the camera) lies
    # within 6 m of the right kerb of a 4.5 m carriageway: it was taken for bays along the
    # right kerb, deeper than the carriageway; it is no row of either kerb
    lot = [_car(a, a + 1.8, 3.7, 8.2) for a in (10.0, 12.5, 15.0, 17.5)]
    assert _rows(lot, -2.0, 2.5, monkeypatch) == {}


def test_no_parking_strip_over_the_ego_vehicles_path():
    row = {-1: parked.ParkedRow(-1, 12.0, "parallel", 0.0, 1.2)}
    # an unmarked kerb lane 5.3 m wide beside a parked row: a 2.2 m strip, unless the ego
    # vehicle drives within 1 m of where it would end (its cars stand partly on the footway)
    cw = Carriageway(-2.1, 3.2, (), None, 0, "one-way")
    far = _carriageway_lanes(cw, 0, 1, row, ego_s=1.2)
    assert [(lane.role, lane.right, lane.left) for lane in far][0] == ("parking", -2.1, pytest.approx(0.1))
    near = _carriageway_lanes(cw, 0, 1, row, ego_s=-0.4)
    assert all(lane.role != "parking" for lane in near)
    # a marked strip along the kerb holding the ego vehicle's path is its lane, not parking
    line = StreetLine(0.53, "dashed", 7.0, 20.0, 13.0)
    marked = Carriageway(-2.1, 3.2, (line,), None, 0, "one-way")
    lanes = _carriageway_lanes(marked, 0, 1, row, ego_s=-0.4)
    assert [lane.role for lane in lanes] == ["moving", "untold"]  # beyond the ego lane on a one-way street
    assert _carriageway_lanes(marked, 0, 1, row, ego_s=1.9)[0].role == "parking"


def test_a_line_under_the_ego_vehicles_path_is_no_lane_boundary():
    # a bright streak under the ego vehicle made a 1.9 m "parking strip" it drove in
    cw = Carriageway(-2.0, 5.0, (StreetLine(-0.1, "dashed", 7.0, 30.0, 23.0),
                                 StreetLine(2.4, "dashed", 7.0, 30.0, 23.0)), None, 0, "one-way")
    lanes = _carriageway_lanes(cw, 0, 1, {}, ego_s=0.3)
    # (the lane keeps right: at most a lane's width from its kerb, the rest beyond it untold)
    assert [(lane.role, lane.right) for lane in lanes][:1] == [("moving", -2.0)] and lanes[0].left > 1.7
    assert all(lane.role == "untold" for lane in lanes[1:])
