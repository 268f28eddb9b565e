"""Stage 2b, a step of the label-free surfaces (surfaces.py): a footway is wide enough to walk.

The sidewalk test of surfaces.py takes flat ground a kerb's height above the road. A kerb's own
top and the paved or leaf-covered edge of a grass verge behind it pass that test too: a strip a
few decimetres wide between the road's gutter and the grass. Nobody walks there (German
guidance asks 1.5 m of footway at the least, 2.5 m as a rule), and a person or sign placed on
it stands on the kerb. Such a strip is told from a footway along the image row, where the
ground lies at one depth: the found pixels of a row, merged across gaps shorter than STRIP_GAP
(a paving's joints, the matcher's speckle), make runs; a run narrower than FOOTWAY_LEAST whose
outer end (away from the camera's line) meets grass is the kerb and the verge's edge. A run
whose outer end meets anything else (a wall, a parked car hiding the rest, the image's edge)
is left as found: its width is not seen. The grass is a verge (``verges``): a stretch along
the street, not a patch of leaves or sun on a footway.
"""
from __future__ import annotations

import cv2
import numpy as np

from synthcompose.geometry.depth import nearest_in_row

#: the narrowest footway, metres across (a person's 0.4 m stance with room on both sides)
FOOTWAY_LEAST = 0.8
#: found pixels of a row this close (metres) are one strip
STRIP_GAP = 0.3
#: the grass is looked for this many pixels beyond a strip's outer end
STOP_REACH = 4
#: grass that bounds a kerb-wide strip is at least this many working pixels across (a paving's
#: yellow grit is scattered pixels)
LAWN_LEAST = 5
#: and on the whole at most this much brighter than the road in front of the car (sunlit paving
#: beyond a shadow reads as saturated as grass, and brighter)
LAWN_BRIGHTER = 1.05
#: and runs at least this far along the view, metres (a verge follows the street)
LAWN_ALONG = 3.0


def kerb_strips(side: np.ndarray, grass: np.ndarray, z: np.ndarray, fx: float, u0: float) -> np.ndarray:
    """(h, w) bool: the pixels of ``side`` in strips along their row narrower than FOOTWAY_LEAST
    whose outer end meets ``grass`` within STOP_REACH pixels. ``z``: depth per pixel (NaN where
    unknown); ``fx``, ``u0``: the working camera's focal length and centre column."""
    h, w = side.shape
    finite = np.isfinite(z) & (z > 0)
    zf = np.where(finite, z, 0.0)
    # merge: a gap of non-grass pixels shorter than STRIP_GAP between found pixels of the row,
    # at the depth of the found pixel before it
    left, right = nearest_in_row(side)
    rows = np.arange(h)[:, None]
    z_left = np.where(left >= 0, zf[rows, np.clip(left, 0, w - 1)], 0.0)
    gap_px = STRIP_GAP * fx / np.where(z_left > 0, z_left, np.inf)
    merged = side | ((left >= 0) & (right < w) & (right - left <= gap_px + 1) & ~grass)
    # runs of the merged row, numbered in raster order
    start = merged & ~np.pad(merged, ((0, 0), (1, 0)))[:, :-1]
    ident = (np.cumsum(start.ravel()) * merged.ravel()).reshape(h, w)
    n = int(ident.max())
    if n == 0:
        return np.zeros_like(side)
    flat = ident.ravel()
    length = np.bincount(flat, minlength=n + 1)[1:]
    known = np.bincount(flat, weights=finite.ravel(), minlength=n + 1)[1:]
    depth = np.bincount(flat, weights=zf.ravel(), minlength=n + 1)[1:] / np.maximum(known, 1)
    r, first = np.nonzero(start)
    last = first + length - 1
    narrow = (known > 0) & (length * depth / fx < FOOTWAY_LEAST)
    # grass within STOP_REACH pixels beyond the outer end: after the last pixel on the camera's
    # right, before the first on its left
    seen = np.pad(np.cumsum(grass, axis=1), ((0, 0), (1, 0)))  # seen[r, c]: grass in columns < c
    outward = (first + last) / 2.0 > u0
    lo = np.where(outward, last + 1, first - STOP_REACH).clip(0, w)
    hi = np.where(outward, last + 1 + STOP_REACH, first).clip(0, w)
    meets = seen[r, hi] - seen[r, lo] > 0
    kerb = np.zeros(n + 1, bool)
    kerb[1:] = narrow & meets
    return kerb[ident] & side


def verges(grass: np.ndarray, value: np.ndarray, seed: np.ndarray, z: np.ndarray) -> np.ndarray:
    """(h, w) bool: the verges among flat ``grass``: its 4-connected stretches at least
    LAWN_LEAST pixels across that run LAWN_ALONG metres or more along the view (a verge follows
    the street; fallen leaves and sunlit patches on a footway are blobs) and whose mean
    brightness (``value``: HSV value) is at most LAWN_BRIGHTER times the road's in front of the
    car (the ``seed``): sunlit paving beyond a shadow reads as saturated as grass, but brighter
    than the shaded asphalt (leverkusen_000052's corner: HSV value 76-86 against 69;
    dusseldorf_000020's verge 43-53 against 52). ``z``: depth per pixel, NaN where unknown."""
    grass = cv2.morphologyEx(grass.astype(np.uint8), cv2.MORPH_OPEN, np.ones((LAWN_LEAST,) * 2, np.uint8))
    n, comp = cv2.connectedComponents(grass, connectivity=4)
    if n <= 1 or not seed.any():
        return np.zeros(grass.shape, bool)
    flat = comp.ravel()
    count = np.maximum(np.bincount(flat, minlength=n), 1)
    mean = np.bincount(flat, weights=value.astype(np.float64).ravel(), minlength=n) / count
    known = np.isfinite(z).ravel() & (flat > 0)
    near, far = np.full(n, np.inf), np.full(n, -np.inf)
    np.minimum.at(near, flat[known], z.ravel()[known])
    np.maximum.at(far, flat[known], z.ravel()[known])
    keep = (mean <= LAWN_BRIGHTER * np.median(value[seed])) & (far - near >= LAWN_ALONG)
    keep[0] = False
    return keep[comp]
