"""The camera's look, measured on the photo and given to the inserted objects: its noise and
blur (:class:`CameraMatch`; the compose stage applies them to the object layer only)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np


#: what :func:`estimate_blur` measures on edges as sharp as the renderer's (4x MSAA resolved,
#: i.e. box-filtered over the pixel): the object layer is blurred by the rest of the photo's
RENDER_BLUR_SIGMA = 0.82
#: the object blur is kept below this (pixels): beyond, the photo is out of focus or smeared
#: and a Gaussian is no longer a good model
MAX_OBJECT_BLUR = 1.6

_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)  # L2 norm 6


def _grouped_median(values: np.ndarray) -> float:
    """Median of non-negative integer-valued data, interpolated within its integer bin (a plain
    median of integers moves in steps of 1)."""
    counts = np.bincount(values.astype(np.int64))
    cum = np.cumsum(counts)
    half = cum[-1] / 2.0
    k = int(np.searchsorted(cum, half))
    below = cum[k - 1] if k > 0 else 0
    return float(k - 0.5 + (half - below) / max(counts[k], 1))


def estimate_noise(rgb: np.ndarray) -> np.ndarray:
    """(3,) noise standard deviation of each channel, in 8-bit code values: robust MAD of a
    Laplacian-like high-pass (Immerkaer's mask, blind to planes) over the flat half of the
    image, away from edges and clipped values."""
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    smooth = cv2.GaussianBlur(grey, (0, 0), 1.0)
    grad = cv2.magnitude(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    lo, hi = np.quantile(grad[::4, ::4], [0.5, 0.8])
    flat = grad <= lo
    flat &= cv2.dilate((grad > hi).astype(np.uint8), np.ones((5, 5), np.uint8)) == 0
    channels = cv2.split(np.ascontiguousarray(rgb))
    flat &= (cv2.min(cv2.min(channels[0], channels[1]), channels[2]) > 4) & \
        (cv2.max(cv2.max(channels[0], channels[1]), channels[2]) < 251)
    flat[:2], flat[-2:], flat[:, :2], flat[:, -2:] = False, False, False, False
    if flat.sum() < 500:
        flat[2:-2, 2:-2] = True
    out = np.empty(3)
    for c in range(3):
        # integer mask on 8-bit data: exact in 16 bits (|r| <= 16 * 255)
        r = cv2.filter2D(channels[c], cv2.CV_16S, _IMMERKAER, borderType=cv2.BORDER_REFLECT)
        out[c] = 1.4826 * _grouped_median(np.abs(r[flat])) / 6.0
    return out


def estimate_blur(rgb: np.ndarray, reblur: float = 1.0) -> float:
    """Blur of the photo as the sigma (pixels) of an equivalent Gaussian, from its strong edges:
    re-blurring a step edge of blur s by ``reblur`` lowers its peak gradient by the factor
    sqrt(s^2 + reblur^2) / s (Zhuo & Sim's defocus estimate); median over edge pixels. An ideal
    edge box-filtered over the pixel measures :data:`RENDER_BLUR_SIGMA`."""
    grey8 = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    grey = grey8.astype(np.float32)
    re = cv2.GaussianBlur(grey, (0, 0), reblur)

    edges = cv2.Canny(grey8, 40, 100) > 0
    edges[:3], edges[-3:], edges[:, :3], edges[:, -3:] = False, False, False, False
    if edges.sum() < 50:
        return float("nan")

    def grad(a: np.ndarray) -> np.ndarray:  # gradient magnitude at the edge pixels
        gx, gy = cv2.Sobel(a, cv2.CV_32F, 1, 0)[edges], cv2.Sobel(a, cv2.CV_32F, 0, 1)[edges]
        return np.sqrt(gx * gx + gy * gy) / np.float32(8.0)

    g, gr = grad(grey), grad(re)
    strong = g >= max(8.0, float(np.quantile(g, 0.6)))
    ratio = g[strong] / np.maximum(gr[strong], 1e-6)
    ratio = ratio[ratio > 1.01]
    if len(ratio) < 20:
        return float("nan")
    return float(np.median(reblur / np.sqrt(ratio ** 2 - 1.0)))


@dataclass(frozen=True)
class CameraMatch:
    """What the inserted object gets so that it looks taken by the same camera.

    noise_sigma       : the photo's noise per channel, 8-bit code values (sRGB)
    blur_sigma        : the photo's blur, Gaussian sigma in pixels (:func:`estimate_blur`)
    object_blur_sigma : blur applied to the object layer: sqrt(blur^2 - RENDER_BLUR_SIGMA^2)
    seed              : of the noise (same seed, same noise)
    """

    noise_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)
    blur_sigma: float = 0.0
    object_blur_sigma: float = 0.0
    seed: int = 0

    @classmethod
    def measure(cls, rgb: np.ndarray, seed: int = 0) -> "CameraMatch":
        noise = estimate_noise(rgb)
        blur = estimate_blur(rgb)
        extra = 0.0 if not math.isfinite(blur) else math.sqrt(max(blur ** 2 - RENDER_BLUR_SIGMA ** 2, 0.0))
        return cls(tuple(float(v) for v in noise), float(blur) if math.isfinite(blur) else 0.0,
                   float(min(extra, MAX_OBJECT_BLUR)), int(seed))

    @property
    def blur_radius(self) -> int:
        """Half width of the blur kernel in pixels (0: no blur)."""
        return 0 if self.object_blur_sigma < 0.1 else int(math.ceil(2.5 * self.object_blur_sigma))

    def to_dict(self) -> dict:
        return {"noise_sigma_8bit": [round(v, 3) for v in self.noise_sigma],
                "blur_sigma_px": round(self.blur_sigma, 3), "object_blur_sigma_px": round(self.object_blur_sigma, 3),
                "noise_seed": self.seed}
