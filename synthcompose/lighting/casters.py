"""Cue: the shadows of the casters in view (the sun ahead of the camera)."""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.camera import Camera

from .grid import Grid
from .light import OCCLUDER_IDS
from .shadows import ground_cells

CASTER_MAX_HEIGHT = 6.0  # metres above their ground: the caster points used (lower parts of walls)
CASTER_POINTS = 1500  # at most, evenly spread over the casters
_CAST_CELL = 0.2  # ground-plan cell of the landing map, metres
_CAST_NEAR = 0.6  # metres: ground this near a caster's foot is dark from contact shadow alone
#: a caster sun needs this agreement (mean over the caster points) and this many points whose
#: shadow lands on dark ground
CASTER_MIN_AGREEMENT, CASTER_MIN_DARK = 0.015, 25
#: only for ground without a brighter level: at most this share of the ground samples lies a
#: shadow step above their class's median (which is then the lit level, not the shadow's)
CASTER_MAX_BRIGHT = 0.004
#: degrees: above this the shadows lie at the casters' feet for any azimuth
CASTER_MAX_ELEVATION = 70.0


@dataclass(eq=False)
class _CasterCue:
    """Points of the things standing in view, with their height above their own ground, and a
    ground-plan map of the ground in view (log luminance against its class's level): for a sun
    direction, where each point's shadow lands and how dark the ground there is."""

    xy: np.ndarray  # (P, 2) float32 plan position of the caster points
    height: np.ndarray  # (P,) float32 above the ground under them
    rel: np.ndarray  # (nx * ny,) float32 log luminance of the ground cell minus its class level; nan unseen
    origin: tuple[float, float]
    shape: tuple[int, int]

    def landings(self, az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
        """(D, P) rel of the ground where each point's shadow lands, nan where that ground is not
        in view (hidden, out of the picture, near a caster's foot)."""
        az, el = np.radians(np.atleast_1d(az_deg)), np.radians(np.atleast_1d(el_deg))
        run = (self.height[None, :] / np.tan(el)[:, None]).astype(np.float32)
        lx = self.xy[None, :, 0] - run * np.cos(az).astype(np.float32)[:, None]
        ly = self.xy[None, :, 1] - run * np.sin(az).astype(np.float32)[:, None]
        nx, ny = self.shape
        ix = np.floor((lx - self.origin[0]) / _CAST_CELL).astype(np.int32)
        iy = np.floor((ly - self.origin[1]) / _CAST_CELL).astype(np.int32)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        flat = np.where(inside, ix * ny + iy, 0)
        return np.where(inside, self.rel[flat], np.nan)

    def score(self, az_deg, el_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per direction (D,): the agreement (mean over the points of +1 for a shadow landing on
        dark ground, -1 on lit ground, 0 out of view), the number of points landing on dark
        ground, and the median darkness (log ratio to the class level) where they land dark."""
        r = self.landings(az_deg, el_deg)
        seen = np.isfinite(r)
        e = np.where(seen, np.clip((-np.where(seen, r, 0.0) - 0.25) / 0.1, -1.0, 1.0), 0.0)
        dark = e > 0.5
        step = np.array([float(np.median(r[i][dark[i]])) if dark[i].any() else 0.0 for i in range(len(r))])
        return e.sum(axis=1) / e.shape[1], dark.sum(axis=1), step


def caster_cue(g: Grid, camera: Camera) -> _CasterCue | None:
    ground, d_here = ground_cells(g, camera, unknown_normals=True)
    standing = np.isin(g.label, OCCLUDER_IDS)
    # ground seen below something standing that is not clearly nearer than it (under a car's
    # body, at its foot) is dark from contact shadow alone
    caster = standing & np.isfinite(d_here)
    d_above = np.minimum.accumulate(np.where(caster, d_here, np.inf), axis=0)  # nearest above, per column
    under = d_above < d_here + _CAST_NEAR
    ground &= ~under
    rr, cc = np.nonzero(ground)
    if len(rr) < 200:
        return None
    gp, cls = g.points[rr, cc], g.label[rr, cc]
    ll = np.log(g.lum[rr, cc])
    rel = np.empty(len(rr), np.float32)
    for k in np.unique(cls):
        sel = cls == k
        rel[sel] = ll[sel] - np.median(ll[sel])
    x0, y0 = float(gp[:, 0].min()) - 1.0, float(gp[:, 1].min()) - 1.0
    nx = int((gp[:, 0].max() - x0) / _CAST_CELL) + 2
    ny = int((gp[:, 1].max() - y0) / _CAST_CELL) + 2
    ix = ((gp[:, 0] - x0) / _CAST_CELL).astype(np.int64)
    iy = ((gp[:, 1] - y0) / _CAST_CELL).astype(np.int64)
    flat = ix * ny + iy
    count = np.bincount(flat, minlength=nx * ny)
    total = np.bincount(flat, weights=rel, minlength=nx * ny)
    plan = np.where(count > 0, total / np.maximum(count, 1), np.nan).astype(np.float32)
    # ground height under everything: the nearest ground seen, on a coarser plan
    k = 5
    cx, cy = nx // k + 1, ny // k + 1
    cflat = (ix // k) * cy + iy // k
    ccount = np.bincount(cflat, minlength=cx * cy)
    cz = (np.bincount(cflat, weights=gp[:, 2], minlength=cx * cy) / np.maximum(ccount, 1)).reshape(cx, cy)
    unknown = (ccount == 0).reshape(cx, cy).astype(np.uint8)
    _, lab = cv2.distanceTransformWithLabels(unknown, cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL)
    known_idx = np.flatnonzero(unknown.ravel() == 0)
    # labels number the zero pixels in raster order (1-based)
    zmap = cz.ravel()[known_idx[np.clip(lab.ravel() - 1, 0, len(known_idx) - 1)]].reshape(cx, cy)

    occ = g.pure & standing & np.isfinite(g.points[..., 0])
    orr, occ_c = np.nonzero(occ)
    op = g.points[orr, occ_c]
    ox = np.clip(((op[:, 0] - x0) / _CAST_CELL).astype(np.int64) // k, 0, cx - 1)
    oy = np.clip(((op[:, 1] - y0) / _CAST_CELL).astype(np.int64) // k, 0, cy - 1)
    h = op[:, 2] - zmap[ox, oy]
    # ground under anything standing (a car's body: seen below it) or near its foot is left
    # out: dark from contact shadow alone
    foot = h < 3.0
    fx = ((op[foot, 0] - x0) / _CAST_CELL).astype(np.int64)
    fy = ((op[foot, 1] - y0) / _CAST_CELL).astype(np.int64)
    inside = (fx >= 0) & (fx < nx) & (fy >= 0) & (fy < ny)
    near = np.zeros((nx, ny), np.uint8)
    near[fx[inside], fy[inside]] = 1
    r = int(round(_CAST_NEAR / _CAST_CELL))
    near = cv2.dilate(near, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    plan[near.ravel() > 0] = np.nan
    keep = (h > 0.2) & (h < CASTER_MAX_HEIGHT) & (np.hypot(op[:, 0] - camera.x, op[:, 1] - camera.y) < 45.0)
    op, h = op[keep], h[keep]
    if len(h) < 20:
        return None
    if len(h) > CASTER_POINTS:
        pick = np.linspace(0, len(h) - 1, CASTER_POINTS).astype(np.int64)
        op, h = op[pick], h[pick]
    return _CasterCue(op[:, :2].astype(np.float32), h.astype(np.float32), plan, (x0, y0), (nx, ny))


def sun_from_casters(cue: _CasterCue, coarse: list):
    """A sun found from the shadows of the casters in view, for ground without a clear second
    brightness level (the sun ahead of the camera: the shadows of cars, poles and people fall
    towards it, a small share of the ground): (agreement, azimuth, elevation, shadow log ratio),
    or None. The best coarse direction, refined, must land at least :data:`CASTER_MIN_DARK` of
    the points on dark ground and score :data:`CASTER_MIN_AGREEMENT`."""
    # a high sun puts the shadows at the casters' feet, whatever its azimuth: not judged
    az = np.array([c[1] for c in coarse if c[2] <= CASTER_MAX_ELEVATION])
    el = np.array([c[2] for c in coarse if c[2] <= CASTER_MAX_ELEVATION])
    agree, dark, step = cue.score(az, el)
    i = int(np.argmax(agree))
    best = (float(agree[i]), float(az[i]), float(el[i]), float(step[i]), int(dark[i]))
    faz, fel = np.meshgrid(best[1] + np.arange(-10.0, 10.1, 5.0),
                           np.clip(best[2] + np.arange(-8.0, 8.1, 4.0), 8.0, CASTER_MAX_ELEVATION), indexing="ij")
    faz, fel = faz.ravel() % 360.0, fel.ravel()
    agree, dark, step = cue.score(faz, fel)
    j = int(np.argmax(agree))
    if agree[j] > best[0]:
        best = (float(agree[j]), float(faz[j]), float(fel[j]), float(step[j]), int(dark[j]))
    if best[0] < CASTER_MIN_AGREEMENT or best[4] < CASTER_MIN_DARK:
        return None
    return best[:4]
