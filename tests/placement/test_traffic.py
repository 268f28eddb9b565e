"""Traffic sense on generated streets laid out as traffic uses them (synthetic.streets): the
street found (centre line, kerbs, crossings), the lanes' directions, and where vehicles,
people and signs are placed, measured against the scene's exact layout."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from synthcompose.geometry.depth import back_project, disparity_to_depth, make_frame
from synthcompose.labels import label_id
from synthcompose.placement import PlacementRules, check_pose, footprint_corners, footprints_overlap, place_object
from synthcompose.placement.lanes import _carriageway_lanes, lanes
from synthcompose.placement.poses import PoseTests
from synthcompose.placement.rules import PERSON_STANCE, POLE_FOOT, standing_footprint
from synthcompose.placement.street import Carriageway, StreetLine, find_street
from synthcompose.placement.traffic import SIGN_EDGE, sign_distance
from synthcompose.synthetic import StreetKind, random_scene, render_scene

from ..helpers import SIZES, street_offset
from ..tolerances import CAR_YAW_TO_ROAD_DEG, LANE_CENTRED_M, STREET_CENTRE_M, STREET_KERB_M, TRAFFIC_PLACED_MIN

W, H = 1024, 512
RULES = PlacementRules(distance=(7.0, 40.0))


def _frame(kind: str, seed: int):
    scene = random_scene(np.random.default_rng([21, seed]), W, H, street=kind)
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera,
                       photo=arrays["rgb"])
    return scene, frame


@pytest.fixture(scope="module", params=[("two-way", 0), ("two-way", 1), ("one-way", 0), ("zebra", 0)],
                ids=lambda p: f"{p[0]}-{p[1]}")
def street(request):
    return _frame(*request.param)


def _facing_along(scene, yaw: float) -> int:
    """+1 when a heading points along the street (away from the camera), -1 against it."""
    return 1 if math.cos(yaw - scene.street_heading) > 0 else -1


def test_the_street_is_found_centre_line_and_kerbs(street):
    scene, frame = street
    st = find_street(frame)
    ego = st.ego
    w = scene.road_half_width
    assert abs(ego.right - street_offset(scene, frame, -w)) <= STREET_KERB_M
    assert abs(ego.left - street_offset(scene, frame, w)) <= STREET_KERB_M
    if StreetKind.of(scene.street_kind).one_way:
        assert ego.centre is None  # no centre line, the ego vehicle in the middle: one-way
    else:
        assert ego.centre is not None and abs(ego.centre - street_offset(scene, frame, 0.0)) <= STREET_CENTRE_M
    if scene.zebra is not None:
        assert any(c.start <= scene.zebra[1] + 1.0 and c.end >= scene.zebra[0] - 1.0 for c in st.crossings)


def _placed_in_turn(frame, class_name: str, n: int, seed: int, orientation: str | None = None) -> list:
    """Up to ``n`` objects of ``class_name`` placed one after the other, each with the ones
    placed before it standing (as a batch places them)."""
    rng = np.random.default_rng(seed)
    placed: list = []
    for _ in range(n):
        res = place_object(frame, class_name, SIZES[class_name], rng, RULES, orientation=orientation, others=placed)
        if res.placement is not None:
            placed.append(res.placement)
    return placed


@pytest.mark.parametrize("mode", ["along-road", "moving", "parked"])
def test_vehicles_face_their_lane_centred_never_across_a_marking(street, mode):
    """Right-hand traffic: right of the centre line (street b < 0) a vehicle faces along the
    street, left of it against; on a one-way street all along. A moving one is centred in its
    true lane (centre line, parking lines) and its footprint stays inside it; a parked one stands
    in the parking strip."""
    scene, frame = street
    kind = StreetKind.of(scene.street_kind)
    w, strip = scene.road_half_width, kind.depth
    asked = 4
    placed = _placed_in_turn(frame, "car", asked, 4, mode)
    for p in placed:
        a, b = (float(v) for v in scene.to_street(*p.position[:2]))
        corners = footprint_corners(p.matrix, p.extents)
        cb = np.array([float(scene.to_street(x, y)[1]) for x, y in corners])
        along = _facing_along(scene, p.yaw)
        want = 1 if kind.one_way or b < 0 else -1
        assert along == want, (p.traffic, a, b)
        assert p.traffic.direction == ("with" if want > 0 else "against")
        off = math.degrees(abs(math.remainder(p.yaw - scene.street_heading, math.pi)))
        assert off <= CAR_YAW_TO_ROAD_DEG
        if p.traffic.role == "moving":
            assert mode != "parked"
            # the true lanes: the centre line (two-way) and the parking lines bound them
            edges = [-(w - strip), w - strip] + ([] if kind.one_way else [0.0])
            lo = max([e for e in edges if e <= b], default=-(w - strip))
            hi = min([e for e in edges if e >= b], default=w - strip)
            if kind.one_way:  # two unmarked lanes: the street's own split
                lo, hi = (-(w - strip), 0.0) if b < 0 else (0.0, w - strip)
            assert abs(b - (lo + hi) / 2) <= LANE_CENTRED_M + 0.3 * kind.one_way, (b, lo, hi)
            assert cb.min() >= lo - 0.1 and cb.max() <= hi + 0.1, "across a lane marking"
        else:
            assert mode != "moving" and p.traffic.role == "parked"
            assert abs(b) >= w - strip - 0.1 and cb.min() >= -w - 0.1 and cb.max() <= w + 0.1
    if mode != "parked":  # free places at the kerb are few where the parked rows are dense
        assert len(placed) >= TRAFFIC_PLACED_MIN * asked, f"{len(placed)}/{asked} placed"


def test_people_stand_on_the_footway_walking_or_waiting(street):
    scene, frame = street
    placed = _placed_in_turn(frame, "person", 3, 6)
    for p in placed:
        corners = footprint_corners(p.matrix, p.extents)
        assert all(str(scene.surface_label(x, y)) == "sidewalk" for x, y in corners), "a person off the footway"
        assert p.pose_hint in ("walking", "standing")
        if p.pose_hint == "walking":  # along the footway, either way
            assert math.degrees(abs(math.remainder(p.yaw - scene.street_heading, math.pi))) <= CAR_YAW_TO_ROAD_DEG
    assert placed
    for i in range(len(placed)):
        for j in range(i + 1, len(placed)):
            a = footprint_corners(placed[i].matrix, placed[i].extents, 0.25)
            b = footprint_corners(placed[j].matrix, placed[j].extents, 0.25)
            assert not footprints_overlap(a, b), "people closer than 0.5 m"


def test_signs_at_the_kerb_facing_the_traffic_they_regulate(street):
    """A sign on the right kerb of a two-way street faces the camera (the drivers going along
    the street read it); on the left kerb it faces away (the oncoming drivers read it); on a
    one-way street both face the camera."""
    scene, frame = street
    kind = StreetKind.of(scene.street_kind)
    placed = _placed_in_turn(frame, "traffic sign", 2, 8)
    for p in placed:
        a, b = (float(v) for v in scene.to_street(*p.position[:2]))
        from_kerb = abs(b) - scene.road_half_width
        near = sign_distance(SIZES["traffic sign"])
        assert near - 0.4 <= from_kerb <= near + SIGN_EDGE + 0.4, from_kerb
        traffic = 1 if kind.one_way or b < 0 else -1
        assert _facing_along(scene, p.yaw) == -traffic  # the face looks at the drivers coming
    assert placed


def test_a_sign_that_bars_the_traffic_it_faces_turns_its_back_to_our_way(street):
    """No entry, no vehicles (the cast's ``faces: away``): facing the drivers going our way,
    such a sign would tell them (and the camera's car) they should not be there. It stands where
    any sign does, on either kerb, with its back to our way; the record says whose traffic it
    faces, and the checker agrees (the same pose claimed as an ordinary sign is wrong on the
    kerb whose traffic goes our way)."""
    scene, frame = street
    kind = StreetKind.of(scene.street_kind)
    ext = SIZES["traffic sign"]
    placed = [place_object(frame, "traffic sign", ext, np.random.default_rng(s), RULES, pose_hint="away").placement
              for s in range(3)]
    placed = [p for p in placed if p is not None]
    assert placed
    for p in placed:
        b = float(scene.to_street(*p.position[:2])[1])
        traffic = 1 if kind.one_way or b < 0 else -1  # the traffic of the lane beside it
        assert _facing_along(scene, p.yaw) == 1  # its face away from the camera
        assert p.traffic.direction == "against" and p.traffic.pose_hint == "away"
        assert check_pose(frame, "traffic sign", ext, p.matrix, RULES, claim=p.traffic) is None
        turned = replace(p.traffic, pose_hint=None)  # the same pose claimed as an ordinary sign
        why = check_pose(frame, "traffic sign", ext, p.matrix, RULES, claim=turned)
        if traffic > 0:
            assert why is not None and why.reason == "sign not facing its traffic"
        else:
            assert why is None


def test_the_cast_turns_no_entry_away_and_a_speed_limit_to_its_traffic():
    from synthcompose.cast import cast_model, load_catalogue
    from synthcompose.stages.place import _posed_as

    cat = load_catalogue()
    for sign, want in (("de-267", "away"), ("de-250", "away"), ("de-260", "away"), ("de-220-20", "away"),
                       ("de-274-50", None)):
        _, drawn = cast_model(cat.get(sign), None, np.random.default_rng(0))
        assert _posed_as(drawn, None) == want, sign


def test_signs_stand_on_grass_verges_and_islands_people_do_not(street):
    """Where the strip beside the kerb is grass (Cityscapes ``terrain``: a verge, a median
    island) instead of a footway, signs still stand at its kerb's edge facing the traffic they
    regulate; people, who walk on footways, are not put on it."""
    scene, frame = street
    grass = frame.label_ids.copy()
    grass[grass == label_id("sidewalk")] = label_id("terrain")
    verge = make_frame(frame.depth, grass, frame.camera, photo=frame.photo)
    placed = _placed_in_turn(verge, "traffic sign", 2, 8)
    assert placed
    for p in placed:
        b = float(scene.to_street(*p.position[:2])[1])
        near = sign_distance(SIZES["traffic sign"])
        assert near - 0.4 <= abs(b) - scene.road_half_width <= near + SIGN_EDGE + 0.4
    assert not _placed_in_turn(verge, "person", 1, 6)


def test_a_sign_needs_ground_under_its_pole_not_under_its_plate(street):
    """A sign stands on its pole: the support asked (placement's and the checker's) is the
    pole's foot, so its plate may reach over a verge's edge or a hedge's foot; a car's whole
    footprint needs ground."""
    _, frame = street
    sign, car = SIZES["traffic sign"], SIZES["car"]
    assert standing_footprint("traffic sign", sign) == (min(sign[0], POLE_FOOT), POLE_FOOT)
    assert standing_footprint("car", car) == car[:2]
    grid = PoseTests.of(frame, sign, RULES, ("sidewalk",), "traffic sign").grid
    reach = POLE_FOOT / 2 + RULES.footprint_margin
    assert np.abs(grid[:, 1]).max() <= reach + 1e-9 < sign[1] / 2
    placed = _placed_in_turn(frame, "traffic sign", 2, 8)
    assert placed and all(check_pose(frame, "traffic sign", sign, p.matrix, RULES) is None for p in placed)


def test_signs_and_people_stand_plumb_vehicles_lie_on_the_ground():
    """On a street climbing 6 % and cambered, a sign's pole and a person stand plumb (gravity);
    a car's axes follow the road's plane."""
    scene = random_scene(np.random.default_rng([21, 0]), W, H, street="two-way", slope=0.06)
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera,
                       photo=arrays["rgb"])
    for cls in ("traffic sign", "person"):
        placed = _placed_in_turn(frame, cls, 2, 8)
        assert placed and all(np.allclose(p.matrix[:3, 2], (0.0, 0.0, 1.0)) for p in placed), cls
    cars = _placed_in_turn(frame, "car", 2, 8)
    assert cars and all(math.degrees(math.acos(p.matrix[2, 2])) > 1.5 for p in cars)


def test_left_hand_traffic_mirrors_the_directions():
    """The ego vehicle's lane goes with it; the lanes across the centre line (left of it for
    right-hand traffic, right of it for left-hand) come towards it."""
    right_hand = Carriageway(-1.6, 4.8, (StreetLine(1.6, "dashed", 5.0, 40.0, 20.0),), 1.6, 0, "marking")
    left_hand = Carriageway(-4.8, 1.6, (StreetLine(-1.6, "dashed", 5.0, 40.0, 20.0),), -1.6, 0, "marking")
    assert [lane.direction for lane in _carriageway_lanes(right_hand, 0, 1, {})] == [1, -1]
    assert [lane.direction for lane in _carriageway_lanes(left_hand, 0, -1, {})] == [-1, 1]


def test_where_nothing_tells_the_direction_the_ego_lane_keeps_right_and_reaches_half_a_lane_past_it():
    """leverkusen_000048: a car ahead hides the right kerb and the ego vehicle straddles a centre
    line the markings missed; the carriageway left is one 4 m "lane" from the car ahead to a
    strip along the verge, whose left part is the oncoming half (a real car comes towards us
    there). Where nothing tells the direction, the ego vehicle's lane reaches half a lane to the
    oncoming side and the rest is ``untold``; traffic keeps right, so it is at most a lane wide
    from its kerb's side; left-hand traffic mirrors it; a dual road's other half beyond the
    oncoming kerb tells the direction, and the lane is whole."""
    strip = StreetLine(2.98, "dashed", 9.0, 20.0, 4.0)
    cw = Carriageway(-1.0, 3.55, (strip,), None, 0, "one-way")
    got = [(ln.role, ln.right, ln.left) for ln in _carriageway_lanes(cw, 0, 1, {}, ego_s=-0.04)]
    assert got == [("moving", -1.0, pytest.approx(1.835)), ("untold", pytest.approx(1.835), 2.98),
                   ("none", 2.98, 3.55)]
    mirrored = Carriageway(-3.55, 1.0, (StreetLine(-2.98, "dashed", 9.0, 20.0, 4.0),), None, 0, "one-way")
    got = [(ln.role, ln.right, ln.left) for ln in _carriageway_lanes(mirrored, 0, -1, {}, ego_s=0.04)]
    assert got == [("none", -3.55, -2.98), ("untold", -2.98, pytest.approx(-1.835)),
                   ("moving", pytest.approx(-1.835), 1.0)]
    # traffic keeps right: the lane is at most a lane's width (3.75 m) from its kerb's side
    wide = Carriageway(-2.5, 3.55, (strip,), None, 0, "one-way")
    got = [(ln.role, ln.right, ln.left) for ln in _carriageway_lanes(wide, 0, 1, {}, ego_s=-0.04)]
    assert got[0] == ("moving", -2.5, pytest.approx(1.25)) and got[1][0] == "untold"
    dual = [(ln.role, ln.right, ln.left) for ln in _carriageway_lanes(cw, 0, 1, {}, ego_s=-0.04, dual=True)]
    assert dual == [("moving", -1.0, 2.98), ("none", 2.98, 3.55)]
    # a lane that reaches less than half a lane and a little to the ego vehicle's left is whole
    narrow = Carriageway(-1.6, 1.85, (), None, 0, "one-way")
    assert [ln.role for ln in _carriageway_lanes(narrow, 0, 1, {}, ego_s=0.15)] == ["moving"]


def test_a_street_without_a_sign_of_its_direction_has_no_vehicle_beyond_the_ego_lane():
    """No centre line and the ego vehicle not keeping right of the middle: the street is taken
    as one-way, but it may be a two-way street whose left half comes towards us. The lanes
    beyond the ego vehicle's own lane on that side are ``untold`` (no vehicle, either way); on
    a marked street the same lanes are moving lanes against us; left-hand traffic mirrors it."""
    unmarked = Carriageway(-4.1, 4.3, (StreetLine(3.7, "dashed", 13.0, 18.0, 5.0),), None, 0, "one-way")
    got = [(ln.role, ln.direction) for ln in _carriageway_lanes(unmarked, 0, 1, {}, ego_s=-0.26)]
    assert got == [("moving", 1), ("untold", 1), ("none", 1)]
    mirrored = Carriageway(-4.3, 4.1, (StreetLine(-3.7, "dashed", 13.0, 18.0, 5.0),), None, 0, "one-way")
    assert [ln.role for ln in _carriageway_lanes(mirrored, 0, -1, {}, ego_s=0.26)] == ["none", "untold", "moving"]
    marked = Carriageway(-4.1, 4.3, (StreetLine(0.5, "dashed", 6.0, 40.0, 20.0),), 0.5, 0, "marking")
    assert [(ln.role, ln.direction) for ln in _carriageway_lanes(marked, 0, 1, {}, ego_s=-2.0)] == \
        [("moving", 1), ("moving", -1)]
    # the same on the generated one-way street, found from its photo: every vehicle the placement
    # returns stands in the ego vehicle's lane or on its kerb's side, and the checker agrees
    scene, frame = _frame("one-way", 0)
    street = find_street(frame)
    found = lanes(frame, street, 1)
    assert street.ego.centre is None and any(ln.role == "untold" for ln in found)
    ego = min((ln for ln in found if ln.role == "moving"),
              key=lambda ln: max(ln.right - street.ego_offset, street.ego_offset - ln.left, 0.0))
    cars = []
    for mode in ("along-road", "moving", "parked"):
        for p in _placed_in_turn(frame, "car", 4, 4, mode):
            assert p.traffic.lateral_m <= ego.left + 1e-6, (mode, p.traffic)
            assert check_pose(frame, "car", SIZES["car"], p.matrix, RULES, orientation=mode, claim=p.traffic) is None
            cars.append(p)
    assert cars  # the ego vehicle's side still takes them


def test_the_generated_street_kinds_keep_the_earlier_streets():
    """Without a street kind the scene is the one earlier versions drew; with one, the ego
    vehicle keeps right of the centre line, and one-way streets draw none."""
    plain = random_scene(np.random.default_rng([21, 0]), W, H)
    again = random_scene(np.random.default_rng([21, 0]), W, H, street=None)
    assert plain == again and plain.street_kind is None and plain.centre_line
    two = random_scene(np.random.default_rng([21, 0]), W, H, street="two-way")
    cam_b = float(two.to_street(two.camera.x, two.camera.y)[1])
    assert -2.0 < cam_b < -1.2
    assert not random_scene(np.random.default_rng([21, 0]), W, H, street="one-way").centre_line
    with pytest.raises(ValueError):
        random_scene(np.random.default_rng([21, 0]), W, H, street="roundabout")


def test_a_person_over_a_side_streets_carriageway_is_rejected():
    """A side street's far kerb seen at 37 m: its pixels under a person's feet are sidewalk, but
    the stereo puts them 3 m short, over the side street's carriageway. The person may not stand
    there (the check and so the placement reject it); the same person on the footway passes."""
    from synthcompose.placement.boxes import pose_matrix
    from synthcompose.placement.verdict import on_carriageway

    scene = random_scene(np.random.default_rng([11, 1]), W, H)
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera)
    over = np.array([36.59, 5.88])
    assert str(scene.surface_label(*over)) == "road" and scene.in_crossing(*over)
    up = np.array([0.0, 0.0, 1.0])
    why = on_carriageway(frame, pose_matrix(np.array([*over, 0.167]), up, -3.1), SIZES["person"])
    assert why is not None and why.reason == "on the carriageway"
    on_footway = np.array([20.49, 6.91])
    assert str(scene.surface_label(*on_footway)) == "sidewalk"
    assert on_carriageway(frame, pose_matrix(np.array([*on_footway, 0.148]), up, -3.07), SIZES["person"]) is None


def test_no_vehicle_in_the_lanes_of_a_street_that_ends_ahead():
    # a T-junction seen head-on: a house front across the street 17 m ahead. The axis found
    # along the view is no street anyone drives along (leverkusen_000045: a car faced the house)
    from dataclasses import replace

    from synthcompose.placement.ends import street_ends
    from synthcompose.synthetic.scene import Box

    scene = random_scene(np.random.default_rng([21, 0]), W, H, street="two-way")
    cam_a = float(scene.camera.x)
    house = Box((cam_a + 17.0, -30.0, 0.0), (cam_a + 25.0, 30.0, 9.0), "building", label_id("building"),
                texture="facade")
    ended = replace(scene, boxes=tuple(scene.boxes) + (house,))
    for s, ends in ((scene, False), (ended, True)):
        arrays = render_scene(s)
        frame = make_frame(disparity_to_depth(arrays["disparity"], s.camera), arrays["label_ids"], s.camera,
                           photo=arrays["rgb"])
        assert street_ends(frame, find_street(frame)) is ends
        if ends:
            for seed in range(3):
                got = place_object(frame, "car", (4.4, 1.8, 1.5), np.random.default_rng(seed), RULES)
                assert got.placement is None or got.placement.traffic.where != "carriageway"


def test_a_person_needs_the_footway_under_their_feet_not_under_their_arms(street):
    """A walking person's box is as wide as their swinging arms (0.75 m here); only their feet
    (standing_footprint: at most PERSON_STANCE wide) need the footway and the kerb's clearance.
    A footway narrowed to 1.1 m between its kerb and a verge (too narrow for the whole box and
    the clearance on both sides) still holds them within 25 m (farther, the stereo's depth band
    is wider than the footway), feet on it, and the checker agrees."""
    scene, frame = street
    walker = (0.8, 0.75, 1.75)
    assert standing_footprint("person", walker) == (0.8, PERSON_STANCE)
    labels = frame.label_ids.copy()
    v, u = np.nonzero((labels == label_id("sidewalk")) & np.isfinite(frame.depth))
    _, xyz = back_project(frame.depth, frame.camera, v, u)
    beyond = np.abs(scene.to_street(xyz[:, 0], xyz[:, 1])[1]) > scene.road_half_width + 1.1
    labels[v[beyond], u[beyond]] = label_id("terrain")
    narrow = make_frame(frame.depth, labels, frame.camera, photo=frame.photo)
    rng, rules = np.random.default_rng(3), PlacementRules(distance=(7.0, 25.0))
    placed = [r.placement for r in (place_object(narrow, "person", walker, rng, rules, pose_hint="walking")
                                    for _ in range(3)) if r.placement is not None]
    assert placed
    for p in placed:
        feet = footprint_corners(p.matrix, standing_footprint("person", walker))
        assert all(str(scene.surface_label(x, y)) == "sidewalk" for x, y in feet), "a foot off the footway"
        assert check_pose(narrow, "person", walker, p.matrix, rules) is None


def _t_junction(seed: int):
    """A T-junction seen head-on, near (leverkusen_000045's layout): a street 7 m wide whose road
    ends 15 m ahead at the far kerb of a cross street 6 m wide (``street_end``), the footway
    beyond 2.5 m deep, a house front across behind it. The far footway's paving gets the
    asphalt's colours (pixels of the road drawn at random): only its kerb tells it from the road.
    Returns the scene, its rendered arrays and the far footway's pixels."""
    from dataclasses import replace

    from synthcompose.synthetic.scene import Box

    scene = random_scene(np.random.default_rng([21, seed]), W, H)
    a0 = float(scene.camera.x)
    end, walk = a0 + 15.0, 2.5
    house = Box((end + walk, -40.0, -1.0), (end + walk + 8.0, 40.0, 9.0), "building", label_id("building"),
                texture="facade")
    scene = replace(scene, road_half_width=3.5, sidewalk_width=walk, parking_lane=1.0, boxes=(house,), poles=(),
                    crossing=(a0 + 9.0, end), street_end=end)
    arrays = render_scene(scene, stereo="realistic", photo="realistic")
    truth = arrays["label_ids"]
    z = disparity_to_depth(arrays["disparity"], scene.camera)
    v, u = np.nonzero((truth == label_id("sidewalk")) & np.isfinite(z))
    _, xyz = back_project(z, scene.camera, v, u)
    a, b = scene.to_street(xyz[:, 0], xyz[:, 1])
    far = (a > end + 0.05) & (np.abs(b) < 8.0)
    footway = np.zeros(truth.shape, bool)
    footway[v[far], u[far]] = True
    rgb = arrays["rgb"].copy()
    road = np.argwhere((truth == label_id("road")) & (z > 8.0) & (z < end))
    pick = road[np.random.default_rng(seed).integers(len(road), size=int(footway.sum()))]
    rgb[footway] = rgb[pick[:, 0], pick[:, 1]]
    return scene, dict(arrays, rgb=rgb), footway


@pytest.mark.parametrize("seed", [0, 1])
def test_a_street_that_ends_at_a_t_junction_has_its_far_footway_found_and_used(seed):
    """At a T-junction seen head-on the far footway runs across the view, paved like the road:
    without labels it is found by its kerb across the view (kerbs_ahead.py), and people and
    signs stand there (the street's own carriageway runs into the cross street: no lane of it
    holds them, the kerb across does), on the footway, as the checker agrees."""
    from synthcompose.placement.ends import end_kerb, street_ends
    from synthcompose.placement.surfaces import SIDEWALK, find_surfaces

    scene, arrays, footway = _t_junction(seed)
    found = find_surfaces(arrays["disparity"], arrays["rgb"], scene.camera).labels
    assert footway.sum() > 2000
    assert (found[footway] == SIDEWALK).mean() > 0.25, "the far footway is not found"
    assert (found[footway] == label_id("road")).mean() < 0.05, "the far footway is taken for road"
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), found, scene.camera, labelled=False,
                       photo=arrays["rgb"])
    street = find_street(frame)
    assert street_ends(frame, street) and end_kerb(frame, street) is not None
    end = scene.street_end
    for cls, size in (("person", SIZES["person"]), ("traffic sign", SIZES["traffic sign"])):
        got = [place_object(frame, cls, size, np.random.default_rng(k), RULES) for k in range(2)]
        placed = [g.placement for g in got if g.placement is not None]
        assert placed, f"no {cls} placed: {got[0].rejections}"
        for p in placed:
            a, _ = scene.to_street(*np.asarray(p.matrix)[:2, 3])
            assert end < a < end + scene.sidewalk_width, f"a {cls} off the far footway ({a - end:.2f} m past the kerb)"
            assert p.traffic.where == "footway"
            assert check_pose(frame, cls, size, p.matrix, RULES) is None


