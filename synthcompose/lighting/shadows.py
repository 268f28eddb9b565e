"""Cue 1: cast shadows on the ground (two brightness levels), and the occluders' height maps."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from synthcompose.camera import Camera

from .grid import Grid
from .light import GROUND_IDS, OCCLUDER_IDS

CELL = 0.25  # height-map cell, metres
UNSEEN_TOP = 20.0  # metres: what an occluder cut by the image top may reach
EDGE_MARGIN_DEG = 4.0  # sun elevation margin around a predicted shadow edge
_MARCH = np.concatenate([np.arange(1, 33) * CELL, 8.0 + np.arange(1, 45) * 2 * CELL]).astype(np.float32)  # to 30 m
_PAD = int(math.ceil(30.0 / CELL)) + 2


@dataclass(eq=False)
class ShadowCue:
    """Ground samples, and their occluders' horizons computed per azimuth on demand."""

    samples: np.ndarray  # (N, 3) vehicle points of ground cells
    rel: np.ndarray  # (N,) log luminance minus its class median (clipped)
    lin: np.ndarray  # (N, 3) linear colour
    cls: np.ndarray  # (N,) label
    maps: tuple[np.ndarray, np.ndarray, int, int]  # flat height maps (seen, unseen tops raised), nx, ny
    cells: tuple[np.ndarray, np.ndarray]  # (N, 1) float32 map coordinates of the samples
    view: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # distances to / unit vectors of the borders
    top: float  # height (m) above which nothing is assumed to stand
    ground: np.ndarray | None = None  # (h, w) bool grid: the ground cells sampled from (no markings)
    cache: dict = field(default_factory=dict)

    def horizons(self, az_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N,) tangents of the occluders' horizon towards ``az_deg`` (as seen, with unseen tops
        raised) and how far (m) the path stays inside the camera's view."""
        key = round(az_deg % 360.0, 3)
        if key not in self.cache:
            self.cache[key] = _march(self, math.radians(key))
        return self.cache[key]

    def shadowed(self, az_deg: float, el_deg: float) -> tuple[np.ndarray, np.ndarray]:
        """Bool (N,) pairs (shadowed, known) for that sun: a sample is known when a seen occluder
        is in the way, or when the path to the sun stays in view until it has risen above
        everything, unseen tops of occluders included."""
        horizon, horizon_hi, seen = self.horizons(az_deg)
        tan_el = math.tan(math.radians(el_deg))
        # a few degrees of margin: near a predicted shadow's edge the state is not known
        shadow = horizon > math.tan(math.radians(min(el_deg + EDGE_MARGIN_DEG, 89.0)))
        lit_tan = math.tan(math.radians(max(el_deg - EDGE_MARGIN_DEG, 1.0)))
        need = np.minimum((self.top - self.samples[:, 2]) / tan_el, _MARCH[-1])
        return shadow, shadow | ((horizon_hi <= lit_tan) & (seen >= need))


def _march(cue: ShadowCue, a: float, steps: np.ndarray | None = None):
    """Horizon tangents of the samples towards azimuth ``a`` (radians) over the march steps."""
    hm, hm_hi, nx, ny = cue.maps
    fx0, fy0 = cue.cells
    dz0 = cue.samples[:, 2].astype(np.float32)[:, None]
    march = _MARCH if steps is None else steps
    ca, sa = np.float32(math.cos(a)), np.float32(math.sin(a))
    cells = march / np.float32(CELL)
    ix = (fx0 + ca * cells[None, :]).astype(np.int32)  # >= 0 by the map's border: a floor
    iy = (fy0 + sa * cells[None, :]).astype(np.int32)
    flat = np.clip(ix, 0, nx - 1) * ny + np.clip(iy, 0, ny - 1)
    rise = hm[flat] - dz0
    if steps is not None:
        return rise
    inv = (1.0 / march)[None, :]
    horizon = (rise * inv).max(axis=1)
    horizon_hi = ((hm_hi[flat] - dz0) * inv).max(axis=1)
    # how far the path stays inside the camera's view wedge (analytically)
    f_left, f_right, e_left, e_right = cue.view
    seen = np.full(len(dz0), float(march[-1]))
    for f0, rate in ((f_left, -(e_left[0] * sa - e_left[1] * ca)), (f_right, e_right[0] * sa - e_right[1] * ca)):
        if rate < 0:
            seen = np.minimum(seen, np.maximum(f0, 0.0) / -rate)
        seen = np.where(f0 < 0, 0.0, seen)
    return horizon, horizon_hi, seen


