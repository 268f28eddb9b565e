"""Stage 2b, step 1 of the label-free surfaces (surfaces.py): the road's ground profile - the
disparity of the ground on each image row, following the road's slope, the car's pitch and the
road's bends - and the road's remaining tilt and camber across and along the view; and what
lies level with the road of its own row."""
from __future__ import annotations

import numpy as np

from synthcompose.camera import Camera

from .medians import group_medians

#: the car's own lane ahead: within this far left or right of the camera's line, metres
LANE_HALF = 1.2
#: the road's crown is fitted within this far across from the car, metres
CROWN_REACH = 3.5
#: the ground profile follows the road's bends: rows within this share of the quadratic
#: profile's disparity, their offsets smoothed over this many working rows
PROFILE_FOLLOW, PROFILE_ROWS = 0.06, 11


def plane_disparity(camera: Camera, rows: np.ndarray, width: int) -> np.ndarray:
    """(len(rows), width) disparity of the camera's ground plane z = 0 (V) at each pixel (0
    above the horizon)."""
    u = np.arange(width, dtype=np.float64)
    v = np.asarray(rows, np.float64)[:, None]
    ray_o = np.stack(np.broadcast_arrays((u[None] - camera.u0) / camera.fx, (v - camera.v0) / camera.fy,
                                         np.ones((len(rows), width))), -1)
    m = camera.vehicle_from_optical
    ray_z = ray_o @ m[2, :3]  # height change along the ray per unit optical depth
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(ray_z < -1e-6, -m[2, 3] / ray_z, np.inf)  # optical depth where the ray meets z = 0
    return np.where(np.isfinite(z), camera.fx * camera.baseline / z, 0.0)


