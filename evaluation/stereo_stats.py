"""Statistics of a disparity map that tell semi-global matching from exact geometry.

Used by ``benchmarks/stereo_stats.py`` (real frames against generated ones) and the tests of
:mod:`synthcompose.synthetic.stereo`. Every figure is measured on the Cityscapes-coded
disparity (uint16, 0 invalid) with the frame's labels and camera:

valid            share of pixels with a disparity
left_band_valid  share of valid pixels in the leftmost 100 columns at 2048 px wide (scaled
                 with the width; the right camera sees little of them)
residual_med/p90 road disparity against a least-squares plane in 31x31 px windows (at least
                 60 % valid road pixels): median absolute residual per window, median and 90th
                 percentile over windows
normals_up       road pixels 7-40 m deep whose normal from 2 px differences of the
                 back-projected points is within 24 degrees of the vehicle's up axis
sigma_d          :func:`synthcompose.placement.frame_noise` (the placement's own estimate)
height_<band>    road height in the vehicle frame (median, MAD) at optical depth 5-10, 10-20,
                 20-40 m
fatten_right/left  at row-wise edges of near objects ("things", poles, signs) against a
                 background at least 4 px of disparity farther (at 2048 px wide): how many of
                 the 8 background pixels next to the edge take the object's disparity (nearer
                 to it than to the background's), mean over edges; on the left side of objects also the share
                 of those pixels that are invalid (occluded_left)

Pixel sizes are those of a 2048 px wide frame: a narrower one is measured as a real frame
scaled down (windows and steps scaled, residuals and sigma_d in pixels of 2048 px).
"""
from __future__ import annotations

import numpy as np

from synthcompose.camera import Camera
from synthcompose.geometry.depth import back_project, disparity_to_depth, make_frame
from synthcompose.io.files import decode_disparity
from synthcompose.labels import HAS_INSTANCES, label_id

WINDOW = 31
BANDS = ((5.0, 10.0), (10.0, 20.0), (20.0, 40.0))
#: near objects whose edges are measured: instance classes and poles, signs, lights
_OBJECT = HAS_INSTANCES.copy()
for _n in ("pole", "traffic sign", "traffic light"):
    _OBJECT[label_id(_n)] = True
_ROAD = label_id("road")


def _px(disparity: np.ndarray) -> np.ndarray:
    d = decode_disparity(disparity)
    d[disparity == 0] = np.nan
    return d


def plane_residuals(d: np.ndarray, mask: np.ndarray, window: int = WINDOW, min_share: float = 0.6) -> np.ndarray:
    """Median absolute residual (px) of a least-squares plane d = a u + b v + c in each non-overlapping
    ``window`` square holding at least ``min_share`` valid masked pixels."""
    H, W = d.shape
    v, u = np.mgrid[0:window, 0:window].astype(np.float64)
    out = []
    for r in range(0, H - window + 1, window):
        for c in range(0, W - window + 1, window):
            m = mask[r:r + window, c:c + window] & np.isfinite(d[r:r + window, c:c + window])
            n = int(m.sum())
            if n < min_share * window * window:
                continue
            a = np.column_stack([u[m], v[m], np.ones(n)])
            y = d[r:r + window, c:c + window][m].astype(np.float64)
            coef, *_ = np.linalg.lstsq(a, y, rcond=None)
            out.append(float(np.median(np.abs(y - a @ coef))))
    return np.asarray(out)


