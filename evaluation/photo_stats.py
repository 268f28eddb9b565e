"""Statistics of a photo that tell Cityscapes' camera from clean shading (the photo's side of
``benchmarks/stereo_stats.py``; the generator's :mod:`.camera` is calibrated on them):

v_median, v_p5, v_p95  brightness (HSV V, 0-255) over the frame: median, 5th, 95th percentile
s_median, s_p90        saturation (HSV S, 0-255) over the frame
road_v, sky_v          median brightness of the road's and the sky's pixels (with labels)
road_green             the road's median green over the mean of its red and blue (sRGB): the
                       real frames' greenish cast
noise                  the image noise the compose stage measures (Immerkaer, 8-bit levels,
                       mean of the channels): what an inserted object is given
"""
from __future__ import annotations

import cv2
import numpy as np

from synthcompose.labels import label_id

_ROAD, _SKY = label_id("road"), label_id("sky")


def photo_stats(rgb: np.ndarray, label_ids: np.ndarray | None = None) -> dict[str, float]:
    """The figures of the module doc for one (H, W, 3) uint8 RGB photo."""
    from synthcompose.lighting.camera_match import estimate_noise

    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    v, s = hsv[..., 2], hsv[..., 1]
    out = {"v_median": float(np.median(v)), "v_p5": float(np.percentile(v, 5)),
           "v_p95": float(np.percentile(v, 95)), "s_median": float(np.median(s)),
           "s_p90": float(np.percentile(s, 90)), "noise": float(np.mean(estimate_noise(rgb)))}
    if label_ids is not None:
        road, sky = label_ids == _ROAD, label_ids == _SKY
        if road.sum() > 1000:
            out["road_v"] = float(np.median(v[road]))
            r, g, b = np.median(rgb[road].astype(np.float32), axis=0)
            out["road_green"] = float(g / max((r + b) / 2, 1.0))
        if sky.sum() > 1000:
            out["sky_v"] = float(np.median(v[sky]))
    return out
