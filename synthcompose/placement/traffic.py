"""Traffic sense: where and which way a vehicle, a person or a sign stands in the street's
lanes (``lanes.py``) and footways.

**A vehicle** drawn in a lane is moved across it to the lane's centre (moving) or to the kerb
(parked: ``PARK_GAP`` from it, at the frame's own parked cars' angle) and faces its lane's
direction; off the street's carriageways, on a side street whose kerbs give its direction, in
its right half's lane (right-hand traffic). **A person** on a footway walks along it or stands;
within ``KERB_WAIT`` of the kerb, waiting there facing the road. **A sign** stands ``SIGN_KERB``
from the kerb, its face towards the traffic of the lane beside that kerb (the drivers who read
it): for right-hand traffic a sign on the right kerb of a two-way street faces the camera, one
on the left kerb faces away from it (its back is seen, as real left-kerb signs are).

The placement (search.py) asks here for each candidate; ``verdict.py`` checks a finished pose
against the same rules (the checker and the placement's last test).
"""
from __future__ import annotations

import math

import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .claim import Traffic
from .ends import end_kerb, past_end, street_ends
from .lanes import Lane, lane_at, lanes, no_vehicle_in, sun_direction_of
from .parked import parked_rows
from .road import road_line
from .rules import KERB_CLEARANCE, Rejection
from .street import Carriageway, Street, find_street

#: a parked car's side stands this far from the kerb (metres)
PARK_GAP = 0.25
#: a moving vehicle keeps this far from its lane's markings (metres); one wider than WIDE_BODY
#: (a lorry's or a bus's extents hold its mirrors, which reach over the markings of a town's
#: 3 m lanes) only WIDE_MARGIN
LANE_MARGIN, WIDE_BODY, WIDE_MARGIN = 0.15, 2.55, 0.05
#: a person this close to the kerb may be waiting there (metres)
KERB_WAIT = 1.2
#: a sign's plate (its footprint across the footway) ends this far from the kerb (metres): the
#: kerb clearance of the placement rules and a little more
SIGN_KERB = KERB_CLEARANCE + 0.1
#: a sign stands at the kerb's edge: its plate's edge within SIGN_KERB to SIGN_KERB + SIGN_EDGE
#: of the kerb (metres)
SIGN_EDGE = 0.5
#: a footway belongs to the street when it is within this of one of its kerbs (metres)
FOOTWAY_REACH = 6.0
#: the orientations that follow traffic
TRAFFIC_ORIENTATIONS = ("along-road", "moving", "parked", "pedestrian", "facing-traffic")


def sign_distance(extents) -> float:
    """How far from the kerb a sign of ``extents`` (l, w, h) stands, its face along the street."""
    return float(extents[1]) / 2 + SIGN_KERB


def sign_faces(direction: int, hint: str | None) -> int:
    """Whose traffic a sign's face is towards: +1 ours, -1 the other way. The traffic of the
    lane beside its kerb (``direction``), or, for a sign that bars the traffic it faces (``hint``
    ``away``: no entry), always the other way: no driver going our way reads it."""
    return -1 if hint == "away" else direction


def lane_room(width: float) -> float:
    """The lane width a moving vehicle ``width`` metres wide needs (metres)."""
    return width + 2 * (LANE_MARGIN if width <= WIDE_BODY else WIDE_MARGIN)


def hand_of(traffic: str) -> int:
    """+1 for right-hand traffic, -1 for left-hand."""
    return -1 if traffic == "left-hand" else 1


def _side(cw: Carriageway, s: float, hand: int) -> str | None:
    if cw.centre is None:
        return None
    return "right" if s < cw.centre else "left"


