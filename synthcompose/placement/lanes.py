"""The lanes of the street: the spaces between each carriageway's kerbs, lane markings and
centre line (``street.py``), what each is for and which way its traffic goes.

A marking that leaves a lane narrower than ``MIN_LANE`` between two others is not a lane
boundary (tram rails, a double line) and is dropped, the weakest first. A strip between a
kerb and a marking 1.9-2.9 m wide is a parking strip (narrower: a cycle lane, no car); an
unmarked lane along a kerb with room for a parked row (``WIDE``) has one where the frame's own
cars are parked along that kerb (``parked.py``); a moving lane wider than ``LANE_WIDTH`` is
split into lanes (the ego vehicle's centred on it); a moving lane that holds the centre line (its
marking dropped as a short stretch of paint) is split there, one lane each way.

Directions (right-hand traffic, ``hand`` = +1; left-hand mirrors it): on a two-way
carriageway the lanes right of the centre line go with the ego vehicle (+1, along the street
away from the camera), those left of it come towards it (-1); a one-way carriageway goes with
the ego vehicle; the other half of a dual road goes against it when on its oncoming side. A
parking strip takes the direction of the lane beside it.

A carriageway taken as one-way has no sign of its direction: no centre line, and the ego vehicle
not keeping right of its middle. It may as well be a two-way street whose driver keeps to the
middle, whose left half comes towards us (the frame's own cars parked there face the camera).
Its lanes beyond the ego vehicle's own lane on its left (right, for left-hand traffic) are
``untold``: no vehicle is put there, facing either way; the ego vehicle's own lane and those on
its kerb's side go with it on either street. Its own lane reaches at most half a lane
(``EGO_REACH``) to that side, and, as traffic keeps right (StVO 2 (2)), at most a lane's width
from its kerb's side: a car ahead that hides the kerb, or a driver straddling a centre line the
markings missed, leaves one wide "lane" whose far part is the oncoming half. A dual road's
other half beyond the oncoming kerb tells the direction: none of this applies there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.geometry.depth import Frame

from .parked import parked_rows
from .rules import Rejection
from .street import EGO_HALF_LANE, Carriageway, Street
from .street_lines import SOLID_RUN

#: narrower than this, a space between two markings is no lane (metres)
MIN_LANE = 2.3
#: a marked strip along a kerb this wide is a parking strip (metres): up to MIN_MOVING always,
#: up to STRIP[1] where the frame's own cars park along that kerb (else a moving lane)
STRIP, MIN_MOVING = (1.9, 2.9), 2.5
#: an unmarked lane along a kerb this wide has room for a parked row of this width (metres)
WIDE, ROW_WIDTH = 4.3, 2.2
#: a parking strip keeps this far from the ego vehicle's path (metres: half its width and a little)
EGO_CLEAR = 1.0
#: a moving lane is at most this wide; wider, it is split into lanes at least LANE_MIN_SPLIT
#: wide (metres)
LANE_WIDTH, LANE_MIN_SPLIT = 3.75, 2.75
#: a centre line this far inside a moving lane splits it (metres)
CENTRE_INSIDE = 0.5
#: where nothing tells a carriageway's direction, the ego vehicle's own lane reaches at most this
#: far to its oncoming side (metres: half a lane)
EGO_REACH = LANE_WIDTH / 2


@dataclass(frozen=True)
class Lane:
    """A lane across the street (s from ``right`` to ``left``, metres): ``role`` ``moving``,
    ``parking``, ``none`` (a cycle lane) or ``untold`` (its direction not seen: no vehicle),
    ``direction`` +1 with the ego vehicle, -1 against,
    the carriageway's index, and for a parking strip the kerb it runs along (``kerb`` -1 right,
    +1 left, 0 none)."""

    right: float
    left: float
    role: str
    direction: int
    carriageway: int
    kerb: int = 0

    @property
    def centre(self) -> float:
        return (self.left + self.right) / 2

    @property
    def width(self) -> float:
        return self.left - self.right

    def to_dict(self) -> dict:
        return {"right_m": round(self.right, 3), "left_m": round(self.left, 3), "role": self.role,
                "direction": self.direction, "carriageway": self.carriageway}


def lanes(frame: Frame, street: Street, hand: int) -> tuple[Lane, ...]:
    """Every lane of the street (cached on the frame)."""
    key = ("lanes", id(street), hand)

    def make() -> tuple[Lane, ...]:
        rows = parked_rows(frame, street)
        # a dual road's other half on the oncoming side tells the ego carriageway's direction
        dual = any(cw.side == hand for cw in street.carriageways)
        return tuple(lane for k, cw in enumerate(street.carriageways)
                     for lane in _carriageway_lanes(cw, k, hand, rows if cw.side == 0 else {}, street.ego_offset, dual))
    return frame.derived(key, make)


def sun_direction_of(cw: Carriageway, s: float, hand: int) -> int:
    if cw.side != 0:
        return -hand * cw.side
    if cw.centre is None:
        return 1
    return 1 if hand * (cw.centre - s) > 0 else -1


def _carriageway_lanes(cw: Carriageway, k: int, hand: int, rows: dict, ego_s: float = 0.0,
                       dual: bool = False) -> list[Lane]:
    # boundaries: (offset, kind, cover); the kerbs and the centre line are never dropped
    # a line under the ego vehicle's own path is no lane line: it does not drive on one
    marks = [m for m in cw.markings if cw.side != 0 or abs(m.offset - ego_s) > EGO_HALF_LANE]
    bounds = [(cw.right, "kerb", math.inf)] + [(m.offset, m.kind, m.cover) for m in marks]
    bounds += [(cw.left, "kerb", math.inf)]
    if cw.centre is not None and all(abs(b[0] - cw.centre) > 1e-6 for b in bounds):
        bounds.append((cw.centre, "centre", math.inf))
    # a row of bays along a kerb: its depth is a boundary, the markings inside it are its bays'
    for side, row in rows.items():
        if row.layout == "parallel":
            continue
        kerb = cw.left if side > 0 else cw.right
        edge = kerb - side * (row.depth + 0.3)
        bounds = [b for b in bounds if b[1] == "kerb" or side * (kerb - b[0]) > row.depth + 0.6]
        bounds.append((edge, "bays", math.inf))
    bounds.sort()
    # the centre line is kept, unless it is a short stretch of paint and a long line would go
    bounds = [(o, kind, max(c, SOLID_RUN) * 2 if cw.centre is not None and abs(o - cw.centre) < 1e-6 else c)
              for o, kind, c in bounds]
    while True:  # a marking leaving a narrow lane between two others is none (rails, double lines)
        narrow = [i for i in range(1, len(bounds) - 2) if bounds[i + 1][0] - bounds[i][0] < MIN_LANE]
        if not narrow:
            break
        i = narrow[0]
        drop = min((i, i + 1), key=lambda j: bounds[j][2])
        if not math.isfinite(bounds[drop][2]):
            break
        del bounds[drop]
    out: list[Lane] = []
    n = len(bounds)
    for i in range(n - 1):
        lo, hi = bounds[i][0], bounds[i + 1][0]
        width = hi - lo
        kerb = -1 if i == 0 else (1 if i == n - 2 else 0)
        if n == 2:
            kerb = 0
        marked_strip = kerb != 0 and bounds[i + (1 if kerb < 0 else 0)][1] in ("solid", "dashed")
        # a marked strip along the kerb: a cycle lane when narrow, a parking strip when a car fits
        # and is no lane's width, or where the frame's own cars park along that kerb
        # (the ego vehicle drives in a moving lane: a strip over its path is none)
        clear_of_ego = cw.side != 0 or (hi <= ego_s - EGO_CLEAR if kerb < 0 else lo >= ego_s + EGO_CLEAR)
        if marked_strip and clear_of_ego and (width < STRIP[0] or width < MIN_MOVING or (kerb in rows and width < STRIP[1])):
            role = "none" if width < STRIP[0] else "parking"
            out.append(Lane(lo, hi, role, 0, k, kerb))
            continue
        for side in (-1, 1):  # an unmarked kerb lane beside the frame's own parked row
            on_kerb = (side == -1 and i == 0) or (side == 1 and i == n - 2)
            # (never over the ego vehicle's own path: it drives there; the row's cars stand
            # partly on the footway where the kerb is nearer to it than that)
            inner = lo + ROW_WIDTH if side == -1 else hi - ROW_WIDTH
            clear = cw.side != 0 or side * (inner - ego_s) >= EGO_CLEAR
            if on_kerb and side in rows and hi - lo >= WIDE and clear:
                if side == -1:
                    out.append(Lane(lo, lo + ROW_WIDTH, "parking", 0, k, -1))
                    lo += ROW_WIDTH
                else:
                    out.append(Lane(hi - ROW_WIDTH, hi, "parking", 0, k, 1))
                    hi -= ROW_WIDTH
        if hi - lo < MIN_LANE:
            continue
        for a, b in _split(lo, hi):
            out.append(Lane(a, b, "moving", sun_direction_of(cw, (a + b) / 2, hand), k))
    # a moving lane holding the centre line (its marking dropped as a short stretch of paint)
    # is two lanes, one each way: split there
    centre = cw.centre
    if cw.side == 0 and centre is not None:
        out = [part for ln in out for part in _split_at(ln, centre)]
    # a carriageway whose direction nothing tells: the ego vehicle's own lane reaches half a
    # lane to its oncoming side, and no farther (a two-way street's oncoming lane lies beyond)
    if cw.side == 0 and centre is None and not dual:
        out = [part for ln in out for part in (_split_at(ln, _ego_reach(ln, ego_s, hand))
                                               if ln.right <= ego_s <= ln.left else [ln])]
    # the ego vehicle drives with its own lane (the moving lane nearest to it): where the
    # centre line found says otherwise, the centre is taken at the ego lane's far edge
    if cw.side == 0 and centre is not None:
        ego = _ego_lane(out, ego_s)
        if ego is not None and hand * (centre - ego.centre) < 0:
            centre = ego.left if hand > 0 else ego.right
    # every lane (a parking strip too) goes the way of its side of the centre line
    two_way = cw.side == 0 and centre is not None
    roles = _untold(cw, out, ego_s, hand, dual)
    return [Lane(ln.right, ln.left, role, (1 if hand * (centre - ln.centre) > 0 else -1) if two_way
                 else sun_direction_of(cw, ln.centre, hand), k, ln.kerb) for ln, role in zip(out, roles)]


def _ego_reach(lane: Lane, ego_s: float, hand: int) -> float:
    """Where the ego vehicle's own ``lane`` ends on its oncoming side, on a carriageway whose
    direction nothing tells: half a lane past the ego vehicle's path, and at most a lane's width
    from its kerb's side (traffic keeps right, StVO 2 (2)), never within EGO_HALF_LANE of that
    path."""
    kerb_side = lane.right if hand > 0 else lane.left
    keep = kerb_side + hand * LANE_WIDTH
    near = ego_s + hand * EGO_HALF_LANE
    edge = max(keep, near) if hand > 0 else min(keep, near)
    reach = ego_s + hand * EGO_REACH
    return min(edge, reach) if hand > 0 else max(edge, reach)


def _untold(cw: Carriageway, out: list[Lane], ego_s: float, hand: int, dual: bool = False) -> list[str]:
    """Each lane's role, ``untold`` where the ego carriageway is one-way for want of any sign
    of its direction and the lane lies beyond the ego vehicle's own lane (the moving lane
    nearest its path) on the oncoming side: there a two-way street's traffic would come
    towards us."""
    roles = [ln.role for ln in out]
    if cw.side != 0 or cw.centre is not None or dual:
        return roles
    ego = _ego_lane(out, ego_s)
    if ego is None:
        return roles
    return ["untold" if role != "none" and hand * (ln.centre - ego.centre) > 0 else role for ln, role in zip(out, roles)]


def _ego_lane(out: list[Lane], ego_s: float) -> Lane | None:
    """The ego vehicle's own lane: the moving lane nearest its path (at offset ``ego_s``)."""
    return min((ln for ln in out if ln.role == "moving"), key=lambda m: _gap(m, ego_s), default=None)


