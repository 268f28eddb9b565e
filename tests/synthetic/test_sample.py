"""Tests of the synthetic street generator (synthcompose.synthetic): files, geometry, labels."""
from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose.geometry.depth import disparity_to_depth, point_cloud
from synthcompose.io.dataset import ImageSetId, find_image_sets, read_image_set
from synthcompose.labels import KNOWN_IDS, label_id
from synthcompose.synthetic import StreetScene, make_sample, random_scene, render_scene

from ..tolerances import (
    BACKPROJECTED_HEIGHT_M,
    CAMERA_OFF_CENTRE_M,
    EXACT_DEPTH_HEIGHT_M,
    EXACT_HOLES_SHARE,
    FLOAT64_SLACK_M,
    GROUND_NORMAL_FD,
    GROUND_ORIGIN_EXACT_M,
    KERB_DIRECTION_DEG,
    POLE_BASE_M,
    TILT_SHOWS_M,
    TURNED_DEPTH_MEDIAN_REL,
    TURNED_DEPTH_REL,
    TURNED_DEPTH_SHARE,
    TURNED_LABELS_DIFFER_MAX,
)

W, H, SEED, COUNT = 512, 256, 7, 2
KINDS = ("rgb", "labelIds", "instanceIds", "color", "disparity", "camera")
ROAD, SIDEWALK, POLE, CAR, SKY, EGO = (label_id(n) for n in ("road", "sidewalk", "pole", "car", "sky", "ego vehicle"))


def scene_of(frame: int, seed: int = SEED, **kw) -> StreetScene:
    """The scene make_sample draws for one frame."""
    return random_scene(np.random.default_rng([seed, frame]), W, H, **kw)


@pytest.fixture(scope="module")
def sample_root(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[ImageSetId]]:
    root = tmp_path_factory.mktemp("sample")
    # exact disparity: these tests check the generator's geometry to the centimetre
    return root, make_sample(root, count=COUNT, width=W, height=H, seed=SEED, stereo="exact", photo="clean")


@pytest.fixture(scope="module")
def rendered() -> list[tuple[StreetScene, dict[str, np.ndarray]]]:
    return [(s, render_scene(s, stereo="exact", photo="clean")) for s in (scene_of(i) for i in range(4))]


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
        assert np.abs(z[road]).max() < BACKPROJECTED_HEIGHT_M
        # sidewalk tops: away from the vertical kerb faces (along the road and the cross street)
        kerb_x = scene.crossing[1]
        top = near & (cloud.labels == SIDEWALK) & (np.abs(y) > scene.road_half_width + 0.05) \
            & (np.abs(x - kerb_x) > 0.1)
        assert np.abs(z[top] - scene.kerb_height).max() < BACKPROJECTED_HEIGHT_M
        checked_sidewalk += top.sum()
    assert checked_sidewalk > 1000


def test_exact_depth_matches_surfaces(rendered):
    for scene, arr in rendered:
        cam = scene.camera
        cloud = point_cloud(arr["depth"], arr["label_ids"], cam)
        x, y, z = cloud.vehicle.T
        road = cloud.labels == ROAD
        close = road & (cloud.optical[:, 2] < 60)
        assert np.abs(z[close]).max() < EXACT_DEPTH_HEIGHT_M
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
        assert EXACT_HOLES_SHARE[0] < holes.sum() / np.isfinite(depth).sum() < EXACT_HOLES_SHARE[1]


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


# ---------------------------------------------------------------------- graded, cambered, turned streets
#: sha256 over the decoded pixels (dtype, shape, bytes) and camera JSON bytes of
#: make_sample(count=2, width=256, height=128, seed=11), computed with the generator before the
#: heading/slope/camber options existed. Decoded content rather than PNG bytes, so that another
#: PNG encoder build cannot fail it; equal PNG bytes for equal content are what
#: test_same_seed_gives_identical_files checks. (The PNG files' own sha256 was
#: 13b29a3544435f0b744942d6aa656fe8e56a8627702328f269b985a0e6706c41 with OpenCV 5.0.0.)
DEFAULT_CONTENT_SHA256 = "1f152df717fe53560bf4131cb038e8aabb9731cf0962e39ef34529d1b750389f"
TILTED = {"heading_deg": 15.0, "slope": 0.04, "camber": 0.025}


def _content_sha256(root: Path, idents: list[ImageSetId]) -> str:
    h = hashlib.sha256()
    for ident in idents:
        for kind in KINDS:
            path = ident.path(root, kind)
            if kind == "camera":
                h.update(path.read_bytes())
            else:
                a = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
                h.update(f"{a.dtype.str}{a.shape}".encode())
                h.update(a.tobytes())
    return h.hexdigest()