def vehicle_spot(frame: Frame, street: Street, point: np.ndarray, extents, mode: str, rng: np.random.Generator,
                 jitter: float, hand: int) -> tuple[np.ndarray, float, Traffic] | Rejection:
    """Where a vehicle drawn at ``point`` (V) stands in traffic: moved across its lane to the
    lane's centre (moving) or to the kerb (parked), and its heading; or why it cannot.
    ``mode``: ``along-road`` (as the lane is), ``moving`` or ``parked``."""
    a, s = (float(v[0]) for v in street.to_road(point[None, :2]))
    lane = street_lane(frame, street, s, hand)
    if lane is None:
        return side_street_spot(frame, street, point, extents, mode, rng, jitter, hand)
    l, w, _ = extents
    cw = street.carriageways[lane.carriageway]
    why = no_vehicle_in(lane)
    if why:
        return why
    if mode == "moving" and lane.role != "moving":
        return Rejection("not a moving lane", f"a {lane.role} lane")
    if mode == "parked" and lane.role != "parking":
        return Rejection("not a parking place", f"a {lane.role} lane")
    heading = float(street.heading(a))
    layout = None
    if lane.role == "moving":
        if lane.width < lane_room(w):
            return Rejection("lane narrower than the vehicle", f"{lane.width:.2f} m for {w:.2f} m")
        target = lane.centre + float(rng.uniform(-0.1, 0.1)) * min(1.0, (lane.width - w) / 1.0)
        yaw = heading + (0.0 if lane.direction > 0 else math.pi) + float(rng.uniform(-jitter, jitter))
        role = "moving"
    else:
        layout, angle, across = parking_fit(frame, street, lane, extents)
        if lane.width < across + PARK_GAP - 0.1:
            return Rejection("parking place narrower than the vehicle", f"{lane.width:.2f} m for {across:.2f} m")
        kerb = lane.right if lane.kerb < 0 else lane.left
        target = kerb - lane.kerb * (PARK_GAP + across / 2)
        # nose towards the traffic's direction, turned into the bay by the row's angle
        yaw = heading + (0.0 if lane.direction > 0 else math.pi) + lane.direction * lane.kerb * angle
        yaw += float(rng.uniform(-jitter, jitter)) / 2
        role = "parked"
    xy = street.to_plan(a, target)
    traffic = Traffic(role, "carriageway" if cw.side == 0 else "other carriageway", _side(cw, target, hand),
                      "with" if lane.direction > 0 else "against", a, target, math.degrees(heading), cw.centre,
                      (lane.right, lane.left), None, layout)
    return np.array([xy[0], xy[1], point[2]]), yaw, traffic


def street_lane(frame: Frame, street: Street, s: float, hand: int) -> Lane | None:
    """The lane at offset ``s`` across the street; None off the street's lanes, and on the ego
    carriageway of a street that ends ahead (ends.py: a T-junction seen head-on, where the
    road ahead runs across the view and a vehicle there stands on that side street)."""
    lane = lane_at(lanes(frame, street, hand), s)
    if lane is not None and lane.carriageway == 0 and street_ends(frame, street):
        return None
    return lane


def parking_fit(frame: Frame, street: Street, lane: Lane, extents) -> tuple[str, float, float]:
    """How a vehicle of ``extents`` parks in a parking ``lane``: as the frame's own row along
    that kerb (layout, angle to the street in radians, the footprint's depth from the kerb in
    metres); parallel where the frame has no row."""
    l, w, _ = extents
    row = parked_rows(frame, street).get(lane.kerb) if street.carriageways[lane.carriageway].side == 0 else None
    layout = row.layout if row is not None else "parallel"
    angle = 0.0 if row is None or layout == "parallel" else math.radians(row.angle_deg)
    return layout, angle, abs(w * math.cos(angle)) + abs(l * math.sin(angle))


