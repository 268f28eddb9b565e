"""The label-free surfaces' medians taken group by group at once (placement/medians.py) give
what ``np.median`` gave one bin or row at a time: the loops they replace are kept here as the
reference and compared on random data and on generated frames' ground profiles."""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from synthcompose.io.files import decode_disparity
from synthcompose.placement import ground_profile as gp
from synthcompose.placement.kerbs import BIN, binned_profile
from synthcompose.placement.medians import group_medians
from synthcompose.placement.surfaces import SCALE
from synthcompose.synthetic import random_scene, render_scene


def test_group_medians_are_numpys_medians():
    rng = np.random.default_rng(0)
    for trial in range(600):
        n, m = int(rng.integers(1, 30)), int(rng.integers(0, 300))
        dtype = [np.float32, np.float64, np.int64, np.uint8][trial % 4]
        groups = rng.integers(0, n, m)
        if dtype in (np.float32, np.float64):
            values = (rng.normal(size=m) * 10.0 ** rng.integers(-3, 4)).astype(dtype)
            if trial % 7 == 0:
                values[rng.random(m) < 0.05] = np.nan
            if trial % 11 == 0:
                values = np.round(values)  # ties
        else:
            values = rng.integers(0, 50, m).astype(dtype)
        least = int(rng.integers(1, 6))
        want = np.full(n, np.nan)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for k in range(n):
                if (groups == k).sum() >= least:
                    want[k] = np.median(values[groups == k])
        assert np.array_equal(group_medians(groups, values, n, least), want, equal_nan=True)


def _binned_profile_loop(height, ok, key, lo_m, hi_m, least):
    bins = np.rint(key[ok] / BIN).astype(np.int64)
    h = height[ok]
    lo, hi = int(round(lo_m / BIN)), int(round(hi_m / BIN))
    keep = (bins >= lo) & (bins <= hi)
    bins, h = bins[keep] - lo, h[keep]
    order = np.argsort(bins, kind="stable")
    bins, h = bins[order], h[order]
    starts = np.searchsorted(bins, np.arange(hi - lo + 2))
    med = np.full(hi - lo + 1, np.nan)
    for k in range(hi - lo + 1):
        a, b = starts[k], starts[k + 1]
        if b - a >= least:
            med[k] = np.median(h[a:b])
    return (np.arange(lo, hi + 1) * BIN), med


def test_binned_profile_is_the_loops():
    rng = np.random.default_rng(1)
    for _ in range(50):
        height = rng.normal(0, 0.1, (60, 80)).astype(np.float32)
        key = rng.uniform(-10, 40, (60, 80))
        ok = rng.random((60, 80)) < 0.7
        for lo_m, hi_m, least in [(-8.0, 8.0, 5), (4.0, 30.0, 3)]:
            got, want = binned_profile(height, ok, key, lo_m, hi_m, least), _binned_profile_loop(height, ok, key, lo_m,
                                                                                                  hi_m, least)
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1], equal_nan=True)


def _ground_profile_loop(disp, plane, cam):
    h, w = disp.shape
    centre = np.abs(np.arange(w) - w / 2) < 0.35 * w
    rows, ratio, weight = [], [], []
    for r in range(h):
        if plane[r, w // 2] <= 1.0:
            continue
        d, pr = disp[r, centre], plane[r, centre]
        near = np.isfinite(d) & (np.abs(d / pr - 1) < 0.12)
        if near.sum() < 0.1 * centre.sum():
            continue
        rows.append(r)
        ratio.append(float(np.median(d[near] / pr[near])))
        weight.append(float(near.sum()))
    return np.array(rows, float), np.array(ratio), np.sqrt(np.array(weight))


def _road_bends_loop(disp, plane, fit, cam):
    h, w = disp.shape
    cols = np.arange(w)
    rows, off = [], []
    for r in range(h):
        p = plane[r, int(round(cam.u0))] if 0 <= cam.u0 < w else plane[r, w // 2]
        if p <= 1.0:
            continue
        half = gp.LANE_HALF * p * fit[r] / cam.baseline
        lane = np.abs(cols - cam.u0) < half
        rr = disp[r, lane] / plane[r, lane]
        near = np.isfinite(rr) & (np.abs(rr / fit[r] - 1) < gp.PROFILE_FOLLOW)
        if near.sum() < max(5, 0.3 * lane.sum()):
            continue
        rows.append(r)
        off.append(float(np.median(rr[near])) - fit[r])
    if len(rows) < gp.PROFILE_ROWS:
        return np.zeros(h)
    off = np.array(off)
    k = gp.PROFILE_ROWS // 2
    med = np.array([np.median(off[max(0, i - k):i + k + 1]) for i in range(len(off))])
    mean = np.convolve(np.pad(med, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), mode="valid")
    return np.interp(np.arange(h), rows, mean, left=0.0, right=0.0)


@pytest.mark.parametrize("seed", [3, 8])
def test_ground_profile_is_the_loops(seed, monkeypatch):
    scene = random_scene(np.random.default_rng([40, seed]), 1024, 512)
    arrays = render_scene(scene, stereo="realistic")
    cam, png = scene.camera, arrays["disparity"]
    d = decode_disparity(png)
    d[png <= 1] = np.nan
    step = int(round(1 / SCALE))
    h, w = int(round(png.shape[0] * SCALE)), int(round(png.shape[1] * SCALE))
    disp = d[::step, ::step][:h, :w] * SCALE
    sub = replace(cam, fx=cam.fx * SCALE, fy=cam.fy * SCALE, u0=cam.u0 * SCALE, v0=cam.v0 * SCALE, width=w, height=h)
    plane = gp.plane_disparity(sub, np.arange(h), w)
    fits = []
    monkeypatch.setattr(gp, "road_bends", lambda disp, plane, fit, cam: fits.append(fit) or np.zeros(len(fit)))
    gp.ground_profile(disp, plane, sub)
    assert fits, "the frame's ground has too few rows to fit"
    fit = fits[0]
    monkeypatch.undo()
    assert np.array_equal(gp.road_bends(disp, plane, fit, sub), _road_bends_loop(disp, plane, fit, sub))
    # and the rows, ratios and weights the quadratic is fitted to
    rows, ratio, weight = _ground_profile_loop(disp, plane, sub)
    seen = []
    monkeypatch.setattr(np, "polyfit", lambda x, y, deg, w=None: seen.append((x, y, w)) or np.zeros(3))
    gp.ground_profile(disp, plane, sub)
    monkeypatch.undo()
    x, y, wt = seen[0]
    assert np.array_equal(x, rows / h) and np.array_equal(y, ratio) and np.array_equal(wt, weight)