def _height_map(g: Grid, label_ids: np.ndarray, depth: np.ndarray, camera: Camera, occluder_ids):
    """Max height of occluder points per ground-plan cell (V frame), 3x3 dilated: as seen, and
    raised to at least :data:`UNSEEN_TOP` (or 8 m more) where the occluder runs out of the top of
    the image (its top is unseen)."""
    H, W = depth.shape
    step = max(1, W // 512)
    v, u = np.mgrid[0:H:step, 0:W:step]
    z = depth[v, u]
    lab = label_ids[v, u]
    keep = np.isfinite(z) & np.isin(lab, occluder_ids)
    top = np.zeros(z.shape, bool)
    top[:2] = True
    v, u, z, top = v[keep], u[keep], z[keep].astype(np.float64), top[keep]
    opt = np.column_stack([(u - camera.u0) * z / camera.fx, (v - camera.v0) * z / camera.fy, z])
    m = camera.vehicle_from_optical
    p = opt @ m[:3, :3].T + m[:3, 3]
    # the map, with a border of _PAD empty cells so that any march from a sample stays inside
    x0, y0 = camera.x - 10.0 - _PAD * CELL, camera.y - 50.0 - _PAD * CELL
    nx, ny = int(110.0 / CELL) + 2 * _PAD, int(100.0 / CELL) + 2 * _PAD
    ix = np.floor((p[:, 0] - x0) / CELL).astype(np.int64)
    iy = np.floor((p[:, 1] - y0) / CELL).astype(np.int64)
    inside = (ix >= _PAD) & (ix < nx - _PAD) & (iy >= _PAD) & (iy < ny - _PAD)
    maps = []
    for hz in (p[:, 2], np.where(top, np.maximum(p[:, 2] + 8.0, UNSEEN_TOP), p[:, 2])):
        hm = np.full(nx * ny, -1e4, np.float32)
        order = np.argsort(hz[inside], kind="stable")  # the highest point of a cell is written last
        hm[(ix[inside] * ny + iy[inside])[order]] = hz[inside][order].astype(np.float32)
        maps.append(cv2.dilate(hm.reshape(nx, ny), np.ones((3, 3), np.uint8)))
    return maps, (x0, y0)


def _view_edges(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Ground-plan unit vectors of the image's left and right borders (2 degrees inside)."""
    left = math.atan(camera.u0 / camera.fx) - math.radians(2.0)
    right = -math.atan((camera.width - 1 - camera.u0) / camera.fx) + math.radians(2.0)
    return (np.array([math.cos(camera.yaw + left), math.sin(camera.yaw + left)]),
            np.array([math.cos(camera.yaw + right), math.sin(camera.yaw + right)]))


MARKING_WIDTH = 1.75  # metres: brighter ground narrower than this is paint or kerbstone, not sunlight
_PLAN_CELL = 0.25


def _markings(g: Grid, rr: np.ndarray, cc: np.ndarray, camera: Camera) -> np.ndarray:
    """Bool per ground cell (rr, cc): part of a bright structure narrower than
    :data:`MARKING_WIDTH` on the ground plan (lane markings, kerbstones) - a white top-hat of the
    log luminance, per class, on a plan grid. Lit patches are wider and stay."""
    out = np.zeros(len(rr), bool)
    pts, cls = g.points[rr, cc], g.label[rr, cc]
    ll = np.log(np.maximum(g.lum[rr, cc], 1e-6)).astype(np.float32)
    ix = np.floor((pts[:, 0] - camera.x + 5.0) / _PLAN_CELL).astype(np.int64)
    iy = np.floor((pts[:, 1] - camera.y + 50.0) / _PLAN_CELL).astype(np.int64)
    nx, ny = int(55.0 / _PLAN_CELL), int(100.0 / _PLAN_CELL)
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    k = int(round(MARKING_WIDTH / _PLAN_CELL)) | 1
    kernel = np.ones((k, k), np.uint8)
    for c in np.unique(cls):
        sel = np.nonzero(inside & (cls == c))[0]
        flat = ix[sel] * ny + iy[sel]
        total = np.bincount(flat, weights=ll[sel], minlength=nx * ny)
        count = np.bincount(flat, minlength=nx * ny)
        plan = np.where(count > 0, total / np.maximum(count, 1), 1e4).astype(np.float32).reshape(nx, ny)
        opened = cv2.dilate(np.where(plan < 1e3, cv2.erode(plan, kernel), -1e4).astype(np.float32), kernel)
        tophat = ll[sel] - opened.ravel()[flat]
        out[sel] = (tophat > 0.3) & (opened.ravel()[flat] > -1e3)
    return out


@dataclass(frozen=True, eq=False)
class Occluders:
    """The height maps of everything standing on the ground, and the camera's view borders."""

    maps: tuple[np.ndarray, np.ndarray, int, int]  # flat maps (seen, unseen tops raised), nx, ny
    origin: tuple[float, float]  # (x, y) of cell (0, 0) in V
    edges: tuple[np.ndarray, np.ndarray]  # unit vectors of the image's left and right borders
    top: float  # height (m) above which nothing is assumed to stand

    @classmethod
    def build(cls, g: Grid, label_ids: np.ndarray, depth: np.ndarray, camera: Camera) -> "Occluders":
        (hm, hm_hi), origin = _height_map(g, label_ids, depth, camera, OCCLUDER_IDS)
        finite = hm_hi[hm_hi > -1e3]
        top = float(min(np.max(finite), 25.0)) if finite.size else 0.0
        return cls((hm.ravel(), hm_hi.ravel(), hm.shape[0], hm.shape[1]), origin, _view_edges(camera), top)

    def cue(self, pts: np.ndarray, camera: Camera, lin: np.ndarray | None = None,
            cls: np.ndarray | None = None) -> ShadowCue:
        """Shadow queries for vehicle-frame points ``pts`` (N, 3)."""
        (x0, y0), (e_left, e_right) = self.origin, self.edges
        rel_x, rel_y = pts[:, 0] - camera.x, pts[:, 1] - camera.y
        n = len(pts)
        return ShadowCue(
            pts, np.zeros(n), np.zeros((n, 3)) if lin is None else lin, np.zeros(n, np.uint8) if cls is None else cls,
            self.maps,
            (np.clip((pts[:, 0] - x0) / CELL, 0, None).astype(np.float32)[:, None],
             np.clip((pts[:, 1] - y0) / CELL, 0, None).astype(np.float32)[:, None]),
            (-(e_left[0] * rel_y - e_left[1] * rel_x), e_right[0] * rel_y - e_right[1] * rel_x, e_left, e_right),
            self.top)


def ground_cells(g: Grid, camera: Camera, unknown_normals: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Cells of pure ground (:data:`GROUND_IDS`) with a point and some light, facing up (not kerb
    faces; nan normals fail too, unless ``unknown_normals``), within 45 m of the camera on the
    ground plan; and every cell's distance from the camera on the ground plan. Real stereo
    leaves most ground cells without a normal (the grid's planarity tests fail on its noise: 94 %
    of a street frame's ground cells within 10 m, 98 % at 10-30 m)."""
    dist = np.hypot(g.points[..., 0] - camera.x, g.points[..., 1] - camera.y)
    ground = g.pure & np.isin(g.label, GROUND_IDS) & np.isfinite(g.points[..., 0]) & (g.lum > 1e-4)
    up = g.normals[..., 2] > 0.9
    if unknown_normals:
        up |= np.isnan(g.normals[..., 2])
    ground &= up & (dist < 45.0)
    return ground, dist


def shadow_cue(g: Grid, occ: Occluders, camera: Camera, max_samples: int = 2000) -> ShadowCue | None:
    ground, _ = ground_cells(g, camera)
    ground &= np.abs(g.points[..., 1] - camera.y) < 48.0
    rr, cc = np.nonzero(ground)
    if len(rr) < 200:
        return None
    keep = ~_markings(g, rr, cc, camera)
    rr, cc = rr[keep], cc[keep]
    if len(rr) < 200:
        return None
    unmarked = np.zeros(ground.shape, bool)
    unmarked[rr, cc] = True
    if len(rr) > max_samples:  # even spread, deterministic
        pick = np.linspace(0, len(rr) - 1, max_samples).astype(np.int64)
        rr, cc = rr[pick], cc[pick]
    pts, cls = g.points[rr, cc], g.label[rr, cc]
    cue = occ.cue(pts, camera)
    # samples with an occluder within half a metre (under cars, at wall feet) are dark from
    # ambient occlusion whatever the sun does: left out
    near = np.zeros(len(rr), bool)
    for a in np.radians(np.arange(0.0, 360.0, 30.0)):
        near |= (_march(cue, a, _MARCH[:2]) > 0.15).any(axis=1)
    keep = ~near
    if keep.sum() < 150:
        return None
    pts, cls, rr, cc = pts[keep], cls[keep], rr[keep], cc[keep]
    cue = occ.cue(pts, camera, g.lin[rr, cc].astype(np.float64), cls)
    loglum = np.log(g.lum[rr, cc])
    rel = np.empty(len(rr))
    for k in np.unique(cls):
        sel = cls == k
        rel[sel] = loglum[sel] - np.median(loglum[sel])
    cue.rel = np.clip(rel, -2.5, 1.5)  # (markings are gone; an outlier component takes the rest)
    cue.ground = unmarked
    return cue


@dataclass(frozen=True)
class Mixture:
    """Two brightness levels of the ground: lit (per class) and shadowed (shared log ratio)."""

    delta: float  # log(shadow / lit)
    share: float  # share of samples in shadow
    sigma: float
    gain: float  # log-likelihood gain per sample over one level
    posterior: np.ndarray  # (N,) probability of each sample being in shadow


_OUTLIER = 0.04 / 4.0  # density of the uniform outlier component over rel in [-2.5, 1.5]


def fit_mixture(cue: ShadowCue, iterations: int = 30) -> Mixture:
    """EM fit of a lit level mu_c per class, a shared shadow step delta, a shared width and a
    uniform outlier component to the ground samples' log luminance; the best of a few starts."""
    r, cls = cue.rel, cue.cls
    classes, inv = np.unique(cls, return_inverse=True)

    def dens(x, m, s):
        return np.exp(-0.5 * ((x - m) / s) ** 2) / (s * math.sqrt(2 * math.pi))

    def fit(delta: float, share: float):
        mu = np.array([np.quantile(r[inv == j], 1.0 - share / 2) for j in range(len(classes))])
        sigma = 0.1
        for _ in range(iterations):
            m = mu[inv]
            p_lit = (1 - share) * dens(r, m, sigma)
            p_sh = share * dens(r, m + delta, sigma)
            tot = p_lit + p_sh + _OUTLIER
            w_lit, w_sh = p_lit / tot, p_sh / tot
            for j in range(len(classes)):
                sel = inv == j
                den = w_lit[sel].sum() + w_sh[sel].sum()
                if den > 1e-9:
                    mu[j] = (w_lit[sel] @ r[sel] + w_sh[sel] @ (r[sel] - delta)) / den
            m = mu[inv]
            if w_sh.sum() > 1e-6:
                delta = float(min(w_sh @ (r - m) / w_sh.sum(), 0.0))
            share = float(np.clip(w_sh.sum() / (w_lit.sum() + w_sh.sum()), 1e-3, 1 - 1e-3))
            var = (w_lit @ (r - m) ** 2 + w_sh @ (r - m - delta) ** 2) / max(w_lit.sum() + w_sh.sum(), 1e-9)
            sigma = float(np.clip(math.sqrt(var), 0.03, 1.0))
        m = mu[inv]
        p_lit = (1 - share) * dens(r, m, sigma)
        p_sh = share * dens(r, m + delta, sigma)
        ll = float(np.log(p_lit + p_sh + _OUTLIER).mean())
        return ll, delta, share, sigma, p_sh / np.maximum(p_lit + p_sh, 1e-300)

    best = max((fit(d0, s0) for d0, s0 in ((-0.3, 0.3), (-0.7, 0.15), (-1.2, 0.1), (-1.2, 0.4))),
               key=lambda t: t[0])
    ll2, delta, share, sigma, post = best
    # one level per class, same outlier model
    mu1 = np.array([np.median(r[inv == j]) for j in range(len(classes))])[inv]
    s1 = float(np.clip(np.sqrt(np.mean((r - mu1) ** 2)), 0.03, 1.0))
    ll1 = float(np.log(dens(r, mu1, s1) + _OUTLIER).mean())
    return Mixture(delta, share, sigma, ll2 - ll1, post)


def shadow_score(cue: ShadowCue, mix: Mixture, shadow: np.ndarray, known: np.ndarray) -> float:
    """Log-likelihood ratio (nats per ground sample) of the predicted shadow mask against
    shadows that could be anywhere: > 0 where the prediction agrees with the dark samples.
    Samples whose state the visible scene cannot tell count zero."""
    q = np.clip(mix.posterior, 0.02, 0.98)
    a = np.clip(np.log(q / mix.share), -3.0, 3.0)
    b = np.clip(np.log((1 - q) / (1 - mix.share)), -3.0, 3.0)
    return float(np.where(known, np.where(shadow, a, b), 0.0).sum() / len(q))