def ground_profile(disp: np.ndarray, plane: np.ndarray, cam: Camera) -> np.ndarray:
    """(h,) ground disparity per row: per row, the median disparity of the pixels within 12 %
    of the camera's plane, weighted to the central columns; then a robust quadratic in the
    row of d_g / d_plane, so slopes and pitch are followed but single rows are not."""
    h, w = disp.shape
    centre = np.abs(np.arange(w) - w / 2) < 0.35 * w
    d, pr = disp[:, centre], plane[:, centre]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = d / pr
        near = np.isfinite(d) & (np.abs(q - 1) < 0.12)
    counts = near.sum(axis=1)
    taken = np.flatnonzero(~(plane[:, w // 2] <= 1.0) & (counts >= 0.1 * centre.sum()))  # rows with support
    out = np.full(h, np.nan)
    if len(taken) < 10:
        ok = plane[:, w // 2] > 1.0
        out[ok] = 1.0
        return out
    near[np.setdiff1d(np.arange(h), taken)] = False
    ratio = group_medians(np.nonzero(near)[0], q[near], h)[taken]  # each row's median ratio
    rows, weight = taken.astype(float), np.sqrt(counts[taken].astype(float))
    keep = np.ones(len(rows), bool)
    coef = np.array([0.0, 0.0, 1.0])
    for _ in range(4):
        coef = np.polyfit(rows[keep] / h, ratio[keep], 2, w=weight[keep])
        res = ratio - np.polyval(coef, rows / h)
        keep = np.abs(res) < max(3 * 1.4826 * np.median(np.abs(res[keep])), 0.005)
    ok = plane[:, w // 2] > 1.0
    fit = np.polyval(coef, np.arange(h) / h)
    out[ok] = (fit + road_bends(disp, plane, fit, cam))[ok]
    return out  # ratio to the plane's disparity, per row


def road_bends(disp: np.ndarray, plane: np.ndarray, fit: np.ndarray, cam: Camera) -> np.ndarray:
    """(h,) the road's bends off the quadratic profile (a dip before a junction, a crest): per
    row, the median ratio of the car's own lane ahead (within LANE_HALF of the camera's line:
    carriageway, not the pavements that pull the wide median) within PROFILE_FOLLOW of the
    fit, its offset smoothed over PROFILE_ROWS rows (a road bends over metres, never row by
    row); 0 where no row has support. ``cam``: the working camera."""
    h, w = disp.shape
    p = plane[:, int(round(cam.u0))] if 0 <= cam.u0 < w else plane[:, w // 2]
    half = LANE_HALF * p * fit / cam.baseline  # pixels: LANE_HALF at the ground's depth, per row
    half[p <= 1.0] = 0.0  # rows the ground does not reach: no lane
    lane = np.abs(np.arange(w) - cam.u0)[None, :] < half[:, None]
    span = np.flatnonzero(lane.any(axis=0))
    if len(span) == 0:
        return np.zeros(h)
    c0, c1 = span[0], span[-1] + 1  # the columns some row's lane takes
    lane = lane[:, c0:c1]
    with np.errstate(divide="ignore", invalid="ignore"):
        rr = disp[:, c0:c1] / plane[:, c0:c1]
        near = lane & np.isfinite(rr) & (np.abs(rr / fit[:, None] - 1) < PROFILE_FOLLOW)
    counts = near.sum(axis=1)
    rows = np.flatnonzero(~(p <= 1.0) & (counts >= np.maximum(5, 0.3 * lane.sum(axis=1))))
    if len(rows) < PROFILE_ROWS:
        return np.zeros(h)
    near[np.setdiff1d(np.arange(h), rows)] = False
    off = group_medians(np.nonzero(near)[0], rr[near], h)[rows] - fit[rows]
    k = PROFILE_ROWS // 2
    # the median of the rows within k places of each (fewer at the ends)
    at = np.arange(len(off))[:, None] + np.arange(-k, k + 1)[None, :]
    inside = (at >= 0) & (at < len(off))
    med = group_medians(np.nonzero(inside)[0], off[at[inside]], len(off))
    mean = np.convolve(np.pad(med, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), mode="valid")
    return np.interp(np.arange(h), rows, mean, left=0.0, right=0.0)


def road_tilt(height: np.ndarray, d: np.ndarray, cam: Camera, fb: float) -> np.ndarray:
    """(h, w) the road's remaining slope across and along the view: a robust plane h = a + b x +
    c y + d y^2 (x forward, y left, metres: d is the crown of a cambered road, whose middle stands
    above its gutters) through the near-level pixels, so a cambered or sideways
    sloping road stays level from kerb to kerb. ``d``: full-resolution disparity at the
    working pixels of ``cam``; ``fb``: the full-resolution f B."""
    u = np.arange(height.shape[1])[None, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(np.isfinite(height) & (d > 0), fb / d, np.nan)
    lateral = -(u - cam.u0) * z / cam.fx
    # the carriageway around the car only: a kerbside pavement 10-15 cm up must not bend the
    # crown up to it (it would read as road); beyond CROWN_REACH the crown is held
    ok = np.isfinite(height) & (np.abs(height) < 0.1) & (z > 4) & (z < 30) & (np.abs(lateral) < CROWN_REACH)
    if ok.sum() < 500:
        return np.zeros_like(height)
    sel = np.flatnonzero(ok.ravel())[:: max(1, int(ok.sum() // 20000))]
    A = np.column_stack([np.ones(len(sel)), z.ravel()[sel], lateral.ravel()[sel], lateral.ravel()[sel] ** 2])
    hv = height.ravel()[sel]
    keep = np.ones(len(sel), bool)
    coef = np.zeros(4)
    for _ in range(4):
        coef, *_ = np.linalg.lstsq(A[keep], hv[keep], rcond=None)
        res = hv - A @ coef
        keep = np.abs(res) < max(3 * 1.4826 * np.median(np.abs(res[keep])), 0.02)
    lat = np.nan_to_num(lateral)
    held = np.clip(lat, -CROWN_REACH, CROWN_REACH)
    tilt = coef[0] + coef[1] * np.nan_to_num(z) + coef[2] * lat + coef[3] * held ** 2
    return tilt.astype(np.float32)


def level_with_row_road(height: np.ndarray, road: np.ndarray, band: np.ndarray, least: int = 10) -> np.ndarray:
    """(h, w) bool: pixels less than ``band`` above the median height of their row's ``road``
    pixels (none on rows with fewer than ``least`` of them)."""
    rows = np.flatnonzero(road.sum(axis=1) >= least)
    out = np.zeros(height.shape, bool)
    if len(rows) == 0:
        return out
    med = np.nanmedian(np.where(road[rows], height[rows], np.nan), axis=1)
    with np.errstate(invalid="ignore"):
        out[rows] = height[rows] - med[:, None] < band[rows]
    return out