def test_default_output_unchanged_by_the_new_options(tmp_path):
    # the exact-disparity mode is the generator of before: the same content
    idents = make_sample(tmp_path, count=2, width=256, height=128, seed=11, stereo="exact", photo="clean")
    assert _content_sha256(tmp_path, idents) == DEFAULT_CONTENT_SHA256
    # None and 0 are the same flat street along x
    a = random_scene(np.random.default_rng([3, 1]), 256, 128)
    b = random_scene(np.random.default_rng([3, 1]), 256, 128, heading_deg=0, slope=0.0, camber=0)
    assert a == b and a.street_is_vehicle_frame and a.street_heading == 0 and a.slope == a.camber == 0


@pytest.fixture(scope="module")
def tilted() -> list[tuple[StreetScene, dict[str, np.ndarray]]]:
    """Frames of a street turned by 15 deg, 4 % uphill, 2.5 % camber, and a steeper variant."""
    scenes = [scene_of(i, **TILTED) for i in range(2)]
    scenes.append(scene_of(2, heading_deg=-22.0, slope=-0.06, camber=0.03))
    return [(s, render_scene(s, stereo="exact")) for s in scenes]  # back-projection to 2 cm


def _off_steps(scene: StreetScene, x: np.ndarray, y: np.ndarray, margin: float) -> np.ndarray:
    """Points at least ``margin`` away from the kerb lines (where the ground height jumps)."""
    a, b = scene.to_street(x, y)
    return (np.abs(np.abs(b) - scene.road_half_width) > margin) & (np.abs(a - scene.crossing[0]) > margin) \
        & (np.abs(a - scene.crossing[1]) > margin)


def test_tilted_street_frame_and_parameters(tilted):
    scene = tilted[0][0]
    cam = scene.camera
    assert scene.street_heading == pytest.approx(np.radians(15.0)) and not scene.street_is_vehicle_frame
    assert (scene.slope, scene.camber) == (0.04, 0.025)
    # the camera stayed where it was: over the road, near the centre line; ground 0 under V's origin
    a, b = scene.to_street(cam.x, cam.y)
    assert abs(float(b)) < CAMERA_OFF_CENTRE_M and str(scene.surface_label(cam.x, cam.y)) == "road"
    assert float(scene.ground_height(0.0, 0.0)) == pytest.approx(0.0, abs=GROUND_ORIGIN_EXACT_M)
    # frames round-trip; road_direction is the unit street direction, away from the camera
    x, y = np.random.default_rng(0).uniform(-20, 80, (2, 50))
    assert np.allclose(scene.to_vehicle(*scene.to_street(x, y)), (x, y))
    d = scene.road_direction(x, y)
    assert d.shape == (50, 2) and np.allclose(d, [np.cos(np.radians(15)), np.sin(np.radians(15))])
    a2, _ = scene.to_street(cam.x + d[0, 0], cam.y + d[0, 1])
    assert float(a2 - a) == pytest.approx(1.0)