def test_the_record_says_where_the_street_ends():
    """The record's street says where a street ends (``end``: the kerb across it), so that a
    person on the T-junction's far footway is measured off the carriageway from the record alone
    (eval_traffic.py: a person there on leverkusen_000045 was counted on the ego carriageway,
    its lateral offset inside the carriageway's kerbs); a point short of that kerb is still on
    the street, and a street that goes on records no end."""
    from synthcompose.placement.ends import end_record, past_recorded_end
    from synthcompose.placement.surfaces import find_surfaces

    scene, arrays, _ = _t_junction(0)
    found = find_surfaces(arrays["disparity"], arrays["rgb"], scene.camera).labels
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), found, scene.camera, labelled=False,
                       photo=arrays["rgb"])
    street = find_street(frame)
    record = street.to_dict() | {"end": end_record(frame, street)}
    assert record["end"] is not None and record["end"]["kerb"] is not None
    end = scene.street_end
    for a, beyond in ((end + scene.sidewalk_width / 2, True), (end - 3.0, False), (end - 8.0, False)):
        x, y = scene.to_vehicle(a, 0.0)
        assert past_recorded_end(record, x, y) == beyond, (a - end, beyond)
    placed = place_object(frame, "person", SIZES["person"], np.random.default_rng(0), RULES).placement
    assert placed is not None and past_recorded_end(record, *np.asarray(placed.matrix)[:2, 3])

    plain = random_scene(np.random.default_rng([21, 0]), W, H)
    arrays = render_scene(plain, stereo="realistic", photo="realistic")
    found = find_surfaces(arrays["disparity"], arrays["rgb"], plain.camera).labels
    frame = make_frame(disparity_to_depth(arrays["disparity"], plain.camera), found, plain.camera, labelled=False,
                       photo=arrays["rgb"])
    assert end_record(frame, find_street(frame)) is None


