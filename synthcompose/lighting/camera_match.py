"""The camera's look, measured on the photo and given to the inserted objects: its noise and
blur (:class:`CameraMatch`; the compose stage applies them to the object layer only)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.colour import LUM, linear_to_srgb, srgb_to_linear
from synthcompose.labels import category_ids, label_id

#: what :func:`estimate_blur` measures on an ideal step edge box-filtered over the pixel
BOX_EDGE_SIGMA = 0.82
#: what it measures on the renderer's objects without the camera match: sharper than a box
#: edge (textures sampled bilinearly, shading once per pixel, silhouettes from 4 samples):
#: 0.62-0.72 on the cast's cars inserted into real 2048x1024 frames, 0.79 on the generated
#: scene of tests/look/test_camera_blur.py (smaller cars); the
#: object layer is blurred by the rest of the photo's, so that it measures as the photo does
RENDER_BLUR_SIGMA = 0.67
#: the object blur is kept below this (pixels): beyond, the photo is out of focus or smeared
#: and a Gaussian is no longer a good model
MAX_OBJECT_BLUR = 1.6

_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)  # L2 norm 6

#: noise and blur are pixel-level measures: they are taken at full resolution, but on a sample
#: of the frame - a quarter of its SAMPLE_TILE x SAMPLE_TILE tiles, staggered over its rows and
#: columns (scenes are layered by rows: sky, facades, road), each read with SAMPLE_MARGIN pixels
#: of context (more than the filters reach: the Gaussian of sigma 1 at 4 pixels, the Sobel and
#: the Immerkaer mask at 1, the dilation at 2), so that each pixel of a tile gets the values the
#: whole frame would give it (the Canny edges' tracing aside); a quarter of the frame's pixels
#: leaves the medians far more samples than they need
SAMPLE_TILE, SAMPLE_MARGIN = 64, 8
_FRAME_BORDER = 3  # pixels along the frame's border that never count (the filters' own border)


def sample_tiles(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tiles noise and blur are measured on (:data:`SAMPLE_TILE`), with their context,
    stacked one above the other: (n * (T + 2M), T + 2M, 3) uint8, and a bool array of that
    shape: the pixels that count (in the tile, in the frame). A small frame is used whole."""
    H, W = rgb.shape[:2]
    T, M = SAMPLE_TILE, SAMPLE_MARGIN
    inside = np.zeros((H + 2 * M + T, W + 2 * M + T), bool)
    inside[M + _FRAME_BORDER:M + H - _FRAME_BORDER, M + _FRAME_BORDER:M + W - _FRAME_BORDER] = True
    if H < 4 * T or W < 4 * T:
        return rgb, inside[M:M + H, M:M + W].copy()
    # the frame reflected at its border as the filters would; T more at the far sides for the
    # last, partial tiles (their pixels out of the frame do not count)
    pad = cv2.copyMakeBorder(rgb, M, M + T, M, M + T, cv2.BORDER_REFLECT_101)
    tiles, counts = [], []
    for i, r0 in enumerate(range(0, H, T)):
        for j, c0 in enumerate(range(0, W, T)):
            if (2 * i + j) % 4 == 0:
                window = (slice(r0, r0 + T + 2 * M), slice(c0, c0 + T + 2 * M))
                tiles.append(pad[window])
                count = np.zeros((T + 2 * M, T + 2 * M), bool)
                count[M:M + T, M:M + T] = inside[window][M:M + T, M:M + T]
                counts.append(count)
    return np.concatenate(tiles), np.concatenate(counts)


def _grouped_median(values: np.ndarray) -> float:
    """Median of non-negative integer-valued data, interpolated within its integer bin (a plain
    median of integers moves in steps of 1)."""
    counts = np.bincount(values.astype(np.int64))
    cum = np.cumsum(counts)
    half = cum[-1] / 2.0
    k = int(np.searchsorted(cum, half))
    below = cum[k - 1] if k > 0 else 0
    return float(k - 0.5 + (half - below) / max(counts[k], 1))