def no_vehicle_in(lane: Lane) -> Rejection | None:
    """Why no vehicle stands in ``lane`` whatever it claims (a cycle lane; a lane whose
    direction nothing tells), or None (the placement and the checker ask the same)."""
    if lane.role == "none":
        return Rejection("in a cycle lane", f"a {lane.width:.1f} m strip along the kerb")
    if lane.role == "untold":
        return Rejection("lane's direction not seen", "beyond the ego lane, no centre line")
    return None


def _split_at(lane: Lane, s: float) -> list[Lane]:
    """A moving ``lane`` split at ``s`` when ``s`` lies more than CENTRE_INSIDE inside it."""
    if lane.role != "moving" or not lane.right + CENTRE_INSIDE < s < lane.left - CENTRE_INSIDE:
        return [lane]
    return [Lane(lane.right, s, "moving", lane.direction, lane.carriageway),
            Lane(s, lane.left, "moving", lane.direction, lane.carriageway)]


def _gap(lane: Lane, s: float) -> float:
    """How far ``s`` is outside ``lane`` (0 inside), metres."""
    return max(lane.right - s, s - lane.left, 0.0)


def _split(lo: float, hi: float) -> list[tuple[float, float]]:
    """A moving space split into equal lanes at most LANE_WIDTH (+ 0.5 m) wide."""
    if hi - lo <= LANE_WIDTH + 0.5:
        return [(lo, hi)]
    n = max(1, min(int(math.ceil((hi - lo) / LANE_WIDTH)), int((hi - lo) / LANE_MIN_SPLIT)))
    edges = np.linspace(lo, hi, n + 1)
    return [(float(a), float(b)) for a, b in zip(edges[:-1], edges[1:])]


def lane_at(all_lanes: tuple[Lane, ...], s: float) -> Lane | None:
    return next((lane for lane in all_lanes if lane.right <= s <= lane.left), None)


