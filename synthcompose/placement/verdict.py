"""The traffic rules of a finished pose: what :func:`check_pose` adds to the geometric rules
for an object placed with traffic sense (``traffic.py``), and what check-placement measures.

Given the pose and what the placement said of it (its :class:`~.claim.Traffic`), measured
again on the frame's street (``street.py``, ``lanes.py``):

* a vehicle in a lane: the lane's role is the one claimed (moving / parked) and the one its
  orientation allows; a moving vehicle's centre within ``LANE_CENTRED`` of its lane's centre,
  its footprint inside the lane (not across a marking), its heading within ``YAW_LIMIT`` of its
  lane's direction; a parked one inside its strip, along (or at the row's angle to) the kerb,
  nose the way of the traffic beside it; on a side street, the same for the side street's lane;
* a person on the footway (never on the carriageway: the allowed surface), walking along it or
  standing facing the road when so claimed; neither a person nor a sign where the road's
  points outnumber the footway's on the ground plan around its footprint
  (``on_carriageway``: a side street's carriageway seen in front of its far kerb, which the
  stereo's depth noise puts at the footprint's place while the pixels under it are the kerb's);
* a sign at the kerb's edge (from ``traffic.sign_distance`` to ``SIGN_EDGE`` beyond, give or
  take ``SIGN_BAND``), facing the
  traffic of the lane beside it.
"""
from __future__ import annotations

import math

import numpy as np

from synthcompose.geometry.depth import Frame, back_project
from synthcompose.labels import label_id

from .claim import Traffic
from .lanes import no_vehicle_in
from .rules import GROUND_LEVEL, Rejection, label_mask
from .street import EGO_HALF_LANE
from .traffic import (
    SIGN_EDGE,
    footway_kerb,
    hand_of,
    lane_room,
    parking_fit,
    side_street_spot,
    sign_distance,
    sign_faces,
    street_lane,
    street_of,
)

#: a moving vehicle's centre is this close to its lane's centre (metres)
LANE_CENTRED = 0.3
#: headings within this of the lane's (or footway's) direction (degrees)
YAW_LIMIT = 10.0
#: a standing person faces the road within this (degrees)
FACING_LIMIT = 45.0
#: a sign stands within this of its place at the kerb's edge (traffic.sign_distance, metres)
SIGN_BAND = 0.3
#: a footprint may reach this far over its lane's markings (the markings' own width, metres)
MARKING_SLACK = 0.05
#: a marking seen over at least this along the street is a lane line wherever it is (metres)
LINE_SEEN = 6.0
#: a person's or a sign's footprint grown by this (metres) is where the ground plan's points tell
#: carriageway from footway; at least CARRIAGEWAY_MIN points are needed to say so
CARRIAGEWAY_REACH, CARRIAGEWAY_MIN = 0.3, 12


def _angle(a: float, b: float) -> float:
    """|a - b| in degrees, wrapped to [0, 180]."""
    return abs(math.degrees(math.remainder(a - b, 2 * math.pi)))


def check_traffic(frame: Frame, extents, m: np.ndarray, orientation: str, claim: Traffic | None,
                  traffic: str = "right-hand") -> Rejection | None:
    """The first traffic rule the pose ``m`` (V <- O) breaks, or None. ``claim``: what the
    placement said of the object (None: not placed with traffic sense, nothing to check)."""
    if claim is None:
        return None
    hand = hand_of(traffic)
    street = street_of(frame, traffic)
    yaw = math.atan2(m[1, 0], m[0, 0])
    point = m[:3, 3]
    if claim.role in ("moving", "parked"):
        return _vehicle(frame, street, extents, m, yaw, orientation, claim, hand)
    kerb = footway_kerb(frame, street, point, hand)
    if kerb is None:
        return Rejection("no footway direction", "no kerb near")
    dist, towards, heading, direction, _, _ = kerb
    why = on_carriageway(frame, m, extents)
    if why:
        return why
    if claim.role == "sign":
        near = sign_distance(extents)
        if not near - SIGN_BAND <= dist <= near + SIGN_EDGE + SIGN_BAND:
            return Rejection("sign not at the kerb's edge", f"{dist:.2f} m from the kerb")
        want = heading + (math.pi if sign_faces(direction, claim.pose_hint) > 0 else 0.0)
        if _angle(yaw, want) > YAW_LIMIT:
            return Rejection("sign not facing its traffic", f"{_angle(yaw, want):.0f} deg off")
        return None
    if claim.pose_hint == "walking":
        off = min(_angle(yaw, heading), _angle(yaw, heading + math.pi))
        if off > YAW_LIMIT:
            return Rejection("not walking along the footway", f"{off:.0f} deg off its direction")
    elif claim.pose_hint == "standing":
        off = _angle(yaw, math.atan2(towards[1], towards[0]))
        if off > FACING_LIMIT:
            return Rejection("not facing the road", f"{off:.0f} deg off")
    return None


