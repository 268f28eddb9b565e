"""Does an augmented image set still make a stereo pair? A semi-global matcher (OpenCV's
StereoSGBM) is run on the augmented left/right photos and on the input pair, and compared with
the disparity the tool wrote (:func:`check_pair`).

* over the inserted objects' visible pixels (the record's masks): the share of the pixels where
  the matcher finds a disparity that lies within 1 px of the written one (also over those the
  right camera sees too, :func:`seen_by_both`: a hidden pixel has no match to find);
* elsewhere: the share of pixels where the matcher finds the same disparity (within 1 px) on the
  augmented pair as on the input pair, over the pixels whose matching window saw no change in
  either photo (the left window, and the right one at the input pair's match).

Used by ``benchmarks/eval_stereo.py`` (generated and real frames) and the tests.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import decode_disparity, decode_rle, read_png
from synthcompose.labels import label_ids
from synthcompose.lighting.camera_match import estimate_noise
from synthcompose.record import read_record

#: the matcher's settings: 5x5 windows, eight paths, a left-right check, a match 15 % better
#: than the next, up to 256 px at 2048 px wide (an object 1.9 m from a Cityscapes camera; in
#: proportion at other widths), output in 1/16 px
BLOCK = 5
NUM_DISPARITIES = 256
#: a window measures a disparity when its horizontal texture bounds the disparity's error
#: (sqrt(2) sigma_noise / sqrt(sum of squared horizontal gradients), the matching cost's
#: curvature) to this many pixels: flat paint, a plain window, a blank plate do not
MEASURABLE_PX = 0.2
#: a window holds one surface when the written disparity within it spans at most this (pixels):
#: a block matcher takes one disparity per window, so where a window straddles a depth edge (an
#: object's outline, a pane's frame over the street seen through it) it cannot measure both
ONE_DEPTH_SPAN = 2.0


def sgbm(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """(H, W) float32 disparity of an RGB pair by OpenCV's StereoSGBM, NaN where none."""
    span = max(16, int(round(NUM_DISPARITIES * left.shape[1] / 2048 / 16)) * 16)
    matcher = cv2.StereoSGBM_create(minDisparity=0, numDisparities=span, blockSize=BLOCK,
                                    P1=4 * 3 * BLOCK ** 2, P2=12 * 3 * BLOCK ** 2, disp12MaxDiff=1,
                                    uniquenessRatio=15, speckleWindowSize=100, speckleRange=2,
                                    mode=cv2.STEREO_SGBM_MODE_HH)
    raw = matcher.compute(cv2.cvtColor(left, cv2.COLOR_RGB2GRAY), cv2.cvtColor(right, cv2.COLOR_RGB2GRAY))
    d = raw.astype(np.float32) / 16.0
    d[raw <= 0] = np.nan
    return d


@dataclass(frozen=True)
class PairCheck:
    """One image set's figures (shares in 0..1; NaN when there is nothing to count)."""

    key: str
    object_pixels: int  # visible pixels of the inserted objects (left view)
    matched: int  # of those, where the matcher found a disparity
    within_1px: float  # of the matched, share within 1 px of the written disparity
    matched_measurable: int  # of the matched, where the window's texture measures a disparity
    within_1px_measurable: float  # of those, share within 1 px of the written disparity
    median_error_px: float  # median |matcher - written| over the matched
    within_1px_both_views: float  # within_1px over the matched pixels the right camera sees too
    within_1px_measurable_both_views: float  # within_1px_measurable over the pixels the right camera sees too
    real_matched: int  # the frame's own cars and people (labels): matched pixels
    real_within_1px: float  # of those, within 1 px of the input disparity (the same matcher)
    real_within_1px_measurable: float
    residual_at_written: float  # mean |left - right at u - written disparity| on the objects, 8-bit levels
    residual_off_half_px: float  # the same with the disparity 0.5 px off (the mean of both signs)
    elsewhere_pixels: int  # pixels whose matching windows saw no change
    elsewhere_same: float  # share of those (matched on both pairs) with the same disparity within 1 px
    right_changed: int  # pixels of the right photo that changed
    #: within_1px_measurable_both_views over the pixels whose window holds one depth (one_depth)
    within_1px_one_depth: float = float("nan")

    def to_dict(self) -> dict:
        return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


