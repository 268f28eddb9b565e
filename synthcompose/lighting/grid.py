"""The working grid: the photo reduced to cells, with their points and normals."""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.placement.noise import STEP, measure_sigma

from .light import FINE_IDS, GROUND_IDS, LEVEL_LUT, LUM


@dataclass(eq=False)
class Grid:
    """The photo reduced to cells of ``f`` x ``f`` pixels (mean linear colour)."""

    f: int
    lin: np.ndarray  # (h, w, 3) float32 linear RGB
    lum: np.ndarray  # (h, w) float32
    label: np.ndarray  # (h, w) uint8, the cell's label (pure cells only are used)
    pure: np.ndarray  # (h, w) bool: one label, finite depth throughout, nothing clipped
    points: np.ndarray  # (h, w, 3) float64 vehicle-frame point at the cell centre (nan unknown)
    normals: np.ndarray  # (h, w, 3) unit normals facing the camera (nan where not planar)


def _cell_reduce(a: np.ndarray, f: int, op) -> np.ndarray:
    """Min (``cv2.erode``) or max (``cv2.dilate``) of ``a`` (no NaN) over each f x f cell, (h, w):
    the erosion's (dilation's) value at each cell's centre pixel, taken as the minimum (maximum)
    of the cell's f rows, then of f columns of that (half of the morphology's cost)."""
    h, w = a.shape[0] // f, a.shape[1] // f
    if f == 1:
        return a[:h, :w].copy()
    pick = np.minimum if op is cv2.erode else np.maximum
    rows = a[0:h * f:f, :w * f]
    for i in range(1, f):
        rows = pick(rows, a[i:h * f:f, :w * f])
    out = rows[:, 0::f]
    for j in range(1, f):
        out = pick(out, rows[:, j::f])
    return np.ascontiguousarray(out)  # not a view that keeps the whole frame's array


def _cell_mean(a: np.ndarray, f: int) -> np.ndarray:
    """Mean of ``a`` (float32) over each f x f cell, (h, w)."""
    h, w = a.shape[0] // f, a.shape[1] // f
    a = a[: h * f, : w * f]
    return cv2.resize(a, (w, h), interpolation=cv2.INTER_AREA) if f > 1 else a.copy()


def _linear_cell_mean(rgb: np.ndarray, f: int, band_cells: int = 64) -> np.ndarray:
    """``_cell_mean(cv2.LUT(rgb, LEVEL_LUT), f)``, ``band_cells`` rows of cells at a time: the
    same values (each cell's mean is its own f x f pixels') without the whole linear photo in
    memory at once ((H, W, 3) float32: 24 MB at 2048x1024)."""
    h = rgb.shape[0] // f
    step = f * band_cells
    if f == 1 or h * f <= step:
        return _cell_mean(cv2.LUT(rgb, LEVEL_LUT), f)
    return np.concatenate([_cell_mean(cv2.LUT(rgb[r0:min(r0 + step, h * f)], LEVEL_LUT), f)
                           for r0 in range(0, h * f, step)])