def side_street_spot(frame: Frame, street: Street, point: np.ndarray, extents, mode: str,
                      rng: np.random.Generator, jitter: float, hand: int) -> tuple[np.ndarray, float, Traffic] | Rejection:
    """A vehicle off the street's carriageways: on a side street (an arm of a junction) whose
    direction the kerbs there make clear, in its right (``hand``) half's lane, facing that
    half's direction; moving only."""
    if mode == "parked":
        return Rejection("not a parking place", "off the street's carriageways")
    a = float(point[0])
    line = road_line(frame, np.array([label_id("road")]), point)
    if line is None or line.ambiguous:
        return Rejection("no clear road direction (junction)", "off the street's lanes, no single kerb direction")
    heading = float(street.heading(a))
    turn = abs(math.remainder(line.angle - heading, math.pi))
    if turn < math.radians(30):
        return Rejection("off the lanes", "beside the street's carriageways, along them")
    l, w, _ = extents
    # the side street's direction pointing away from the street the camera is on
    d = np.array([math.cos(line.angle), math.sin(line.angle)])
    _, ps = street.to_road(point[None, :2])
    ahead = street.to_road((point[:2] + d)[None])
    if abs(float(ahead[1][0])) < abs(float(ps[0])):
        d = -d
    width, offset = _arm_width(frame, d, point)
    if width is None or width < 2 * lane_room(w) or width > 16.0:
        return Rejection("no clear road direction (junction)", "the side street's kerbs are not both seen")
    normal = np.array([-d[1], d[0]])  # left of d
    # ``offset``: the point's position across the side street from its middle (left of d
    # positive); the right half (right-hand traffic) goes along d, the other against it
    half = width / 2
    go = 1 if hand * offset < 0 else -1
    lane_centre = -hand * go * half / 2
    xy = point[:2] + normal * (lane_centre - offset)
    yaw = math.atan2(d[1], d[0]) + (0.0 if go > 0 else math.pi) + float(rng.uniform(-jitter, jitter))
    # on a side street: lateral, centre and lane in its own frame (across d, from its middle);
    # "with" means along d, away from the street the camera is on
    traffic = Traffic("moving", "side street", "right" if lane_centre < 0 else "left",
                      "with" if go > 0 else "against", a, lane_centre, math.degrees(math.atan2(d[1], d[0])), 0.0,
                      (lane_centre - half / 2, lane_centre + half / 2))
    return np.array([xy[0], xy[1], point[2]]), yaw, traffic


def _arm_width(frame: Frame, d: np.ndarray, point: np.ndarray) -> tuple[float | None, float]:
    """The side street's width between its two kerb lines through ``point``'s cross-section
    (the street along unit ``d``), and ``point``'s offset from its middle (left of d positive)."""
    from .road import surface_edges

    edges = surface_edges(frame, np.array([label_id("road")]))
    n = np.array([-d[1], d[0]])
    rel = edges - point[:2]
    along, across = rel @ d, rel @ n
    near = np.abs(along) <= 6.0
    left = across[near & (across > 0.5)]
    right = across[near & (across < -0.5)]
    if len(left) < 8 or len(right) < 8:
        return None, 0.0
    lo, hi = float(np.percentile(right, 90)), float(np.percentile(left, 10))
    return hi - lo, -(hi + lo) / 2


def footway_kerb(frame: Frame, street: Street, point: np.ndarray, hand: int):
    """The kerb a footway point belongs to: (distance to it, unit vector towards the road
    (V ground plan), the street's heading there, the traffic direction of the lane beside it
    (+1 along the heading), ``where``, side of the street) or None when no kerb is near."""
    a, s = (float(v[0]) for v in street.to_road(point[None, :2]))
    best = None
    if street_ends(frame, street):
        # the street ends ahead: its carriageway runs into the cross street, whose far footway
        # lies across the view beyond the kerb seen there (ends.py)
        line = end_kerb(frame, street)
        if line is not None and past_end(frame, line, point[None, :2])[0]:
            return _kerb_of(line, line.offset_of(point[:2]), hand)
        if street.ego.contains(s):
            return None
    for cw in street.carriageways:
        if cw.contains(s):
            return None  # inside a carriageway (the kerb's own stones)
        for kerb, side in ((cw.right, -1), (cw.left, 1)):
            d = side * (s - kerb)  # >0: beyond the kerb, outside the carriageway
            if 0.0 <= d <= FOOTWAY_REACH and (best is None or d < best[0]):
                best = (d, kerb, side, cw)
    if best is not None:
        d, kerb, side, cw = best
        heading = float(street.heading(a))
        n = np.array([-math.sin(heading), math.cos(heading)])
        lane = lane_at(lanes(frame, street, hand), kerb - side * 0.3)
        direction = lane.direction if lane is not None else sun_direction_of(cw, kerb - side * 0.3, hand)
        return d, -side * n, heading, direction, "footway", "left" if side > 0 else "right"
    return _kerb_line(frame, point, hand)


