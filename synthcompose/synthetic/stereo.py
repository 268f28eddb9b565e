"""Disparity as a semi-global matcher measures it, made from a generated frame's exact depth.

Real Cityscapes disparity is SGM output computed at half resolution and written back at full
resolution in 2x2 blocks, in the 1/256 px coding (``p = 256 d + 1``, 0 invalid). What the
generator reproduces, from the exact depth, the rendered photo and its labels (measured on real
frames with ``benchmarks/stereo_stats.py``; the figures are in the README):

* the matcher's grid: half resolution for frames 1536 px wide or more, blocks of 2x2 pixels;
* noise correlated along rows (streaks, as SGM's path aggregation leaves them) and in patches,
  a few tenths of a pixel, growing where the photo has little texture (its local gradient
  energy is low);
* foreground fattening: a nearer object's disparity spreads a few pixels over the farther
  background beside it (and half as far above and below it);
* holes: occlusion shadows (left of nearer objects: background the right camera does not
  see), most of the left band whose points fall outside the right image, the sky (which
  otherwise takes small disparities propagated from the skyline), the bonnet, texture-less
  surfaces, speckle, and the frame border SGM leaves empty (top rows, outer columns).

Everything random comes from ``seed``: the same seed gives the same bytes.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.io.files import DISPARITY_SCALE
from synthcompose.labels import label_id

STEREO_MODES = ("realistic", "exact")

#: matcher noise: base amplitude (px of a 2048 px wide image; scaled with the width) and its
#: growth where texture is weak
NOISE_PX = 0.38
#: a frame's noise amplitude is NOISE_PX times a factor drawn from this range (real frames differ)
FRAME_GAIN = (0.9, 1.2)
WEAK_GAIN = 1.5
#: the amplitude varies in patches (log-normal, this sigma of its log; PATCHES px): the
#: heavy tail of real residuals
AMP_SPREAD, AMP_PATCHES = 0.45, 10.0
#: gradient energy (grey levels, Sobel on the matcher's grid) below which texture is weak
TEXTURE_REF = 5.0
#: streak and patch correlation lengths (Gaussian sigmas, matcher pixels) and their weights
STREAK = (5.0, 0.8)
PATCH = 2.5
MIX = (0.6, 0.6, 0.3)  # streak, patch, per-pixel
#: fattening: reach in matcher pixels (per pixel 0..FATTEN, about FATTEN_MEAN) and the jump it needs
FATTEN, FATTEN_MEAN = 3, 1.3
FATTEN_JUMP = 1.5
#: share of occluded pixels, and of pixels outside the right image, left invalid
OCCLUDED_HOLES = 0.95
OUT_OF_VIEW_HOLES = 0.95
#: hole rate within a matcher pixel of a disparity jump (the left-right check fails there)
EDGE_HOLES = 0.07
#: hole rate: speckle everywhere, plus where texture is weak (sky, bonnet, plain walls)
SPECKLE = 0.02
WEAK_HOLES = 0.35
#: the bonnet: share left valid (reflections matched)
EGO_VALID = 0.15
#: empty frame border at 2048x1024: top rows, left and right columns
BORDER_TOP, BORDER_SIDE = 30, 10

_SKY, _EGO = label_id("sky"), label_id("ego vehicle")


def _field(rng: np.random.Generator, shape: tuple[int, int], sx: float, sy: float) -> np.ndarray:
    """Gaussian white noise blurred by (sx, sy) pixels, scaled to unit standard deviation."""
    f = rng.standard_normal(shape, dtype=np.float32)
    if sx > 0 or sy > 0:
        f = cv2.GaussianBlur(f, (0, 0), sigmaX=max(sx, 0.3), sigmaY=max(sy, 0.3),
                             borderType=cv2.BORDER_REFLECT)
    return f / np.float32(max(float(f.std()), 1e-6))


def _threshold(rate: np.ndarray | float) -> np.ndarray | float:
    """Level t such that a unit normal field exceeds it with about probability ``rate``
    (the logistic approximation of the normal tail)."""
    rate = np.clip(rate, 1e-4, 1 - 1e-4)
    return np.log(1.0 / rate - 1.0) / 1.702


def texture_weakness(grey: np.ndarray) -> np.ndarray:
    """(h, w) float32 in (0, 1]: 1 where the photo (grey, matcher grid) has no local gradient
    energy, falling as 1 / (1 + (g / TEXTURE_REF)^2)."""
    grey = cv2.GaussianBlur(grey, (0, 0), 1.0)  # the photo's pixel noise is no texture to match
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1)
    g2 = cv2.GaussianBlur(gx * gx + gy * gy, (0, 0), 3.0)
    return (1.0 / (1.0 + g2 / np.float32(TEXTURE_REF ** 2))).astype(np.float32)


def _edge_value(d: np.ndarray, mask: np.ndarray, from_top: bool) -> np.ndarray:
    """(w,) per column: ``d`` at the first pixel outside ``mask`` met from the top (or the
    bottom), the row nearest that edge when the whole column is masked."""
    h = len(d)
    rows = np.arange(h)[:, None]
    if from_top:
        first = np.where(~mask, rows, h - 1).min(axis=0)
    else:
        first = np.where(~mask, rows, 0).max(axis=0)
    return d[first, np.arange(d.shape[1])]


def _sky_disparity(d: np.ndarray, sky: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Small disparities for the sky: a random share of the skyline's disparity below each
    column, as the matcher's paths carry it up into the uniform sky."""
    skyline = _edge_value(d, sky, from_top=True)
    skyline = cv2.GaussianBlur(skyline[None, :].astype(np.float32), (0, 0), sigmaX=20.0)[0]
    share = np.clip(0.5 + 0.35 * _field(rng, d.shape, 12.0, 6.0), 0.0, 1.0)
    return np.where(sky, share * skyline[None, :], d).astype(np.float32)


