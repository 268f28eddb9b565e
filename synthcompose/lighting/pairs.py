"""Cue 2: shading of surface pairs on the two faces of a convex edge (the sun's direction)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .grid import Grid
from .light import SHADING_IDS, sun_direction_of


@dataclass(eq=False)
class PairCue:
    n1: np.ndarray  # (N, 3)
    n2: np.ndarray
    y: np.ndarray  # (N,) log luminance ratio 1 / 2
    label: np.ndarray  # (N,) class of the pair
    rc: np.ndarray  # (N, 4) grid cells (row, col) of both ends
    weight: np.ndarray  # (N,) so that no one object (image region) outweighs the rest
    z: np.ndarray  # (N,) height (vehicle frame: above the ground under the camera) of the lower end
    terms: dict = field(default_factory=dict)  # direction-free terms of pair_fit, float32


def pair_cue(g: Grid, max_pairs: int = 6000) -> PairCue | None:
    ok = g.pure & np.isfinite(g.normals[..., 0]) & np.isin(g.label, SHADING_IDS) & (g.lum > 1e-4)
    h, w = ok.shape
    n1s, n2s, ys, labs, rcs = [], [], [], [], []
    loglum = np.log(np.maximum(g.lum, 1e-6))
    nx, ny, nz = (np.ascontiguousarray(g.normals[..., i]) for i in range(3))
    cos20 = np.float32(math.cos(math.radians(20)))
    for d in (2, 3, 5):
        for dr, dc in ((0, d), (d, 0), (d, d), (d, -d)):
            a = (slice(max(0, -dr), h - max(0, dr)), slice(max(0, -dc), w - max(0, dc)))
            b = (slice(a[0].start + dr, a[0].stop + dr), slice(a[1].start + dc, a[1].stop + dc))
            both = ok[a] & ok[b] & (g.label[a] == g.label[b])
            both &= nx[a] * nx[b] + ny[a] * ny[b] + nz[a] * nz[b] < cos20
            idx = np.nonzero(both)
            if not len(idx[0]):
                continue
            ia = (idx[0] + a[0].start, idx[1] + a[1].start)
            ib = (ia[0] + dr, ia[1] + dc)
            na, nb = g.normals[ia], g.normals[ib]
            la, lb = loglum[ia], loglum[ib]
            dpq = g.points[ib] - g.points[ia]
            gap = np.linalg.norm(dpq, axis=-1)
            keep = gap < 1.0
            # convex edges only (each point behind the other's tangent plane): one object's
            # faces; a concave corner is as often two buildings meeting, with two albedos
            keep &= (np.sum(dpq * na, axis=-1) < -0.01 * gap) & (np.sum(-dpq * nb, axis=-1) < -0.01 * gap)
            keep &= np.abs(la - lb) < 1.8  # no light makes more of a step
            # shading keeps the colour (nearly: sun and sky differ); a change of
            # chromaticity is a change of paint (lamps, plates, trims)
            ca = g.lin[ia] / np.maximum(g.lin[ia].sum(axis=-1, keepdims=True), 1e-6)
            cb = g.lin[ib] / np.maximum(g.lin[ib].sum(axis=-1, keepdims=True), 1e-6)
            keep &= np.abs(ca - cb).max(axis=-1) < 0.1
            if keep.any():
                n1s.append(na[keep])
                n2s.append(nb[keep])
                ys.append(la[keep] - lb[keep])
                labs.append(g.label[ia][keep])
                rcs.append(np.column_stack([ia[0][keep], ia[1][keep], ib[0][keep], ib[1][keep]]))
    if not ys:
        return None
    n1, n2, y = np.concatenate(n1s), np.concatenate(n2s), np.concatenate(ys)
    lab, rc = np.concatenate(labs), np.concatenate(rcs)
    if len(y) < 30:
        return None
    # regions of 1/32 of the grid width: each counts at most like PAIRS_PER_REGION pairs, and
    # keeps at most PAIRS_KEPT_PER_REGION of its pairs (evenly spread: its mean speaks for it)
    side = max(4, w // 32)
    region = (rc[:, 0] // side) * (w // side + 1) + rc[:, 1] // side
    order = np.argsort(region, kind="stable")
    counts = np.bincount(region)
    first = np.cumsum(counts) - counts
    rank = np.empty(len(y), np.int64)
    rank[order] = np.arange(len(y)) - first[region[order]]
    total = counts[region]
    keep = (rank * PAIRS_KEPT_PER_REGION) % total < PAIRS_KEPT_PER_REGION
    if keep.sum() > max_pairs:
        keep[np.nonzero(keep)[0][np.linspace(0, keep.sum() - 1, keep.sum() - max_pairs).astype(np.int64)]] = False
    n1, n2, y, lab, rc, region, total = (v[keep] for v in (n1, n2, y, lab, rc, region, total))
    kept = np.bincount(region)[region]
    weight = np.minimum(total, PAIRS_PER_REGION) / kept * PAIR_CLASS_WEIGHT[lab]
    z = np.fmin(g.points[rc[:, 0], rc[:, 1], 2], g.points[rc[:, 2], rc[:, 3], 2])
    return PairCue(n1, n2, y, lab, rc, weight, z)


PAIRS_PER_REGION = 6
PAIRS_KEPT_PER_REGION = 24
#: trust in each class's pairs, measured with benchmarks/eval_lighting.py (sun within 20 degrees
#: of the truth; the windows' colour change keeps them out of building pairs): building corners
#: are the best cue; a car's faces often change paint or carry lamps, so cars weigh a quarter;
#: kerbs (road / sidewalk pairs) weigh little: a kerb's face is a few pixels high, its normal from
#: the depth is poor and its pairs pull the fit away from the sun (at full weight they halved the
#: share of suns found within 20 degrees)
PAIR_CLASS_WEIGHT = np.ones(256)
PAIR_CLASS_WEIGHT[[7, 8]] = 0.05
PAIR_CLASS_WEIGHT[[26, 27, 28, 29, 30, 31]] = 0.25
KS = np.array([0.85, 0.7, 0.55, 0.42, 0.3, 0.2])  # sky shares tried with a sun
GAMMAS = np.array([0.15, 0.3, 0.5])  # ground bounce ratios tried
_SCALE = 0.15  # robust loss scale (log units)
_SHADOWED_PAIR = 0.5  # loss for explaining a pair as lying in a cast shadow (ambient only)


def rho(res: np.ndarray) -> np.ndarray:
    return np.log1p((res / _SCALE) ** 2)


def pair_none(cue: PairCue) -> tuple[np.ndarray, float]:
    """Per-pair losses of the best ambient-only model, and its ground ratio."""
    best = None
    for gm in GAMMAS:
        h1 = gm + (1 - gm) * (0.5 + 0.5 * cue.n1[:, 2])
        h2 = gm + (1 - gm) * (0.5 + 0.5 * cue.n2[:, 2])
        loss = rho(cue.y - np.log(h1 / h2))
        if best is None or loss @ cue.weight < best[0] @ cue.weight:
            best = (loss, float(gm))
    return best


def pair_sun(t: dict, az_deg: float, el_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The sun's light on each end of the pairs (float32 terms ``t`` of :func:`pair_fit`),
    relative to an up-facing surface's."""
    d = sun_direction_of(az_deg, el_deg).astype(np.float32)
    return np.maximum(t["n1"] @ d, 0) / d[2], np.maximum(t["n2"] @ d, 0) / d[2]


