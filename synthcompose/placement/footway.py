"""Stage 2b, the footway's part of the surfaces found without labels (``surfaces.py``): what is
grass, and which raised ground beside the road is a footway.

* **Grass** is green against the road and saturated (chlorophyll): on the labelled frames the
  true sidewalk is about 10 units of HSV saturation above the road at the median, the true
  terrain 40-50. A grey paving stone a shade yellower than the asphalt is not grass.
* **A footway is raised by a kerb.** Where a raised region meets the road, its ground stands
  a kerb's height above the road's ground right beside it (a step of KERB_STEP or more, medians
  over the pixels along their common border). Ground that reads raised against the road's
  profile but rises from the road without a step is the road itself where the profile does not
  follow it (a far road climbing beyond a junction, sunlit asphalt the colour models miss).
"""
from __future__ import annotations

import cv2
import numpy as np

#: grass: green, more saturated than the road by GRASS_SATURATION, or yellower (LAB b*) by
#: GRASS_YELLOW and more saturated by GRASS_YELLOW_SATURATION (HSV saturation, smoothed)
GRASS_SATURATION, GRASS_YELLOW, GRASS_YELLOW_SATURATION = 18, 5, 10
#: a footway stands at least this far above the road beside it, metres (kerbs are 3-20 cm)
KERB_STEP = 0.03
#: the border between a region and the road: pixels within this many working pixels of the other
STEP_PX = 3
#: pixels on each side of the border needed to measure a step (fewer: the region is kept)
STEP_MIN_PX = 20


def grass(hsv: np.ndarray, lab: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """(h, w) bool: grass. Relative to the level ground in front of the car (``seed``):
    Cityscapes photos are greenish grey all over. The saturation is smoothed as the LAB image
    is (a pixel's own saturation is texture and noise)."""
    sat = cv2.GaussianBlur(hsv[..., 1].astype(np.float32), (0, 0), 2.0)
    s_road = float(np.median(sat[seed])) if seed.any() else 40.0
    b_road = float(np.median(lab[..., 2][seed])) if seed.any() else 132.0
    more = sat - s_road
    yellow = (lab[..., 2] >= b_road + GRASS_YELLOW) & (more >= GRASS_YELLOW_SATURATION)
    return (hsv[..., 0] >= 25) & (hsv[..., 0] <= 95) & ((more >= GRASS_SATURATION) | yellow)


def kerb_stepped(comp: np.ndarray, keep: np.ndarray, road: np.ndarray, height: np.ndarray) -> np.ndarray:
    """``keep`` (per label of ``comp``, the connected regions of candidate footway) with the
    regions that rise from the road without a kerb's step dropped. ``height``: metres above
    the road's profile (NaN unknown)."""
    keep = keep.copy()
    kernel = np.ones((2 * STEP_PX + 1,) * 2, np.uint8)
    by_road = cv2.dilate(road.astype(np.uint8), kernel).astype(bool)
    # the label of the region beside each road pixel (the larger label where two are near)
    beside = cv2.dilate(comp.astype(np.float32), kernel).astype(np.int64)
    for i in np.flatnonzero(keep):
        edge = height[(comp == i) & by_road]
        ring = height[road & (beside == i)]
        edge, ring = edge[np.isfinite(edge)], ring[np.isfinite(ring)]
        if len(edge) < STEP_MIN_PX or len(ring) < STEP_MIN_PX:
            continue
        if float(np.median(edge) - np.median(ring)) < KERB_STEP:
            keep[i] = False
    return keep