def _kerb_line(frame: Frame, point: np.ndarray, hand: int):
    """footway_kerb's answer from the kerb line seen near ``point`` (road.road_line), or None."""
    line = road_line(frame, np.array([label_id("road")]), point)
    if line is None or line.ambiguous:
        return None
    return _kerb_of(line, line.offset, hand)


def _kerb_of(line, offset: float, hand: int):
    """footway_kerb's answer for a footway point ``offset`` metres off a kerb ``line`` (road.RoadLine)."""
    if abs(offset) > FOOTWAY_REACH:
        return None
    heading = line.angle
    n = np.array([-math.sin(heading), math.cos(heading)])
    towards = -n if offset > 0 else n
    # right-hand: the traffic beside a kerb has the kerb on its right
    t = np.array([-towards[1], towards[0]]) * hand
    direction = 1 if t @ np.array([math.cos(heading), math.sin(heading)]) > 0 else -1
    return abs(offset), towards, heading, direction, "footway", "left" if offset > 0 else "right"


def person_spot(frame: Frame, street: Street, point: np.ndarray, rng: np.random.Generator,
                hand: int, hint: str | None = None) -> tuple[np.ndarray, float, Traffic] | Rejection:
    """A person on a footway: walking along it, or standing (waiting at the kerb facing the
    road, or by a door or a parked car facing the street). ``hint``: the pose the person's
    model was given before the placement (``walking`` / ``standing``, the cast's posing); None
    decides here by the place (near the kerb mostly waiting)."""
    kerb = footway_kerb(frame, street, point, hand)
    a, s = (float(v[0]) for v in street.to_road(point[None, :2]))
    if kerb is None:
        return Rejection("no footway direction", "no kerb near the footway")
    dist, towards, heading, _, where, side = kerb
    face_road = math.atan2(towards[1], towards[0])
    standing = rng.random() < (0.6 if dist <= KERB_WAIT else 0.2) if hint is None else hint == "standing"
    if standing:
        yaw = face_road + float(rng.uniform(-1, 1)) * math.radians(15 if dist <= KERB_WAIT else 35)
        direction, hint = None, "standing"
    else:
        forward = rng.random() < 0.5
        yaw = heading + (0.0 if forward else math.pi) + float(rng.uniform(-1, 1)) * math.radians(6)
        direction, hint = ("with" if forward else "against"), "walking"
    traffic = Traffic(hint, where, side, direction, a, s, math.degrees(heading), None, None, hint)
    return point, yaw, traffic


