"""Stage 2b, a step of the label-free surfaces (surfaces.py): kerbs from the ground's profile
across the street.

The sidewalk test of surfaces.py takes a pixel's height over the road's profile, a smooth
surface fitted along the image rows. A road has a camber: its gutters lie a few centimetres
below its crown, so a low kerb (6-10 cm over the gutter) puts the footway only 2-5 cm over the
profile, inside the level band, and paving of the asphalt's colour is then taken for road.

Across the street the step is plain: binned by the offset across the camera's line, the median
height of the flat ground climbs by the kerb's height within a few decimetres and stays there
(the footway). Over a band of depth (4-10 m, 8-16 m, ...) thousands of pixels go into each bin, so a
5 cm step stands well above the matcher's noise. A kerb is taken where two neighbouring bands see the
same step at about the same offset (the street's own line, straight over 20 m; a step seen in
one band alone is a parked car's sill, a hedge's foot or noise), and along its line each slice
of depth must see the step again (where the kerb ends, at a junction, the ground beyond is a
cross street's carriageway). The ground beyond the line is no road; flat and at the footway's
height, it is footway (surfaces.py: unless as saturated as grass).
"""
from __future__ import annotations

import numpy as np

from .medians import group_medians

#: the bands of depth (metres ahead) in which a kerb is looked for; a kerb is one two neighbouring
#: bands see (the camera sees a kerb 2-4 m off its line from 4 m on, one of a wide street's
#: 4-8 m off from about 10 m on), its line through the two offsets at the bands' middles
KERB_BANDS = ((4.0, 10.0), (8.0, 16.0), (13.0, 22.0), (18.0, 30.0))
#: width of the bins across the street, metres; least pixels in a bin
BIN, BIN_LEAST = 0.2, 20
#: a kerb steps up by KERB_STEP (to at most KERB_TOP) over the lowest ground within KERB_RISE
#: before it (the gutter), onto a flat footway at least KERB_PLATEAU wide that stays within
#: PLATEAU_SPREAD of its median height
KERB_STEP, KERB_TOP, KERB_RISE, KERB_PLATEAU, PLATEAU_SPREAD = 0.05, 0.35, 0.6, 1.0, 0.04
#: the gutter before a kerb lies about at the road's profile: the camber drops a road's edge
#: at most about 12 cm below its crown (3 % over 4 m), and a gutter is never raised much
GUTTER_LOW, GUTTER_HIGH = -0.12, 0.08
#: the ego vehicle's own lane: no kerb within this of the camera's line
KERB_FROM = 1.0
#: the two bands' kerbs are the same line if their offsets differ by at most this (metres)
KERB_AGREE = 0.6
#: the ground beyond a kerb's line starts this far past it (metres); the footway there is the
#: flat ground within the noise band at its depth of the footway's height
BEYOND = 0.1
#: farthest depth the line is carried to beyond the farther band's middle (a street runs
#: straight about this far)
KERB_REACH = 10.0
#: along the line, slices of this depth (metres) each see the step again (at least half a kerb
#: between the KERB_SIDE metres either side of the line, with SLICE_LEAST pixels on each; a
#: slice with fewer is skipped): from the first slice that sees no step (a corner, a driveway
#: lowered to the road) on, the ground beyond the line is not this kerb's footway
SLICE, KERB_SIDE, SLICE_LEAST = 2.0, 0.8, 30


