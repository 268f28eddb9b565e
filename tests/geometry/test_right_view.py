"""The right view of the stereo pair: the right camera, the generator's right photo, the left
frame carried to the right view, and a batch that augments both photos (or, switched off, the
left one alone) so that a stereo matcher still finds the written disparity."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from evaluation.stereo_check import BLOCK, check_pair, one_depth, seen_by_both
from synthcompose.camera import Camera
from synthcompose.cli import main
from synthcompose.geometry.right_view import carry_to_right
from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.io.files import decode_disparity, read_png
from synthcompose.synthetic import make_sample, random_scene, render_scene

from ..helpers import write_manifest
from ..tolerances import (
    PAIR_ELSEWHERE_SAME_MIN,
    PAIR_WITHIN_1PX_MEASURABLE_MIN,
    PAIR_WITHIN_1PX_MIN,
    RIGHT_CHANGE_MARGIN_PX,
    RIGHT_CHANGE_OUTSIDE_MAX,
    RIGHT_PHOTO_MATCH_MARGIN,
)

W, H = 1024, 512


def _camera(width: int = 64, height: int = 32) -> Camera:
    return Camera(fx=50.0, fy=50.0, u0=width / 2, v0=height / 2, baseline=0.2, x=1.7, y=0.1, z=1.2,
                  yaw=0.02, pitch=0.03, roll=0.0, width=width, height=height)


def test_right_camera_sees_a_point_disparity_pixels_to_the_left():
    cam = _camera()
    right = cam.right_camera()
    p_v = np.array([[12.0, 0.5, 1.0]])  # a point 12 m ahead, vehicle frame
    seen = []
    for c in (cam, right):
        m = c.optical_from_vehicle
        p = p_v @ m[:3, :3].T + m[:3, 3]
        seen.append((c.project(p)[0], p[0, 2]))
    (ul, z), (ur, zr) = seen
    assert z == pytest.approx(zr)
    assert ul[1] == pytest.approx(ur[1])
    assert ul[0] - ur[0] == pytest.approx(cam.fx * cam.baseline / z)


def test_carried_depth_moves_near_surfaces_and_fills_what_the_left_camera_does_not_see():
    cam = _camera()
    depth = np.full((cam.height, cam.width), 20.0, np.float32)  # a wall: disparity 0.5 px
    depth[:, 30:40] = 2.0  # a pole in front of it: disparity 5 px
    labels = np.full(depth.shape, 11, np.uint8)  # building
    labels[:, 30:40] = 17  # pole
    labels[-2:, :] = 1  # ego vehicle: stays where it is
    out = carry_to_right(depth, cam, slice(0, cam.height), slice(0, cam.width), {"labels": labels},
                         keep=labels == 1)
    row = out["depth"][5]
    assert (row[25:35] == 2.0).all()  # the pole, 5 px to the left
    assert row[24] == 20.0 and row[36] == 20.0
    assert (out["labels"][5, 25:35] == 17).all()
    # right of the pole: the wall the left camera did not see there, never the pole
    assert (out["labels"][5, 35:40] == 11).all() and (row[35:40] == 20.0).all()
    assert (out["labels"][-2:] == 1).all()
    # outside the block asked for: nothing
    part = carry_to_right(depth, cam, slice(2, 6), slice(10, 20), {"labels": labels})
    assert np.isinf(part["depth"][0]).all() and (part["labels"][0] == 0).all()
    assert (part["depth"][2:6, 10:20] == 20.0).all()


def _carried_pixel_by_pixel(depth, cam, r0, r1, c0, c1, layer, keep):
    """carry_to_right's rules read one right pixel at a time (the test's reference)."""
    fb = cam.fx * cam.baseline
    H, W = depth.shape
    z_out = np.full((H, W), np.inf, np.float32)
    l_out = np.zeros((H, W), layer.dtype)
    for r in range(r0, r1):
        landed = {}  # right column -> (disparity step, source column) of the nearest surface
        for c in range(c0, W):
            z = depth[r, c]
            d = fb / max(float(z), 1e-6) if np.isfinite(z) and z > 0 else 0.0
            t = c0 + int(np.rint((c - c0) - d))  # rounded in the block's columns (half to even)
            if c0 <= t < c1:
                landed[t] = max(landed.get(t, (-1, -1)), (int(np.rint(d * 256)), c))
        for t in range(c0, c1):
            if t in landed:
                src = landed[t][1]
            else:  # the farther of the nearest landed ones along the row
                lefts = [k for k in landed if k < t]
                rights = [k for k in landed if k > t]
                if not lefts and not rights:
                    continue
                zl = depth[r, landed[max(lefts)][1]] if lefts else -np.inf
                zr = depth[r, landed[min(rights)][1]] if rights else -np.inf
                src = landed[max(lefts)][1] if zl >= zr else landed[min(rights)][1]
            z_out[r, t] = depth[r, src]
            l_out[r, t] = layer[r, t] if keep[r, t] else layer[r, src]
    return z_out, l_out


@pytest.mark.parametrize("rows_at_once", [64, 5, 1])
def test_carried_layers_follow_the_rules_pixel_by_pixel(monkeypatch, rows_at_once):
    """Random depths with holes and near surfaces: the carried depth and labels are those of the
    rules read one pixel at a time (the nearest surface landing on a pixel, the farther of the
    nearest landed ones where none does, labels of the image kept in place), whatever number of
    rows is carried at once."""
    from synthcompose.geometry import right_view

    monkeypatch.setattr(right_view, "ROWS_AT_ONCE", rows_at_once)
    cam = _camera(48, 12)
    rng = np.random.default_rng(11)
    depth = rng.choice(np.array([0.6, 1.5, 4.0, 30.0, np.inf], np.float32), (12, 48), p=[0.1, 0.2, 0.2, 0.4, 0.1])
    labels = rng.integers(1, 30, depth.shape).astype(np.uint8)
    keep = rng.random(depth.shape) < 0.1
    for r0, r1, c0, c1 in ((0, 12, 0, 48), (2, 9, 7, 30), (5, 6, 40, 48)):
        out = carry_to_right(depth, cam, slice(r0, r1), slice(c0, c1), {"labels": labels}, keep=keep)
        z, lab = _carried_pixel_by_pixel(depth, cam, r0, r1, c0, c1, labels, keep)
        assert np.array_equal(out["depth"], z) and np.array_equal(out["labels"], lab), (r0, r1, c0, c1)


def test_generated_right_photo_is_the_scene_from_the_right_camera():
    scene = random_scene(np.random.default_rng([4, 0]), 512, 256)
    both = render_scene(scene, stereo="exact", right=True)
    left = render_scene(scene, stereo="exact")
    for key in left:  # the left view does not depend on the right one
        assert np.array_equal(both[key], left[key]), key
    cam = scene.camera
    d = np.where(np.isfinite(both["depth"]), cam.fx * cam.baseline / both["depth"], 0.0).astype(np.float32)
    xs, ys = np.meshgrid(np.arange(cam.width, dtype=np.float32), np.arange(cam.height, dtype=np.float32))
    lft = both["rgb"].astype(np.float32)
    seen = (xs - d >= 0) & (both["label_ids"] != 1)  # in the right image, not the bonnet

    def residual(shift: float) -> float:
        warped = cv2.remap(both["right_rgb"].astype(np.float32), xs - d + np.float32(shift), ys, cv2.INTER_LINEAR)
        return float(np.abs(warped - lft)[seen].mean())

    at = residual(0.0)
    assert at * RIGHT_PHOTO_MATCH_MARGIN < min(residual(-2.0), residual(2.0))


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Generated image sets with right photos (exact disparity: its 2 % holes only), augmented
    with the right view on and off."""
    root = tmp_path_factory.mktemp("stereo")
    data = root / "in"
    make_sample(data, count=2, width=W, height=H, seed=7, stereo="exact", right=True)
    runs = {}
    for name, extra in (("on", {}), ("off", {"render": {"right_view": False}})):
        manifest = write_manifest(root / f"{name}.json", data, root / name, seed=3, **extra)
        assert main(["batch", str(manifest), "--workers", "1"]) == 0
        runs[name] = root / name
    return data, runs


