"""What the cost work must not change: the optimised paths give the bytes (or the pixels) the
plain ones give (docs/performance.md). No timing is asserted here."""
from __future__ import annotations

import json
import random

import cv2
import numpy as np
import pytest

from synthcompose.io.files import dumps_json


def _reference_layout(obj, indent: str, out: list[str]) -> None:
    """dumps_json's layout checked element by element (what it did before its text check)."""
    enc = json.JSONEncoder(allow_nan=False, separators=(", ", ": "))
    flat = lambda v: all(isinstance(x, (int, float)) or (isinstance(x, list) and  # noqa: E731
                         all(isinstance(y, (int, float)) for y in x)) for x in v)
    if isinstance(obj, dict) and obj:
        out.append("{")
        for k, (key, value) in enumerate(obj.items()):
            name = key if isinstance(key, str) else enc.encode(key).strip('"')
            out.append(("," if k else "") + "\n" + indent + "  " + enc.encode(name) + ": ")
            _reference_layout(value, indent + "  ", out)
        out.append("\n" + indent + "}")
    elif isinstance(obj, (list, tuple)) and obj and not flat(obj):
        out.append("[")
        for k, value in enumerate(obj):
            out.append(("," if k else "") + "\n" + indent + "  ")
            _reference_layout(value, indent + "  ", out)
        out.append("\n" + indent + "]")
    else:
        out.append(enc.encode(obj))


def _random_document(rng: random.Random, depth: int = 0):
    leaves = [lambda: rng.randint(-5, 10 ** 6), lambda: rng.random() * 10 ** rng.randint(-8, 8), lambda: True,
              lambda: None, lambda: 'a "b"\n', lambda: 1e-7, lambda: -0.0, lambda: 12345678901234567890]
    r = rng.random()
    if depth > 3 or r < 0.35:
        return rng.choice(leaves)()
    if r < 0.55:
        return {(str(rng.randint(0, 9)) if rng.random() < 0.8 else rng.randint(0, 3)): _random_document(rng, depth + 1)
                for _ in range(rng.randint(0, 4))}
    if r < 0.65:
        return tuple(_random_document(rng, depth + 1) for _ in range(rng.randint(0, 4)))
    if r < 0.8:
        return [[rng.randint(0, 2000), rng.randint(0, 1000)] for _ in range(rng.randint(0, 5))]
    return [_random_document(rng, depth + 1) for _ in range(rng.randint(0, 5))]


def test_json_layout_is_the_element_by_element_one():
    rng = random.Random(7)
    docs = [_random_document(rng) for _ in range(3000)]
    docs += [[(1, 2), (3, 4)], [[1, [2]]], [[1, 2], [3, (4, 5)]], [1, None], [[True, False]], [[], [1]], ((1, 2),)]
    for doc in docs:
        out: list[str] = []
        _reference_layout(doc, "", out)
        assert dumps_json(doc) == ("".join(out) + "\n").encode("utf-8"), doc
    for bad in ([1.0, float("nan")], [[1, 2], {3}], {"x": [float("inf")]}):
        with pytest.raises((ValueError, TypeError)):
            dumps_json(bad)


# ------------------------------------------------------------------ the renderer's cheaper paths
def _board(name: str, quads) -> "Model":  # noqa: F821 (imported inside: GL-free collection)
    """A model of flat quads facing -x (the camera), each (corners, colour) a part of its own."""
    from synthcompose.models import MeshPart, Model

    parts = []
    for corners, colour in quads:
        n = len(corners)
        parts.append(MeshPart(
            positions=np.asarray(corners, np.float32), normals=np.tile([-1.0, 0.0, 0.0], (n, 1)).astype(np.float32),
            uvs=np.zeros((n, 2), np.float32), colors=np.tile([*colour, 1.0], (n, 1)).astype(np.float32),
            material=np.tile([0.0, 0.9], (n, 1)).astype(np.float32),
            indices=np.array([[0, 1, 2], [0, 2, 3]], np.uint32), texture=None))
    return Model(name, tuple(parts), (0.4, 2.0, 1.8))


