"""Cue: straight shadow edges on the ground (the sun's azimuth)."""
from __future__ import annotations

import math

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.labels import label_ids

from .grid import Grid
from .light import LUM
from .pairs import PairCue, pair_fit
from .shadows import Mixture, ShadowCue

#: a straight edge between lit and shadowed ground at least this long (metres, on the ground
#: plan) and off the street's axis and its normal by more than LINE_AXIS_BAND degrees is the
#: shadow of something vertical: it runs along the sun's azimuth
LINE_MIN_LENGTH, LINE_AXIS_BAND = 3.0, 10.0
#: the vertical surfaces whose shadow lines the sun direction is read from
WALL_IDS = label_ids("building", "wall")
#: the shading gain a direction along such an edge may lose against the best direction
LINE_MARGIN = 0.3
_LINE_BIN = 0.25  # metres: offset and length bins of the edge search
_LINE_MAX_DIST = 30.0  # metres: edges farther from the camera are too coarse on the plan
_LINE_GAP = 3  # empty bins bridged along an edge


def _street_axis(g: Grid) -> float:
    """Direction (degrees, mod 180) of the street: normal to the walls' most common facing (the
    vehicle's heading when no wall is in view)."""
    sub = (slice(None, None, 2), slice(None, None, 2))  # every other cell is plenty
    normals = g.normals[sub]
    sel = g.pure[sub] & np.isin(g.label[sub], WALL_IDS) & (np.abs(normals[..., 2]) < 0.3)
    if sel.sum() < 50:
        return 0.0
    n = normals[sel]
    h = np.bincount(np.round(np.degrees(np.arctan2(n[:, 1], n[:, 0]))).astype(np.int64) % 180,
                    minlength=180).astype(np.float64)
    h = np.convolve(np.concatenate([h[-2:], h, h[:2]]), np.ones(5), "valid")
    return float((np.argmax(h) + 90) % 180)


def find_shadow_line(g: Grid, camera: Camera, cue: ShadowCue, mix: Mixture) -> tuple[float, float]:
    """The longest straight edge between lit and shadowed ground on the ground plan, off the
    street's axis and its normal by more than :data:`LINE_AXIS_BAND` (kerbs, roof lines,
    building ends): (direction in degrees mod 180, length in metres); length 0 without one."""
    lengths = _shadow_line_lengths(g, camera, cue, mix)
    i = int(np.argmax(lengths))
    if lengths[i] <= 0:
        return 0.0, 0.0
    # a straight edge keeps much of its length a few degrees either side: the centre of the
    # directions that keep most of it
    off = np.arange(-10, 11)
    near = lengths[(i + off) % 180]
    w = np.where(near >= 0.85 * lengths[i], near, 0.0)
    return float((i + off @ w / w.sum()) % 180.0), float(lengths[i])


