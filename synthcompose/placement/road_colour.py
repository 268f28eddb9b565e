"""Stage 2b, a step of the label-free surfaces (surfaces.py): the road's colour.

The road is told from the ground beside it by colour as well as height: a robust LAB model of
the level ground in front of the car (the seed), and where the car's own lane runs on into
another light (sunlit beyond a cast shadow, or shadowed beyond sun) a model of that light too;
the road is the level pixels within a few robust spreads of a model, connected to the seed.
Grass is kept off it by hue saturation read at each pixel's own brightness (a dark pixel reads
more saturated).
"""
from __future__ import annotations

import cv2
import numpy as np

#: a second light on the lane (a sunlit band beyond a cast shadow, or the reverse): lane
#: pixels off the road's colour models on rows where at least LANE_BAND_SHARE of the lane is off
#: them (a light band spans the lane; paint does not), at least LANE_MODE_SHARE of the frame's
#: working pixels and 30 pixels (a far patch of sun is few pixels: a count, not a share of the lane)
LANE_BAND_SHARE, LANE_MODE_SHARE = 0.6, 1e-4
#: the road's saturation is measured per brightness bin of this many HSV value levels, in bins
#: that hold at least VALUE_LEAST of the seed's pixels
VALUE_BIN, VALUE_LEAST = 16, 100
#: the colour model's least robust spread, LAB
SPREAD_FLOOR = (10.0, 4.0, 4.0)


def saturation_by_value(hsv: np.ndarray, seed: np.ndarray, floor: float) -> np.ndarray:
    """(h, w) float32: the road's hue saturation at each pixel's brightness (HSV value, a
    5-pixel median, in bins of VALUE_BIN): the median over the ``seed``'s pixels of that
    brightness where it is higher than ``floor``, the seed's median over all (a darker road
    reads more saturated; the brightest bins of a seed hold its white paint, which reads less,
    so they keep the median over all); a brightness with fewer than VALUE_LEAST seed pixels
    takes the nearest bin's that has them (40 where no bin has them)."""
    value = cv2.medianBlur(hsv[..., 2], 5)
    of = value // VALUE_BIN
    s = hsv[..., 1][seed]
    where = of[seed]
    table = np.full(256 // VALUE_BIN, np.nan, np.float32)
    for k in np.unique(where):
        inside = where == k
        if inside.sum() >= VALUE_LEAST:
            table[k] = np.median(s[inside])
    known = np.flatnonzero(np.isfinite(table))
    if len(known) == 0:
        return np.full(value.shape, 40.0, np.float32)
    table = np.maximum(table, np.float32(floor))
    nearest = known[np.abs(np.arange(len(table))[:, None] - known[None, :]).argmin(axis=1)]
    return table[nearest][of]


def colour_model(ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(median, robust spread) of (N, 3) LAB colours."""
    med = np.median(ref, axis=0)
    return med, np.maximum(1.4826 * np.median(np.abs(ref - med), axis=0), SPREAD_FLOOR)


def road_models(lab: np.ndarray, seed: np.ndarray, lane: np.ndarray) -> list:
    """Colour models of the road: the ground in front of the car and, where the lane ahead
    runs on into another light (sunlit beyond a cast shadow, or shadowed beyond sun: the same
    asphalt, its colour scaled by the shadow's ratio per channel), a model of that light from
    the lane's pixels there (at most two more)."""
    if seed.sum() < 100:
        return []
    models = [colour_model(lab[seed])]
    rows = np.nonzero(lane.any(axis=1))[0]
    for _ in range(2):
        off = lane & ~road_coloured(lab, models)
        n_lane, n_off = lane[rows].sum(axis=1), off[rows].sum(axis=1)
        band = rows[(n_off >= LANE_BAND_SHARE * n_lane) & (n_off >= 3)]
        pick = np.zeros_like(lane)
        pick[band] = off[band]
        if pick.sum() < max(30, LANE_MODE_SHARE * lane.size):
            break
        models.append(colour_model(lab[pick]))
    return models


def road_coloured(lab: np.ndarray, models: list, limit: float = 3.0) -> np.ndarray:
    """Pixels within ``limit`` robust spreads of one of the road's colour models."""
    out = np.zeros(lab.shape[:2], bool)
    for med, spread in models:
        d = (lab - med) / spread
        # the channels' squares added column by column (NumPy's sum over an axis of 3 is slow)
        out |= np.sqrt((d[..., 0] ** 2 + d[..., 1] ** 2 + d[..., 2] ** 2) / 3.0) < limit
    return out


def road_region(level: np.ndarray, seed: np.ndarray, lab: np.ndarray, models: list) -> np.ndarray:
    """The level pixels of the road's colours connected to the ground in front of the car."""
    h, w = level.shape
    if not models:
        return np.zeros((h, w), bool)
    road = level & road_coloured(lab, models)
    road = cv2.morphologyEx(road.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    road = cv2.morphologyEx(road, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)).astype(bool) & level
    n, comp = cv2.connectedComponents(road.astype(np.uint8), connectivity=4)
    keep = np.zeros(n, bool)
    keep[np.unique(comp[seed & road])] = True
    keep[0] = False
    return keep[comp]