def test_no_kerb_across_the_view_where_the_street_goes_on(monkeypatch):
    """The kerb across the view is taken only where the street ends: not on streets going on past
    their cross street, and not on the T-junction with its house taken away (a raised table or
    an island across the road leaves the road beyond it open: nothing stands across it)."""
    from dataclasses import replace

    from synthcompose.placement import kerbs_ahead, surfaces

    seen = []

    def spy(ground, flat, z, y, band):
        seen.append(kerbs_ahead.find_kerb_ahead(ground, flat, z, y))
        return kerbs_ahead.kerb_ahead(ground, flat, z, y, band)

    monkeypatch.setattr(surfaces, "kerb_ahead", spy)
    for seed in (0, 1):
        scene = random_scene(np.random.default_rng([21, seed]), W, H, street="two-way")
        arrays = render_scene(scene, stereo="realistic", photo="realistic")
        surfaces.find_surfaces(arrays["disparity"], arrays["rgb"], scene.camera)
        ended, _, _ = _t_junction(seed)
        open_end = replace(ended, boxes=())
        arrays = render_scene(open_end, stereo="realistic", photo="realistic")
        surfaces.find_surfaces(arrays["disparity"], arrays["rgb"], open_end.camera)
    assert seen == [None] * 4


def _box_in_front(frame, sign, extents, nearer: float, class_name: str):
    """A box of ``extents`` on the line from the camera to ``sign``'s foot, its centre
    ``nearer`` metres nearer the camera, lengthwise along that line."""
    foot = sign.matrix[:3, 3]
    away = foot[:2] - frame.camera.position[:2]
    away /= np.linalg.norm(away)
    m = np.eye(4)
    m[:2, 0], m[:2, 1] = away, (-away[1], away[0])
    m[:3, 3] = (*(foot[:2] - nearer * away), foot[2])
    return replace(sign, class_name=class_name, extents=tuple(extents), vehicle_from_object=tuple(map(tuple, m)))