def measurable(rgb: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose matching window has the texture to measure a disparity to
    :data:`MEASURABLE_PX` at the photo's own noise level (``lighting.camera.estimate_noise``)."""
    gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    gx = cv2.Sobel(gray, cv2.CV_32F, 1, 0, ksize=1) * 0.5  # central difference, code values per pixel
    energy = cv2.boxFilter(gx * gx, -1, (BLOCK, BLOCK), normalize=False)
    sigma = max(float(np.mean(estimate_noise(rgb))), 0.5)  # at least the 8-bit quantisation's
    return energy >= 2.0 * sigma ** 2 / MEASURABLE_PX ** 2


def _agreement(d: np.ndarray, truth: np.ndarray, mask: np.ndarray, texture: np.ndarray) -> tuple:
    """(found, within 1 px of the found, measurable found, within 1 px of those, median error of
    the found)."""
    found = mask & np.isfinite(d) & np.isfinite(truth)
    err = np.abs(d - truth)
    share = float((err[found] <= 1.0).mean()) if found.any() else float("nan")
    median = float(np.median(err[found])) if found.any() else float("nan")
    both = found & texture
    share_m = float((err[both] <= 1.0).mean()) if both.any() else float("nan")
    return int(found.sum()), share, int(both.sum()), share_m, median


def seen_by_both(disparity: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels of the left view whose surface the right camera sees too, by the
    disparity itself: a pixel is hidden from the right camera when a nearer pixel to its right
    lands left of it (more than half a pixel) in the right view. Hidden pixels have no match;
    a matcher gives them a neighbour's disparity."""
    cols = np.arange(disparity.shape[1], dtype=np.float32)
    x = np.where(np.isfinite(disparity), cols - disparity, np.inf).astype(np.float32)
    # the leftmost landing point of the pixels to the right of each pixel
    right_min = np.minimum.accumulate(x[:, ::-1], axis=1)[:, ::-1]
    after = np.concatenate([right_min[:, 1:], np.full((x.shape[0], 1), np.inf, np.float32)], axis=1)
    return np.isfinite(disparity) & (after >= x - 0.5)


def one_depth(disparity: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose matching window (BLOCK x BLOCK) holds one surface of the
    written disparity: known all over it and spanning at most :data:`ONE_DEPTH_SPAN` pixels."""
    known = np.isfinite(disparity)
    d = np.where(known, disparity, 0.0).astype(np.float32)
    kernel = np.ones((BLOCK, BLOCK), np.uint8)
    span = cv2.dilate(d, kernel) + cv2.dilate(-d, kernel)
    whole = cv2.erode(known.astype(np.uint8), kernel) > 0
    return whole & (span <= ONE_DEPTH_SPAN)


def photo_residual(left: np.ndarray, right: np.ndarray, disparity: np.ndarray, mask: np.ndarray,
                   shift: float = 0.0) -> float:
    """Mean |left - right| (8-bit levels, all channels) over ``mask`` with the right photo read
    at u - disparity + shift (bilinear): no matcher, the pair's agreement with the disparity
    itself. Smallest at shift 0 when the disparity is the one the pixels have between the views."""
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return float("nan")
    box = slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1)  # the mask's box alone
    xs, ys = np.meshgrid(np.arange(box[1].start, box[1].stop, dtype=np.float32),
                         np.arange(box[0].start, box[0].stop, dtype=np.float32))
    d = disparity[box]
    mapx = (xs - np.nan_to_num(d, nan=0.0) + np.float32(shift)).astype(np.float32)
    warped = cv2.remap(right.astype(np.float32), mapx, ys, cv2.INTER_LINEAR)  # maps index the whole photo
    ok = mask[box] & np.isfinite(d) & (mapx >= 0)
    return float(np.abs(warped - left[box].astype(np.float32))[ok].mean()) if ok.any() else float("nan")


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return (a != b).any(axis=2)


def check_pair(inputs: Path, outputs: Path, ident: ImageSetId) -> PairCheck:
    """Match the augmented pair under ``outputs`` and the input pair under ``inputs``."""
    left_in, right_in = read_png(ident.path(inputs, "rgb"), "rgb8"), read_png(ident.path(inputs, "right"), "rgb8")
    left_out, right_out = read_png(ident.path(outputs, "rgb"), "rgb8"), read_png(ident.path(outputs, "right"), "rgb8")
    written_raw = read_png(ident.path(outputs, "disparity"), "gray16")
    written = np.where(written_raw > 0, decode_disparity(written_raw), np.nan)
    record = read_record(ident.path(outputs, "record"))
    h, w = left_out.shape[:2]
    objects = np.zeros((h, w), bool)
    for o in record.objects:
        if o.mask_rle is not None:
            objects |= decode_rle(o.mask_rle).astype(bool)
    d_out = sgbm(left_out, right_out)
    d_in = sgbm(left_in, right_in)
    texture = measurable(left_out)
    matched, within, matched_m, within_m, median = _agreement(d_out, written, objects, texture)
    both_views = objects & seen_by_both(written)
    _, within_both, _, within_both_m, _ = _agreement(d_out, written, both_views, texture)
    _, _, _, within_one_depth, _ = _agreement(d_out, written, both_views & one_depth(written), texture)
    # the same matcher on the frame's own cars and people, against the input's disparity
    real_matched, real_within, real_within_m = 0, float("nan"), float("nan")
    if ident.path(inputs, "labelIds").exists():
        labels = read_png(ident.path(inputs, "labelIds"), "gray8")
        own = cv2.erode(np.isin(labels, label_ids("car", "person")).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        raw_in = read_png(ident.path(inputs, "disparity"), "gray16")
        disp_in = np.where(raw_in > 0, decode_disparity(raw_in), np.nan)
        real_matched, real_within, _, real_within_m, _ = _agreement(d_in, disp_in, own & ~objects, measurable(left_in))

    # the pair against the written disparity, no matcher: inside the objects (away from their
    # outline, where the background's own disparity takes over)
    inner = cv2.erode(objects.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
    at = photo_residual(left_out, right_out, written, inner)
    off = 0.5 * (photo_residual(left_out, right_out, written, inner, 0.5) +
                 photo_residual(left_out, right_out, written, inner, -0.5))

    # elsewhere: the left window unchanged, and the right window at the input pair's match
    kernel = np.ones((BLOCK, BLOCK), np.uint8)
    left_touch = cv2.dilate(_changed(left_in, left_out).astype(np.uint8), kernel) > 0
    right_changed = _changed(right_in, right_out)
    right_touch = cv2.dilate(right_changed.astype(np.uint8), kernel) > 0
    both = np.isfinite(d_in) & np.isfinite(d_out) & ~objects & ~left_touch
    rows, cols = np.nonzero(both)
    target = np.rint(cols - d_in[rows, cols]).astype(np.int64)
    inside = target >= 0
    keep = np.zeros_like(both)
    keep[rows[inside], cols[inside]] = ~right_touch[rows[inside], target[inside]]
    same = np.abs(d_out[keep] - d_in[keep]) <= 1.0
    return PairCheck(ident.key, int(objects.sum()), matched, within, matched_m, within_m, median, within_both,
                     within_both_m, real_matched,
                     real_within, real_within_m, at, off, int(keep.sum()), float(same.mean()) if same.size else float("nan"),
                     int(right_changed.sum()), within_1px_one_depth=within_one_depth)