def make_grid(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera, work_width: int,
          smooth: int = 1) -> Grid:
    H, W = label_ids.shape
    f = max(1, int(round(W / work_width)))
    h, w = H // f, W // f
    lin = _linear_cell_mean(rgb, f)
    lab_min, lab_max = _cell_reduce(label_ids, f, cv2.erode), _cell_reduce(label_ids, f, cv2.dilate)
    # depth of a cell: the mean of its known depths (stereo leaves holes), if half are known
    d = depth.astype(np.float32, copy=False)
    known = np.isfinite(d)
    n_known = np.rint(_cell_mean(known.astype(np.float32), f) * (f * f))
    dmin = _cell_reduce(np.where(known, d, np.float32(np.inf)), f, cv2.erode)
    dmax = _cell_reduce(np.where(known, d, np.float32(-np.inf)), f, cv2.dilate)
    dsum = _cell_mean(np.where(known, d, np.float32(0.0)), f).astype(np.float64) * (f * f)
    clipped = _cell_reduce(cv2.max(cv2.max(rgb[..., 0], rgb[..., 1]), rgb[..., 2]), f, cv2.dilate) >= 250
    pure = (lab_min == lab_max) & (2 * n_known >= f * f) & (dmax <= dmin * 1.04 + 0.02) & ~clipped
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(2 * n_known >= f * f, dsum / np.maximum(n_known, 1), np.nan).astype(np.float64)
    if smooth > 1:
        z = _smoothed_depth(z, lab_min, lab_min == lab_max, smooth)
    uc = (np.arange(w) * f + (f - 1) / 2.0)[None, :]
    vc = (np.arange(h) * f + (f - 1) / 2.0)[:, None]
    opt = np.stack([(uc - camera.u0) * z / camera.fx, (vc - camera.v0) * z / camera.fy, z], axis=-1)
    m = camera.vehicle_from_optical
    pts = opt @ m[:3, :3].T + m[:3, 3]
    normals = _normals(pts, lab_min, pure, camera)
    if f > 1:  # a face narrower than 5 cells, or a cell within 2 of a corner: at pixel scale
        rr, cc = np.nonzero(pure & np.isnan(normals[..., 0]) & np.isin(lab_min, FINE_IDS))
        normals[rr, cc] = _fine_normals(rr * f + f // 2, cc * f + f // 2, label_ids, d, camera)
    lum = (lin @ LUM.astype(np.float32)).astype(np.float32)
    return Grid(f, lin, lum, lab_min, pure, pts, normals)


#: a frame whose disparity errs by more than this (pixels, :func:`noise.measure_sigma` on its
#: ground) came from a real matcher: its cells are averaged over SMOOTH x SMOOTH before the
#: normals are taken; exact disparity (1/256 px coding, measured at the floor) keeps its cells
NOISY_SIGMA_D, SMOOTH = 0.15, 3


def smoothing_for(depth: np.ndarray, label_ids: np.ndarray, camera: Camera) -> tuple[int, float]:
    """(cells to average, the frame's measured disparity error in pixels)."""
    fb = camera.fx * camera.baseline
    # measure_sigma's rows (every 4th) and their neighbours STEP rows away all lie on every 4th
    # row (STEP a multiple of 4): the disparity of those rows alone gives the same figure
    k = 4 if STEP % 4 == 0 else 1
    rows = slice(None, None, k)
    with np.errstate(divide="ignore"):
        disparity = np.where(np.isfinite(depth[rows]), fb / depth[rows], np.nan).astype(np.float32)
    sigma = measure_sigma(disparity, np.isin(label_ids[rows], GROUND_IDS), stride=4 // k, row_step=STEP // k)
    return (SMOOTH if sigma > NOISY_SIGMA_D else 1), sigma


def _smoothed_depth(z: np.ndarray, label: np.ndarray, one_label: np.ndarray, cells: int) -> np.ndarray:
    """Cell depths with their disparity (1 / z) averaged over the ``cells`` x ``cells`` cells
    of the same label around each cell. Real stereo (semi-global matching) errs by a few tenths
    of a pixel of disparity, about the same everywhere, so the depth error grows with z^2: at
    20 m, +-0.2 px is +-17 cm along the ray, while neighbouring cells 3 px apart are 3 cm apart
    on the ground - the normals from cell differences are noise. On a plane the disparity is an
    affine function of the pixel, so its average over cells is the plane's own disparity at
    their centroid: planes stay planar and the noise drops by about the window's width."""
    known = np.isfinite(z) & one_label
    disp = np.where(known, 1.0 / np.where(known, z, 1.0), 0.0).astype(np.float32)
    out = z.copy()
    k = (cells, cells)
    for lab in np.unique(label[known]):
        m = (known & (label == lab)).astype(np.float32)
        num = cv2.boxFilter(disp * m, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT)
        den = cv2.boxFilter(m, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT)
        sel = m > 0
        out[sel] = 1.0 / np.maximum(num[sel] / den[sel], 1e-6)
    return out


def _normals(p: np.ndarray, label: np.ndarray, pure: np.ndarray, camera: Camera) -> np.ndarray:
    """Normals from differences of cell points 1 and 2 cells apart; nan where the surface is not
    locally planar (creases, depth edges), where the two disagree or where labels change."""
    h, w, _ = p.shape
    out = np.full((h, w, 3), np.nan, np.float32)
    if h < 5 or w < 5:
        return out
    # one plane per coordinate, relative to the camera (unknown cells fail `pure` anyway)
    rel = np.nan_to_num(p - camera.position, nan=0.0).astype(np.float32)
    P = [np.ascontiguousarray(rel[..., i]) for i in range(3)]
    c = (slice(2, h - 2), slice(2, w - 2))

    def sh(dr: int, dc: int) -> tuple[slice, slice]:
        return slice(2 + dr, h - 2 + dr), slice(2 + dc, w - 2 + dc)

    ok = pure[c].copy()
    lab0 = label[c]
    for dr in range(-2, 3):
        for dc in (-2, -1, 0, 1, 2):
            if (dr == 0) != (dc == 0):
                ok &= pure[sh(dr, dc)] & (label[sh(dr, dc)] == lab0)
    p0 = [q[c] for q in P]
    normals = []
    for k in (1, 2):
        du, dv = [], []
        for q, q0 in zip(P, p0):
            qa, qb, qc, qd = q[sh(0, k)], q[sh(0, -k)], q[sh(k, 0)], q[sh(-k, 0)]
            du.append(qa - qb)
            dv.append(qc - qd)
            if q is P[0]:
                dev_u, dev_v = (qa + qb - 2 * q0) ** 2, (qc + qd - 2 * q0) ** 2
            else:
                dev_u += (qa + qb - 2 * q0) ** 2
                dev_v += (qc + qd - 2 * q0) ** 2
        # collinearity along each axis: a crease or a depth edge bends it
        for dev, span in ((dev_u, du), (dev_v, dv)):
            ok &= np.sqrt(dev) <= 0.08 * np.sqrt(span[0] ** 2 + span[1] ** 2 + span[2] ** 2) + 1e-3
        n = [du[1] * dv[2] - du[2] * dv[1], du[2] * dv[0] - du[0] * dv[2], du[0] * dv[1] - du[1] * dv[0]]
        norm = np.maximum(np.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2), 1e-12)
        normals.append([v / norm for v in n])
    n1, n2 = normals
    ok &= np.abs(n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]) >= math.cos(math.radians(10))
    # facing the camera: against the point's offset from it
    sign = np.where(n2[0] * p0[0] + n2[1] * p0[1] + n2[2] * p0[2] > 0, np.float32(-1.0), np.float32(1.0))
    sign[~ok] = np.nan
    out[c] = np.stack([v * sign for v in n2], axis=-1)
    return out