def estimate_noise(rgb: np.ndarray, counted: np.ndarray | None = None) -> np.ndarray:
    """(3,) noise standard deviation of each channel, in 8-bit code values: robust MAD of a
    Laplacian-like high-pass (Immerkaer's mask, blind to planes) over the flat half of the
    image, away from edges and clipped values. ``counted``: (H, W) bool, the pixels that count
    (the others are context: :func:`sample_tiles`); None: all but the border."""
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    smooth = cv2.GaussianBlur(grey, (0, 0), 1.0)
    grad = cv2.magnitude(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    lo, hi = np.quantile(grad[::4, ::4] if counted is None else grad[counted][::16], [0.5, 0.8])
    flat = grad <= lo
    flat &= cv2.dilate((grad > hi).astype(np.uint8), np.ones((5, 5), np.uint8)) == 0
    channels = cv2.split(np.ascontiguousarray(rgb))
    flat &= (cv2.min(cv2.min(channels[0], channels[1]), channels[2]) > 4) & \
        (cv2.max(cv2.max(channels[0], channels[1]), channels[2]) < 251)
    flat[:2], flat[-2:], flat[:, :2], flat[:, -2:] = False, False, False, False
    if counted is not None:
        flat &= counted
    if flat.sum() < 500:
        flat[2:-2, 2:-2] = True if counted is None else counted[2:-2, 2:-2]
    out = np.empty(3)
    for c in range(3):
        # integer mask on 8-bit data: exact in 16 bits (|r| <= 16 * 255)
        r = cv2.filter2D(channels[c], cv2.CV_16S, _IMMERKAER, borderType=cv2.BORDER_REFLECT)
        out[c] = 1.4826 * _grouped_median(np.abs(r[flat])) / 6.0
    return out


def estimate_blur(rgb: np.ndarray, reblur: float = 1.0, counted: np.ndarray | None = None) -> float:
    """Blur of the photo as the sigma (pixels) of an equivalent Gaussian, from its strong edges:
    re-blurring a step edge of blur s by ``reblur`` lowers its peak gradient by the factor
    sqrt(s^2 + reblur^2) / s (Zhuo & Sim's defocus estimate); median over edge pixels. An ideal
    edge box-filtered over the pixel measures :data:`BOX_EDGE_SIGMA`. ``counted``: as for
    :func:`estimate_noise`."""
    grey8 = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    grey = grey8.astype(np.float32)
    re = cv2.GaussianBlur(grey, (0, 0), reblur)

    edges = cv2.Canny(grey8, 40, 100) > 0
    edges[:3], edges[-3:], edges[:, :3], edges[:, -3:] = False, False, False, False
    if counted is not None:
        edges &= counted
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
        sample, counted = sample_tiles(rgb)
        noise = estimate_noise(sample, counted)
        blur = estimate_blur(sample, counted=counted)
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


# ---------------------------------------------------------------- the camera's tone on the object
#: real objects of a class with fewer visible pixels are not references (too far, too hidden)
MIN_REFERENCE_PIXELS = 400
#: a class needs this many references in the frame (else its group's, else none)
MIN_REFERENCES = 3
#: the central share of the references' tones an object's tone is placed in
CENTRAL = (0.15, 0.85)
#: object pixels the tone is measured on (an even spread of them)
TONE_SAMPLES = 4000
#: classes that stand in for each other as references (Cityscapes ids): vehicles, people
REFERENCE_GROUPS = (category_ids("vehicle"), category_ids("human"))
ROAD_ID = label_id("road")
#: without references in the frame (no labels, or too few cars): cars' tones relative to the
#: road's under the same light and camera - per-car median HSV value against the road's (in
#: linear light) and saturation against the road's, at the 10th, 15th, 30th, 50th, 70th, 85th
#: and 90th percentiles of the 41 cars of the real development set (4 frames; the saturation
#: ratio, the camera's colour cast and noise, held within 0.85-1.45 on each frame; the value
#: ratio varies from frame to frame with the cars parked there)
ROAD_PRIOR = ((0.22, 0.28, 0.39, 0.57, 0.94, 1.48, 1.6), (0.98, 1.03, 1.08, 1.13, 1.18, 1.45, 1.47))
ROAD_PRIOR_CLASSES = (26, 27, 28, 29)  # car, truck, bus, caravan
#: the road's tone is taken on every ROAD_STRIDE-th row and column (single pixels, not averaged)
ROAD_STRIDE = 2


def _linear(v: float) -> float:
    return float(srgb_to_linear(np.float64(v)))


def _hsv_vs(srgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """HSV value and saturation (0-255) of sRGB colours in [0, 1], (N, 3)."""
    r, g, b = srgb[:, 0], srgb[:, 1], srgb[:, 2]  # (column by column: NumPy's max over an axis of 3 is slow)
    mx, mn = np.maximum(np.maximum(r, g), b), np.minimum(np.minimum(r, g), b)
    return 255.0 * mx, 255.0 * np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-9), 0.0)