def _fatten(d: np.ndarray, rng: np.random.Generator, jump: float = FATTEN_JUMP) -> np.ndarray:
    """Background pixels within a random 0..FATTEN matcher pixels of a nearer object (sideways,
    and half that vertically) take its disparity (where it is ``jump`` px or more nearer)."""
    reach = np.clip(np.rint(FATTEN_MEAN + 0.8 * _field(rng, d.shape, 2.0, 2.0)), 0, FATTEN)
    out = d.copy()
    for r in range(1, FATTEN + 1):
        k = np.ones((2 * (r // 2) + 1, 2 * r + 1), np.uint8)
        grown = cv2.dilate(d, k)
        take = (reach >= r) & (grown - d > jump + 0.05 * d)
        out[take] = np.maximum(out[take], grown[take])
    return out


def _unseen(d_grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Occluded (a pixel to the right lands at or left of this one in the right image) and
    out-of-view (lands left of the right image) masks, disparity in matcher pixels."""
    u = np.arange(d_grid.shape[1], dtype=np.float32)[None, :]
    x_r = u - d_grid
    suffix = np.minimum.accumulate(x_r[:, ::-1], axis=1)[:, ::-1]
    nxt = np.concatenate([suffix[:, 1:], np.full((len(x_r), 1), np.inf, np.float32)], axis=1)
    return nxt < x_r - 0.5, x_r < 0


def sgm_disparity(depth: np.ndarray, rgb: np.ndarray, label_ids: np.ndarray, camera: Camera,
                  seed: int) -> np.ndarray:
    """(H, W) uint16 Cityscapes disparity with SGM's noise, fattening and holes (module doc)
    from the exact optical depth (inf where nothing is: sky, bonnet), the photo and labels."""
    H, W = depth.shape
    b = 2 if W >= 1536 else 1
    rng = np.random.default_rng([int(seed), 0x53474D])
    dep = depth[::b, ::b]
    lab = label_ids[::b, ::b]
    h, w = dep.shape
    fb = np.float32(camera.fx * camera.baseline)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(np.isfinite(dep) & (dep > 0), fb / dep, 0).astype(np.float32)
    sky, ego = lab == _SKY, lab == _EGO
    grey = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY).astype(np.float32)
    if b > 1:
        grey = cv2.resize(grey, (w, h), interpolation=cv2.INTER_AREA)
    weak = texture_weakness(grey)

    d = _sky_disparity(d, sky, rng)
    d = np.where(ego, _edge_value(d, ego, from_top=False)[None, :], d)  # the road it reflects
    # the matcher's errors are fractions of its own pixel: a frame narrower than Cityscapes'
    # 2048 px (a real frame scaled down) has its disparity, and their size, scaled with it
    scale = np.float32(W / 2048)
    d = _fatten(d, rng, FATTEN_JUMP * scale)
    occluded, outside = _unseen(d / b)
    jump = cv2.dilate(d, np.ones((3, 3), np.uint8)) - cv2.erode(d, np.ones((3, 3), np.uint8))
    edges = jump > FATTEN_JUMP * scale + 0.05 * d

    noise = (MIX[0] * _field(rng, (h, w), *STREAK) + MIX[1] * _field(rng, (h, w), PATCH, PATCH)
             + MIX[2] * _field(rng, (h, w), 0, 0))
    noise /= np.float32(math.sqrt(sum(m * m for m in MIX)))
    gain = rng.uniform(*FRAME_GAIN)
    amp = np.float32(NOISE_PX * gain) * scale * (1.0 + np.float32(WEAK_GAIN) * weak)
    amp *= np.exp(np.float32(AMP_SPREAD) * _field(rng, (h, w), AMP_PATCHES, AMP_PATCHES)
                  - np.float32(AMP_SPREAD ** 2 / 2))
    d = np.maximum(d + amp * noise, 0.0)

    holes = _field(rng, (h, w), 1.5, 1.5) > _threshold(SPECKLE + WEAK_HOLES * weak)
    blobs = _field(rng, (h, w), 3.0, 3.0)
    holes |= occluded & (_field(rng, (h, w), 1.0, 1.0) > _threshold(OCCLUDED_HOLES))
    holes |= edges & (_field(rng, (h, w), 0, 0) > _threshold(EDGE_HOLES))
    holes |= outside & (blobs > _threshold(OUT_OF_VIEW_HOLES))
    holes |= ego & (blobs > _threshold(1 - EGO_VALID))
    top = int(round(BORDER_TOP * H / 1024 / b))
    side = int(round(BORDER_SIDE * W / 2048 / b))
    holes[:top] = True
    if side:
        holes[:, :side] = True
        holes[:, -side:] = True

    code = np.clip(np.rint(d * np.float32(DISPARITY_SCALE)) + 1, 1, 65535).astype(np.uint16)
    code[holes] = 0
    if b > 1:
        code = np.repeat(np.repeat(code, b, axis=0), b, axis=1)[:H, :W]
    return np.ascontiguousarray(code)
