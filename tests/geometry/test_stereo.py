"""Generated disparity measures like real Cityscapes SGM output.

The ranges are those measured on four real development frames (2048x1024) with
``benchmarks/stereo_stats.py`` (docs/stereo.md, "Generated stereo and photo"), widened by a few points; the
scenes here are 1024x512, a real frame scaled down: their noise is scaled with the width, and
``stereo_stats`` measures them with windows and steps scaled and gives pixel figures in pixels
of a 2048 px frame, so the ranges apply as they are.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from evaluation.stereo_stats import stereo_stats
from synthcompose.io.dataset import read_image_set
from synthcompose.labels import label_id
from synthcompose.synthetic import make_sample, random_scene, render_scene

from ..tolerances import (
    CLEAN_PHOTO_NOISE,
    EGO_INVALID_MIN,
    EXACT_NORMALS_UP_MIN,
    EXACT_RESIDUAL_MAX_PX,
    EXACT_VALID_MIN,
    FATTENING_MIN,
    FATTENING_REL,
    OCCLUSION_LEFT_INVALID_MIN,
    OCCLUSION_RIGHT_INVALID_MAX,
    REAL_PHOTO_RANGES,
    REAL_STEREO_RANGES,
    SKY_INVALID_SHARE,
)

W, H = 1024, 512
SKY, EGO = label_id("sky"), label_id("ego vehicle")


@pytest.fixture(scope="module")
def frames():
    out = []
    for i in range(3):
        scene = random_scene(np.random.default_rng([5, i]), W, H)
        arrays = render_scene(scene)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            stats = stereo_stats(arrays["disparity"], scene.camera, arrays["label_ids"])
        out.append((scene, arrays, stats))
    return out


@pytest.mark.parametrize("key, lo, hi", [(key, lo, hi) for key, (lo, hi) in REAL_STEREO_RANGES.items()])
def test_figures_in_the_real_ranges(frames, key, lo, hi):
    for _, _, stats in frames:
        assert lo <= stats[key] <= hi, (key, stats[key])


def test_exact_disparity_is_far_from_real(frames):
    scene, _, _ = frames[0]
    exact = render_scene(scene, stereo="exact")
    stats = stereo_stats(exact["disparity"], scene.camera, exact["label_ids"])
    assert stats["residual_med"] < EXACT_RESIDUAL_MAX_PX and stats["normals_up"] > EXACT_NORMALS_UP_MIN
    assert stats["valid"] > EXACT_VALID_MIN


def test_holes_where_real_ones_are(frames):
    for scene, arrays, _ in frames:
        d, labels = arrays["disparity"], arrays["label_ids"]
        sky, ego = labels == SKY, labels == EGO
        if sky.sum() > 500:
            lo, hi = SKY_INVALID_SHARE  # real: 23-37 % of the sky invalid
            assert lo < (d[sky] == 0).mean() < hi
        assert (d[ego] == 0).mean() > EGO_INVALID_MIN  # real bonnets: 80-88 % invalid
        assert (d[:15] == 0).all() and (d[:, :5] == 0).all() and (d[:, -5:] == 0).all()  # border
        # 2x2 blocks only at 2048 px: here every pixel is the matcher's own
        assert not (d[:, 0::2] == d[:, 1::2]).all()


def test_occlusion_shadow_left_of_a_near_object():
    """A pole in front of a far wall: the background just left of it is mostly invalid (the
    right camera does not see it), just right of it mostly valid, and near the pole's right
    edge the background takes the pole's disparity (fattening)."""
    base = random_scene(np.random.default_rng([5, 0]), W, H)
    scene = dataclasses.replace(base, poles=(dataclasses.replace(base.poles[0], x=8.0, y=0.5, radius=0.15),)
                                if base.poles else ())
    if not scene.poles:
        pytest.skip("no pole to move")
    arrays = render_scene(scene)
    d, labels, depth = arrays["disparity"], arrays["label_ids"], arrays["depth"]
    pole = labels == label_id("pole")
    rows = np.flatnonzero(pole.sum(axis=1) >= 6)
    rows = rows[(rows > H * 0.25) & (rows < H * 0.45)]  # pole against the far background
    assert len(rows) > 10
    left_invalid, right_invalid, right_fat = [], [], []
    for r in rows:
        cols = np.flatnonzero(pole[r])
        c0, c1 = cols.min(), cols.max()
        d_pole = scene.camera.fx * scene.camera.baseline / np.median(depth[r, cols]) * 256 + 1
        left_invalid.append((d[r, c0 - 6:c0 - 1] == 0).mean())
        right = d[r, c1 + 1:c1 + 3].astype(float)
        right_invalid.append((right == 0).mean())
        right_fat.append(np.mean(np.abs(right - d_pole) < FATTENING_REL * d_pole))
    assert np.mean(left_invalid) > OCCLUSION_LEFT_INVALID_MIN
    assert np.mean(right_invalid) < OCCLUSION_RIGHT_INVALID_MAX
    assert np.mean(right_fat) > FATTENING_MIN


def test_same_seed_same_bytes_and_exact_mode_unchanged(tmp_path):
    scene = random_scene(np.random.default_rng([5, 7]), 512, 256)
    a, b = render_scene(scene), render_scene(scene)
    assert np.array_equal(a["disparity"], b["disparity"])
    other = render_scene(dataclasses.replace(scene, noise_seed=scene.noise_seed + 1))
    assert not np.array_equal(a["disparity"], other["disparity"])
    exact = render_scene(scene, stereo="exact")
    for key in ("rgb", "label_ids", "instance_ids", "depth"):  # only the disparity differs
        assert np.array_equal(a[key], exact[key])
    ok = exact["disparity"] > 0
    fb = scene.camera.fx * scene.camera.baseline
    expected = np.rint(fb / exact["depth"][ok].astype(np.float64) * 256) + 1
    assert np.array_equal(exact["disparity"][ok], expected.astype(np.uint16))
    with pytest.raises(ValueError):
        render_scene(scene, stereo="sgm")
    # make_sample writes the realistic disparity by default
    (ident,) = make_sample(tmp_path, count=1, width=512, height=256, seed=3)
    written = read_image_set(tmp_path, ident).disparity
    again = render_scene(random_scene(np.random.default_rng([3, 0]), 512, 256))["disparity"]
    assert np.array_equal(written, again)


@pytest.mark.parametrize("key, lo, hi", [(key, lo, hi) for key, (lo, hi) in REAL_PHOTO_RANGES.items()])
def test_photo_figures_in_the_real_ranges(frames, key, lo, hi):
    from evaluation.photo_stats import photo_stats

    for _, arrays, _ in frames:
        value = photo_stats(arrays["rgb"], arrays["label_ids"]).get(key)
        assert value is None or lo <= value <= hi, (key, value)


def test_clean_photo_keeps_the_shading(frames):
    """photo="clean" is the shading as it was (brighter, grey road, more noise); the labels,
    depth and exact disparity do not depend on the photo."""
    from evaluation.photo_stats import photo_stats

    scene, arrays, _ = frames[0]
    clean = render_scene(scene, photo="clean", stereo="exact")
    exact = render_scene(scene, stereo="exact")
    assert np.array_equal(clean["disparity"], exact["disparity"])
    assert np.array_equal(clean["label_ids"], arrays["label_ids"])
    assert photo_stats(clean["rgb"])["noise"] > CLEAN_PHOTO_NOISE > photo_stats(arrays["rgb"])["noise"]