def _points(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W, 3) vehicle-frame points, NaN where the depth is not finite."""
    H, W = depth.shape
    v, u = np.mgrid[0:H, 0:W]
    v, u = v.ravel(), u.ravel()
    dz = np.where(np.isfinite(depth), depth, np.nan).astype(np.float32)
    _, p = back_project(dz, camera, v, u)
    return p.reshape(H, W, 3)


def normals_up_share(points: np.ndarray, depth: np.ndarray, mask: np.ndarray, step: int = 2,
                     near: float = 7.0, far: float = 40.0, max_deg: float = 24.0) -> float:
    """Share of ``mask`` pixels ``near``-``far`` m deep (whose step-px neighbours right and
    below are in the mask too) with a normal within ``max_deg`` of up."""
    p = points[:-step, :-step]
    du = points[:-step, step:] - p
    dv = points[step:, :-step] - p
    n = np.cross(du, dv)
    m = mask[:-step, :-step] & mask[:-step, step:] & mask[step:, :-step]
    z = depth[:-step, :-step]
    m &= (z >= near) & (z <= far) & np.isfinite(n).all(axis=2)
    if not m.any():
        return float("nan")
    n = n[m]
    cos = np.abs(n[:, 2]) / np.maximum(np.linalg.norm(n, axis=1), 1e-12)
    return float(np.mean(cos >= np.cos(np.radians(max_deg))))


def edge_fattening(d: np.ndarray, labels: np.ndarray, reach: int = 8, gap: int = 12,
                   min_jump: float = 4.0) -> dict[str, float]:
    """Foreground fattening and occlusion holes at row-wise object edges (see the module doc);
    ``gap`` (background from this many px beyond the edge) and ``min_jump`` are for 2048 px
    wide frames and scale with the width."""
    obj = _OBJECT[labels]
    H, W = d.shape
    gap = max(reach // 2, round(gap * W / 2048))
    min_jump = min_jump * W / 2048
    out: dict[str, float] = {}
    for side, sgn in (("right", 1), ("left", -1)):
        # edge pixel e: object at e, background at e + sgn
        if sgn > 0:
            r, e = np.nonzero(obj[:, :-1] & ~obj[:, 1:])
        else:
            r, e = np.nonzero(~obj[:, :-1] & obj[:, 1:])
            e = e + 1
        keep = (e - (gap + reach) >= 0) & (e + gap + reach < W)
        r, e = r[keep], e[keep]
        inner = np.nanmedian(np.stack([d[r, e - sgn * k] for k in range(2, 6)]), axis=0)
        outer_idx = [e + sgn * k for k in range(gap, gap + reach)]
        bg_lab = np.stack([obj[r, i] for i in outer_idx])
        outer = np.nanmedian(np.stack([d[r, i] for i in outer_idx]), axis=0)
        with np.errstate(invalid="ignore"):
            ok = (inner - outer > min_jump) & ~bg_lab.any(axis=0)
        r, e, inner, outer = r[ok], e[ok], inner[ok], outer[ok]
        near = np.stack([d[r, e + sgn * k] for k in range(1, reach + 1)])
        nearer = np.abs(near - inner) < np.abs(near - outer)
        # consecutive pixels from the edge outwards that took the object's disparity
        run = np.cumprod(nearer, axis=0).sum(axis=0)
        out[f"fatten_{side}"] = float(run.mean()) if len(r) else float("nan")
        out[f"invalid_{side}"] = float(np.mean(~np.isfinite(near))) if len(r) else float("nan")
        out[f"edges_{side}"] = float(len(r))
    return out


def stereo_stats(disparity: np.ndarray, camera: Camera, label_ids: np.ndarray | None = None) -> dict[str, float]:
    """The figures of the module doc for one frame; without ``label_ids`` only the label-free ones."""
    d = _px(disparity)
    H, W = d.shape
    valid = np.isfinite(d)
    out = {"valid": float(valid.mean()), "left_band_valid": float(valid[:, :max(1, round(100 * W / 2048))].mean())}
    if label_ids is None:
        return out
    # a narrower frame is a real one scaled down: windows and steps shrink with it, and its
    # pixel figures are given in pixels of a 2048 px wide frame
    k = 2048 / W
    road = (label_ids == _ROAD) & valid
    res = plane_residuals(d, road, window=2 * int(round(WINDOW / k / 2)) + 1) * k
    out["residual_med"] = float(np.median(res)) if len(res) else float("nan")
    out["residual_p90"] = float(np.percentile(res, 90)) if len(res) else float("nan")
    depth = disparity_to_depth(disparity, camera)
    points = _points(depth, camera)
    out["normals_up"] = normals_up_share(points, depth, road, step=max(1, int(round(2 / k))))
    from synthcompose.placement import frame_noise  # not at import time: placement is the heavier package
    out["sigma_d"] = frame_noise(make_frame(depth, label_ids, camera)).sigma_d * k
    zr = depth[road]
    hr = points[..., 2][road]
    for lo, hi in BANDS:
        h = hr[(zr >= lo) & (zr < hi)]
        med = float(np.median(h)) if len(h) else float("nan")
        out[f"height_{lo:g}_{hi:g}"] = med
        out[f"height_mad_{lo:g}_{hi:g}"] = float(np.median(np.abs(h - med))) if len(h) else float("nan")
    out.update(edge_fattening(d, label_ids))
    return out