def _ground_plan(frame: Frame, stride: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The frame's ground-level points on the ground plan (every ``stride``-th pixel, V) and
    whether each is road; cached on the frame."""
    key = ("ground_plan", stride)

    def make() -> tuple[np.ndarray, np.ndarray]:
        lab = frame.label_ids[::stride, ::stride]
        v, u = np.nonzero(label_mask([label_id(n) for n in GROUND_LEVEL])[lab]
                          & np.isfinite(frame.depth[::stride, ::stride]))
        _, pts = back_project(frame.depth, frame.camera, v * stride, u * stride)
        return pts[:, :2].astype(np.float64), lab[v, u] == label_id("road")
    return frame.derived(key, make)


def on_carriageway(frame: Frame, m: np.ndarray, extents) -> Rejection | None:
    """A person's or a sign's place is carriageway when, on the ground plan around its footprint (grown by
    CARRIAGEWAY_REACH), the road's points outnumber the other ground's: the pixels under its
    feet may be a footway's (a far kerb seen across a side street) while the stereo depth
    puts them on that side street's carriageway."""
    xy, road = _ground_plan(frame)
    c = m[:3, 3]
    reach = math.hypot(extents[0], extents[1]) / 2 + CARRIAGEWAY_REACH
    near = (np.abs(xy[:, 0] - c[0]) <= reach) & (np.abs(xy[:, 1] - c[1]) <= reach)
    if near.sum() < CARRIAGEWAY_MIN:
        return None
    local = (xy[near] - c[:2]) @ m[:2, :2]
    inside = (np.abs(local[:, 0]) <= extents[0] / 2 + CARRIAGEWAY_REACH) & \
        (np.abs(local[:, 1]) <= extents[1] / 2 + CARRIAGEWAY_REACH)
    n = int(inside.sum())
    share = float(road[near][inside].mean()) if n else 0.0
    if n >= CARRIAGEWAY_MIN and share > 0.5:
        return Rejection("on the carriageway", f"{share:.0%} of {n} ground points around it are road")
    return None


def _vehicle(frame: Frame, street, extents, m: np.ndarray, yaw: float, orientation: str, claim: Traffic,
             hand: int) -> Rejection | None:
    l, w, _ = extents
    point = m[:3, 3]
    a, s = (float(v[0]) for v in street.to_road(point[None, :2]))
    lane = street_lane(frame, street, s, hand)
    if lane is None:
        if claim.where != "side street":
            return Rejection("not in a lane", f"{s:.2f} m across the street, in no lane")
        spot = side_street_spot(frame, street, point, extents, "moving", np.random.default_rng(0), 0.0, hand)
        if isinstance(spot, Rejection):
            return spot
        centre, want, _ = spot
        off = float(np.hypot(*(centre[:2] - point[:2])))
        if off > LANE_CENTRED:
            return Rejection("not centred in its lane", f"{off:.2f} m from the side street's lane centre")
        if _angle(yaw, want) > YAW_LIMIT:
            return Rejection("facing against its lane" if _angle(yaw, want) > 90 else "not along its lane",
                             f"{_angle(yaw, want):.0f} deg off the side street's lane")
        return None
    why = no_vehicle_in(lane)
    if why:
        return why
    role = "moving" if lane.role == "moving" else "parked"
    if role != claim.role or (orientation in ("moving", "parked") and role != orientation):
        return Rejection("not a moving lane" if role == "parked" else "not a parking place",
                         f"a {lane.role} lane, claimed {claim.role}")
    off = _angle(yaw, _lane_heading(frame, street, lane, a))
    if off > YAW_LIMIT:
        return Rejection("facing against its lane" if off > 90 else "not along its lane",
                         f"{off:.0f} deg off its lane's direction")
    # the footprint across the street: inside the lane (a marking is not crossed)
    corners = np.array([[sx * l / 2, sy * w / 2, 0.0] for sx in (-1, 1) for sy in (-1, 1)]) @ m[:3, :3].T + point
    _, cs = street.to_road(corners[:, :2])
    slack = MARKING_SLACK if role == "moving" else MARKING_SLACK + 0.3
    if cs.min() < lane.right - slack or cs.max() > lane.left + slack:
        return Rejection("across a lane marking", f"the footprint spans {cs.min():.2f}..{cs.max():.2f} m, "
                                                   f"its lane {lane.right:.2f}..{lane.left:.2f} m")
    if role == "moving":
        why = _over_a_line(street.carriageways[lane.carriageway], street, a, cs)
        if why:
            return why
    if role == "moving" and abs(s - lane.centre) > LANE_CENTRED:
        return Rejection("not centred in its lane", f"{abs(s - lane.centre):.2f} m from its centre")
    if role == "moving" and lane.width < lane_room(w) - 1e-6:
        return Rejection("lane narrower than the vehicle", f"{lane.width:.2f} m for {w:.2f} m")
    return None


def _over_a_line(cw, street, a: float, cs: np.ndarray) -> Rejection | None:
    """A moving vehicle (its footprint's corners across the street ``cs``, at ``a`` along it)
    spans no marking of its carriageway seen there over at least LINE_SEEN metres, even one the
    lanes left out (a dashed line beside a short stretch of paint), except one under the ego
    vehicle's own path (within EGO_HALF_LANE of it: the ego vehicle does not drive on a lane
    line, so that is no lane line)."""
    for mk in cw.markings:
        if mk.end - mk.start < LINE_SEEN or not mk.start - 1.0 <= a <= mk.end + 1.0:
            continue
        if abs(mk.offset - street.ego_offset) <= EGO_HALF_LANE:
            continue
        if cs.min() + MARKING_SLACK < mk.offset < cs.max() - MARKING_SLACK:
            return Rejection("across a lane marking", f"a {mk.kind} line at {mk.offset:.2f} m under the "
                                                       f"footprint ({cs.min():.2f}..{cs.max():.2f} m)")
    return None


def lane_yaw_error(frame: Frame, extents, m: np.ndarray, traffic: str = "right-hand") -> float | None:
    """Degrees (0-180) between a vehicle's heading and its lane's direction (None when it
    stands in no lane of the street): 180 is a vehicle facing against its lane."""
    hand = hand_of(traffic)
    street = street_of(frame, traffic)
    point = m[:3, 3]
    a, s = (float(v[0]) for v in street.to_road(point[None, :2]))
    lane = street_lane(frame, street, s, hand)
    yaw = math.atan2(m[1, 0], m[0, 0])
    if lane is None:
        spot = side_street_spot(frame, street, point, extents, "moving", np.random.default_rng(0), 0.0, hand)
        return None if isinstance(spot, Rejection) else _angle(yaw, spot[1])
    return _angle(yaw, _lane_heading(frame, street, lane, a))


def _lane_heading(frame: Frame, street, lane, a: float, extents=(4.4, 1.8, 1.5)) -> float:
    """The heading a vehicle in ``lane`` at ``a`` has (radians, V): its lane's direction; in
    a parking strip turned by the frame's own parked cars' angle."""
    want = float(street.heading(a)) + (0.0 if lane.direction > 0 else math.pi)
    if lane.role == "parking":
        want += lane.direction * lane.kerb * parking_fit(frame, street, lane, extents)[1]
    return want
