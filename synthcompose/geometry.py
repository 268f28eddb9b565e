"""Stage 2 - geometry: disparity <-> depth and the scene's point cloud, vectorised NumPy.

Cityscapes disparity: a 16-bit PNG value p > 0 encodes d = (p - 1) / 256 pixels; p = 0 is
invalid. Depth along the optical axis is z = baseline * fx / d (metres).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .camera import Camera

DISPARITY_SCALE = 256.0


def disparity_to_depth(disparity: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W) uint16 Cityscapes disparity -> (H, W) float32 depth in metres (optical z).

    Invalid pixels (p = 0, or p = 1 which means d = 0, infinitely far) get ``inf``:
    nothing real is known to be there, so anything rendered is in front of them.
    """
    d = (disparity.astype(np.float32) - 1.0) / DISPARITY_SCALE
    depth = np.full(disparity.shape, np.inf, np.float32)
    ok = d > 0
    depth[ok] = np.float32(camera.baseline * camera.fx) / d[ok]
    return depth


def depth_to_disparity(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W) float depth in metres -> (H, W) uint16 Cityscapes disparity.

    Non-finite or non-positive depth encodes as 0 (invalid); values are clipped to 65535.
    """
    depth = np.asarray(depth, np.float64)
    out = np.zeros(depth.shape, np.uint16)
    ok = np.isfinite(depth) & (depth > 0)
    p = np.rint(camera.baseline * camera.fx / depth[ok] * DISPARITY_SCALE) + 1.0
    out[ok] = np.clip(p, 1, 65535).astype(np.uint16)
    return out


@dataclass(frozen=True, eq=False)
class PointCloud:
    """The valid-depth pixels of one frame as 3D points.

    pixels   : (N, 2) int32 (row v, column u)
    optical  : (N, 3) float32, optical frame S (x right, y down, z forward), metres
    vehicle  : (N, 3) float32, vehicle frame V (ISO 8855: x forward, y left, z up), metres
    labels   : (N,) uint8 label id of each point
    """

    pixels: np.ndarray
    optical: np.ndarray
    vehicle: np.ndarray
    labels: np.ndarray

    def __len__(self) -> int:
        return len(self.labels)


def point_cloud(depth: np.ndarray, label_ids: np.ndarray, camera: Camera) -> PointCloud:
    """Back-project every pixel with finite depth (pinhole model)."""
    v, u = np.nonzero(np.isfinite(depth))
    z = depth[v, u]
    x = (u.astype(np.float32) - np.float32(camera.u0)) * z / np.float32(camera.fx)
    y = (v.astype(np.float32) - np.float32(camera.v0)) * z / np.float32(camera.fy)
    optical = np.stack([x, y, z], axis=1)
    m = camera.vehicle_from_optical.astype(np.float32)
    vehicle = optical @ m[:3, :3].T + m[:3, 3]
    return PointCloud(np.stack([v, u], axis=1).astype(np.int32), optical, vehicle, label_ids[v, u])
