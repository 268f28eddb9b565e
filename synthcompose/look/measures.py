"""How an inserted object looks next to the photo: the measures the look is judged by, and the
side-by-side view for judging it by eye.

* :func:`tone` - median brightness and saturation (HSV, 0-255) of an object's pixels, and
  :func:`real_tones` the same for every real object of a class in the frame;
* :func:`shadow_blotchiness` - in a ring around an object, how far the ratio output / input
  deviates from its smoothed copy, in units of the shadow's own depth: a soft shadow is smooth
  (small), a shadow that follows the noise of the real depth pixel by pixel is blotchy;
* :func:`contact_error` - at an object's lowest points, the real depth just below them against
  the object's own depth there;
* :func:`side_by_side` - per object, crops of the input, the output and the nearest real object
  of the same class.

All work on full-frame arrays as written (sRGB uint8, Cityscapes ids and disparity encoding).
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.colour import LUM, SRGB8_TO_LINEAR

#: real objects smaller than this (visible pixels) are too far or too hidden to compare
MIN_REAL_PIXELS = 400
#: the ratio's smoothing (pixels) and the shadow depth below which a pixel is not in the shadow
SHADOW_SIGMA, SHADOW_MIN_DEPTH = 4.0, 0.03
LEVEL_LUT = SRGB8_TO_LINEAR


@dataclass(frozen=True)
class Tone:
    """Median brightness (V) and saturation (S) of an object's pixels, HSV 0-255."""

    brightness: float
    saturation: float
    pixels: int