def _records(out: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((out / "synthcompose").rglob("*_synthcompose.json"))]


def test_both_views_written_and_recorded(pair):
    data, runs = pair
    idents = find_image_sets(data)
    for ident in idents:
        assert ident.path(runs["on"], "right").is_file()
        assert not ident.path(runs["off"], "right").exists()
        assert read_png(ident.path(runs["on"], "right"), "rgb8").shape == (H, W, 3)
    for rec in _records(runs["on"]):
        assert rec["status"] == "done" and rec["views"] == ["left", "right"]
        assert "right" in rec["source"] and rec["source_fingerprint"]["right"] is not None
    for rec in _records(runs["off"]):
        assert rec["views"] == ["left"] and "right" not in rec["source"]


def test_switched_off_the_left_outputs_are_the_same_bytes(pair):
    data, runs = pair
    for ident in find_image_sets(data):
        for kind in ("rgb", "labelIds", "instanceIds", "disparity", "polygons"):
            a, b = ident.path(runs["on"], kind), ident.path(runs["off"], kind)
            assert a.read_bytes() == b.read_bytes(), (ident.key, kind)


def test_right_photo_changes_only_where_the_left_changes_land_in_the_right_view(pair):
    """Each changed left pixel (object or shadow) carried to the right view by the written
    disparity: the right photo changes there and nowhere else (a margin for the blur and the
    disparity's holes)."""
    data, runs = pair
    for ident in find_image_sets(data):
        src = read_image_set(data, ident, right=True)
        left_out = read_png(ident.path(runs["on"], "rgb"), "rgb8")
        right_out = read_png(ident.path(runs["on"], "right"), "rgb8")
        disp = read_png(ident.path(runs["on"], "disparity"), "gray16")
        changed_left = (left_out != src.rgb).any(axis=2) & (disp > 0)
        v, u = np.nonzero(changed_left)
        ur = np.rint(u - decode_disparity(disp[v, u])).astype(int)
        ok = ur >= 0
        expected = np.zeros(changed_left.shape, np.uint8)
        expected[v[ok], ur[ok]] = 1
        k = 2 * RIGHT_CHANGE_MARGIN_PX + 1
        expected = cv2.dilate(expected, np.ones((k, k), np.uint8)) > 0
        changed_right = (right_out != src.right_rgb).any(axis=2)
        assert changed_right.sum() > 0.5 * changed_left.sum(), ident.key
        outside = changed_right & ~expected
        assert outside.sum() <= RIGHT_CHANGE_OUTSIDE_MAX * changed_right.sum(), (ident.key, int(outside.sum()))