def test_ground_height_slope_camber_and_normals(tilted):
    for scene, _ in tilted:
        w, k, g, c = scene.road_half_width, scene.kerb_height, scene.slope, scene.camber
        along = np.array([10.0, 11.0, 60.0])
        for bb in (0.0, 0.7 * w, -0.7 * w):  # road: slope along, camber across
            z = scene.ground_height(*scene.to_vehicle(along, bb))
            assert np.allclose(np.diff(z) / np.diff(along), g)
            assert float(z[0]) == pytest.approx(scene.crown_z + g * 10 - c * abs(bb))
        for bb in (w + 0.5, w + 2.0, -(w + 1.0)):  # sidewalk: kerb above the road edge, flat across
            z = scene.ground_height(*scene.to_vehicle(10.0, bb))
            assert float(z) == pytest.approx(scene.crown_z + g * 10 - c * w + k)
            assert str(scene.surface_label(*scene.to_vehicle(10.0, bb))) == "sidewalk"
        # normals = the normalised gradient of ground_height (central differences off the edges)
        rng = np.random.default_rng(1)
        x, y = scene.to_vehicle(rng.uniform(5, 80, 400), rng.uniform(-w - 3, w + 3, 400))
        keep = _off_steps(scene, x, y, 0.01) & (np.abs(scene.to_street(x, y)[1]) > 0.01)
        x, y = x[keep], y[keep]
        e = 1e-4
        gx = (scene.ground_height(x + e, y) - scene.ground_height(x - e, y)) / (2 * e)
        gy = (scene.ground_height(x, y + e) - scene.ground_height(x, y - e)) / (2 * e)
        n = np.stack([-gx, -gy, np.ones_like(gx)], axis=1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        assert np.allclose(scene.ground_normal(x, y), n, atol=GROUND_NORMAL_FD)


def test_tilted_back_projection_matches_ground_height(tilted):
    """Written disparity -> depth -> points: road and sidewalk tops within 2 cm (< 30 m)."""
    for scene, arr in tilted:
        cam = scene.camera
        cloud = point_cloud(disparity_to_depth(arr["disparity"], cam), arr["label_ids"], cam)
        x, y, z = cloud.vehicle.astype(np.float64).T
        near = (cloud.optical[:, 2] < 30) & _off_steps(scene, x, y, 0.05)
        err = np.abs(z - scene.ground_height(x, y))
        road = near & (cloud.labels == ROAD)
        top = near & (cloud.labels == SIDEWALK)  # off the steps: no kerb face points
        assert road.sum() > 2000 and top.sum() > 500
        assert err[road].max() < BACKPROJECTED_HEIGHT_M and err[top].max() < BACKPROJECTED_HEIGHT_M
        # the ground really is tilted: the flat z = 0 / kerb-height model is far off
        assert np.abs(z[road]).max() > TILT_SHOWS_M


def test_tilted_exact_depth_matches_surfaces(tilted):
    for scene, arr in tilted:
        cam = scene.camera
        cloud = point_cloud(arr["depth"], arr["label_ids"], cam)
        x, y, z = cloud.vehicle.astype(np.float64).T
        close = cloud.optical[:, 2] < 60
        road = cloud.labels == ROAD
        assert (scene.surface_label(x[road], y[road]) == "road").all()
        assert np.abs(z - scene.ground_height(x, y))[road & close].max() < EXACT_DEPTH_HEIGHT_M
        # sidewalk: tops at the ground height, kerb faces between road edge and sidewalk top
        walk = close & (cloud.labels == SIDEWALK)
        a, b = scene.to_street(x, y)
        face = walk & ~_off_steps(scene, x, y, 0.002)
        edge = scene.road_edge_height(a)
        assert np.abs(z - scene.ground_height(x, y))[walk & ~face].max() < EXACT_DEPTH_HEIGHT_M
        assert face.sum() > 50
        assert ((z[face] > edge[face] - EXACT_DEPTH_HEIGHT_M)
                & (z[face] < edge[face] + scene.kerb_height + EXACT_DEPTH_HEIGHT_M)).all()
        assert (np.isfinite(arr["depth"]) == ~np.isin(arr["label_ids"], [SKY, EGO])).all()


def _kerb_direction_deg(scene: StreetScene, arr: dict[str, np.ndarray], max_depth: float = 40.0) -> float:
    """Direction (deg, in V) of the road/sidewalk boundary lines seen in the label image: the
    angle at which the boundary points, back-projected onto the ground plan, line up best."""
    labels, depth = arr["label_ids"], arr["depth"]
    walk = labels == SIDEWALK
    edge = (labels == ROAD) & (np.roll(walk, 1, axis=1) | np.roll(walk, -1, axis=1)
                               | np.roll(walk, 1, axis=0) | np.roll(walk, -1, axis=0))
    edge[:, [0, -1]] = False
    edge[[0, -1], :] = False
    edge &= depth < max_depth
    mask = np.full(labels.shape, 0, np.uint8)
    mask[edge] = ROAD
    cloud = point_cloud(np.where(edge, depth, np.inf).astype(np.float32), mask, scene.camera)
    p = cloud.vehicle[:, :2].astype(np.float64)
    assert len(p) > 100
    best, best_score = 0.0, -1.0
    for deg in np.arange(-45.0, 45.0, 0.05):
        t = np.radians(deg)
        s = p @ np.array([-np.sin(t), np.cos(t)])  # offset across the candidate direction
        counts = np.bincount(np.floor((s - s.min()) / 0.05).astype(int))
        score = float((counts.astype(np.float64) ** 2).sum())
        if score > best_score:
            best, best_score = deg, score
    return best


def test_road_direction_matches_kerb_lines(tilted):
    for scene, arr in tilted:
        d = scene.road_direction(np.array([20.0]), np.array([0.0]))[0]
        expected = np.degrees(np.arctan2(d[1], d[0]))
        assert abs(_kerb_direction_deg(scene, arr) - expected) < KERB_DIRECTION_DEG
    flat = scene_of(0)
    assert abs(_kerb_direction_deg(flat, render_scene(flat))) < KERB_DIRECTION_DEG


def test_turning_the_street_equals_turning_the_camera(tilted):
    """Heading h about the camera's ground point = the same street seen by a camera yawed by -h."""
    scene, arr = tilted[0]
    h = scene.street_heading
    same = dataclasses.replace(scene, street_heading=0.0, street_origin=(0.0, 0.0),
                               camera=dataclasses.replace(scene.camera, yaw=scene.camera.yaw - h))
    other = render_scene(same)
    assert (arr["label_ids"] != other["label_ids"]).mean() < TURNED_LABELS_DIFFER_MAX
    finite = np.isfinite(arr["depth"]) & np.isfinite(other["depth"])
    rel = np.abs(arr["depth"][finite] / other["depth"][finite] - 1)
    assert np.median(rel) < TURNED_DEPTH_MEDIAN_REL and (rel < TURNED_DEPTH_REL).mean() > TURNED_DEPTH_SHARE


def test_objects_stand_on_the_true_ground(tilted):
    for scene, _ in tilted:
        for pole in scene.poles:  # the ground under the pole's disc is at or above its base
            ang = np.linspace(0, 2 * np.pi, 16)
            x, y = scene.to_vehicle(pole.x + pole.radius * np.cos(ang), pole.y + pole.radius * np.sin(ang))
            ground = scene.ground_height(x, y)
            assert ground.min() >= pole.base_z - FLOAT64_SLACK_M
            assert ground.min() - pole.base_z < POLE_BASE_M + pole.radius * abs(scene.slope)
        wheels = [b for b in scene.boxes if b.label == "car" and b.color == (26, 26, 28)]
        assert wheels and all(b.rotation is not None for b in wheels)  # cars tilt with the road
        for box in wheels + [b for b in scene.boxes if b.label == "person"][::3]:
            bottom = box.corners()[[0, 1, 2, 3]]  # corners with z = lo (bit 2 clear)
            x, y = scene.to_vehicle(bottom[:, 0], bottom[:, 1])
            ground = scene.ground_height(x, y)
            if box.label == "car":  # wheels: their bottom face lies in the road plane
                assert np.allclose(bottom[:, 2], ground, atol=FLOAT64_SLACK_M)
            else:  # upright pedestrians: sunk by at most the grade over their footprint
                assert (bottom[:, 2] <= ground + FLOAT64_SLACK_M).all()
                assert (ground - bottom[:, 2]).max() < abs(scene.slope) * 0.3 + FLOAT64_SLACK_M
        # exact containment test in V, also for the tilted car boxes
        body = next(b for b in scene.boxes if b.label == "car")
        centre = scene.points_to_vehicle(body.corners().mean(axis=0)[None])
        assert scene.inside_objects(centre).all()
        assert not scene.inside_objects(centre + [0.0, 0.0, 3.0]).any()


def test_pole_hides_road_on_turned_graded_streets():
    cases = [(20, 0.05), (-25, -0.06), (25, 0.0), (-10, 0.06), (28, 0.03), (-28, -0.03)]
    for frame, (heading, slope) in enumerate(cases):
        scene = scene_of(frame, heading_deg=heading, slope=slope, camber=0.03)
        arr = render_scene(scene)
        without = render_scene(dataclasses.replace(scene, poles=()))
        assert ((arr["label_ids"] == POLE) & (without["label_ids"] == ROAD)).sum() >= 3, (heading, slope)


def test_occluding_pole_false_drops_only_the_corner_poles():
    rng_args = ([SEED, 1], W, H)
    full = random_scene(np.random.default_rng(rng_args[0]), *rng_args[1:], heading_deg=10, slope=0.03)
    bare = random_scene(np.random.default_rng(rng_args[0]), *rng_args[1:], heading_deg=10, slope=0.03,
                        occluding_pole=False)
    assert bare.boxes == full.boxes and len(bare.poles) < len(full.poles)
    assert bare.poles == full.poles[len(full.poles) - len(bare.poles):]
    assert not any(bare.crossing[0] - 1.0 <= p.x <= bare.crossing[0] for p in bare.poles)


def test_option_ranges_are_checked():
    for kw in ({"heading_deg": 29.0}, {"slope": 0.3}, {"camber": -0.2}, {"slope": float("nan")}):
        with pytest.raises(ValueError):
            random_scene(np.random.default_rng(0), 256, 128, **kw)
    # no road: camber has nothing to crown, the ground is the graded sidewalk plane
    scene = random_scene(np.random.default_rng(0), 256, 128, road=False, slope=0.05, camber=0.03)
    assert scene.camber == 0 and scene.kerb_height == 0
    arr = render_scene(scene)
    assert not (arr["label_ids"] == ROAD).any()
    cloud = point_cloud(arr["depth"], arr["label_ids"], scene.camera)
    x, y, z = cloud.vehicle.astype(np.float64).T
    walk = (cloud.labels == SIDEWALK) & (cloud.optical[:, 2] < 60)
    assert np.abs(z - scene.ground_height(x, y))[walk].max() < EXACT_DEPTH_HEIGHT_M