def _render_passes(gl, model, names=("irpv", "ir", "alpha", "odepth", "plane", "objc", "id", "id_depth"), **kw):
    from synthcompose.render import Lighting, Renderer, RenderObject

    from ..helpers import make_camera

    renderer = Renderer(gl, shading="pixel")
    pose = np.eye(4)
    pose[:3, 3] = (9.0, 0.0, 0.0)
    light = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.5)
    passes = renderer.render(make_camera(), [RenderObject(model, pose, (0.2, 0.2, 0.2))], light, **kw)
    out = {name: passes.read(name).copy() for name in names}
    renderer.release(passes)
    return out


def test_depth_prepass_keeps_the_first_drawn_of_coplanar_parts(gl_clean):
    """Two parts in one plane, overlapping: the first in the file is seen, as with a single
    forward pass and a strict depth test (the pre-pass draws the lit pass in reverse with <=)."""
    quad = [[0, 1.0, 0.3], [0, -1.0, 0.3], [0, -1.0, 1.8], [0, 1.0, 1.8]]
    red, blue = (0.6, 0.05, 0.05), (0.05, 0.1, 0.6)
    for first, second in ((red, blue), (blue, red)):
        p = _render_passes(gl_clean, _board(f"coplanar-{first}", [(quad, first), (quad, second)]), names=("objc",))
        inside = p["objc"][..., 3] >= 0.999
        assert inside.sum() > 5000
        rgb = p["objc"][inside][:, :3]
        wanted = 0 if first == red else 2  # the first part's strongest channel
        assert (rgb.argmax(axis=1) == wanted).all()


def test_banded_render_keeps_coverage_and_ids_and_the_shading_to_rounding(gl_clean, monkeypatch):
    import synthcompose.render.renderer as renderer_module
    from synthcompose.render import bands

    board = _board("banded", [([[0, 1.0, 0.3], [0, -0.2, 0.3], [0, 0.35, 1.8], [0, 1.0, 1.8]], (0.6, 0.05, 0.05)),
                              ([[0, -0.2, 0.3], [0, -1.0, 0.3], [0, -1.0, 1.8], [0, 0.35, 1.8]], (0.05, 0.1, 0.6))])
    photo = np.random.default_rng(5).integers(0, 256, (320, 640, 3), np.uint8)
    whole = _render_passes(gl_clean, board, photo=photo)
    monkeypatch.setattr(renderer_module, "row_bands", lambda w, h: bands.row_bands(w, h, 3000))
    banded = _render_passes(gl_clean, board, photo=photo)
    assert len(bands.row_bands(whole["id"].shape[1], whole["id"].shape[0], 3000)) >= 5
    for name in ("alpha", "id", "id_depth"):
        assert np.array_equal(whole[name], banded[name]), name
    for name in ("irpv", "ir", "objc", "odepth", "plane"):
        diff = np.abs(whole[name] - banded[name])
        assert np.quantile(diff, 0.999) <= 1e-3 and diff.max() <= 0.5, (name, diff.max())


