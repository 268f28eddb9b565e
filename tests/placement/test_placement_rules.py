"""Placement rules end to end: occlusion by the real scene, visibility rules, unlabelled
frames, class balancing, disparity holes and the check-placement report."""
from __future__ import annotations

import json

import numpy as np
import pytest

from synthcompose.cli import main
from synthcompose.compose import Composer, SceneLayers
from synthcompose.geometry.depth import disparity_to_depth, make_frame
from synthcompose.labels import label_id
from synthcompose.models import load_model
from synthcompose.placement import PlacementRules, frame_noise, place_object
from synthcompose.placement.frequency import count_classes, object_weights
from synthcompose.placement.surfaces import find_surfaces
from synthcompose.render import Lighting, Renderer, RenderObject
from synthcompose.synthetic import make_sample, random_scene, render_scene

from ..helpers import SIZES, H, W, pose_behind_a_pole, write_manifest
from ..tolerances import (
    BALANCE_FAVOURS_RATIO,
    CAR_YAW_TO_ROAD_DEG,
    GROUND_Z_M,
    OCCLUSION_DEPTH_MARGIN_M,
    ROAD_FOUND_PRECISION_MIN,
    ROAD_FOUND_RECALL_MIN,
    ground_z_tolerance,
)

POLE, CAR, ROAD = label_id("pole"), label_id("car"), label_id("road")


def test_real_pole_in_front_hides_the_inserted_car(gl_clean):
    scene = random_scene(np.random.default_rng([11, 0]), 1024, 512)
    arrays = render_scene(scene)
    cam = scene.camera
    depth = disparity_to_depth(arrays["disparity"], cam)
    m = pose_behind_a_pole(scene)
    model = load_model("builtin:box", (("length", 1.6),))
    renderer, composer = Renderer(gl_clean), Composer(gl_clean)
    passes = renderer.render(cam, [RenderObject(model, m, (0.2, 0.2, 0.2))], Lighting.daylight(), photo=arrays["rgb"])
    ids, id_depth = passes.read("id"), passes.read("id_depth")
    rows, cols = passes.roi.slices
    scene_layers = SceneLayers(arrays["rgb"], arrays["label_ids"], arrays["instance_ids"].astype(np.int32),
                               arrays["disparity"], depth, cam.baseline * cam.fx * 256)
    out = composer.compose(passes, scene_layers, [CAR], [CAR * 1000 + 99])
    renderer.release(passes)
    obj = ids > 0
    real_d = depth[rows, cols]
    in_front = obj & (real_d < id_depth - OCCLUSION_DEPTH_MARGIN_M)  # the real scene is clearly nearer
    behind_ = obj & (real_d > id_depth + OCCLUSION_DEPTH_MARGIN_M)
    assert (arrays["label_ids"][rows, cols][in_front] == POLE).sum() > 5, "the pole should cover part of the car"
    assert (out.label_ids[rows, cols][in_front] == arrays["label_ids"][rows, cols][in_front]).all()
    assert (out.rgb[rows, cols][in_front] == arrays["rgb"][rows, cols][in_front]).all()
    assert (out.label_ids[rows, cols][behind_] == CAR).all()


@pytest.fixture(scope="module")
def holes_frame():
    scene = random_scene(np.random.default_rng([11, 1]), 1024, 512)
    arrays = render_scene(scene)
    disp = arrays["disparity"].copy()
    disp[np.random.default_rng(0).random(disp.shape) < 0.15] = 0  # 15% holes, as on real stereo
    return scene, make_frame(disparity_to_depth(disp, scene.camera), arrays["label_ids"], scene.camera)


def test_placement_with_many_disparity_holes(holes_frame):
    scene, frame = holes_frame
    rng = np.random.default_rng(1)
    noise = frame_noise(frame)
    for cls in ("car", "person"):
        res = place_object(frame, cls, SIZES[cls], rng, PlacementRules())
        assert res.placement is not None, res.rejections
        x, y, z = res.placement.position
        # the generated disparity is SGM-like: the height is known to the stereo error at that depth
        depth = float(frame.to_optical(np.array([[x, y, z]]))[0, 2])
        assert abs(z - float(scene.ground_height(x, y))) <= ground_z_tolerance(noise, depth)


def test_visibility_rules_are_enforced(holes_frame):
    scene, frame = holes_frame
    strict = PlacementRules(max_occluded_fraction=0.0, min_visible_pixels=4000)
    for seed in range(3):
        res = place_object(frame, "car", SIZES["car"], np.random.default_rng(seed), strict)
        if res.placement is None:
            assert res.rejections
            continue
        assert res.placement.occluded_estimate == 0.0
        assert not res.placement.truncated


