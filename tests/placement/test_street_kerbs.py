"""The street's kerbs where a frame without labels finds no ground at the kerb itself: its stones
and a gutter under leaves are neither road nor footway (label 0) between the two."""
from __future__ import annotations

import numpy as np
import pytest

from synthcompose.geometry.depth import disparity_to_depth, make_frame, nearest_in_row
from synthcompose.labels import label_id
from synthcompose.placement import PlacementRules, place_object
from synthcompose.placement.road import GUTTER
from synthcompose.placement.street import find_street
from synthcompose.synthetic import random_scene, render_scene

from ..helpers import street_offset
from ..tolerances import STREET_KERB_M

W, H = 1024, 512


def _with_gutters(scene, arrays, width: float):
    """The frame, and the frame with the footway's first ``width`` metres beside the road along
    each row found as nothing (label 0), as on a frame without labels; and the drawn kerbs'
    offsets (right, left)."""
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    labels = arrays["label_ids"]
    frame = make_frame(depth, labels, scene.camera, photo=arrays["rgb"])
    last, first = nearest_in_row(labels == label_id("road"))
    cols = np.arange(labels.shape[1])[None, :]
    with np.errstate(invalid="ignore"):
        reach = width * scene.camera.fx / depth  # pixels along the row
        strip = (labels == label_id("sidewalk")) & ((cols - last <= reach) & (last >= 0)
                                                    | (first - cols <= reach) & (first < labels.shape[1]))
    assert strip.sum() > 2000  # the strip is there to be bridged
    gutters = np.where(strip, 0, labels).astype(labels.dtype)
    w = scene.road_half_width
    kerbs = street_offset(scene, frame, -w), street_offset(scene, frame, w)
    return frame, make_frame(depth, gutters, scene.camera, photo=arrays["rgb"]), kerbs


@pytest.mark.parametrize("seed", [0, 3, 5])
def test_a_kerb_is_found_across_a_strip_found_as_nothing(seed):
    """The kerbs are where the road ends, with 0.6 m of unfound ground before the footway: as
    with the footway found up to them. Before, the kerb was taken from a stretch far off where
    the road still touched the footway, or from the road's extent: 0.5-1.0 m out on these seeds
    (leverkusen_000030 of the street frames: its right kerb 1.3 m out, its signs drawn on the
    footway's back edge and none placed). A sign asked stands at the kerb."""
    scene = random_scene(np.random.default_rng([21, seed]), W, H, street="two-way")
    arrays = render_scene(scene)
    whole, gutters, (right, left) = _with_gutters(scene, arrays, 0.75 * GUTTER)
    for frame in (whole, gutters):
        ego = find_street(frame).ego
        assert abs(ego.right - right) <= STREET_KERB_M and abs(ego.left - left) <= STREET_KERB_M
    result = place_object(gutters, "traffic sign", (0.1, 0.65, 2.8), np.random.default_rng(seed),
                          PlacementRules(distance=(7.0, 40.0)))
    assert result.placement is not None, result.rejections
    assert result.placement.traffic.role == "sign"


def test_a_wider_strip_of_nothing_is_no_kerb():
    """Past :data:`GUTTER` metres of unfound ground the footway is not the road's kerb (a verge,
    a cycle track, a parked row's place): no kerb points are made across it."""
    from synthcompose.placement.road import _across_gutter

    lab = np.zeros((1, 40), np.uint8)
    lab[0, :10] = label_id("road")
    lab[0, 30:] = label_id("sidewalk")
    road = lab == label_id("road")
    side = lab == label_id("sidewalk")
    depth = np.full(lab.shape, 10.0, np.float32)
    fx = 10.0 / GUTTER * 25  # the road edge to the footway, 21 pixels at 10 m: 0.84 GUTTER
    assert _across_gutter(lab, road, side, depth, fx)[0].nonzero()[0].tolist() == [9]
    assert not _across_gutter(lab, road, side, depth, fx / 2).any()  # 1.6 GUTTER wide
    mirrored = [a[:, ::-1] for a in (lab, road, side, depth)]
    assert _across_gutter(*mirrored, fx)[0].nonzero()[0].tolist() == [30]


@pytest.mark.parametrize("seed", [0, 2])
def test_the_road_runs_on_under_and_behind_a_car_ahead(seed):
    """leverkusen_000048: a car 5.5 m ahead in the ego vehicle's lane hides the right kerb, seen
    only beside its back. Where no kerb line is found the carriageway ends where its road does;
    the ground under and behind the car is hidden, not off the road, so the road runs on to the
    kerb (it ended at the car's flank, 1 m right of the ego vehicle, leaving one lane over the
    whole carriageway's left: the oncoming half)."""
    from dataclasses import replace

    from synthcompose.synthetic.layout import _car_boxes

    scene = random_scene(np.random.default_rng([21, seed]), W, H, street="two-way")
    a0, b0 = (float(np.ravel(v)[0]) for v in scene.to_street(np.array([scene.camera.x]), np.array([scene.camera.y])))
    w0, w = scene.road_half_width, 3.6
    car = _car_boxes(np.random.default_rng(seed), a0 + 7.7, b0 - 0.9, 0.0, 1, label_id("car") * 1000)
    scene = replace(scene, road_half_width=w, sidewalk_width=scene.sidewalk_width + w0 - w, parking_lane=1.0,
                    boxes=tuple(box for box in scene.boxes if box.label != "car") + tuple(car), poles=())
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera,
                       photo=arrays["rgb"])
    street = find_street(frame)
    assert not any(line.kind == "kerb" and line.offset < 0 for line in street.lines)  # no kerb line on the right
    assert abs(street.ego.right - street_offset(scene, frame, -w)) <= STREET_KERB_M