def test_a_stereo_matcher_finds_the_written_disparity_on_the_augmented_pair(pair):
    data, runs = pair
    checks = [check_pair(data, runs["on"], ident) for ident in find_image_sets(data)]
    measured = sum(c.matched_measurable for c in checks)
    within = sum(c.matched_measurable * c.within_1px_measurable for c in checks if c.matched_measurable)
    assert measured > 1000, checks
    assert within / measured >= PAIR_WITHIN_1PX_MEASURABLE_MIN, checks
    # over all the pixels it matched (the issue's figure), pooled over the sets
    matched = sum(c.matched for c in checks)
    assert sum(c.matched * c.within_1px for c in checks if c.matched) >= PAIR_WITHIN_1PX_MIN * matched, checks
    for c in checks:
        assert c.elsewhere_same >= PAIR_ELSEWHERE_SAME_MIN, c
        assert c.residual_at_written < c.residual_off_half_px, c  # the written disparity is the pair's


def test_an_input_without_a_right_photo_gives_the_left_view_alone(tmp_path):
    data = tmp_path / "in"
    make_sample(data, count=1, width=512, height=256, seed=2)
    manifest = write_manifest(tmp_path / "m.json", data, tmp_path / "out", seed=1)
    assert main(["batch", str(manifest), "--workers", "1"]) == 0
    assert not (tmp_path / "out" / "rightImg8bit").exists()
    assert all(r["views"] == ["left"] for r in _records(tmp_path / "out") if r["status"] == "done")


def test_right_view_switch_must_be_a_boolean(tmp_path, capsys):
    manifest = write_manifest(tmp_path / "m.json", tmp_path, tmp_path / "out", render={"right_view": "yes"})
    assert main(["batch", str(manifest)]) != 0
    assert "render/right_view" in capsys.readouterr().err


def test_the_right_render_reuses_the_left_shadow_maps_with_the_same_pixels(gl_clean):
    """The shadow maps depend on the objects and the light, not on the camera: the right view
    draws them once with the left view and gets what a fresh renderer draws."""
    from synthcompose.models import load_model
    from synthcompose.placement import pose_matrix
    from synthcompose.render import Lighting, Renderer, RenderObject

    from ..helpers import make_camera

    cam = make_camera()
    obj = RenderObject(load_model("builtin:box", (("length", 2.0),)),
                       pose_matrix(np.array([12.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]), 0.3), (0.2, 0.2, 0.2))
    light = Lighting.daylight(40.0, 120.0, 0.6)
    both = Renderer(gl_clean)
    both.release(both.render(cam, [obj], light))
    drawn = both.shadows._drawn
    right = both.render(cam.right_camera(), [obj], light)
    assert both.shadows._drawn is drawn  # not drawn again
    fresh = Renderer(gl_clean)
    alone = fresh.render(cam.right_camera(), [obj], light)
    for name in ("irpv", "ir", "alpha", "plane"):
        assert np.array_equal(right.read(name), alone.read(name)), name
    both.release(right)
    fresh.release(alone)


def test_pixels_hidden_from_the_right_camera_are_found_from_the_disparity():
    # a near block (disparity 10) in front of a far wall (2): the 7 wall pixels left of the block
    # land (u - 2) behind the block's landing points (40 .. 50) in the right view
    d = np.full((3, 100), 2.0, np.float32)
    d[:, 50:61] = 10.0
    d[2, 90] = np.nan  # no disparity: not seen
    seen = seen_by_both(d)
    hidden = np.nonzero(~seen[0])[0]
    assert hidden.tolist() == list(range(43, 50))
    assert seen[:, 50:61].all()  # the near block is seen by both
    assert not seen[2, 90] and seen[2, 91]


def test_a_window_straddling_a_depth_edge_holds_two_depths():
    # a near block (disparity 10) in front of a far wall (2), a slanted floor (0.2 px a column)
    d = np.full((20, 100), 2.0, np.float32)
    d[:, 50:61] = 10.0
    d[15:, :] = 5.0 + 0.2 * np.arange(100, dtype=np.float32)[None, :]
    d[5, 20] = np.nan
    one = one_depth(d)
    half = BLOCK // 2
    row = one[10]
    assert not row[50 - half:50 + half].any() and not row[61 - half:61 + half].any()  # the block's sides
    assert row[50 + half:61 - half].all() and row[10:50 - half].all()
    assert not one[5 - half:5 + half + 1, 20 - half:20 + half + 1].any()  # a window with an unknown pixel
    assert one[15 + half:20 - half, 10:90].all()  # a slope of 0.8 px over the window is one surface