def test_truncation_allowed_lets_objects_cross_the_border(holes_frame):
    scene, frame = holes_frame
    rules = PlacementRules(allow_truncation=True, distance=(4.0, 12.0), max_attempts=400)
    truncated = [place_object(frame, "car", SIZES["car"], np.random.default_rng(s), rules).placement
                 for s in range(8)]
    assert any(p is not None and p.truncated for p in truncated)


def test_unlabelled_frame_finds_the_road_from_disparity():
    scene = random_scene(np.random.default_rng([11, 2]), 1024, 512)
    arrays = render_scene(scene)
    labels = find_surfaces(arrays["disparity"], arrays["rgb"], scene.camera).labels
    road = labels == ROAD
    true_road = arrays["label_ids"] == ROAD
    assert (true_road[road]).mean() > ROAD_FOUND_PRECISION_MIN  # what it calls road is road
    assert road[true_road].mean() > ROAD_FOUND_RECALL_MIN  # and it finds most of it


def test_unlabelled_image_sets_in_a_batch(tmp_path):
    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=W, height=H, seed=4)
    for kind in ("labelIds", "instanceIds", "color"):
        ids[0].path(root, kind).unlink()  # like the test split without gtFine
    placeholder = ids[1].path(root, "labelIds")
    import cv2

    cv2.imwrite(str(placeholder), np.zeros((H, W), np.uint8))  # placeholder labels: nothing marked
    out = tmp_path / "out"
    # a box of a car's size (a 4 m cube fits no lane)
    manifest = write_manifest(tmp_path / "m.json", root, out, objects=[
        {"model": "builtin:box", "class": "car", "size": {"width": 1.8}}])
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    for ident in ids:
        record = json.loads(ident.path(out, "record").read_text())
        assert record["status"] == "done", record
        assert record["labels"]["source"].startswith("none")
        obj = record["objects"][0]
        m = np.array(obj["pose"]["vehicle"]["matrix"])
        assert abs(m[2, 3]) < GROUND_Z_M  # on the road plane z = 0
    labels = cv2.imread(str(ids[0].path(out, "labelIds")), cv2.IMREAD_UNCHANGED)
    assert set(np.unique(labels)) <= {0, CAR}


def test_balance_favours_classes_the_dataset_lacks(tmp_path):
    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=320, height=160, seed=3)
    counts = count_classes(root, ids)
    assert counts.get("car", 0) >= 2 and counts.get("truck", 0) == 0
    p = object_weights([1.0, 1.0], ["car", "truck"], "balance", counts)
    assert p[1] > p[0] * BALANCE_FAVOURS_RATIO
    assert np.allclose(object_weights([1.0, 3.0], ["car", "truck"], "weights"), [0.25, 0.75])


def test_check_placement_reports_every_object_within_limits(tmp_path, capsys):
    root = tmp_path / "cs"
    make_sample(root, count=2, width=W, height=H, seed=8)
    out = tmp_path / "out"
    main(["batch", str(write_manifest(tmp_path / "m.json", root, out)), "--no-progress"])
    capsys.readouterr()
    assert main(["check-placement", str(out), "--strict"]) == 0
    report = json.loads((out / "placement_check.json").read_text())
    assert report["objects"] and all(not o["failures"] for o in report["objects"])
    cars = [o for o in report["objects"] if o["name"] == "car"]
    assert cars and all(o["yaw_to_road_deg"] is not None and o["yaw_to_road_deg"] <= CAR_YAW_TO_ROAD_DEG for o in cars)
    assert "objects checked" in capsys.readouterr().out


def test_the_checkers_ground_gap_takes_a_plumb_person_at_its_foot_and_a_car_at_its_corners():
    """A person (or a pole) stands plumb on a slope (placement/search.py): its box's corners are
    off the sloping plane by the slope, its foot is on it; a car lies on the plane. The checker
    measures each where it touches the ground, and still sees either one floating."""
    import math

    from synthcompose.placement.boxes import footprint_grid, pose_matrix
    from synthcompose.placement.ground import GroundFit
    from synthcompose.tools.check import LIMITS, ground_gap

    slope = math.tan(math.radians(8.0))
    normal = np.array([-slope, 0.0, 1.0]) / math.hypot(slope, 1.0)
    fit = GroundFit((slope, 0.0, 0.0), 0.01, normal)  # z = tan(8 deg) x
    at = np.array([10.0, 2.0, 10.0 * slope])
    person = pose_matrix(at, np.array([0.0, 0.0, 1.0]), 0.3)  # plumb
    car = pose_matrix(at, normal, 0.3)  # on the plane
    assert ground_gap(fit, person, footprint_grid(0.6, 0.6), "person") < 1e-9
    assert ground_gap(fit, car, footprint_grid(4.4, 1.8), "car") < 1e-9
    # the person's box corners are off the plane by the slope: measured so, it would fail
    assert ground_gap(fit, person, footprint_grid(0.6, 0.6), "car") > LIMITS["ground_gap_m"] - 0.01
    lifted = person.copy()
    lifted[2, 3] += 0.08
    assert ground_gap(fit, lifted, footprint_grid(0.6, 0.6), "person") > LIMITS["ground_gap_m"]