def _reference_occluder_fill(depth: np.ndarray, ground: np.ndarray | None):
    """occluder_fill as it was written over the whole frame (before it read the holes alone)."""
    from synthcompose.geometry.depth import nearest_in_row

    h, w = depth.shape
    valid = np.isfinite(depth)
    if valid.all():
        return depth, ground
    left, right = nearest_in_row(valid)
    rows = np.arange(h)[:, None]
    padded = np.concatenate([depth, np.full((h, 1), np.inf, depth.dtype)], axis=1)
    lcol = np.where(left < 0, w, left)
    from_left = padded[rows, lcol] >= padded[rows, right]
    farther = np.where(from_left, padded[rows, lcol], padded[rows, right])
    filled = np.where(valid, depth, farther).astype(np.float32)
    if ground is None:
        return filled, None
    gpad = np.concatenate([ground, np.zeros((h, 1), bool)], axis=1)
    source = np.where(from_left, gpad[rows, lcol], gpad[rows, right])
    return filled, ground | (~valid & np.isfinite(farther) & source)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_occluder_fill_of_the_holes_alone_gives_the_whole_frame_ones(dtype):
    from synthcompose.geometry.depth import occluder_fill

    rng = np.random.default_rng(3)
    for holes in (0.0, 0.1, 0.5, 0.97, 1.0):
        depth = rng.uniform(1, 80, (60, 90)).astype(dtype)
        depth[rng.random(depth.shape) < holes] = np.inf
        depth[7] = np.inf  # a row with nothing known
        depth[9, :40] = np.nan
        ground = rng.random(depth.shape) < 0.4
        for g in (None, ground):
            got, want = occluder_fill(depth, g), _reference_occluder_fill(depth, g)
            assert got[0].dtype == want[0].dtype and np.array_equal(got[0], want[0]), holes
            assert (got[1] is None) == (want[1] is None)
            if g is not None:
                assert np.array_equal(got[1], want[1]), holes


def _reference_across_gutter(lab, road, side, depth, fx):
    """road._across_gutter as it was written: each direction over the whole frame, the
    leftwards one on the flipped arrays."""
    from synthcompose.geometry.depth import nearest_in_row
    from synthcompose.placement.road import GUTTER

    def rightwards(lab, road, side, depth):
        H, W = lab.shape
        void = lab == 0
        _, first = nearest_in_row(~void)
        cols = np.minimum(np.arange(W) + 1, W - 1)
        beyond = np.minimum(first[:, cols], W - 1)
        with np.errstate(invalid="ignore"):
            narrow = (beyond - np.arange(W)) * depth / fx <= GUTTER
        return road & void[:, cols] & side[np.arange(H)[:, None], beyond] & narrow

    flip = [a[:, ::-1] for a in (lab, road, side, depth)]
    return rightwards(lab, road, side, depth) | rightwards(*flip)[:, ::-1]


def test_across_gutter_of_the_candidates_alone_gives_the_whole_frame_ones():
    from synthcompose.placement.road import _across_gutter

    rng = np.random.default_rng(8)
    for void_share in (0.05, 0.3, 0.7):
        lab = rng.choice(np.array([7, 8, 21], np.uint8), (40, 120))
        lab[rng.random(lab.shape) < void_share] = 0
        lab[5, 3:60] = 0  # long voids, one to the frame's edge
        lab[6, 70:] = 0
        lab[:, 0] = 7  # road at the edges
        lab[:, -1] = 7
        road, side = lab == 7, lab == 8
        depth = rng.uniform(2, 60, lab.shape).astype(np.float32)
        depth[rng.random(lab.shape) < 0.1] = np.inf
        for fx in (200.0, 1100.0):
            got = _across_gutter(lab, road, side, depth, fx)
            assert got.any() and np.array_equal(got, _reference_across_gutter(lab, road, side, depth, fx))


