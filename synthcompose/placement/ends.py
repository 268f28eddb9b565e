"""Where the ego vehicle's street ends ahead: a wall across its whole carriageway near ahead (a
T-junction seen head-on: the house across the cross street).

The street's axis is fitted to lines that run along it; at a T-junction seen head-on the street
the objects would stand in runs across the view, and the lines found along the view are short
stretches of paint and stereo noise. Vehicles' headings there would come from the wrong street
(a car facing a house front), so where its street ends ahead the carriageway is no lane: a
vehicle there stands on the street across it, along the kerbs seen there
(``traffic.street_lane``, ``traffic.side_street_spot``), or nowhere.

Measured by what stands: points 0.5-3 m above the road (per metre along the street, the road's
median height there) within ``END_NEAR`` ahead across at least ``END_SHARE`` of the
carriageway's width. Vehicles and people ahead cover a lane's width at most; parked rows stand
at its edges (on the development set: 1.0 on leverkusen_000045, at most 0.8 on the others, a
van, people and a sign at a crossing on leverkusen_000037).
"""
from __future__ import annotations

import math

import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .road import RoadLine, line_through, surface_edges
from .street import Street, heights_over_road

#: a wall this near ahead (metres along the street) ...
END_NEAR = 20.0
#: ... across this share of the ego carriageway's width ends the street
END_SHARE = 0.9
#: what stands: this high above the road (metres)
STANDING = (0.5, 3.0)
#: a metre of the street has a road height with at least this many road points
MIN_ROAD_POINTS = 30


def street_ends(frame: Frame, street: Street) -> bool:
    """Whether the ego carriageway's street ends within END_NEAR ahead (cached per street)."""
    return frame.derived(("street_ends", id(street)), lambda: _ends(frame, street))


def _ends(frame: Frame, street: Street) -> bool:
    found = heights_over_road(frame, street, far=END_NEAR + 1, min_points=MIN_ROAD_POINTS)
    if found is None:
        return False
    _, _, a, s, h = found
    cw = street.ego
    sel = (h >= STANDING[0]) & (h <= STANDING[1]) & (a > 0.0) & (a <= END_NEAR) & (s >= cw.right) & (s <= cw.left)
    width = cw.left - cw.right
    if width <= 0 or not sel.any():
        return False
    covered = np.unique(np.floor((s[sel] - cw.right) / 0.25).astype(np.int64))
    return bool(len(covered) * 0.25 >= END_SHARE * width)


#: the kerb across the end: at least this far off the street's direction (degrees); kerb points
#: within END_KERB_BAND of it (metres) over at least END_KERB_LENGTH (metres); END_KERB_TRIES
#: lines tried
END_KERB_TURN, END_KERB_BAND, END_KERB_LENGTH, END_KERB_TRIES = 40.0, 0.3, 2.5, 120
#: a point this far past the end kerb (metres) stands on its far footway
END_PAST = 0.2


def end_kerb(frame: Frame, street: Street):
    """The kerb across the ego carriageway where its street ends (the cross street's far kerb):
    a road.RoadLine fitted to the kerb points within the ego carriageway's width ahead (the
    kerbs along the street, the junction's corners, lie outside it and make the line fitted
    around a point there ambiguous), or None where the street does not end or no such line
    across it is seen. Cached per street."""
    return frame.derived(("end_kerb", id(street)), lambda: _end_kerb(frame, street))


def past_end(frame: Frame, line, xy: np.ndarray) -> np.ndarray:
    """(N,) bool: which ground-plan points (N, 2) (V) lie past the end kerb ``line`` (end_kerb),
    on its far side from the camera, by more than END_PAST (the kerb's own stones)."""
    side = np.sign(line.offset_of((frame.camera.x, frame.camera.y)))
    return -side * line.offsets(np.atleast_2d(np.asarray(xy, float))) > END_PAST


def end_record(frame: Frame, street: Street) -> dict | None:
    """The record's word on where the street ends: None where it goes on; else the kerb across
    it (a point of the line and its direction in V; None where no such kerb is seen) and how far
    past it a point stands on the far footway (a point on the camera's side of it, or on the kerb's
    stones, is still on the street)."""
    if not street_ends(frame, street):
        return None
    line = end_kerb(frame, street)
    kerb = None if line is None else {"point_m": [round(v, 3) for v in line.centre],
                                      "angle_deg": round(math.degrees(line.angle), 2)}
    return {"kerb": kerb, "past_m": END_PAST}


def past_recorded_end(street: dict, x: float, y: float) -> bool:
    """Whether a ground-plan point (V) lies past the kerb across the ego carriageway where a
    record's street (its ``end``, :func:`end_record`) ends, on the far side from the vehicle's
    origin, by more than the recorded ``past_m`` (as :func:`past_end` measures it on a frame)."""
    end = street.get("end") or {}
    kerb = end.get("kerb")
    if not kerb:
        return False
    line = RoadLine(math.radians(kerb["angle_deg"]), 0.0, 0, False, tuple(kerb["point_m"]))
    return -math.copysign(1.0, line.offset_of((0.0, 0.0))) * line.offset_of((x, y)) > end["past_m"]


def _end_kerb(frame: Frame, street: Street):
    if not street_ends(frame, street):
        return None
    edges = surface_edges(frame, np.array([label_id("road")]))
    if not len(edges):
        return None
    a, s = street.to_road(edges)
    cw = street.ego
    sel = (a > 0.0) & (a <= END_NEAR + 5.0) & (s >= cw.right) & (s <= cw.left)
    if sel.sum() < 20:
        return None
    inside = edges[sel]
    # the line across the ego carriageway's width that covers most of it (a painted stop line
    # or a gutter strip taken for ground covers less): all lines through two points at once,
    # each scored by the 0.25 m steps along it that hold a point
    rng = np.random.default_rng(0)
    i, j = rng.integers(len(inside), size=(2, END_KERB_TRIES))
    d = inside[j] - inside[i]
    length = np.hypot(d[:, 0], d[:, 1])
    ok = length >= 1.0
    if not ok.any():
        return None
    d, i = d[ok] / length[ok, None], i[ok]
    rel = inside[None, :, :] - inside[i][:, None, :]
    on = np.abs(rel[..., 0] * d[:, 1, None] - rel[..., 1] * d[:, 0, None]) <= END_KERB_BAND
    along = np.floor((rel[..., 0] * d[:, 0, None] + rel[..., 1] * d[:, 1, None]) / 0.25).astype(np.int64)
    score = np.array([len(np.unique(along[k][on[k]])) for k in range(len(i))])
    k = int(np.argmax(score))
    on = on[k]
    if score[k] * 0.25 < END_KERB_LENGTH:
        return None
    centre, angle = line_through(inside[on])
    turn = abs(math.degrees(math.remainder(angle - float(street.heading(float(np.median(a[sel])))), math.pi)))
    if turn < END_KERB_TURN:
        return None
    return RoadLine(angle, 0.0, int(on.sum()), False, (float(centre[0]), float(centre[1])))