def _norm(v: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(v, axis=-1)`` of (N, 3) vectors, its sum in its order, column by column
    (NumPy's sum over an axis of 3 is slow)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.sum(a * b, axis=-1)`` of (N, 3) vectors, in its order, column by column."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _fine_normals(r: np.ndarray, c: np.ndarray, label_ids: np.ndarray, depth: np.ndarray,
                  camera: Camera) -> np.ndarray:
    """(N, 3) normals at pixels (r, c) from the photo's own pixels 1 and 2 apart, with the tests
    of :func:`_normals`; nan where they fail (or too near the image border)."""
    H, W = label_ids.shape
    out = np.full((len(r), 3), np.nan, np.float32)
    idx = np.nonzero((r >= 2) & (r < H - 2) & (c >= 2) & (c < W - 2))[0]
    r, c = r[idx], c[idx]
    # a pixel's vehicle-frame point is z * (col_ray[u] + row_ray[v]) + t
    m = camera.vehicle_from_optical
    col_ray = (((np.arange(W) - camera.u0) / camera.fx)[:, None] * m[:3, 0]).astype(np.float32)
    row_ray = (((np.arange(H) - camera.v0) / camera.fy)[:, None] * m[:3, 1] + m[:3, 2]).astype(np.float32)
    # the cheap tests first (all nine pixels known, of one label), then each geometric test on
    # the pixels still in the running (most fail): the same normals, for a fraction of the work
    # (the pixels read by their index in the flattened frame: a fifth of a 2-D gather's cost)
    depth_at, label_at = depth.reshape(-1), label_ids.reshape(-1)
    at = r * W + c
    lab0 = np.take(label_at, at)
    ok = np.ones(len(r), bool)
    for dr, dc in ((0, 0), (0, 1), (0, -1), (1, 0), (-1, 0), (0, 2), (0, -2), (2, 0), (-2, 0)):
        near = at + (dr * W + dc)
        ok &= np.isfinite(np.take(depth_at, near)) & (np.take(label_at, near) == lab0)
    idx, r, c, at = idx[ok], r[ok], c[ok], at[ok]

    def point(dr: int, dc: int) -> np.ndarray:  # relative to the camera's position
        return np.take(depth_at, at + (dr * W + dc))[:, None] * (col_ray[c + dc] + row_ray[r + dr])

    normals: list[np.ndarray] = []
    for k in (1, 2):
        p0 = point(0, 0)
        a_u, b_u, a_v, b_v = point(0, k), point(0, -k), point(k, 0), point(-k, 0)
        du, dv = a_u - b_u, a_v - b_v
        ok = np.ones(len(r), bool)
        for a, b, span in ((a_u, b_u, du), (a_v, b_v, dv)):
            ok &= _norm(a + b - 2 * p0) <= 0.08 * _norm(span) + 1e-3
        idx, r, c, at, p0 = idx[ok], r[ok], c[ok], at[ok], p0[ok]
        normals = [n[ok] for n in normals]
        n = np.cross(du[ok], dv[ok])
        normals.append(n / np.maximum(_norm(n), 1e-12)[:, None])
    n1, n2 = normals
    ok = np.abs(_dot(n1, n2)) >= math.cos(math.radians(10))
    n2 = np.where((_dot(n2, p0) > 0)[:, None], -n2, n2)  # facing the camera
    out[idx[ok]] = n2[ok]
    return out