def test_linear_levels_of_the_rows_and_columns_sampled_give_the_whole_frames():
    from synthcompose.lighting.light import LEVEL_LUT
    from synthcompose.lighting.plan import linear_at

    rng = np.random.default_rng(4)
    rgb = rng.integers(0, 256, (120, 200, 3), np.uint8)
    whole = cv2.LUT(rgb, LEVEL_LUT)
    for lo, hi in (((10, 5), (60, 40)), ((-3, -2), (203, 122)), ((150, 90), (199, 119)), ((-30, -30), (-5, -5))):
        u = rng.uniform(lo[0], hi[0], (37, 23)).astype(np.float32)
        v = rng.uniform(lo[1], hi[1], (37, 23)).astype(np.float32)
        u[0, :5], v[0, :5] = [0, 199, 199.0, 0.5, 198.999], [0, 119, 0.25, 119, 118.999]
        u[1, :3] = -10.0
        u[2, :4] = np.round(u[2, :4]) + np.float32(1 / 64)  # near the fixed-point steps
        want = cv2.remap(whole, u, v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        assert np.array_equal(linear_at(rgb, u, v), want), (lo, hi)


def test_nearest_depth_of_some_rows_gives_the_whole_regions():
    """The render makes the planes' nearest scene depth for each band's rows (render.renderer
    nearest_depth with rows): the same values as over the whole region, at its edges too."""
    from synthcompose.render.renderer import NEAREST_PX, nearest_depth

    rng = np.random.default_rng(8)
    depth = rng.uniform(2.0, 40.0, (53, 71)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.3] = np.inf  # the matcher's holes
    depth[rng.random(depth.shape) < 0.05] = 0.0
    depth[20:20 + 2 * NEAREST_PX] = np.inf  # rows with nothing near: 0 there
    region = depth[3:50, 5:66]  # a view, as the renderer passes it
    whole = nearest_depth(region)
    assert (whole == 0).any() and (whole > 0).any()
    for rows in ((0, 1), (0, 9), (7, 8), (10, 31), (40, region.shape[0]), (0, region.shape[0])):
        assert np.array_equal(nearest_depth(region, rows), whole[rows[0]:rows[1]]), rows


def test_byte_counts_are_bincounts():
    """labels.byte_counts (OpenCV's histogram) gives np.bincount's counts of uint8 arrays."""
    from synthcompose.labels import byte_counts

    rng = np.random.default_rng(4)
    for img in (rng.integers(0, 256, (1024, 2048), np.uint8), rng.integers(0, 3, (37, 53), np.uint8),
                rng.integers(0, 256, (60, 80), np.uint8)[::3, 1::2], np.full((5, 7), 255, np.uint8),
                np.zeros((0, 4), np.uint8), rng.integers(0, 256, (3, 4, 5), np.uint8)):
        assert np.array_equal(byte_counts(img), np.bincount(img.ravel(), minlength=256))
    with pytest.raises(TypeError):
        byte_counts(np.zeros(4, np.uint16))


def test_labels_in_is_the_tables_lookup():
    from synthcompose.labels import labels_in

    rng = np.random.default_rng(6)
    frame = rng.integers(0, 34, (64, 96), np.uint8)
    for labels in (frame, frame[::2, 1::3], frame[5:9], np.zeros((0, 3), np.uint8)):
        for ids in ([7], [6, 7, 8, 9, 10], [], [0, 255]):
            want = np.isin(labels, ids)
            got = labels_in(labels, ids)
            assert got.dtype == bool and got.shape == labels.shape and np.array_equal(got, want)


def test_rle_is_pycocotools_of_the_fortran_mask():
    """io.files.encode_rle (OpenCV's transpose) gives what pycocotools gives the mask cast to
    uint8 in Fortran order, and decode_rle reads it back."""
    from pycocotools import mask as coco_mask

    from synthcompose.io.files import decode_rle, encode_rle

    rng = np.random.default_rng(8)
    big = rng.random((90, 130)) < 0.3
    for mask in (big, big[::2, 3:], big.astype(np.uint8), np.zeros((1, 1), bool), np.ones((4, 1), bool),
                 np.zeros((0, 5), bool), (rng.integers(0, 3, (20, 30))).astype(np.int32)):
        rle = coco_mask.encode(np.asfortranarray(mask.astype(np.uint8)))
        want = {"size": [int(v) for v in rle["size"]], "counts": rle["counts"].decode("ascii")}
        assert encode_rle(mask) == want
        if mask.max(initial=0) <= 1:  # (RLE holds binary masks)
            assert np.array_equal(decode_rle(encode_rle(mask)), mask.astype(bool))


def test_sums_over_three_channels_column_by_column_are_numpys():
    """grid._norm, road_coloured's and camera_match._hsv_vs's column-by-column sums, maxima and
    minima give NumPy's reductions over the last axis bit for bit."""
    from synthcompose.lighting.camera_match import _hsv_vs
    from synthcompose.lighting.grid import _norm
    from synthcompose.placement.road_colour import road_coloured

    rng = np.random.default_rng(10)
    for dtype in (np.float32, np.float64):
        v = rng.normal(size=(5000, 3)).astype(dtype)
        assert np.array_equal(_norm(v), np.linalg.norm(v, axis=-1))
    lab = rng.normal(128, 20, (64, 96, 3)).astype(np.float32)
    models = [(np.array([120.0, 128.0, 131.0]), np.array([6.0, 2.0, 3.0])),
              (np.array([100.5, 127.0, 129.0], np.float32), np.array([9.0, 1.5, 2.5], np.float32))]
    want = np.zeros(lab.shape[:2], bool)
    for med, spread in models:
        want |= np.sqrt((((lab - med) / spread) ** 2).sum(axis=-1) / 3.0) < 3.0
    assert np.array_equal(road_coloured(lab, models), want)
    srgb = np.clip(rng.normal(0.5, 0.4, (4000, 3)), 0, 1)
    mx, mn = srgb.max(axis=1), srgb.min(axis=1)
    v, s = _hsv_vs(srgb)
    assert np.array_equal(v, 255.0 * mx) and np.array_equal(s, 255.0 * np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-9), 0.0))