def test_a_sign_may_stand_behind_a_car_that_hides_its_pole_never_its_plate():
    """A driver reads a sign's plate over a car parked in front of its pole, as at real kerbs:
    the rule that no inserted object hides a sign is about its plate (the top SIGN_PLATE of
    it). A car 4 m nearer on the line of sight hides the pole and leaves the sign placeable,
    placed before it or after it; a lorry there hides the plate (and most of the sign), and the
    sign is rejected either way round. Before, the car rejected the sign too (half its box
    hidden): substitutes drawn after the frame's cars found no kerb left (leverkusen_000031,
    000034, 000055)."""
    _, frame = _frame("two-way", 0)
    sign = _placed_in_turn(frame, "traffic sign", 1, 8)[0]
    assert sign.distance > 10.0
    signs = PoseTests.of(frame, sign.extents, RULES, ("sidewalk",), "traffic sign")
    assert signs.visibility(sign.matrix, [])[0] is None
    car = _box_in_front(frame, sign, SIZES["car"], 4.0, "car")
    lorry = _box_in_front(frame, sign, (6.0, 2.4, 3.4), 4.0, "truck")
    assert signs.visibility(sign.matrix, [car])[0] is None
    assert signs.visibility(sign.matrix, [lorry])[0] is not None
    for other in (car, lorry):
        tests = PoseTests.of(frame, other.extents, RULES, ("road",), other.class_name)
        assert (tests.visibility(other.matrix, [sign])[0] is None) == (other is car)