def pair_fit(cue: PairCue, none: np.ndarray, az_deg: float, el_deg: float) -> tuple[float, float, float]:
    """(gain in nats per pair over the ambient-only model, sky share, ground ratio) of the best
    sunny model for that sun direction. A pair may instead lie in a cast shadow (ambient only,
    at a small extra cost), so shadowed objects do not speak against the sun."""
    t = cue.terms
    if not t:  # the sky's part of each end's light, k * ambient(n), for every (k, ground ratio)
        k, gm = KS[:, None, None], GAMMAS[None, :, None]
        for name, n in (("kh1", cue.n1), ("kh2", cue.n2)):
            t[name] = (k * (gm + (1 - gm) * (0.5 + 0.5 * n[:, 2])[None, None, :])).astype(np.float32)
        t["sun_share"] = (1 - KS[:, None, None]).astype(np.float32)
        t["n1"], t["n2"], t["y"] = cue.n1.astype(np.float32), cue.n2.astype(np.float32), cue.y.astype(np.float32)
    s1, s2 = pair_sun(t, az_deg, el_deg)
    e1 = np.maximum(t["kh1"] + t["sun_share"] * s1, np.float32(1e-4))
    e2 = np.maximum(t["kh2"] + t["sun_share"] * s2, np.float32(1e-4))
    loss = rho(t["y"] - np.log(e1 / e2))
    loss = np.minimum(loss, (none + _SHADOWED_PAIR).astype(np.float32)).astype(np.float64) @ cue.weight
    i, j = np.unravel_index(int(np.argmin(loss)), loss.shape)
    return float((none @ cue.weight - loss[i, j]) / cue.weight.sum()), float(KS[i]), float(GAMMAS[j])