@dataclass(frozen=True, eq=False)
class ToneReference:
    """The tones of the frame's own objects, per class (Cityscapes id): (n, 2) arrays of each
    object's median HSV value and saturation (0-255) - what this camera makes of such objects."""

    tones: dict

    road: tuple[float, float] | None = None  # the road's median HSV value and saturation

    @classmethod
    def measure(cls, rgb: np.ndarray, instance_ids: np.ndarray | None,
                label_ids: np.ndarray | None = None) -> "ToneReference":
        """From the photo, its instance ids (None: no objects to refer to) and its labels (or the
        surfaces found without them: the road, for :data:`ROAD_PRIOR`)."""
        road = None
        if label_ids is not None:
            # medians over the road: every ROAD_STRIDE-th pixel of every ROAD_STRIDE-th row is
            # plenty, and keeps each pixel's own noise (which the references' tones carry too)
            sub = (slice(None, None, ROAD_STRIDE),) * 2
            on_road = label_ids[sub] == ROAD_ID
            if on_road.sum() * ROAD_STRIDE ** 2 >= 2000:
                px = cv2.cvtColor(rgb[sub][on_road][None], cv2.COLOR_RGB2HSV_FULL)[0]
                road = (float(np.median(px[:, 2])), float(np.median(px[:, 1])))
        if instance_ids is None:
            return cls({}, road)
        from synthcompose.look.measures import instance_tones

        tones: dict[int, list] = {}
        for inst, t in instance_tones(rgb, instance_ids, None, MIN_REFERENCE_PIXELS, fallback=False).items():
            tones.setdefault(inst // 1000, []).append((t.brightness, t.saturation))
        return cls({k: np.asarray(v) for k, v in tones.items()}, road)

    def for_class(self, class_id: int) -> tuple[np.ndarray | None, str]:
        """The reference tones for an object of ``class_id`` and what they are: its class's, else
        its group's (vehicles, people), else None."""
        own = self.tones.get(class_id)
        if own is not None and len(own) >= MIN_REFERENCES:
            return own, f"class x{len(own)}"
        for group in REFERENCE_GROUPS:
            if class_id in group:
                found = [self.tones[c] for c in group if c in self.tones]
                if found and sum(len(f) for f in found) >= MIN_REFERENCES:
                    pooled = np.concatenate(found)
                    return pooled, f"group x{len(pooled)}"
        if self.road is not None and class_id in ROAD_PRIOR_CLASSES:
            v_road, s_road = self.road
            lin = np.array([_linear(v_road / 255.0) * r for r in ROAD_PRIOR[0]])
            v = 255.0 * linear_to_srgb(lin)
            return np.column_stack([v, s_road * np.asarray(ROAD_PRIOR[1])]), "road prior"
        return None, "none"


def _saturation_for(colours: np.ndarray, target: float, noise: np.ndarray, gain: float) -> float:
    """The factor s (c' = gain (Y + s (c - Y)), linear) that gives ``colours`` (N, 3) the median
    HSV saturation ``target`` once the camera's ``noise`` (N, 3, sRGB units) is on them, as the
    compose puts it (bisection; saturation grows with s)."""
    y = (colours @ LUM)[:, None]

    def median_s(s: float) -> float:
        c = gain * np.maximum(y + s * (colours - y), 0.0)
        return float(np.median(_hsv_vs(np.clip(linear_to_srgb(c) + noise, 0, 1))[1]))

    lo, hi = 0.0, 4.0
    if median_s(hi) <= target:
        return hi
    for _ in range(16):  # to 4 / 2^16: far below one step of 8-bit saturation
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if median_s(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def object_tones(objc: np.ndarray, ids: np.ndarray, classes, ranks, reference: ToneReference,
                 fallback_gain: float = 1.0, match: CameraMatch | None = None) -> list[dict]:
    """The camera's look for each rendered object k = 1..K (``objc``: the render's premultiplied
    object colour, float16 or float32; ``ids``: its object index per pixel; ``classes``/``ranks``: each object's
    Cityscapes id and its appearance's (lightness, colourfulness) rank).

    Where the frame has references for its class, the object's median HSV value and saturation
    are placed at its ranks within the central :data:`CENTRAL` share of the references' tones
    (a white car among the frame's lighter cars, a black one among its darker; order kept, the
    frame's exposure, contrast and muted colours taken on): a gain and a saturation factor on
    its linear colour. The references' tones include the camera's noise, so the object's are
    taken with the noise ``match`` will give it (noise makes dark colours look more saturated).
    Without references the gain is ``fallback_gain`` (the photo's exposure) and the colours
    stay. Returns per object {"gain", "saturation", "reference"}."""
    out = []
    for k, (cid, (q_v, q_s)) in enumerate(zip(classes, ranks), start=1):
        ref, what = reference.for_class(int(cid))
        sel = (ids == k) & (objc[..., 3] >= np.float32(0.999))  # (in float32 for a pass in half floats too)
        if ref is None or sel.sum() < 20:
            out.append({"gain": float(fallback_gain), "saturation": 1.0,
                        "reference": what if ref is None else "too small"})
            continue
        colours = objc[..., :3][sel].astype(np.float64)
        if len(colours) > TONE_SAMPLES:  # an even spread: a median needs no more
            colours = colours[:: len(colours) // TONE_SAMPLES + 1]
        lo, hi = CENTRAL
        v_t = float(np.quantile(ref[:, 0], lo + (hi - lo) * q_v))
        s_t = float(np.quantile(ref[:, 1], lo + (hi - lo) * q_s))
        sigma = np.asarray(match.noise_sigma if match is not None else (0.0, 0.0, 0.0), float) / 255.0
        noise = np.random.default_rng(k).standard_normal(colours.shape) * sigma
        y = (colours @ LUM)[:, None]
        gain = 1.0
        for _ in range(3):  # the gain moves the saturation in sRGB a little: solve the two in turn
            sat = _saturation_for(colours, s_t, noise, gain)
            v_now = float(np.median(_hsv_vs(linear_to_srgb(np.maximum(y + sat * (colours - y), 0.0)))[0]))
            gain = _linear(v_t / 255.0) / max(_linear(v_now / 255.0), 1e-6)
        out.append({"gain": float(np.clip(gain, 0.05, 20.0)), "saturation": float(sat), "reference": what,
                    "target_hsv_value": round(v_t, 1), "target_hsv_saturation": round(s_t, 1)})
    return out