def _inner(mask: np.ndarray, fallback: bool = True) -> np.ndarray | None:
    """The mask without its border pixel (antialiased edges mix in the background); where that
    leaves fewer than 20 pixels, the whole mask (``fallback``) or None."""
    inner = cv2.erode(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    if inner.sum() >= 20:
        return inner
    return mask if fallback else None


def tone(rgb: np.ndarray, mask: np.ndarray, fallback: bool = True) -> Tone | None:
    """The :class:`Tone` of ``rgb`` (H, W, 3 uint8 sRGB) over ``mask``; None when it is empty
    (or, without ``fallback``, has fewer than 20 pixels inside its border)."""
    m = _inner(mask, fallback)
    if m is None or not m.any():
        return None
    hsv = cv2.cvtColor(rgb[m][None], cv2.COLOR_RGB2HSV_FULL)[0]
    return Tone(float(np.median(hsv[:, 2])), float(np.median(hsv[:, 1])), int(m.sum()))


def instance_tones(rgb: np.ndarray, instance_ids: np.ndarray, class_id: int | None = None,
                   min_pixels: int = MIN_REAL_PIXELS, fallback: bool = True) -> dict[int, Tone]:
    """Instance id -> :class:`Tone` of every real object (of ``class_id``; None: of every class
    with instances) in the frame with at least ``min_pixels`` visible pixels. Each object is
    measured within its bounding box (one pixel wider): the same pixels as over the frame."""
    out = {}
    sel = (instance_ids // 1000) == class_id if class_id is not None else instance_ids >= 1000
    rows, cols = np.nonzero(sel)
    if not len(rows):
        return out
    values = instance_ids[rows, cols]
    order = np.argsort(values, kind="stable")  # pixels grouped by instance
    grouped = values[order]
    starts = np.concatenate([[0], np.flatnonzero(grouped[1:] != grouped[:-1]) + 1])
    ids, counts = grouped[starts], np.diff(np.append(starts, len(grouped)))
    bounds = [np.minimum.reduceat(rows[order], starts), np.maximum.reduceat(rows[order], starts),
              np.minimum.reduceat(cols[order], starts), np.maximum.reduceat(cols[order], starts)]
    H, W = instance_ids.shape
    for k, (inst, n) in enumerate(zip(ids, counts)):
        if n >= min_pixels:
            r0, r1, c0, c1 = (int(b[k]) for b in bounds)
            box = (slice(max(r0 - 1, 0), min(r1 + 2, H)), slice(max(c0 - 1, 0), min(c1 + 2, W)))
            t = tone(rgb[box], instance_ids[box] == inst, fallback)
            if t is not None:
                out[int(inst)] = t
    return out


def real_tones(rgb: np.ndarray, instance_ids: np.ndarray, class_id: int,
               min_pixels: int = MIN_REAL_PIXELS) -> dict[int, Tone]:
    """Instance id -> :class:`Tone` of every real object of ``class_id`` in the frame with at
    least ``min_pixels`` visible pixels."""
    return instance_tones(rgb, instance_ids, class_id, min_pixels)


def _ring(mask: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Pixels around ``mask`` out to a quarter of its size (at least 12 px), 6 px clear of it
    (its antialiased edge, and the camera match's blur and noise there), and as clear of every
    other inserted object (``others``)."""
    ys, xs = np.nonzero(mask)
    size = max(int(xs.max() - xs.min()), int(ys.max() - ys.min())) + 1
    reach = max(12, size // 4)
    outer = cv2.dilate(mask.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1,) * 2))
    clear = np.ones((13, 13), np.uint8)
    inner = cv2.dilate((mask | others).astype(np.uint8), clear)
    return outer.astype(bool) & ~inner.astype(bool)


def shadow_blotchiness(src: np.ndarray, out: np.ndarray, mask: np.ndarray, objects: np.ndarray) -> float | None:
    """Mean over the ring around ``mask`` (pixels where the shadow's depth exceeds
    :data:`SHADOW_MIN_DEPTH`) of ``|r - G(r)| / |1 - G(r)|``: r = output / input luminance
    (linear), G its Gaussian-smoothed copy (sigma :data:`SHADOW_SIGMA`, over the ring only).
    None where no pixel of the ring is in a shadow. ``objects``: every inserted object's pixels."""
    if not mask.any():
        return None
    ring = _ring(mask, objects)
    if ring.sum() < 50:
        return None
    y_src = cv2.LUT(src, LEVEL_LUT) @ LUM
    y_out = cv2.LUT(out, LEVEL_LUT) @ LUM
    r = np.where(ring, y_out / np.maximum(y_src, 1e-4), 0.0).astype(np.float32)
    w = ring.astype(np.float32)
    num = cv2.GaussianBlur(r * w, (0, 0), SHADOW_SIGMA)
    den = cv2.GaussianBlur(w, (0, 0), SHADOW_SIGMA)
    g = np.where(den > 1e-3, num / np.maximum(den, 1e-6), 1.0)
    depth = np.abs(1.0 - g)
    sel = ring & (depth > SHADOW_MIN_DEPTH)
    if sel.sum() < 20:
        return None
    return float(np.mean(np.abs(r[sel] - g[sel]) / depth[sel]))


def decode_depth(disparity: np.ndarray, focal_baseline: float) -> np.ndarray:
    """Depth (metres, inf where invalid) from Cityscapes' disparity encoding (d * 256 + 1)."""
    d = (disparity.astype(np.float32) - 1.0) / 256.0
    with np.errstate(divide="ignore"):
        return np.where(disparity > 0, focal_baseline / np.maximum(d, 1e-6), np.inf).astype(np.float32)


def contact_error(src_depth: np.ndarray, out_depth: np.ndarray, mask: np.ndarray, ground: np.ndarray,
                  span: int = 12, labels: np.ndarray | None = None) -> float | None:
    """Relative error ``real depth / object depth - 1`` at the object's lowest points: the
    columns of ``mask`` whose lowest pixel lies within 2 % of the object's height (at least
    2 px) of its lowest row. The real depth there is the real ground's just below them: the
    ground is a plane, so its disparity is affine in the pixel - fitted (least squares) to the
    ``ground`` pixels in the ``span`` rows under those columns and read at the contact pixels
    (one pixel lower, the ground at 35 m is already 1.3 % nearer). Columns whose foot is hidden
    (no ground right under it) are left out; with ``labels``, only the ground of the foot's own
    label is fitted (a sign 20 cm from the kerb has the road, lower, a few rows below it). None
    without enough ground."""
    ys, xs = np.nonzero(mask)
    if not len(ys):
        return None
    H = mask.shape[0]
    bottom = np.full(mask.shape[1], -1)
    np.maximum.at(bottom, xs, ys)
    lowest, top = int(ys.max()), int(ys.min())
    near = max(2, int(round(0.02 * (lowest - top + 1))))
    cols = np.nonzero((bottom >= lowest - near) & (bottom >= 0))[0]
    cols = cols[np.isfinite(out_depth[bottom[cols], cols])]
    # only where the foot is seen: the pixel under it is ground, not something in front of it
    below = np.minimum(bottom[cols] + 1, H - 1)
    cols = cols[ground[below, cols] & (bottom[cols] + 1 < H)]
    if len(cols) < 2:
        return None
    uu, vv, dd, used = [], [], [], []
    for c in cols:
        rows = np.arange(bottom[c] + 1, min(bottom[c] + 1 + span, H))
        rows = rows[ground[rows, c] & np.isfinite(src_depth[rows, c])]
        if labels is not None:
            rows = rows[labels[rows, c] == labels[bottom[c] + 1, c]]
        if len(rows) < span // 2:  # under the foot is mostly something else (a nearer object)
            continue
        used.append(c)
        uu.append(np.full(len(rows), c))
        vv.append(rows)
        dd.append(1.0 / src_depth[rows, c])
    if not uu:
        return None
    u, v, d = np.concatenate(uu), np.concatenate(vv), np.concatenate(dd)
    if len(d) < 10 or np.ptp(v) < 2:
        return None
    cols = np.asarray(used)
    # across a thin foot (a pole: a few columns) the slope along the row is not known: rows only
    wide = np.ptp(u) >= 16
    A = np.column_stack([np.ones(len(u)), u if wide else np.zeros(len(u)), v]).astype(np.float64)
    # start from the median: over a dozen rows the ground's own change is small against a mismatch
    dev = np.abs(d - np.median(d))
    keep = dev <= max(4.5 * float(np.median(dev)), 1e-4 * float(np.median(d)))
    for _ in range(3):  # robust: stereo mismatches (a blob 40 % nearer) are left out
        coef, *_ = np.linalg.lstsq(A[keep], d[keep], rcond=None)
        res = d - A @ coef
        mad = float(np.median(np.abs(res[keep])))
        keep = np.abs(res) <= max(4.5 * mad, 1e-4 * float(np.median(d)))
        if keep.sum() < 10:
            return None
    inv = coef[0] + (coef[1] * cols if wide else 0.0) + coef[2] * bottom[cols]
    if (inv <= 0).any():
        return None
    return float(np.median(1.0 / inv) / np.median(out_depth[bottom[cols], cols]) - 1.0)


# ------------------------------------------------------------------ the side-by-side view
def _box(mask: np.ndarray, pad: float = 0.25) -> tuple[int, int, int, int]:
    ys, xs = np.nonzero(mask)
    x0, x1, y0, y1 = int(xs.min()), int(xs.max()) + 1, int(ys.min()), int(ys.max()) + 1
    px, py = int(pad * (x1 - x0)) + 8, int(pad * (y1 - y0)) + 8
    H, W = mask.shape
    return max(x0 - px, 0), max(y0 - py, 0), min(x1 + px, W), min(y1 + py, H)


def nearest_real(instance_ids: np.ndarray, class_id: int, mask: np.ndarray,
                 min_pixels: int = MIN_REAL_PIXELS) -> np.ndarray | None:
    """Mask of the real object of ``class_id`` whose centre lies nearest to ``mask``'s (among
    those with ``min_pixels`` visible pixels), or None."""
    ys, xs = np.nonzero(mask)
    c = np.array([xs.mean(), ys.mean()])
    best, best_d = None, np.inf
    ids, counts = np.unique(instance_ids[(instance_ids // 1000) == class_id], return_counts=True)
    for inst, n in zip(ids, counts):
        if n < min_pixels:
            continue
        m = instance_ids == inst
        yy, xx = np.nonzero(m)
        d = float(np.hypot(xx.mean() - c[0], yy.mean() - c[1]))
        if d < best_d:
            best, best_d = m, d
    return best


def _panel(img: np.ndarray, box, height: int, caption: str) -> np.ndarray:
    x0, y0, x1, y1 = box
    crop = img[y0:y1, x0:x1]
    scale = height / crop.shape[0]
    crop = cv2.resize(crop, (max(1, int(round(crop.shape[1] * scale))), height),
                      interpolation=cv2.INTER_NEAREST if scale >= 1 else cv2.INTER_AREA)
    bar = np.full((22, crop.shape[1], 3), 24, np.uint8)
    cv2.putText(bar, caption, (4, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (235, 235, 235), 1, cv2.LINE_AA)
    return np.concatenate([bar, crop], axis=0)


def side_by_side(src: np.ndarray, out: np.ndarray, mask: np.ndarray, instance_ids: np.ndarray | None,
                 class_id: int, height: int = 256) -> np.ndarray:
    """(h, w, 3) uint8: the input and the output cropped around ``mask`` (the inserted object),
    and the nearest real object of the same class in the input (when ``instance_ids`` has one),
    each ``height`` pixels high with a caption."""
    box = _box(mask)
    panels = [_panel(src, box, height, "input"), _panel(out, box, height, "output")]
    real = None if instance_ids is None else nearest_real(instance_ids, class_id, mask)
    if real is not None:
        panels.append(_panel(src, _box(real), height, "nearest real object of its class"))
    gap = np.full((panels[0].shape[0], 6, 3), 255, np.uint8)
    row = [panels[0]]
    for p in panels[1:]:
        row += [gap, p]
    return np.concatenate(row, axis=1)
