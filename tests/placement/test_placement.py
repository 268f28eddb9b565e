"""Placement on generated scenes whose geometry is known exactly."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from synthcompose.geometry.depth import disparity_to_depth, make_frame
from synthcompose.placement import ALLOWED_SURFACES, PlacementRules, frame_noise, place_object, prefilter, strict_inside
from synthcompose.synthetic import random_scene, render_scene

from ..helpers import SIZES
from ..tolerances import (
    CAR_YAW_TO_ROAD_DEG,
    FOOTPRINT_ALLOWED_MIN,
    FOOTPRINT_GAP_SLACK_M,
    PENETRATION_M,
    PREFILTER_MAX_SHARE,
    ground_z_tolerance,
)

W, H = 1024, 512


#: street geometries: flat and straight; turned, uphill and cambered; turned the other way, downhill
STREETS = {
    "flat": {},
    "turned-uphill-cambered": {"heading_deg": 15.0, "slope": 0.04, "camber": 0.025},
    "turned-downhill-cambered": {"heading_deg": -20.0, "slope": -0.05, "camber": 0.03},
}


@pytest.fixture(scope="module", params=[(name, seed) for name in STREETS for seed in (0, 1)],
                ids=lambda p: f"{p[0]}-{p[1]}")
def frame(request):
    name, seed = request.param
    scene = random_scene(np.random.default_rng([11, seed]), W, H, **STREETS[name])
    arrays = render_scene(scene)
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    return scene, arrays, make_frame(depth, arrays["label_ids"], scene.camera)


@pytest.mark.parametrize("cls", ["car", "person", "traffic sign"])
def test_placed_objects_stand_on_allowed_ground_and_hit_nothing(frame, cls):
    """The issue's limits, measured against the exact scene: footprint >= 95% on the allowed
    surface, ground gap <= 5 cm, no penetration beyond 5 cm, cars within 10 deg of the road."""
    scene, arrays, fr = frame
    rng = np.random.default_rng(3)
    rules = PlacementRules()
    placed = []
    for _ in range(2):
        res = place_object(fr, cls, SIZES[cls], rng, rules, others=placed)
        if res.placement is None and placed and cls == "car":
            # these scenes' camera drives on the centre line (no street kind): the street's
            # direction is untold and the lanes beyond the ego vehicle's take no car; a second
            # car where the near lanes have room
            break
        assert res.placement is not None, res.rejections
        p = res.placement
        placed.append(p)
        m, (l, w, h) = p.matrix, p.extents
        # footprint on the allowed surface, every point of it on the ground (dense grid)
        gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, 21) * l, np.linspace(-0.5, 0.5, 11) * w)
        foot = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) @ m[:3, :3].T + m[:3, 3]
        on_allowed = np.isin(scene.surface_label(foot[:, 0], foot[:, 1]), ALLOWED_SURFACES[cls])
        assert on_allowed.mean() >= FOOTPRINT_ALLOWED_MIN
        depth = float(fr.to_optical(m[:3, 3][None])[0, 2])
        assert np.abs(foot[:, 2] - scene.ground_height(foot[:, 0], foot[:, 1])).max() <= \
            ground_z_tolerance(frame_noise(fr), depth)
        # nothing of the scene deeper than 5 cm inside the object's box
        inset = 2 * PENETRATION_M
        gx, gy, gz = np.meshgrid(np.linspace(-0.5, 0.5, 9) * (l - inset), np.linspace(-0.5, 0.5, 5) * (w - inset),
                                 np.linspace(PENETRATION_M, h - PENETRATION_M, 6))
        vol = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()]) @ m[:3, :3].T + m[:3, 3]
        assert not scene.inside_objects(vol).any()
        assert rules.distance[0] <= p.distance <= rules.distance[1]
        if cls == "car":  # along the road: the heading against the street's true direction
            d = scene.road_direction(np.array([m[0, 3]]), np.array([m[1, 3]]))[0]
            off = math.degrees(abs(math.asin(math.sin(p.yaw - math.atan2(d[1], d[0])))))
            assert off <= CAR_YAW_TO_ROAD_DEG
    # objects of one frame keep their distance: footprints grown by half the gap do not overlap
    from synthcompose.placement import footprint_corners, footprints_overlap

    grown = [footprint_corners(p.matrix, p.extents, rules.object_gap / 2 - FOOTPRINT_GAP_SLACK_M) for p in placed]
    for i in range(len(grown)):
        for j in range(i + 1, len(grown)):
            assert not footprints_overlap(grown[i], grown[j])


def test_no_road_gives_no_valid_placement_not_a_crash():
    scene = random_scene(np.random.default_rng([11, 0]), W // 2, H // 2, road=False)
    arrays = render_scene(scene)
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    fr = make_frame(depth, arrays["label_ids"], scene.camera)
    res = place_object(fr, "car", SIZES["car"], np.random.default_rng(0), PlacementRules())
    assert res.placement is None
    assert any("no road pixel" in reason for reason in res.rejections)


def test_prefilter_keeps_every_point_the_strict_test_finds():
    rng = np.random.default_rng(4)
    pts = rng.uniform([-5, -5, -1], [5, 5, 3], (200_000, 3))
    from synthcompose.placement import pose_matrix

    m = pose_matrix(np.array([0.5, -0.3, 0.0]), np.array([0.05, 0.02, 1.0]), 0.7)
    ext = (4.4, 1.8, 1.5)
    all_inside = np.flatnonzero(strict_inside(pts, m, ext, 0.1, 0.1))
    suspects = prefilter(pts, m, ext, 0.1, 0.1)
    assert len(all_inside) > 100
    assert set(all_inside) <= set(suspects)
    assert len(suspects) < len(pts) * PREFILTER_MAX_SHARE


def test_collision_with_a_parked_car_is_found_by_both_searches(frame):
    """A box put over a parked car: the all-points pre-filter + strict test and the pixel-grid
    index + strict test find the same scene points inside it."""
    from synthcompose.placement import box_corners, pose_matrix

    scene, arrays, fr = frame
    car = next(b for b in scene.boxes if b.label == "car")
    centre = scene.points_to_vehicle(((np.array(car.lo) + np.array(car.hi)) / 2)[None])[0]
    ground = float(scene.ground_height(centre[0], centre[1]))
    m = pose_matrix(np.array([centre[0], centre[1], ground]), np.array([0, 0, 1.0]), scene.street_heading)
    pts = fr.cloud.vehicle
    sus = prefilter(pts, m, SIZES["car"], 0.12, 0.1)
    by_prefilter = strict_inside(pts[sus].astype(float), m, SIZES["car"], 0.12, 0.1).sum()
    rect = fr.box_rect(box_corners(m, SIZES["car"], 0.1))
    near, _ = fr.rect_points(*rect)
    by_grid = strict_inside(near, m, SIZES["car"], 0.12, 0.1).sum()
    assert by_prefilter == by_grid
    if (arrays["instance_ids"] == car.instance_id).sum() > 20:  # the camera sees the parked car
        assert by_grid > 10


def test_check_pose_accepts_what_placement_accepted_and_names_the_rule_a_moved_pose_breaks(frame):
    """check_pose (the preview's verdict on a pose moved by hand) runs the batch's own rules:
    every pose place_object accepted passes; lifted, pushed onto the other object, or into a
    parked car of the scene, it fails naming the rule."""
    from synthcompose.placement import RULE_OF, check_pose, pose_matrix

    scene, arrays, fr = frame
    rules = PlacementRules()
    rng = np.random.default_rng(5)
    placed = []
    for _ in range(2):
        res = place_object(fr, "car", SIZES["car"], rng, rules, others=placed)
        if res.placement is None and placed:  # a second car where the lanes have room (above)
            break
        assert res.placement is not None, res.rejections
        assert check_pose(fr, "car", SIZES["car"], res.placement.matrix, rules, others=placed) is None
        placed.append(res.placement)
    first = placed[0]
    lifted = first.matrix
    lifted[2, 3] += 0.5
    why = check_pose(fr, "car", SIZES["car"], lifted, rules)
    assert why is not None and why.rule in ("ground support", "ground plane"), why
    for step in (1.0, -1.0, 0.5, -0.5, 0.0):  # 1 m ahead of (or behind, or half a metre, or on it: where the ground
        # there holds it) the first car, on its plane
        onto = first.matrix
        onto[:3, 3] += step * onto[:3, 0]
        why = check_pose(fr, "car", SIZES["car"], onto, rules, others=[first])
        if why is None or why.reason == "overlaps another inserted object":
            break
    assert why is not None and why.reason == "overlaps another inserted object" and why.rule == "collision", why
    car = next(b for b in scene.boxes if b.label == "car")
    centre = scene.points_to_vehicle(((np.array(car.lo) + np.array(car.hi)) / 2)[None])[0]
    m = pose_matrix(np.array([centre[0], centre[1], float(scene.ground_height(centre[0], centre[1]))]),
                    np.array([0, 0, 1.0]), scene.street_heading)
    why = check_pose(fr, "car", SIZES["car"], m, rules)
    assert why is not None and why.rule in set(RULE_OF.values()) - {"min visible pixels"}, why
    assert str(why).startswith(f"{why.rule}: {why.reason}")


def test_a_pose_outside_the_distance_range_breaks_the_distance_rule(frame):
    """The placement draws its candidates within ``rules.distance``, then moves a vehicle to its
    lane's centre: the pose it returns must still lie in the range, and the checker says so
    (one rule set). A placed car checked against a range that ends 0.5 m short of it breaks
    the ``distance`` rule; against one 0.5 m beyond it, it passes."""
    from synthcompose.placement import check_pose

    scene, arrays, fr = frame
    rules = PlacementRules()
    res = place_object(fr, "car", SIZES["car"], np.random.default_rng(3), rules)
    p = res.placement
    assert p is not None and rules.distance[0] <= p.distance <= rules.distance[1]
    short = replace(rules, distance=(rules.distance[0], p.distance - 0.5))
    why = check_pose(fr, "car", SIZES["car"], p.matrix, short, claim=p.traffic)
    assert why is not None and why.rule == "distance" and why.reason == "outside the distance range", why
    wide = replace(rules, distance=(rules.distance[0], p.distance + 0.5))
    assert check_pose(fr, "car", SIZES["car"], p.matrix, wide, claim=p.traffic) is None
