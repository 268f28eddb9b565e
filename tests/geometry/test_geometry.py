import math

import numpy as np
import pytest

from synthcompose.camera import Camera
from synthcompose.errors import InputError
from synthcompose.geometry.depth import depth_to_disparity, disparity_to_depth, point_cloud

from ..helpers import make_camera
from ..tolerances import BACKPROJECTED_PLANE_M, DEPTH_ROUNDTRIP_DISPARITY_PX, FLOAT32_DISPARITY_PX, REPROJECTION_PX


def test_disparity_depth_roundtrip():
    cam = make_camera()
    rng = np.random.default_rng(0)
    depth = rng.uniform(2.0, 200.0, (64, 64)).astype(np.float32)
    disp = depth_to_disparity(depth, cam)
    back = disparity_to_depth(disp, cam)
    d_true = cam.baseline * cam.fx / depth
    d_back = cam.baseline * cam.fx / back
    assert np.abs(d_back - d_true).max() <= DEPTH_ROUNDTRIP_DISPARITY_PX / 2 + FLOAT32_DISPARITY_PX


def test_invalid_disparity_is_infinitely_far():
    cam = make_camera()
    disp = np.array([[0, 1, 257]], np.uint16)
    depth = disparity_to_depth(disp, cam)
    assert math.isinf(depth[0, 0]) and math.isinf(depth[0, 1])
    assert depth[0, 2] == pytest.approx(cam.baseline * cam.fx / 1.0)
    assert depth_to_disparity(np.array([[np.inf, -1.0, np.nan]]), cam).tolist() == [[0, 0, 0]]


def test_frames_are_inverse_and_iso8855():
    cam = make_camera(yaw=0.0, pitch=0.0, roll=0.0)
    # with no rotation the optical axis looks along vehicle +x, image right is vehicle -y
    m = cam.vehicle_from_optical
    assert np.allclose(m[:3, :3] @ [0, 0, 1], [1, 0, 0])
    assert np.allclose(m[:3, :3] @ [1, 0, 0], [0, -1, 0])
    assert np.allclose(m[:3, :3] @ [0, 1, 0], [0, 0, -1])
    cam = make_camera()
    assert np.allclose(cam.vehicle_from_optical @ cam.optical_from_vehicle, np.eye(4))
    # positive pitch tilts the camera towards the ground
    fwd = make_camera(yaw=0.0, roll=0.0).vehicle_from_optical[:3, :3] @ [0, 0, 1]
    assert fwd[2] < 0


def test_point_cloud_back_projects_a_plane():
    cam = make_camera()
    # analytic depth of the ground plane z = 0 (vehicle) for every pixel below the horizon
    u, v = np.meshgrid(np.arange(cam.width), np.arange(cam.height))
    rays = np.stack([(u - cam.u0) / cam.fx, (v - cam.v0) / cam.fy, np.ones(u.shape)], -1)
    m = cam.vehicle_from_optical
    dz = (rays @ m[:3, :3].T)[..., 2]
    depth = np.where(dz < -1e-3, -m[2, 3] / np.where(dz < -1e-3, dz, -1), np.inf).astype(np.float32)
    labels = np.full(depth.shape, 7, np.uint8)
    cloud = point_cloud(depth, labels, cam)
    assert len(cloud) == np.isfinite(depth).sum()
    assert np.abs(cloud.vehicle[:, 2]).max() < BACKPROJECTED_PLANE_M
    uv = cam.project(cloud.optical)
    assert np.abs(uv[:, 0] - cloud.pixels[:, 1]).max() < REPROJECTION_PX
    assert np.abs(uv[:, 1] - cloud.pixels[:, 0]).max() < REPROJECTION_PX


@pytest.mark.parametrize("bad, message", [
    ({"intrinsic": {"fy": 1, "u0": 1, "v0": 1}}, "has no 'fx'"),
    ({"intrinsic": {"fx": float("nan"), "fy": 1, "u0": 1, "v0": 1}}, "finite number"),
    ({"intrinsic": {"fx": -5, "fy": 1, "u0": 1, "v0": 1}}, "must be positive"),
    ({"intrinsic": {"fx": "a", "fy": 1, "u0": 1, "v0": 1}}, "finite number"),
])
def test_camera_json_errors_name_the_problem(bad, message):
    data = {"extrinsic": {"baseline": 0.2, "x": 1, "y": 0, "z": 1, "yaw": 0, "pitch": 0, "roll": 0}}
    data.update(bad)
    with pytest.raises(InputError, match=message) as err:
        Camera.from_dict(data, 10, 10, "some/camera.json")
    assert "some/camera.json" in str(err.value)


def test_holes_are_filled_for_occlusion_by_the_farther_neighbour():
    """A hole inside a near pole stays the pole's (the pole hides what is inserted behind it);
    an occlusion shadow between background and pole takes the background's depth; a hole open
    to the image border stays unknown."""
    from synthcompose.geometry.depth import occluder_depth

    inf = np.inf
    row = np.array([inf, 30, 30, inf, inf, 5, inf, 5, 30, inf], np.float32)
    out = occluder_depth(np.stack([row, row]))
    np.testing.assert_array_equal(out[0], [inf, 30, 30, 30, 30, 5, 5, 5, 30, inf])
    assert occluder_depth(np.full((2, 3), 4.0, np.float32)).tolist() == [[4.0] * 3] * 2


def test_a_hole_filled_from_the_ground_counts_as_ground():
    """The road (30 m) with a hole beside a near car (5 m): the hole takes the road's depth and
    is ground for the compose (the ground's noise band then keeps an inserted shadow over it);
    the hole inside the car is the car's, not ground; one open to the border stays unknown."""
    from synthcompose.geometry.depth import occluder_fill

    inf = np.inf
    row = np.array([inf, 30, 30, inf, inf, 5, inf, 5, 30, inf], np.float32)
    road = np.array([0, 1, 1, 0, 0, 0, 0, 0, 1, 0], bool)
    depth, ground = occluder_fill(np.stack([row, row]), np.stack([road, road]))
    np.testing.assert_array_equal(depth[0], [inf, 30, 30, 30, 30, 5, 5, 5, 30, inf])
    np.testing.assert_array_equal(ground[0], [0, 1, 1, 1, 1, 0, 0, 0, 1, 0])
