"""Tests of the synthetic street generator (synthcompose.sample): files, geometry, labels."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.dataset import ImageSetId, find_image_sets, read_image_set
from synthcompose.geometry import disparity_to_depth, point_cloud
from synthcompose.labels import KNOWN_IDS, label_id
from synthcompose.sample import StreetScene, make_sample, random_scene, render_scene

W, H, SEED, COUNT = 512, 256, 7, 2
KINDS = ("rgb", "labelIds", "instanceIds", "color", "disparity", "camera")
ROAD, SIDEWALK, POLE, CAR, SKY, EGO = (label_id(n) for n in ("road", "sidewalk", "pole", "car", "sky", "ego vehicle"))


def scene_of(frame: int, seed: int = SEED, **kw) -> StreetScene:
    """The scene make_sample draws for one frame."""
    return random_scene(np.random.default_rng([seed, frame]), W, H, **kw)


@pytest.fixture(scope="module")
def sample_root(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[ImageSetId]]:
    root = tmp_path_factory.mktemp("sample")
    return root, make_sample(root, count=COUNT, width=W, height=H, seed=SEED)


@pytest.fixture(scope="module")
def rendered() -> list[tuple[StreetScene, dict[str, np.ndarray]]]:
    return [(s, render_scene(s)) for s in (scene_of(i) for i in range(4))]


def test_files_at_cityscapes_paths_and_readable(sample_root):
    root, idents = sample_root
    assert [i.name for i in idents] == ["synthtown_000000_000000", "synthtown_000000_000001"]
    assert find_image_sets(root, ["train"]) == idents
    for ident in idents:
        for kind in KINDS:
            assert ident.path(root, kind).is_file(), kind
        ims = read_image_set(root, ident)
        assert ims.size == (W, H)
        assert ims.rgb.dtype == np.uint8 and ims.rgb.shape == (H, W, 3)
        assert ims.label_ids.dtype == np.uint8 and ims.disparity.dtype == np.uint16
        raw = {k: cv2.imread(str(ident.path(root, k)), cv2.IMREAD_UNCHANGED) for k in ("instanceIds", "color")}
        assert raw["instanceIds"].dtype == np.uint16 and raw["instanceIds"].ndim == 2
        assert raw["color"].dtype == np.uint8 and raw["color"].shape == (H, W, 4)
        assert ims.camera == scene_of(int(ident.frame)).camera


def test_back_projected_road_and_sidewalk_heights(sample_root):
    root, idents = sample_root
    checked_sidewalk = 0
    for ident in idents:
        ims = read_image_set(root, ident)
        scene = scene_of(int(ident.frame))
        cam = ims.camera
        cloud = point_cloud(disparity_to_depth(ims.disparity, cam), ims.label_ids, cam)
        near = cloud.optical[:, 2] < 30
        x, y, z = cloud.vehicle.T
        road = near & (cloud.labels == ROAD)
        assert road.sum() > 1000
        assert np.abs(z[road]).max() < 0.02
        # sidewalk tops: away from the vertical kerb faces (along the road and the cross street)
        kerb_x = scene.crossing[1]
        top = near & (cloud.labels == SIDEWALK) & (np.abs(y) > scene.road_half_width + 0.05) \
            & (np.abs(x - kerb_x) > 0.1)
        assert np.abs(z[top] - scene.kerb_height).max() < 0.02
        checked_sidewalk += top.sum()
    assert checked_sidewalk > 1000


def test_exact_depth_matches_surfaces(rendered):
    for scene, arr in rendered:
        cam = scene.camera
        cloud = point_cloud(arr["depth"], arr["label_ids"], cam)
        x, y, z = cloud.vehicle.T
        road = cloud.labels == ROAD
        close = road & (cloud.optical[:, 2] < 60)
        assert np.abs(z[close]).max() < 2e-3
        assert (scene.surface_label(x[road], y[road]) == "road").all()
        # everything except sky and ego vehicle has a finite depth
        finite = np.isfinite(arr["depth"])
        assert (finite == ~np.isin(arr["label_ids"], [SKY, EGO])).all()


def test_disparity_encoding_and_holes(rendered):
    for scene, arr in rendered:
        cam, disp, depth = scene.camera, arr["disparity"], arr["depth"]
        assert disp.dtype == np.uint16
        assert (disp[np.isin(arr["label_ids"], [SKY, EGO])] == 0).all()
        valid = disp > 0
        expected = np.rint(cam.baseline * cam.fx / depth[valid].astype(np.float64) * 256) + 1
        assert np.array_equal(disp[valid], np.clip(expected, 1, 65535).astype(np.uint16))
        holes = (disp == 0) & np.isfinite(depth)
        assert 0.01 < holes.sum() / np.isfinite(depth).sum() < 0.03


def test_labels_and_instance_ids(rendered):
    for scene, arr in rendered:
        labels, inst = arr["label_ids"], arr["instance_ids"].astype(np.int64)
        assert labels.dtype == np.uint8 and arr["instance_ids"].dtype == np.uint16
        assert KNOWN_IDS[labels].all()
        assert set(np.unique(labels)) <= {EGO, ROAD, SIDEWALK, label_id("building"), POLE, SKY,
                                          label_id("person"), CAR}
        for lid in (ROAD, SIDEWALK, POLE, SKY, EGO):
            assert (inst[labels == lid] == lid).all()
        car_ids = set(np.unique(inst[labels == CAR]))
        n_cars = len({b.instance_id for b in scene.boxes if b.label == "car"})
        assert 2 <= n_cars <= 5
        assert car_ids <= {26000 + k for k in range(n_cars)} and len(car_ids) >= 1
        assert all(i // 1000 == label_id("person") for i in np.unique(inst[labels == label_id("person")]))
        assert 2 <= len(scene.poles) <= 4 and (labels == POLE).any()
        # the bottom row is the ego vehicle's bonnet
        assert (labels[-1] == EGO).all() and (labels[-scene.ego_rows - 1] != EGO).any()


def test_a_pole_hides_road(rendered):
    for scene, arr in rendered:
        without = render_scene(dataclasses.replace(scene, poles=()))
        hidden = (arr["label_ids"] == POLE) & (without["label_ids"] == ROAD)
        assert hidden.sum() >= 3


def test_ground_plan(rendered):
    scene = rendered[0][0]
    w, s, k = scene.road_half_width, scene.sidewalk_width, scene.kerb_height
    x = np.array([10.0, 10.0, 10.0, -3.0])
    y = np.array([0.0, w + 0.5, -(w + s + 1), -(w - 0.1)])
    assert list(scene.surface_label(x, y)) == ["road", "sidewalk", "building", "road"]
    assert np.allclose(scene.ground_height(x, y), [0, k, k, 0])
    assert 0.12 <= k <= 0.15 and 4 <= w <= 6 and 3 <= s <= 4
    assert str(scene.surface_label(sum(scene.crossing) / 2, w + s + 5)) == "road"


def test_same_seed_gives_identical_files(tmp_path):
    a = make_sample(tmp_path / "a", count=1, width=256, height=128, seed=11)
    b = make_sample(tmp_path / "b", count=1, width=256, height=128, seed=11)
    c = make_sample(tmp_path / "c", count=1, width=256, height=128, seed=12)
    for kind in KINDS:
        assert a[0].path(tmp_path / "a", kind).read_bytes() == b[0].path(tmp_path / "b", kind).read_bytes()
    assert a[0].path(tmp_path / "a", "rgb").read_bytes() != c[0].path(tmp_path / "c", "rgb").read_bytes()


def test_scene_without_road():
    for frame in range(3):
        scene = scene_of(frame, road=False)
        arr = render_scene(scene)
        assert not scene.has_road and scene.kerb_height == 0
        assert not (arr["label_ids"] == ROAD).any()
        assert (arr["label_ids"] == SIDEWALK).any()
        xs, ys = np.meshgrid(np.linspace(-20, 200, 50), np.linspace(-30, 30, 50))
        assert not (scene.surface_label(xs, ys) == "road").any()
        assert (scene.ground_height(xs, ys) == 0).all()
