"""Placement on real stereo: the frame's measured noise, tolerances that follow it, surfaces
of frames without labels, and placements that survive semi-global-matching noise.

Generated scenes get SGM-like disparity here (patchy noise of a few tenths of a pixel, 1/256
px coding); tests on real Cityscapes frames read their root from SYNTHCOMPOSE_REAL_ROOT and
are skipped without it (CI has no real data)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.geometry.depth import disparity_to_depth, make_frame
from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.labels import label_id
from synthcompose.placement import PlacementRules, check_pose, frame_noise, place_object
from synthcompose.placement.noise import SIGMA_MIN, StereoNoise, measure_sigma
from synthcompose.placement.surfaces import find_surfaces, frame_for
from synthcompose.synthetic import random_scene, render_scene

from ..helpers import SIZES
from ..real_root import REAL, needs_real
from ..tolerances import (
    NOISE_SIGMA_MEASURE_REL,
    NOISY_SCENE_SIGMA_D_PX,
    REAL_PLACED_MIN,
    REAL_ROAD_PRECISION_MIN,
    REAL_SIDEWALK_ROAD_MAX,
    REAL_SIDEWALK_WALKABLE_MIN,
    ROAD_FOUND_PRECISION_MIN,
    ROAD_FOUND_RECALL_SGM_MIN,
    SGM_PLACED_MIN,
)

ROAD, SIDEWALK = label_id("road"), label_id("sidewalk")


def sgm_like(disparity_png: np.ndarray, sigma_px: float, seed: int) -> np.ndarray:
    """Cityscapes disparity with patchy matcher noise of about ``sigma_px`` pixels added."""
    rng = np.random.default_rng(seed)
    d = (disparity_png.astype(np.float32) - 1) / 256
    noise = cv2.GaussianBlur(rng.standard_normal(d.shape).astype(np.float32), (0, 0), 2.0)
    noise *= sigma_px / noise.std()
    out = np.where(disparity_png > 1, np.rint((d + noise) * 256) + 1, 0)
    return np.clip(out, 0, 65535).astype(np.uint16)


def test_the_matchers_noise_is_measured_on_a_plane():
    h, w = 400, 600
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    plane = 5 + 0.01 * u + 0.08 * v  # a plane's disparity is affine in the pixel coordinates
    ground = np.ones((h, w), bool)
    assert measure_sigma(plane, ground) == SIGMA_MIN  # exact: the floor
    rng = np.random.default_rng(0)
    for sigma in (0.2, 0.4):
        noisy = plane + sigma * rng.standard_normal((h, w)).astype(np.float32)
        assert measure_sigma(noisy, ground) == pytest.approx(sigma, rel=NOISE_SIGMA_MEASURE_REL)


def test_tolerances_follow_the_stereo_error():
    n = StereoNoise(0.3, 473.0, 1.22)
    assert n.depth_sigma(40.0) / n.depth_sigma(10.0) == pytest.approx(16.0)  # z squared
    assert n.height_sigma(40.0) / n.height_sigma(10.0) == pytest.approx(4.0)  # z
    assert n.height_band(5.0, 0.05) == 0.05  # near: the fixed floor
    assert n.height_band(40.0, 0.05) == pytest.approx(3 * 1.22 * 40 * 0.3 / 473.0)


def noisy_scene(seed: int, sigma_px: float = 0.3, w: int = 1024, h: int = 512):
    scene = random_scene(np.random.default_rng([seed, 15]), w, h)
    arrays = render_scene(scene, stereo="exact")  # the noise of a known size is added here
    disparity = sgm_like(arrays["disparity"], sigma_px, seed)
    return scene, arrays, disparity


def test_the_noise_of_a_noisy_scene_is_measured():
    scene, arrays, disparity = noisy_scene(3)
    frame = make_frame(disparity_to_depth(disparity, scene.camera), arrays["label_ids"], scene.camera)
    lo, hi = NOISY_SCENE_SIGMA_D_PX  # patchy 0.3 px noise, second differences over 8 px
    assert lo <= frame_noise(frame).sigma_d <= hi


@pytest.mark.parametrize("cls", ["car", "person", "traffic sign"])
def test_placement_survives_sgm_noise(cls):
    """With 0.3 px patchy noise (real frames: 0.27-0.38 px measured the same way) objects are
    placed, and each accepted pose passes the rules again as a pose given outright."""
    placed = asked = 0
    for seed in range(4):
        scene, arrays, disparity = noisy_scene(seed)
        frame = make_frame(disparity_to_depth(disparity, scene.camera), arrays["label_ids"], scene.camera)
        rules = PlacementRules(distance=(7.0, 40.0))
        rng = np.random.default_rng(seed)
        for _ in range(2):
            asked += 1
            result = place_object(frame, cls, SIZES[cls], rng, rules)
            if result.placement is None:
                continue
            placed += 1
            assert check_pose(frame, cls, SIZES[cls], result.placement.matrix, rules) is None
    assert placed >= SGM_PLACED_MIN * asked, f"{placed}/{asked} placed"


def test_surfaces_of_a_frame_without_labels():
    """Road (and sidewalk, raised beside it) found from noisy disparity and the photo alone."""
    precision, recall = [], []
    for seed in range(3):
        scene, arrays, disparity = noisy_scene(seed)
        found = find_surfaces(disparity, arrays["rgb"], scene.camera)
        road, true = found.labels == ROAD, arrays["label_ids"] == ROAD
        if not true.any():
            continue
        precision.append(true[road].mean() if road.any() else 0.0)
        recall.append(road[true].mean())
        assert found.to_dict()["road_share"] > 0
    assert np.mean(precision) > ROAD_FOUND_PRECISION_MIN, (precision, recall)
    assert np.mean(recall) > ROAD_FOUND_RECALL_SGM_MIN, (precision, recall)


def test_surfaces_are_deterministic():
    scene, arrays, disparity = noisy_scene(1)
    a = find_surfaces(disparity, arrays["rgb"], scene.camera).labels
    b = find_surfaces(disparity.copy(), arrays["rgb"].copy(), scene.camera).labels
    assert np.array_equal(a, b)


# ------------------------------------------------------------------ real Cityscapes frames


@needs_real
@pytest.mark.parametrize("cls", ["car", "person", "traffic sign"])
def test_real_frames_take_objects(cls):
    root = Path(REAL)
    asked = placed = 0
    for ident in find_image_sets(root)[:8]:
        frame, _ = frame_for(read_image_set(root, ident))
        rng = np.random.default_rng(0)
        for _ in range(3):
            asked += 1
            result = place_object(frame, cls, SIZES[cls], rng, PlacementRules(distance=(7.0, 40.0)))
            if result.placement is not None:
                placed += 1
                assert check_pose(frame, cls, SIZES[cls], result.placement.matrix,
                                  PlacementRules(distance=(7.0, 40.0))) is None
    assert placed >= REAL_PLACED_MIN * asked, f"{placed}/{asked}"


@needs_real
def test_real_frames_without_labels_find_road_that_is_road():
    root = Path(REAL)
    for ident in find_image_sets(root)[:8]:
        s = read_image_set(root, ident)
        if not s.labelled:
            continue
        found = find_surfaces(s.disparity, s.rgb, s.camera)
        road = found.labels == ROAD
        assert (s.label_ids[road] == ROAD).mean() > REAL_ROAD_PRECISION_MIN
        assert road[s.label_ids == ROAD].mean() > ROAD_FOUND_RECALL_SGM_MIN


@needs_real
def test_real_frames_without_labels_find_sidewalk_on_walkable_ground():
    """Found sidewalk lies beside the road on ground a person can stand on (Cityscapes' sidewalk,
    parking, ground or terrain), not in the road's lane markings or on its crown."""
    root = Path(REAL)
    walkable = [label_id(n) for n in ("sidewalk", "parking", "ground", "terrain")]
    for ident in find_image_sets(root)[:8]:
        s = read_image_set(root, ident)
        if not s.labelled:
            continue
        side = find_surfaces(s.disparity, s.rgb, s.camera).labels == SIDEWALK
        if side.sum() < 1000:
            continue
        truth = s.label_ids[side]
        assert np.isin(truth, walkable).mean() > REAL_SIDEWALK_WALKABLE_MIN, ident.key
        assert (truth == ROAD).mean() < REAL_SIDEWALK_ROAD_MAX, ident.key