def test_the_polygons_segment_values_are_bincounts():
    from synthcompose.write.polygons import _present

    rng = np.random.default_rng(12)
    seg = rng.integers(0, 34, (200, 300)).astype(np.uint16)
    seg[20:40, 30:90] = 26001
    seg[0, 0] = 65535
    for s in (seg, seg.astype(np.int32), seg[::3, 1::2], np.full((4, 4), 7, np.uint16)):
        assert np.array_equal(_present(s), np.flatnonzero(np.bincount(s.ravel())))


def test_nearest_in_row_is_the_where_and_accumulate():
    from synthcompose.geometry.depth import nearest_in_row

    rng = np.random.default_rng(13)
    for shape, p in [((64, 200), 0.5), ((37, 53), 0.05), ((5, 1), 0.5), ((3, 0), 0.5), ((1, 7), 0.0), ((2, 9), 1.0)]:
        mask = rng.random(shape) < p
        for m in (mask, mask[:, 1:] if shape[1] > 1 else mask):
            h, w = m.shape
            cols = np.broadcast_to(np.arange(w, dtype=np.int32), (h, w))
            left = np.maximum.accumulate(np.where(m, cols, np.int32(-1)), axis=1)
            right = np.minimum.accumulate(np.where(m, cols, np.int32(w))[:, ::-1], axis=1)[:, ::-1]
            got = nearest_in_row(m)
            assert got[0].dtype == left.dtype and np.array_equal(got[0], left) and np.array_equal(got[1], right)


def _fit_road_plane_whole_grid(points, labels, camera):
    from synthcompose.lighting.plan import GROUND_IDS

    rel = points[..., :2] - np.array([camera.x, camera.y], np.float32)
    dist = np.hypot(rel[..., 0], rel[..., 1])
    sel = np.isin(labels, GROUND_IDS) & (dist > 4.0) & (dist < 25.0) & np.isfinite(dist)
    road = sel & (labels == GROUND_IDS[1])
    if road.sum() > 2000:
        sel = road
    p, r = points[sel][::5].astype(np.float64), rel[sel][::5].astype(np.float64)
    if len(p) < 200:
        return 0.0, 0.0, 0.0
    A = np.column_stack([np.ones(len(p)), r[:, 0], r[:, 1]])
    keep = np.abs(p[:, 2]) < 0.5
    coef = np.zeros(3)
    for _ in range(4):
        if keep.sum() < 50:
            break
        coef, *_ = np.linalg.lstsq(A[keep], p[keep, 2], rcond=None)
        res = p[:, 2] - A @ coef
        keep = np.abs(res) < max(3 * 1.4826 * float(np.median(np.abs(res[keep]))), 0.03)
    return float(coef[0]), float(coef[1]), float(coef[2])


