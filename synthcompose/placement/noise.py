"""The stereo error of one frame, and the tolerances that follow from it.

Real Cityscapes disparity comes from semi-global matching: its error is roughly constant in
pixels of disparity (σd, a few tenths of a pixel, correlated over patches and streaks), so the
depth error grows with the square of the depth and a ground point's height error with the
depth itself:

    σz(z) = z² σd / (f B)        (along the ray)
    σh(z) = h z σd / (f B)       (height of a ground point seen from a camera h above it)

σd is measured on each frame, on its ground: a plane's disparity is affine in the pixel
coordinates, so its second differences over a step of a few pixels are the matcher's noise
alone. Every placement tolerance that compares real points with a pose is the larger of its
fixed value (what exact geometry needs) and ``k`` of these sigmas.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: second differences over this many pixels: longer than the matcher's smallest patches
STEP = 8
#: floor and ceiling of the measured σd, pixels (exact disparity still has 1/256 px coding and
#: a matcher is never better than about a tenth of a pixel)
SIGMA_MIN, SIGMA_MAX = 0.1, 1.5
#: how many sigmas a tolerance allows
K_SIGMA = 3.0


@dataclass(frozen=True)
class StereoNoise:
    """σd of one frame (pixels) and the camera's f·B (pixel metres) and height (metres)."""

    sigma_d: float
    focal_baseline: float
    camera_height: float

    def depth_sigma(self, z):
        """σz at optical depth ``z`` (metres; arrays welcome)."""
        return np.square(z) * (self.sigma_d / self.focal_baseline)

    def height_sigma(self, z):
        """σh of a ground point at optical depth ``z`` (metres)."""
        return np.asarray(z) * (self.camera_height * self.sigma_d / self.focal_baseline)

    def height_band(self, z, floor: float) -> np.ndarray | float:
        """Height tolerance at depth ``z``: the larger of ``floor`` and K_SIGMA σh."""
        return np.maximum(floor, K_SIGMA * self.height_sigma(z))

    def depth_band(self, z, floor):
        """Depth tolerance at depth ``z``: the larger of ``floor`` (metres, may be an array)
        and K_SIGMA σz."""
        return np.maximum(floor, K_SIGMA * self.depth_sigma(z))

    def to_dict(self) -> dict:
        return {"sigma_disparity_px": round(self.sigma_d, 4)}


def measure_sigma(disparity_px: np.ndarray, ground: np.ndarray, step: int = STEP, stride: int = 4,
                  row_step: int | None = None) -> float:
    """Robust σd (pixels) of the disparity (H, W float, NaN where invalid) over the ``ground``
    mask: the MAD of horizontal and vertical second differences over ``step`` pixels, on every
    ``stride``-th row (enough samples; a tenth of the cost). ``row_step``: the vertical step
    when the columns were subsampled (default ``step``)."""
    H, W = disparity_px.shape
    rs = step if row_step is None else row_step
    r = np.arange(rs, H - rs, stride)
    d, g = disparity_px[r], ground[r]
    horizontal = d[:, step:-step] - 0.5 * (d[:, :-2 * step] + d[:, 2 * step:])
    ok_h = g[:, step:-step] & g[:, :-2 * step] & g[:, 2 * step:]
    vertical = d - 0.5 * (disparity_px[r - rs] + disparity_px[r + rs])
    ok_v = g & ground[r - rs] & ground[r + rs]
    res = [horizontal[ok_h & np.isfinite(horizontal)], vertical[ok_v & np.isfinite(vertical)]]
    r = np.concatenate(res)
    if len(r) < 500:
        return SIGMA_MIN
    mad = float(np.median(np.abs(r - np.median(r))))
    # a second difference of white noise has 1.5 times its variance
    return float(np.clip(1.4826 * mad / np.sqrt(1.5), SIGMA_MIN, SIGMA_MAX))


def stereo_noise(frame, ground_ids) -> StereoNoise:
    """The frame's :class:`StereoNoise`, measured on its pixels of ``ground_ids`` labels (cached)."""
    key = ("stereo_noise", tuple(int(i) for i in ground_ids))

    def measure() -> StereoNoise:
        cam = frame.camera
        fb = float(cam.fx * cam.baseline)
        # every other column, differences over STEP pixels of the full image
        depth = frame.depth[:, ::2]
        with np.errstate(divide="ignore"):
            disparity = (np.float32(fb) / depth).astype(np.float32, copy=False)  # 0 where depth is inf
        disparity[disparity <= 0] = np.nan
        lut = np.zeros(256, bool)
        lut[np.asarray(list(ground_ids), int)] = True
        ground = lut[frame.label_ids[:, ::2]] & np.isfinite(disparity)
        sigma = measure_sigma(disparity, ground, step=STEP // 2, stride=6, row_step=STEP)
        return StereoNoise(sigma, fb, float(cam.z))
    return frame.derived(key, measure)
