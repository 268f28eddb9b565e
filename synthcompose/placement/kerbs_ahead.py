"""Stage 2b, a step of the label-free surfaces (surfaces.py): a kerb across the view ahead (the
far kerb of a cross street at a T-junction seen head-on, where the ego vehicle's street ends).

kerbs.py finds the kerbs that run along the view from the ground's height across it. Where the
street ends ahead, the footway before the house across it runs across the view: its kerb is a
step up along the depth, and the road's profile (ground_profile.py), fitted row by row from the
car's own lane, climbs onto that footway with it (the footway fills the lane's rows beyond the
kerb), so over that profile the footway reads as level road.

Along the depth the step is plain in the heights over the camera's own ground plane (no
profile fitted to the rows): in slices of the ground one metre wide, binned by depth, the ground
before the kerb and the footway beyond it are each straight (a grade, the car's pitch, a road's
dip towards its gutter: a line each), and at the kerb the footway's line stands KERB_STEP to
KERB_TOP above the road's (the kerb's face, smeared over a few decimetres by the matcher, lies
between the two). A kerb ahead is taken where at least ``AHEAD_LEAST`` slices, one of them the
car's own lane, see the step on one straight line across the view (a street meeting the cross
street at up to 50 degrees off square): a step seen in a slice or two is a parked car's sill, a
speed bump or noise. And the street ends there: what stands a few metres past the line (a
house front, a fence, a hedge, parked cars) spans the line's width; a roundabout's island or a
raised table leave the road beyond them open. The flat ground past that line, above the road's
level, and the kerb's face, are footway; no ground past the line is this road.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .kerbs import BEYOND, BIN, KERB_PLATEAU, KERB_STEP, KERB_TOP, PLATEAU_SPREAD, binned_profile

#: lateral slices of this width (metres), centred from -AHEAD_REACH to AHEAD_REACH off the camera's line
AHEAD_SLICE, AHEAD_REACH = 1.0, 6.0
#: depths (metres ahead) in which a kerb across the view is looked for
AHEAD_DEPTH = (5.0, 25.0)
#: the road's line is fitted over this depth before the kerb, the footway's over KERB_PLATEAU
#: beyond it, each leaving out STEP_GAP next to it (the face, smeared by the matcher); metres
STEP_BEFORE, STEP_GAP = 1.5, 0.3
#: least pixels in a bin of a slice's depth profile (a slice one metre wide sees a bin of 0.2 m
#: of a far footway in a few rows)
AHEAD_BIN_LEAST = 8
#: the footway's line rises or falls at most this much per metre of depth (a footway's cross
#: fall, the car's pitch)
FOOTWAY_GRADE = 0.08
#: least slices on one line (their centres spanning at least AHEAD_SPAN metres); a slice's kerb
#: within AHEAD_AGREE (metres of depth) of the line is on it
AHEAD_LEAST, AHEAD_SPAN, AHEAD_AGREE = 4, 3.0, 0.6
#: the line runs across the view: at most this far off square to the camera's line (degrees)
AHEAD_SKEW = 50.0
#: one of the line's slices lies within this of the camera's line: the car's own lane ends there
AHEAD_OWN = 1.5
#: the footway is looked for this deep past the line (metres); the kerb's face this near it
AHEAD_BEYOND, AHEAD_FACE = 8.0, 0.3
#: the footway's ground lies within this of its line (metres; or the noise band at its depth)
FOOTWAY_BAND = 0.06
#: the street ends there: what stands (STANDING metres high) within AHEAD_BEYOND past the line
#: covers at least this share of the line's lateral span (a house front, a fence, a hedge,
#: parked cars; a roundabout's island or a raised table's far side leave the road beyond open)
AHEAD_WALL_SHARE = 0.8
STANDING = (0.5, 3.0)


@dataclass(frozen=True)
class KerbAhead:
    """A kerb across the view: its depth on the camera's line (metres) and that depth's change per
    metre to the left; the footway's height on the line and its rise per metre of depth beyond
    it (over the camera's ground plane); the lateral span (metres left) of the slices that see
    it; the road's height at its foot."""

    depth: float
    skew: float
    top: float
    grade: float
    span: tuple[float, float]
    gutter: float = 0.0  # the road's height at the kerb (over the camera's ground plane)


def kerb_ahead(ground: np.ndarray, flat: np.ndarray, z: np.ndarray, y: np.ndarray,
               band: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(beyond, footway): (h, w) bool masks of the ground past a kerb across the view ahead
    (within the lateral span of the slices that see it) and of the footway there (flat, on the
    footway's line, and the kerb's face); both empty where no such kerb is seen. ``ground``:
    heights over the camera's own ground plane (metres); ``flat``, ``z``, ``y``, ``band`` as
    kerbs.beyond_kerbs'."""
    beyond = np.zeros(ground.shape, bool)
    footway = np.zeros(ground.shape, bool)
    kerb = find_kerb_ahead(ground, flat, z, y)
    if kerb is None:
        return beyond, footway
    with np.errstate(invalid="ignore"):
        past = z - (kerb.depth + kerb.skew * y)
        across = (y >= kerb.span[0]) & (y <= kerb.span[1])
        beyond = (past > BEYOND) & (past < AHEAD_BEYOND) & across
        line = kerb.top + kerb.grade * past
        # flat, above the road's level at the kerb by half the least kerb, not above the footway's
        # line by more than the noise (the matcher pulls a footway's far part towards the wall
        # behind it, and its near part towards the road)
        footway = beyond & flat & (ground > kerb.gutter + KERB_STEP / 2) \
            & (ground < line + np.maximum(FOOTWAY_BAND, band))
        # the kerb's face (Cityscapes labels it sidewalk): not flat, below the footway's line, at
        # the line's depth; seen across the view it spans image rows
        footway |= across & (np.abs(past) <= AHEAD_FACE) & ~flat & (ground < line + FOOTWAY_BAND) \
            & (ground > kerb.gutter - FOOTWAY_BAND)
    return beyond, footway


def step_ahead(depths: np.ndarray, med: np.ndarray) -> tuple[float, float, float, float] | None:
    """The nearest kerb of a depth profile (bin centres, median heights; NaN where unseen): (its
    depth, the footway's height there, the footway's grade, the road's height there), or None.
    Every candidate depth's two lines at once, by running sums over the bins."""
    seen = np.isfinite(med)
    n_bins = len(depths)
    x = np.where(seen, depths, 0.0)
    y = np.where(seen, med, 0.0)
    sums = [np.concatenate([[0.0], np.cumsum(v)]) for v in (seen.astype(float), x, y, x * x, x * y)]
    plateau = int(round(KERB_PLATEAU / BIN))
    idx = np.arange(n_bins)

    def window(lo_m: float, hi_m: float):
        # bins with depths in [d + lo_m, d + hi_m] for each candidate d: [start, stop) per bin
        lo = np.clip(idx + int(math.ceil(lo_m / BIN - 1e-6)), 0, n_bins)
        hi = np.clip(idx + int(math.floor(hi_m / BIN + 1e-6)) + 1, 0, n_bins)
        n, sx, sy, sxx, sxy = (s[np.maximum(hi, lo)] - s[lo] for s in sums)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = (n * sxy - sx * sy) / (n * sxx - sx * sx)
            icpt = (sy - slope * sx) / n
        return lo, np.maximum(hi, lo), n, slope, icpt

    _, _, nb, rb, ri = window(-STEP_BEFORE, -STEP_GAP)
    alo, ahi, na, wb, wi = window(STEP_GAP, STEP_GAP + KERB_PLATEAU)
    with np.errstate(invalid="ignore"):
        step = (wb * depths + wi) - (rb * depths + ri)
        ok = (nb >= 4) & (na >= 0.6 * plateau) & (np.abs(wb) <= FOOTWAY_GRADE) & (step >= KERB_STEP) & (step <= KERB_TOP)
    for i in np.flatnonzero(ok):
        sel = seen[alo[i]:ahi[i]]
        res = med[alo[i]:ahi[i]][sel] - (wb[i] * depths[alo[i]:ahi[i]][sel] + wi[i])
        if np.max(np.abs(res)) <= PLATEAU_SPREAD:
            d = float(depths[i])
            return d, float(wb[i] * d + wi[i]), float(wb[i]), float(rb[i] * d + ri[i])
    return None


def find_kerb_ahead(ground: np.ndarray, flat: np.ndarray, z: np.ndarray, y: np.ndarray) -> KerbAhead | None:
    """The kerb across the view ahead (arguments as kerb_ahead's), or None."""
    ok_all = flat & np.isfinite(ground) & np.isfinite(z) & (np.abs(ground) < 1.0)
    with np.errstate(invalid="ignore"):
        ok_all &= (z >= AHEAD_DEPTH[0]) & (z <= AHEAD_DEPTH[1]) & (np.abs(y) < AHEAD_REACH + AHEAD_SLICE)
    g, zz, yy = ground[ok_all], z[ok_all], y[ok_all]
    seen = []
    for yc in np.arange(-AHEAD_REACH, AHEAD_REACH + 1e-9, AHEAD_SLICE):
        ok = np.abs(yy - yc) < AHEAD_SLICE / 2
        found = step_ahead(*binned_profile(g, ok, zz, *AHEAD_DEPTH, least=AHEAD_BIN_LEAST))
        if found is not None:
            seen.append((float(yc), *found))
    if len(seen) < AHEAD_LEAST:
        return None
    pts = np.array(seen)
    best = None
    for i, j in itertools.combinations(range(len(pts)), 2):
        (y0, d0), (y1, d1) = pts[i, :2], pts[j, :2]
        skew = (d1 - d0) / (y1 - y0)
        if abs(skew) > math.tan(math.radians(AHEAD_SKEW)):
            continue
        on = np.abs(pts[:, 1] - (d0 + skew * (pts[:, 0] - y0))) <= AHEAD_AGREE
        if best is None or on.sum() > best.sum():
            best = on
    if best is None or best.sum() < AHEAD_LEAST:
        return None
    ys = pts[best, 0]
    if ys.max() - ys.min() < AHEAD_SPAN or np.abs(ys).min() > AHEAD_OWN:
        return None
    skew, depth0 = np.polyfit(ys, pts[best, 1], 1)
    if abs(skew) > math.tan(math.radians(AHEAD_SKEW)):
        return None
    half = AHEAD_SLICE / 2
    span = (float(ys.min() - half), float(ys.max() + half))
    kerb = KerbAhead(float(depth0), float(skew), float(np.median(pts[best, 2])), float(np.median(pts[best, 3])), span,
                     float(np.median(pts[best, 4])))
    return kerb if _ends_there(ground, z, y, kerb) else None


def _ends_there(ground: np.ndarray, z: np.ndarray, y: np.ndarray, kerb: KerbAhead) -> bool:
    """Whether what stands within AHEAD_BEYOND past the kerb spans AHEAD_WALL_SHARE of its width."""
    lo, hi = kerb.span
    with np.errstate(invalid="ignore"):
        past = z - (kerb.depth + kerb.skew * y)
        over = ground - (kerb.top + kerb.grade * past)
        wall = (over >= STANDING[0]) & (over <= STANDING[1]) & (past > BEYOND) & (past < AHEAD_BEYOND) \
            & (y >= lo) & (y <= hi)
    covered = np.unique(np.floor((y[wall] - lo) / 0.25).astype(np.int64))
    return len(covered) * 0.25 >= AHEAD_WALL_SHARE * (hi - lo)
