"""Placement on generated scenes whose geometry is known exactly."""
from __future__ import annotations

import numpy as np
import pytest

from synthcompose.geometry import disparity_to_depth, make_frame
from synthcompose.models import load_model
from synthcompose.placement import ALLOWED_SURFACES, PlacementRules, place_object, prefilter, strict_inside
from synthcompose.sample import random_scene, render_scene

from .tolerances import GROUND_Z_M

W, H = 1024, 512
SIZES = {"car": (4.4, 1.85, 1.48), "person": (0.5, 0.6, 1.75), "traffic sign": (0.2, 0.8, 2.5)}


@pytest.fixture(scope="module", params=[0, 1, 2])
def frame(request):
    scene = random_scene(np.random.default_rng([11, request.param]), W, H)
    arrays = render_scene(scene)
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    return scene, arrays, make_frame(depth, arrays["label_ids"], scene.camera)


def _inside_scene_solids(scene, pts: np.ndarray) -> np.ndarray:
    hit = np.zeros(len(pts), bool)
    for box in scene.boxes:
        lo, hi = np.array(box.lo), np.array(box.hi)
        hit |= ((pts >= lo) & (pts <= hi)).all(axis=1)
    for pole in scene.poles:
        r = np.hypot(pts[:, 0] - pole.x, pts[:, 1] - pole.y)
        hit |= (r <= pole.radius) & (pts[:, 2] >= pole.base_z) & (pts[:, 2] <= pole.base_z + pole.height)
    return hit


@pytest.mark.parametrize("cls", ["car", "person", "traffic sign"])
def test_placed_objects_stand_on_allowed_ground_and_hit_nothing(frame, cls):
    scene, arrays, fr = frame
    rng = np.random.default_rng(3)
    rules = PlacementRules()
    placed = []
    for _ in range(3):
        res = place_object(fr, cls, SIZES[cls], rng, rules, others=placed)
        assert res.placement is not None, res.rejections
        p = res.placement
        placed.append(p)
        x, y, z = p.position
        # on the ground: contact point at the true ground height
        assert abs(z - float(scene.ground_height(x, y))) <= GROUND_Z_M
        # footprint on the allowed surface (exact ground plan, dense grid)
        l, w, h = p.extents
        gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, 21) * l, np.linspace(-0.5, 0.5, 11) * w)
        foot = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) @ p.matrix[:3, :3].T + p.matrix[:3, 3]
        labels = scene.surface_label(foot[:, 0], foot[:, 1])
        assert np.isin(labels, ALLOWED_SURFACES[cls]).mean() >= 0.95
        # nothing of the scene inside the object's volume (above the kerb-height band)
        gx, gy, gz = np.meshgrid(np.linspace(-0.5, 0.5, 9) * l, np.linspace(-0.5, 0.5, 5) * w,
                                 np.linspace(0.2, 1.0, 5) * h)
        vol = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()]) @ p.matrix[:3, :3].T + p.matrix[:3, 3]
        assert not _inside_scene_solids(scene, vol).any()
        assert rules.distance[0] <= p.distance <= rules.distance[1]
    # objects of one frame keep their distance: footprints grown by half the gap do not overlap
    from synthcompose.placement import footprint_corners, footprints_overlap

    grown = [footprint_corners(p.matrix, p.extents, rules.object_gap / 2 - 1e-6) for p in placed]
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
    assert len(suspects) < len(pts) / 4


def test_collision_with_a_parked_car_is_rejected(frame):
    scene, arrays, fr = frame
    cloud = fr.cloud
    car = next(b for b in scene.boxes if b.label == "car")
    centre = (np.array(car.lo) + np.array(car.hi)) / 2
    from synthcompose.placement import pose_matrix

    m = pose_matrix(np.array([centre[0], centre[1], 0.0]), np.array([0, 0, 1.0]), 0.0)
    sus = prefilter(cloud.vehicle, m, SIZES["car"], 0.12, 0.1)
    inside = strict_inside(cloud.vehicle[sus].astype(float), m, SIZES["car"], 0.12, 0.1)
    visible_parked = (arrays["instance_ids"] == car.instance_id).sum()
    if visible_parked > 20:  # a parked car the camera sees: its points are inside the box
        assert inside.sum() > 10
