"""The ground in view, resampled onto its own plane seen from above (a ground plan): what the
sun's cues on the ground are measured on, in metres rather than pixels.

The road plane ``z = a + b (x - x_c) + c (y - y_c)`` (vehicle frame, x_c, y_c the camera's foot)
is fitted robustly to the ground's points; each plan cell (:data:`CELL` metres, rows along x from
:data:`NEAR` to :data:`FAR` ahead of the camera, columns along y from :data:`HALF_WIDTH` to its
left to as far to its right) takes the photo's linear colour where the cell's plane point
projects. A cell counts (``valid``) where the real scene seen there is that ground: its depth
agrees with the plane's (a raised sidewalk's to within 15 %: a plane parallel to the road,
sampled through the camera's centre, is the road's scaled about the camera's foot, so directions
on it are kept), its label is ground (or, on a frame without labels, a level pixel), it is not
grass, nothing standing (a car, a wall, a pole) rises within :data:`NEAR_STANDING` of it in
the image column above it (contact shadows, dark whatever the sun does), and the ground seen there
is level (:data:`MAX_SLOPE`): a sun's shadow edge lies on level ground, while a kerb's vertical
face, seen through the plane, climbs from the road's height to the sidewalk's over a band of
cells (its rise per metre about the camera's height over the kerb's distance to the side: 0.2 at
5 m) - left in, the step from its dark face to the lit sidewalk reads as a shadow's edge.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.labels import label_id, labels_in

from .light import GROUND_IDS, LEVEL_LUT

ROAD, SIDEWALK, STANDING = label_id("road"), label_id("sidewalk"), label_id("static")

CELL = 0.05  # metres
NEAR, FAR, HALF_WIDTH = 3.0, 20.0, 12.0  # metres ahead of the camera, and to each side
#: ground this far (metres, on the plan) in front of something standing over it is its contact shadow's
NEAR_STANDING = 0.75
#: a pixel this far above the road plane (metres) stands on the ground (a car, a wall, a pole)
STANDING_HEIGHT = 0.3
#: the sampled depth over the plane's: the road (about 1) and raised ground (a sidewalk's kerb
#: height over the camera's: 0.85-0.95)
DEPTH_RATIO = (0.82, 1.08)
RAISED_RATIO = 0.955
#: ground steeper than this (rise per metre, over SLOPE_BASE metres) is not level: a kerb's face
MAX_SLOPE, SLOPE_BASE = 0.15, 0.3
_STEP = 2  # image subsampling of the point cloud (pixels)
#: metres: how near a shadow must come to a caster's foot (the ground nearer is left out: NEAR_STANDING)
FOOT_REACH = 1.0


@dataclass(frozen=True, eq=False)
class GroundPlan:
    """The ground plan of one photo. Arrays are (rows along x, columns along -y).

    lin      : (nx, ny, 3) float32 linear RGB of the photo at each cell's plane point
    valid    : (nx, ny) bool, the cell shows the ground (module doc)
    cls      : (nx, ny) uint8, the ground's kind: its label where labelled; else road where level,
               sidewalk where raised
    clipped  : (nx, ny) bool, a channel of the photo is clipped there
    u, v     : (nx, ny) float32, the full-resolution pixel of each cell
    footprint: (nx, ny) float32, metres along x one image row spans there (the image's own
               blur, in metres on the plan, is this along x and far less across)
    feet     : (nx, ny) bool, cells where something stands (its points 0.3-2 m over the plane),
               grown by :data:`FOOT_REACH`: where a caster's shadow starts
    plane    : (a, b, c) of the road plane; ``origin``: (x, y) of cell (0, 0)'s corner
    """

    lin: np.ndarray
    valid: np.ndarray
    cls: np.ndarray
    clipped: np.ndarray
    u: np.ndarray
    v: np.ndarray
    footprint: np.ndarray
    feet: np.ndarray
    plane: tuple[float, float, float]
    origin: tuple[float, float]

    def xy(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """(N, 2) vehicle-frame ground-plan position of cells (rows, cols), their centres."""
        x0, y0 = self.origin
        return np.column_stack([x0 + (np.asarray(rows) + 0.5) * CELL, y0 - (np.asarray(cols) + 0.5) * CELL])

    @staticmethod
    def direction(d_row: np.ndarray, d_col: np.ndarray) -> np.ndarray:
        """Ground-plan azimuth (degrees, from x towards y) of a step of (rows, cols) cells."""
        return np.degrees(np.arctan2(-np.asarray(d_col, float), np.asarray(d_row, float)))


def _points(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(h, w, 3) vehicle-frame points of every _STEP-th pixel (nan where unknown)."""
    H, W = depth.shape
    v, u = np.mgrid[0:H:_STEP, 0:W:_STEP].astype(np.float32)
    z = depth[::_STEP, ::_STEP].astype(np.float32)
    z = np.where(np.isfinite(z), z, np.nan)
    m = camera.vehicle_from_optical.astype(np.float32)
    x, y = (u - camera.u0) * z / camera.fx, (v - camera.v0) * z / camera.fy
    return np.stack([m[i, 0] * x + m[i, 1] * y + m[i, 2] * z + m[i, 3] for i in range(3)], axis=-1)