def _shadow_line_lengths(g: Grid, camera: Camera, cue: ShadowCue, mix: Mixture) -> np.ndarray:
    """(180,) per ground-plan direction (degrees, mod 180): the length (metres) of the longest
    straight edge between lit and shadowed ground along it, 0 within :data:`LINE_AXIS_BAND` of
    the street's axis or its normal; measured every other degree, and every degree within 11 of
    the longest (0 where not measured)."""
    rr, cc = np.nonzero(cue.ground)
    near = np.hypot(g.points[rr, cc, 0] - camera.x, g.points[rr, cc, 1] - camera.y) < _LINE_MAX_DIST
    rr, cc = rr[near], cc[near]
    if len(rr) < 200:
        return np.zeros(180)
    # each class's threshold half a shadow step below its lit level (from the mixture's samples)
    loglum = np.log(np.maximum(g.lum[rr, cc], 1e-6))
    sample_log = np.log(np.maximum(cue.lin @ LUM, 1e-6))
    cls = g.label[rr, cc]
    shade = np.full(g.lum.shape, np.nan, np.float32)
    for k in np.unique(cls):
        lit = (cue.cls == k) & (mix.posterior < 0.5)
        if lit.sum() < 20:
            continue
        sel = cls == k
        shade[rr[sel], cc[sel]] = loglum[sel] < float(np.median(sample_log[lit])) + mix.delta / 2
    valid = np.isfinite(shade)
    weight = cv2.GaussianBlur(valid.astype(np.float32), (0, 0), 1.0)
    smooth = cv2.GaussianBlur(np.where(valid, shade, 0.0).astype(np.float32), (0, 0), 1.0) / np.maximum(weight, 1e-6)
    # the shadowed side's cells next to lit ones: an edge one cell thick
    lit_cells = ((smooth < 0.5) & valid).astype(np.uint8)
    edge = valid & (smooth >= 0.5) & (weight > 0.6) & \
        (cv2.dilate(lit_cells, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))) > 0)
    xy = g.points[edge][:, :2]
    xy = xy[np.isfinite(xy).all(axis=1)]
    out = np.zeros(180)
    if len(xy) < 20:
        return out
    xy = xy - xy.mean(axis=0)
    street = _street_axis(g)

    def measure(phi: int) -> None:
        off = min(abs(phi - street) % 180, 180 - abs(phi - street) % 180)
        if off <= LINE_AXIS_BAND or abs(off - 90) <= LINE_AXIS_BAND:
            return
        a = math.radians(phi)
        along = xy[:, 0] * math.cos(a) + xy[:, 1] * math.sin(a)
        across = -xy[:, 0] * math.sin(a) + xy[:, 1] * math.cos(a)
        r = np.floor(across / _LINE_BIN).astype(np.int64)
        t = np.floor(along / _LINE_BIN).astype(np.int64)
        r -= r.min()
        t -= t.min()
        span = int(t.max()) + 1
        cells = np.unique(r * span + t)  # occupied (offset, along) bins, sorted
        cr, ct = cells // span, cells % span
        # runs of occupied bins along one offset, gaps of up to _LINE_GAP bins bridged (a far edge
        # crosses the rows of cells sparsely)
        start = np.ones(len(cells), bool)
        start[1:] = (cr[1:] != cr[:-1]) | (ct[1:] - ct[:-1] > _LINE_GAP + 1)
        run = np.cumsum(start) - 1
        first = ct[start]
        last = np.zeros(int(run[-1]) + 1, np.int64)
        last[run] = ct  # the last write of each run is its largest bin
        out[phi] = float((last - first + 1).max()) * _LINE_BIN

    for phi in range(0, 180, 2):  # every other degree, then every degree round the longest
        measure(phi)
    best = int(np.argmax(out))
    for phi in range(best - 11, best + 12):
        if phi % 2:
            measure(phi % 180)
    return out


def along_line(phi: float, top: float, pairs: PairCue, none: np.ndarray, evidence):
    """The direction of best ``evidence`` (its score, azimuth, elevation, info) whose azimuth lies
    along a straight shadow edge (``phi`` or ``phi + 180``, within 4 degrees) and whose shading
    gain is within :data:`LINE_MARGIN` of the best (``top``) and whose evidence is positive; None
    if there is none. Elevations every 10 degrees, then 2.5 and 5 degrees either side of the best."""
    best = None

    def consider(a: float, e: float) -> None:
        nonlocal best
        if pair_fit(pairs, none, a, e)[0] < top - LINE_MARGIN:
            return
        score, info = evidence(a, e)
        if score > (0.0 if best is None else best[0]):
            best = (score, a, e, info)

    for a0 in (phi, phi + 180.0):
        for a in a0 + np.arange(-4.0, 4.1, 2.0):
            for e in np.arange(10.0, 80.1, 10.0):
                consider(float(a % 360.0), float(e))
    if best is not None:
        a, e = best[1], best[2]
        for de in (-5.0, -2.5, 2.5, 5.0):
            consider(a, float(np.clip(e + de, 8.0, 85.0)))
    return best