def lateral_profile(height: np.ndarray, ok: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(offsets, median heights) of the pixels ``ok`` in bins of :data:`BIN` metres across
    (``y``: offset to the left of the camera's line), NaN where a bin has too few."""
    return binned_profile(height, ok, y, -8.0, 8.0)


def binned_profile(height: np.ndarray, ok: np.ndarray, key: np.ndarray, lo_m: float,
                   hi_m: float, least: int = BIN_LEAST) -> tuple[np.ndarray, np.ndarray]:
    """(bin centres, median heights) of the pixels ``ok`` in bins of :data:`BIN` metres of
    ``key`` (an offset across or a depth) from ``lo_m`` to ``hi_m``, NaN where a bin has fewer
    than ``least``."""
    bins = np.rint(key[ok] / BIN).astype(np.int64)
    h = height[ok]
    lo, hi = int(round(lo_m / BIN)), int(round(hi_m / BIN))
    keep = (bins >= lo) & (bins <= hi)
    return (np.arange(lo, hi + 1) * BIN), group_medians(bins[keep] - lo, h[keep], hi - lo + 1, least)


def kerb_in(offsets: np.ndarray, med: np.ndarray, side: int) -> tuple[float, float] | None:
    """The first kerb outwards on ``side`` (+1 left, -1 right) of a lateral profile: (offset of
    its line, the footway's height), or None."""
    rise, plateau = int(round(KERB_RISE / BIN)), int(round(KERB_PLATEAU / BIN))
    order = np.argsort(side * offsets)
    y, h = offsets[order], med[order]
    for i in range(len(y)):
        if side * y[i] < KERB_FROM or i < rise:
            continue
        before = h[i - rise:i + 1]
        after = h[i + 1:i + 1 + plateau]
        if np.isnan(before).all() or np.isfinite(after).sum() < 0.6 * plateau:
            continue
        gutter = float(np.nanmin(before))
        top = float(np.nanmedian(after))
        if not (KERB_STEP <= top - gutter <= KERB_TOP and GUTTER_LOW <= gutter <= GUTTER_HIGH):
            continue
        if np.nanmax(np.abs(after - top)) > PLATEAU_SPREAD:
            continue
        return float(y[i] + side * BIN / 2), top
    return None


def beyond_kerbs(height: np.ndarray, flat: np.ndarray, z: np.ndarray, y: np.ndarray,
                 band: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(beyond, footway): (h, w) bool masks of the ground beyond a kerb seen in two
    neighbouring bands of depth (from the nearer band's start to :data:`KERB_REACH` past the
    farther band's middle), and of the flat part of it at its footway's height (``height``:
    over the road's profile; ``z``: depth; ``y``: offset left of the camera's line; ``band``:
    the noise band at each pixel's depth)."""
    beyond = np.zeros(height.shape, bool)
    footway = np.zeros(height.shape, bool)
    ok_all = flat & np.isfinite(height) & np.isfinite(z) & (np.abs(height) < KERB_TOP + 0.1)
    profiles = []
    for z0, z1 in KERB_BANDS:
        with np.errstate(invalid="ignore"):
            ok = ok_all & (z > z0) & (z < z1)
        profiles.append(lateral_profile(height, ok, y))
    depths = [(z0 + z1) / 2 for z0, z1 in KERB_BANDS]
    for side in (1, -1):
        found = [kerb_in(offs, med, side) for offs, med in profiles]
        # the nearest two neighbouring bands that see the same kerb
        pair = next((k for k in range(len(found) - 1) if found[k] is not None and found[k + 1] is not None
                     and abs(found[k][0] - found[k + 1][0]) <= KERB_AGREE), None)
        if pair is None:
            continue
        (y0, t0), (y1, t1) = found[pair], found[pair + 1]
        d0, d1 = depths[pair], depths[pair + 1]
        with np.errstate(invalid="ignore"):
            across = side * (y - (y0 + (y1 - y0) / (d1 - d0) * (z - d0)))  # metres past the line
            past = (across > BEYOND) & (z >= KERB_BANDS[pair][0]) & (z <= d1 + KERB_REACH)
            inside = ok_all & (across < -BEYOND) & (across > -KERB_SIDE)
            outside = ok_all & (across > BEYOND) & (across < KERB_SIDE)
        kept = np.zeros(height.shape, bool)
        for s0 in np.arange(KERB_BANDS[pair][0], d1 + KERB_REACH, SLICE):
            with np.errstate(invalid="ignore"):
                zs = (z >= s0) & (z < s0 + SLICE)
            lo, hi = height[inside & zs], height[outside & zs]
            if len(lo) < SLICE_LEAST or len(hi) < SLICE_LEAST:
                continue  # not seen there (a parked car in front): the kerb may go on
            if np.median(hi) - np.median(lo) < KERB_STEP / 2:
                break  # the kerb ends (a corner): nothing beyond is its footway
            kept |= zs
        past &= kept
        beyond |= past
        with np.errstate(invalid="ignore"):
            footway |= past & ok_all & (np.abs(height - (t0 + t1) / 2) < band)
    return beyond, footway