def test_road_plane_fit_over_the_ground_alone_is_the_whole_grids():
    from synthcompose.camera import Camera
    from synthcompose.lighting.plan import _points, fit_road_plane

    cam = Camera(2262.5, 2265.3, 1096.9, 513.1, 0.209, 1.7, 0.1, 1.22, 0.0, 0.05, 0.0, 2048, 1024)
    rng = np.random.default_rng(14)
    for road_share in (0.6, 0.01):
        depth = rng.uniform(2, 60, (1024, 2048)).astype(np.float32)
        depth[rng.random(depth.shape) < 0.1] = np.inf
        pts = _points(depth, cam)
        labels = rng.choice([7, 8, 6, 11, 21, 26], p=[road_share, 0.1, 0.05, 0.1, 0.05, 0.7 - road_share],
                            size=(1024, 2048)).astype(np.uint8)[::2, ::2][: pts.shape[0], : pts.shape[1]]
        pts[..., 2] = np.where(np.isin(labels, [6, 7, 8]), 0.02 * pts[..., 0] + rng.normal(0, 0.03, pts.shape[:2]),
                               pts[..., 2]).astype(np.float32)
        fit = fit_road_plane(pts, labels, cam)
        assert fit == _fit_road_plane_whole_grid(pts, labels, cam) and fit != (0.0, 0.0, 0.0)


def _fine_normals_2d(r, c, label_ids, depth, camera):
    """grid._fine_normals as it was, by 2-D gathers and NumPy's sums over the last axis."""
    import math

    H, W = label_ids.shape
    out = np.full((len(r), 3), np.nan, np.float32)
    idx = np.nonzero((r >= 2) & (r < H - 2) & (c >= 2) & (c < W - 2))[0]
    r, c = r[idx], c[idx]
    m = camera.vehicle_from_optical
    col_ray = (((np.arange(W) - camera.u0) / camera.fx)[:, None] * m[:3, 0]).astype(np.float32)
    row_ray = (((np.arange(H) - camera.v0) / camera.fy)[:, None] * m[:3, 1] + m[:3, 2]).astype(np.float32)
    lab0 = label_ids[r, c]
    ok = np.ones(len(r), bool)
    for dr, dc in ((0, 0), (0, 1), (0, -1), (1, 0), (-1, 0), (0, 2), (0, -2), (2, 0), (-2, 0)):
        ok &= np.isfinite(depth[r + dr, c + dc]) & (label_ids[r + dr, c + dc] == lab0)
    idx, r, c = idx[ok], r[ok], c[ok]

    def point(dr, dc):
        return depth[r + dr, c + dc][:, None] * (col_ray[c + dc] + row_ray[r + dr])

    normals = []
    for k in (1, 2):
        p0 = point(0, 0)
        a_u, b_u, a_v, b_v = point(0, k), point(0, -k), point(k, 0), point(-k, 0)
        du, dv = a_u - b_u, a_v - b_v
        ok = np.ones(len(r), bool)
        for a, b, span in ((a_u, b_u, du), (a_v, b_v, dv)):
            ok &= np.linalg.norm(a + b - 2 * p0, axis=-1) <= 0.08 * np.linalg.norm(span, axis=-1) + 1e-3
        idx, r, c, p0 = idx[ok], r[ok], c[ok], p0[ok]
        normals = [n[ok] for n in normals]
        n = np.cross(du[ok], dv[ok])
        normals.append(n / np.maximum(np.linalg.norm(n, axis=-1), 1e-12)[:, None])
    n1, n2 = normals
    ok = np.abs(np.sum(n1 * n2, axis=-1)) >= math.cos(math.radians(10))
    n2 = np.where((np.sum(n2 * p0, axis=-1) > 0)[:, None], -n2, n2)
    out[idx[ok]] = n2[ok]
    return out