def test_candidates_whose_top_leaves_the_image_are_only_spots_every_pose_rejects():
    """A tall sign near the camera leaves the image at the top (a 3 m sign needs about 10 m on
    Cityscapes' camera): placement draws no candidate whose top is out of the image even a metre
    further away. The filter only spares attempts: every candidate it leaves out, posed level
    where it was drawn at any heading, is "not fully inside the image"; and it leaves in the spots
    further away."""
    from synthcompose.placement.boxes import pose_matrix
    from synthcompose.placement.poses import PoseTests
    from synthcompose.placement.search import candidates

    scene = random_scene(np.random.default_rng([30, 3]), 1024, 512)  # a footway from 7 m
    arrays = render_scene(scene)
    frame = make_frame(disparity_to_depth(arrays["disparity"], scene.camera), arrays["label_ids"], scene.camera)
    extents = (0.13, 0.6, 3.2)
    pool = candidates(frame, np.array([label_id("sidewalk")]), (3.0, 40.0))
    top = pool.top_in_image(frame, extents[2])
    assert 0 < top.sum() < len(top)
    out = np.flatnonzero(~top)
    tests = PoseTests.of(frame, extents, PlacementRules(), ("sidewalk",), "traffic sign")
    rng = np.random.default_rng(0)
    for idx in rng.choice(out, size=min(40, len(out)), replace=False):
        m = pose_matrix(pool.point(int(idx)).astype(float), np.array([0.0, 0.0, 1.0]), float(rng.uniform(-np.pi, np.pi)))
        rejection = tests.image(m, heights=False)
        assert rejection is not None and rejection.reason == "not fully inside the image"
    assert pool.z[top].min() > pool.z[~top].max() - 1.0  # the nearer spots are left out


def test_a_pole_between_the_scene_samples_still_intersects_the_box():
    """Placement samples a box's rectangle every few pixels for scene points inside it;
    check-placement measures every pixel. A thin pole between the samples (a real sign's
    post, one pixel wide) is inside the box for both: the placement measures every pixel once
    the samples pass (leverkusen_000032: a sign placed through a post, then failed by the
    checker's penetration 0.058 m)."""
    from synthcompose.placement.boxes import pose_matrix
    from synthcompose.placement.poses import SCENE_SPACING, PoseTests, deepest_scene_point, scene_clearance
    from synthcompose.placement.rules import MAX_PENETRATION, box_corners
    from synthcompose.placement.search import candidates

    scene = random_scene(np.random.default_rng([30, 3]), 1024, 512)
    arrays = render_scene(scene)
    cam = scene.camera
    frame = make_frame(disparity_to_depth(arrays["disparity"], cam), arrays["label_ids"], cam)
    extents, rules = (0.6, 0.6, 1.75), PlacementRules()
    pool = candidates(frame, np.array([label_id("sidewalk")]), (9.0, 12.0))
    m = pose_matrix(pool.point(len(pool.z) // 2).astype(float), np.array([0.0, 0.0, 1.0]), 0.0)
    assert PoseTests.of(frame, extents, rules, ("sidewalk",), "person").scene(m) is None
    # a one-pixel post through the box's middle, on a column the samples skip
    z = float(frame.to_optical(m[:3, 3][None])[0, 2])
    stride = int(np.clip(SCENE_SPACING * cam.fx / z, 1, 4))  # the samples' spacing there
    assert stride > 1
    r0, r1, c0, c1 = frame.box_rect(box_corners(m, extents, rules.margin))
    (u, v_foot), (_, v_top) = cam.project(frame.to_optical(np.array([m[:3, 3], m[:3, 3] + [0, 0, 1.5]])))
    u = int(round(u))
    u += 1 if (u - max(c0, 0)) % stride == 0 else 0
    depth = frame.depth.copy()
    depth[int(v_top):int(v_foot) - 20, u] = z
    posted = make_frame(depth, arrays["label_ids"], cam)
    clearance = scene_clearance(frame_noise(posted), z, rules.clearance)
    assert deepest_scene_point(posted, m, extents, clearance) > MAX_PENETRATION
    why = PoseTests.of(posted, extents, rules, ("sidewalk",), "person").scene(m)
    assert why is not None and why.reason == "intersects the scene"