def linear_at(rgb: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``cv2.remap(cv2.LUT(rgb, LEVEL_LUT), u, v)`` (bilinear, 0 outside) with the linear levels
    made only for the rows and columns the samples read: the same values (a whole number of
    pixels off changes no sample's weights), without the frame's (H, W, 3) float32 (24 MB)."""
    H, W = rgb.shape[:2]
    reach = (u > -1) & (u < W) & (v > -1) & (v < H)  # samples that read a pixel of the photo
    if not reach.any():  # every sample is 0
        return np.zeros(u.shape + (3,), np.float32)
    # each reads its pixel and the next; one more on each side for rounding
    x0, x1 = max(int(np.floor(u[reach].min())) - 1, 0), min(int(u[reach].max()) + 3, W)
    y0, y1 = max(int(np.floor(v[reach].min())) - 1, 0), min(int(v[reach].max()) + 3, H)
    levels = cv2.LUT(rgb[y0:y1, x0:x1], LEVEL_LUT)
    return cv2.remap(levels, u - np.float32(x0), v - np.float32(y0), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def fit_road_plane(points: np.ndarray, labels: np.ndarray, camera: Camera) -> tuple[float, float, float]:
    """(a, b, c): the plane z = a + b (x - x_c) + c (y - y_c) through the ground points 4-25 m
    away (labels ``labels`` in :data:`GROUND_IDS`; road preferred), robustly (the road, not the
    sidewalks above it); the camera's own ground plane (0, 0, 0) without enough of them."""
    # the ground's points alone (in the grid's order), then their distance: the values the whole
    # grid's would give them, for the third of the grid that is ground
    at = np.flatnonzero(labels_in(labels, GROUND_IDS))
    pts = points.reshape(-1, 3)[at]
    rel = pts[:, :2] - np.array([camera.x, camera.y], np.float32)
    dist = np.hypot(rel[:, 0], rel[:, 1])
    sel = (dist > 4.0) & (dist < 25.0) & np.isfinite(dist)
    road = sel & (labels.reshape(-1)[at] == GROUND_IDS[1])
    if road.sum() > 2000:
        sel = road
    p, r = pts[sel][::5].astype(np.float64), rel[sel][::5].astype(np.float64)
    if len(p) < 200:
        return 0.0, 0.0, 0.0
    A = np.column_stack([np.ones(len(p)), r[:, 0], r[:, 1]])
    keep = np.abs(p[:, 2]) < 0.5
    coef = np.zeros(3)
    for _ in range(4):
        if keep.sum() < 50:
            break
        coef, *_ = np.linalg.lstsq(A[keep], p[keep, 2], rcond=None)
        res = p[:, 2] - A @ coef
        keep = np.abs(res) < max(3 * 1.4826 * float(np.median(np.abs(res[keep]))), 0.03)
    return float(coef[0]), float(coef[1]), float(coef[2])


def ground_plan(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera,
                labelled: bool = True) -> GroundPlan:
    """The :class:`GroundPlan` of a photo: rgb (H, W, 3) uint8 sRGB, label_ids (H, W) uint8
    (found surfaces on a frame without labels: ``labelled`` False), depth (H, W) metres."""
    H, W = label_ids.shape
    pts = _points(depth, camera)
    lab = label_ids[::_STEP, ::_STEP][: pts.shape[0], : pts.shape[1]]
    a, b, c = fit_road_plane(pts, lab, camera)
    height = pts[..., 2] - (a + b * (pts[..., 0] - camera.x) + c * (pts[..., 1] - camera.y))
    known = np.isfinite(height)
    ground = labels_in(lab, GROUND_IDS)
    if not labelled:  # ground the colour model left out (shadows, patches): level pixels
        ground |= (lab == 0) & known & (np.abs(height) < STANDING_HEIGHT)
    standing = known & ~ground & (height > STANDING_HEIGHT) & (height < 4.0)
    dist = np.hypot(pts[..., 0] - camera.x, pts[..., 1] - camera.y)
    # the nearest thing standing above each pixel in its column: ground right in front of it
    # (under a car's body, at a wall's foot) is dark from contact shadow alone
    above = np.minimum.accumulate(np.where(standing, dist, np.inf), axis=0)
    near = above < dist + NEAR_STANDING
    small = cv2.resize(rgb, (lab.shape[1], lab.shape[0]), interpolation=cv2.INTER_AREA)
    hsv = cv2.cvtColor(small, cv2.COLOR_RGB2HSV)
    s_ground = float(np.median(hsv[..., 1][ground])) if ground.any() else 40.0
    green = (hsv[..., 0] >= 30) & (hsv[..., 0] <= 90) & (hsv[..., 1] >= s_ground + 25)
    good = (ground & ~near & ~green).astype(np.uint8)

    nx, ny = int(round((FAR - NEAR) / CELL)), int(round(2 * HALF_WIDTH / CELL))
    x0, y0 = camera.x + NEAR, camera.y + HALF_WIDTH
    gx = (x0 + (np.arange(nx) + 0.5) * CELL)[:, None]
    gy = (y0 - (np.arange(ny) + 0.5) * CELL)[None, :]
    gz = a + b * (gx - camera.x) + c * (gy - camera.y)
    m = camera.optical_from_vehicle
    o = [m[i, 0] * gx + m[i, 1] * gy + m[i, 2] * gz + m[i, 3] for i in range(3)]
    zo = np.where(o[2] > 0.5, o[2], np.nan)
    u = (camera.fx * o[0] / zo + camera.u0).astype(np.float32)
    v = (camera.fy * o[1] / zo + camera.v0).astype(np.float32)
    inside = np.isfinite(u) & (u >= 0) & (u <= W - 1) & (v >= 0) & (v <= H - 1)
    u, v = np.where(inside, u, -10.0).astype(np.float32), np.where(inside, v, -10.0).astype(np.float32)
    lin = linear_at(rgb, u, v)
    seen = cv2.remap(np.asarray(depth, np.float32), u, v, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                     borderValue=float("nan"))
    plane_lab = cv2.remap(label_ids, u, v, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    ok = cv2.remap(good, u / _STEP, v / _STEP, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0) > 0
    brightest = cv2.max(cv2.max(rgb[..., 0], rgb[..., 1]), rgb[..., 2])
    clip = cv2.remap((brightest >= 250).astype(np.uint8), u, v, cv2.INTER_NEAREST,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=1) > 0
    with np.errstate(invalid="ignore"):
        ratio = seen / np.where(np.isfinite(zo), zo, np.inf)
    valid = inside & ok & np.isfinite(ratio) & (ratio > DEPTH_RATIO[0]) & (ratio < DEPTH_RATIO[1])
    # the seen point's height over the road plane: it lies on the cell's ray at `ratio` of the
    # plane point's depth, and height is affine along a ray (the camera's over the plane at 0)
    rise = ((1.0 - np.where(valid, ratio, 1.0)) * (camera.z - a)).astype(np.float32)
    valid &= _level(rise, valid)
    # the ground's kind: its label; where a frame without labels has none (ground the colour
    # model of the found surfaces left out: shadows, patches), level or raised
    cls = np.where(np.isin(plane_lab, GROUND_IDS), plane_lab,
                   np.where(labelled, 0, np.where(ratio < RAISED_RATIO, SIDEWALK, ROAD))).astype(np.uint8)
    cls[~valid] = 0
    footprint = np.nan_to_num(zo * zo / (camera.fy * max(camera.z - a, 0.5)), nan=1.0).astype(np.float32)
    feet = np.zeros((nx, ny), np.uint8)
    low = standing & (height < 2.0)
    fr = np.floor((pts[..., 0][low] - x0) / CELL).astype(np.int64)
    fc = np.floor((y0 - pts[..., 1][low]) / CELL).astype(np.int64)
    inplan = (fr >= 0) & (fr < nx) & (fc >= 0) & (fc < ny)
    feet[fr[inplan], fc[inplan]] = 1
    k = 2 * int(round(FOOT_REACH / CELL)) + 1
    feet = cv2.dilate(feet, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) > 0
    return GroundPlan(lin.astype(np.float32), valid, cls, clip, u, v, footprint, feet, (a, b, c),
                      (float(x0), float(y0)))


def _level(rise: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(nx, ny) bool: cells whose seen ground is level - its height over the road plane (``rise``,
    metres) changes by less than :data:`MAX_SLOPE` per metre, measured over :data:`SLOPE_BASE`
    on the valid cells: a kerb's face or a ramp is not where a shadow's edge is read."""
    sigma = SLOPE_BASE / CELL / 2.0
    w = cv2.GaussianBlur(valid.astype(np.float32), (0, 0), sigma)
    h = cv2.GaussianBlur(np.where(valid, rise, 0.0).astype(np.float32), (0, 0), sigma) / np.maximum(w, 1e-3)
    gx = cv2.Sobel(h, cv2.CV_32F, 1, 0) / (8.0 * CELL)
    gy = cv2.Sobel(h, cv2.CV_32F, 0, 1) / (8.0 * CELL)
    return np.hypot(gx, gy) <= MAX_SLOPE


def completed_labels(label_ids: np.ndarray, depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W) uint8: the labels of a frame without labels (found surfaces, 0 elsewhere)
    completed from its depth: unlabelled level pixels (within :data:`STANDING_HEIGHT` of the
    road plane: ground the colour model left out, the road's shadows among it) become road, and
    unlabelled pixels standing above it (up to 25 m up) something standing (``static``: what
    casts shadows, for the cues that need the casters)."""
    pts = _points(depth, camera)
    lab = label_ids[::_STEP, ::_STEP][: pts.shape[0], : pts.shape[1]]
    a, b, c = fit_road_plane(pts, lab, camera)
    height = pts[..., 2] - (a + b * (pts[..., 0] - camera.x) + c * (pts[..., 1] - camera.y))
    known = np.isfinite(height)
    level = known & (np.abs(height) < STANDING_HEIGHT)
    standing = known & (height >= STANDING_HEIGHT) & (height < 25.0)
    small = np.where(level, ROAD, np.where(standing, STANDING, 0)).astype(np.uint8)
    H, W = label_ids.shape
    full = cv2.resize(small, (W, H), interpolation=cv2.INTER_NEAREST)
    return np.where(label_ids == 0, full, label_ids).astype(np.uint8)