def test_fine_normals_by_flat_gathers_are_the_2d_ones():
    from synthcompose.camera import Camera
    from synthcompose.lighting.grid import _fine_normals

    cam = Camera(1131.0, 1132.0, 548.0, 256.0, 0.209, 1.7, 0.1, 1.22, 0.0, 0.05, 0.0, 1024, 512)
    rng = np.random.default_rng(15)
    v, u = np.mgrid[0:512, 0:1024].astype(np.float64)
    # two planes (a plane's inverse depth is affine in the pixel), a crease between them, holes
    labels = np.where(u < 600, 7, 11).astype(np.uint8)
    depth = np.where(labels == 7, 1.0 / (0.02 + 3e-5 * u + 6e-5 * v), 1.0 / (0.12 - 1e-4 * u + 0 * v)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.02] = np.inf
    r, c = rng.integers(0, 512, 30000), rng.integers(0, 1024, 30000)
    got, want = _fine_normals(r, c, labels, depth, cam), _fine_normals_2d(r, c, labels, depth, cam)
    assert np.isfinite(want[:, 0]).sum() > 1000
    assert np.array_equal(got, want, equal_nan=True)


def test_rect_points_read_by_mask_are_the_gathered_ones():
    from synthcompose.camera import Camera
    from synthcompose.geometry.depth import make_frame

    cam = Camera(1131.0, 1132.0, 548.0, 256.0, 0.209, 1.7, 0.1, 1.22, 0.0, 0.05, 0.0, 300, 200)
    rng = np.random.default_rng(16)
    depth = rng.uniform(3, 40, (200, 300)).astype(np.float32)
    depth[rng.random(depth.shape) < 0.2] = np.inf
    labels = rng.integers(0, 34, (200, 300)).astype(np.uint8)
    frame = make_frame(depth, labels, cam)
    only = np.zeros(256, bool)
    only[[7, 8]] = True
    for args in [dict(), dict(only=only), dict(stride=3), dict(only=only, stride=2)]:
        pts, lab, v, u = frame.rect_points(20, 150, 35, 260, with_pixels=True, **args)
        z = depth[v, u].astype(np.float64)
        optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
        m = cam.vehicle_from_optical
        assert np.array_equal(pts, optical @ m[:3, :3].T + m[:3, 3]) and np.array_equal(lab, labels[v, u])
        assert len(v) and np.isfinite(depth[v, u]).all() and (only[lab].all() if "only" in args else True)


def test_cell_minima_and_maxima_are_the_morphologys():
    import cv2

    from synthcompose.lighting.grid import _cell_reduce

    rng = np.random.default_rng(17)
    for a in (rng.integers(0, 34, (100, 211)).astype(np.uint8), rng.uniform(2, 50, (100, 211)).astype(np.float32),
              np.where(rng.random((100, 211)) < 0.3, np.float32(np.inf), rng.uniform(2, 50, (100, 211)).astype(np.float32))):
        for f in (1, 2, 3, 4):
            h, w = a.shape[0] // f, a.shape[1] // f
            for op in (cv2.erode, cv2.dilate):
                if f == 1:
                    want = a[:h, :w]
                else:
                    want = op(np.ascontiguousarray(a[: h * f, : w * f]), np.ones((f, f), np.uint8),
                              borderType=cv2.BORDER_REPLICATE)[f // 2:: f, f // 2:: f][:h, :w]
                got = _cell_reduce(a, f, op)
                assert got.shape == (h, w) and got.flags.c_contiguous and np.array_equal(got, want), (a.dtype, f, op)