def sign_spot(frame: Frame, street: Street, point: np.ndarray, extents, rng: np.random.Generator, jitter: float,
              hand: int, hint: str | None = None) -> tuple[np.ndarray, float, Traffic] | Rejection:
    """A sign at the kerb's edge (its plate's edge ``SIGN_KERB`` from it), its face towards the
    traffic of the lane beside that kerb; with ``hint`` ``away`` (a sign that bars the traffic
    it faces: no entry), its back to the ego vehicle's direction, on either kerb: no driver
    going our way reads it, whose being there it would forbid."""
    kerb = footway_kerb(frame, street, point, hand)
    if kerb is None:
        return Rejection("no kerb for the sign", "no kerb near")
    dist, towards, heading, direction, where, side = kerb
    if dist > 3.0:
        return Rejection("sign too far from the kerb", f"{dist:.1f} m from it")
    # at the kerb's edge: moved there when it was drawn nearer, or more than SIGN_EDGE beyond
    near = sign_distance(extents)
    target = min(max(dist, near), near + SIGN_EDGE) if dist <= near + SIGN_EDGE else near + SIGN_EDGE / 2
    xy = point[:2] + towards * (dist - target)
    # the face (the model's +x) looks against the traffic that reads it
    faces = sign_faces(direction, hint)
    yaw = heading + (math.pi if faces > 0 else 0.0) + float(rng.uniform(-jitter, jitter))
    a, s = (float(v[0]) for v in street.to_road(xy[None]))
    traffic = Traffic("sign", where, side, "with" if faces > 0 else "against", a, s, math.degrees(heading),
                      pose_hint=hint if hint == "away" else None)
    return np.array([xy[0], xy[1], point[2]]), yaw, traffic


def traffic_candidates(frame: Frame, street: Street, xy: np.ndarray, orientation: str, extents,
                       hand: int) -> np.ndarray:
    """(N,) bool: which candidate ground points (N, 2) (V) can hold the object in traffic: a
    vehicle in a lane of its kind wide enough for it, or off the street's carriageways (a side
    street); a sign at a kerb's edge of the street (all of them where none is); a person on a
    footway, off the kerbs' stones and the carriageways."""
    a, s = street.to_road(xy)
    if orientation in ("along-road", "moving", "parked"):
        keep = np.zeros(len(s), bool)
        w = extents[1]
        ends = street_ends(frame, street)
        for lane in lanes(frame, street, hand):
            if ends and lane.carriageway == 0:  # a side street's (street_lane)
                continue
            ok = (lane.role == "moving" and orientation != "parked" and lane.width >= lane_room(w)) or \
                 (lane.role == "parking" and orientation != "moving"
                  and lane.width >= parking_fit(frame, street, lane, extents)[2] + PARK_GAP - 0.1)
            if ok:
                keep |= (s >= lane.right) & (s <= lane.left)
        if orientation != "parked":
            off = np.ones(len(s), bool)
            for k, cw in enumerate(street.carriageways):
                if not (ends and k == 0):  # a street that ends: its carriageway is a side street's
                    off &= (s < cw.right - 1.0) | (s > cw.left + 1.0)
            keep |= off
        return keep
    if orientation == "facing-traffic":
        near = np.zeros(len(s), bool)
        line = end_kerb(frame, street)
        if line is not None:  # the cross street's far footway, beyond the kerb across the view
            sd = sign_distance(extents)
            d = np.abs(line.offsets(xy))
            near |= past_end(frame, line, xy) & (d >= sd - 0.3) & (d <= sd + SIGN_EDGE + 0.3)
        for cw in street.carriageways:
            for kerb, side in ((cw.right, -1), (cw.left, 1)):
                d = side * (s - kerb)
                sd = sign_distance(extents)  # seen there, not only behind a car
                near |= (d >= sd - 0.3) & (d <= sd + SIGN_EDGE + 0.3)
        return near
    # people: on the footway, not on a kerb's stones or in a carriageway
    keep = np.ones(len(s), bool)
    for cw in street.carriageways:
        keep &= (s < cw.right - KERB_CLEARANCE - 0.1) | (s > cw.left + KERB_CLEARANCE + 0.1)
    line = end_kerb(frame, street)
    if line is not None:  # a street that ends: the cross street's far footway is across it
        keep |= past_end(frame, line, xy)
    return keep


def street_of(frame: Frame, traffic: str) -> Street:
    return find_street(frame, hand_of(traffic))
