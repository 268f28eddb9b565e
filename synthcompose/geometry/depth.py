"""Stage 2 - geometry: disparity <-> depth and the scene's point cloud, vectorised NumPy.

Cityscapes disparity: a 16-bit PNG value p > 0 encodes d = (p - 1) / 256 pixels; p = 0 is
invalid. Depth along the optical axis is z = baseline * fx / d (metres).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable, TypeVar

import numpy as np

from synthcompose.camera import Camera
from synthcompose.io.files import decode_disparity, encode_disparity

T = TypeVar("T")


def disparity_to_depth(disparity: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W) uint16 Cityscapes disparity -> (H, W) float32 depth in metres (optical z).

    Invalid pixels (p = 0, or p = 1 which means d = 0, infinitely far) get ``inf``:
    nothing real is known to be there, so anything rendered is in front of them.
    """
    d = decode_disparity(disparity)
    depth = np.full(disparity.shape, np.inf, np.float32)
    ok = d > 0
    depth[ok] = np.float32(camera.baseline * camera.fx) / d[ok]
    return depth


def nearest_in_row(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(left, right): for each pixel of an (H, W) bool ``mask``, the column of the nearest
    ``mask`` pixel at or to its left along its row (-1 when none) and at or to its right (W
    when none). The row scans that hole filling, room along a row and enclosure share."""
    h, w = mask.shape
    # each pixel's column where ``mask`` (else -1 / W) by a product with the mask: a third of
    # np.where's cost over a row-broadcast column index
    steps = np.arange(1, w + 1, dtype=np.int32)
    at = np.multiply(mask, steps, dtype=np.int32)  # the column + 1 where mask, else 0
    at -= 1
    left = np.maximum.accumulate(at, axis=1)
    back = np.multiply(mask[:, ::-1], steps, dtype=np.int32)  # from the right end: W - the column, else 0
    np.subtract(np.int32(w), back, out=back)
    right = np.minimum.accumulate(back, axis=1)[:, ::-1]
    return left, right


def occluder_depth(depth: np.ndarray) -> np.ndarray:
    """(H, W) float32 depth for occlusion tests, with the matcher's holes (inf) filled
    conservatively: each hole takes the farther of the nearest valid depths to its left and
    right along its row. A hole inside a pole or a plain wall is bounded by it on both sides and
    keeps it in front of what is inserted behind it; an occlusion shadow beside a near object
    (background the right camera did not see) takes the background's depth; a hole with no
    valid pixel on one side stays unknown (inf)."""
    return occluder_fill(depth)[0]


def occluder_fill(depth: np.ndarray, ground: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """(:func:`occluder_depth`, the ground under it): ``ground`` (H, W bool, the real ground's
    pixels, None for none) with each hole that took its depth from a ground pixel counted as
    ground too. A hole in the road beside a near car takes the road's depth from the pixel at
    its edge, whose row the matcher's blocks put up to half a pixel of disparity off the ground
    under the hole (a quarter metre at 16 m): as ground it keeps the ground's noise band in the
    compose, so an inserted shadow over it is not cut along single rows."""
    h, w = depth.shape
    valid = np.isfinite(depth)
    if valid.all():
        return depth, ground
    left, right = nearest_in_row(valid)
    r, c = np.nonzero(~valid)  # the holes alone (a tenth of a real frame): their neighbours' values
    lc, rc = left[r, c], right[r, c]
    inf = np.asarray(np.inf, depth.dtype)
    from_l = np.where(lc >= 0, depth[r, np.maximum(lc, 0)], inf)  # none on a side: inf
    from_r = np.where(rc < w, depth[r, np.minimum(rc, w - 1)], inf)
    from_left = from_l >= from_r
    farther = np.where(from_left, from_l, from_r)
    filled = depth.astype(np.float32)  # a copy
    filled[r, c] = farther
    if ground is None:
        return filled, None
    source = np.where(from_left, (lc >= 0) & ground[r, np.maximum(lc, 0)], (rc < w) & ground[r, np.minimum(rc, w - 1)])
    out = ground.copy()
    out[r, c] |= np.isfinite(farther) & source
    return filled, out


def depth_to_disparity(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """(H, W) float depth in metres -> (H, W) uint16 Cityscapes disparity.

    Non-finite or non-positive depth encodes as 0 (invalid); values are clipped to 65535.
    """
    depth = np.asarray(depth, np.float64)
    out = np.zeros(depth.shape, np.uint16)
    ok = np.isfinite(depth) & (depth > 0)
    out[ok] = encode_disparity(camera.baseline * camera.fx / depth[ok])
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


def pinhole(depth: np.ndarray, camera: Camera, v: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, ...]:
    """(N,) float32 optical-frame x, y, z of pixels (rows ``v``, columns ``u``) (pinhole model)."""
    z = depth[v, u]
    x = (u.astype(np.float32) - np.float32(camera.u0)) * z / np.float32(camera.fx)
    y = (v.astype(np.float32) - np.float32(camera.v0)) * z / np.float32(camera.fy)
    return x, y, z


def back_project(depth: np.ndarray, camera: Camera, v: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) float32 optical and vehicle-frame points of pixels (rows ``v``, columns ``u``)
    with finite depth (pinhole model)."""
    optical = np.stack(pinhole(depth, camera, v, u), axis=1)
    m = camera.vehicle_from_optical.astype(np.float32)
    return optical, optical @ m[:3, :3].T + m[:3, 3]


def point_cloud(depth: np.ndarray, label_ids: np.ndarray, camera: Camera) -> PointCloud:
    """Back-project every pixel with finite depth."""
    v, u = np.nonzero(np.isfinite(depth))
    optical, vehicle = back_project(depth, camera, v, u)
    return PointCloud(np.stack([v, u], axis=1).astype(np.int32), optical, vehicle, label_ids[v, u])


@dataclass(frozen=True, eq=False)
class Frame:
    """Everything placement needs to know about one real frame.

    depth     : (H, W) float32 metres along the optical axis, inf where unknown
    label_ids : (H, W) uint8 (or labels derived from geometry for unlabelled frames)
    photo     : (H, W, 3) uint8 sRGB of the left camera, or None (placement finds the lane
                markings in it; without it the lanes follow the kerbs alone)
    The pixel grid doubles as a spatial index: every scene point inside a 3D box projects
    inside the box's 2D projection, so :meth:`rect_points` finds them without a search; the
    whole frame's point cloud (:attr:`cloud`) is built only when asked for (the preview).
    """

    camera: Camera
    depth: np.ndarray
    label_ids: np.ndarray
    labelled: bool = True
    photo: np.ndarray | None = field(default=None, repr=False)
    _derived: dict = field(default_factory=dict, init=False, repr=False, compare=False)  # see derived()

    def derived(self, key: tuple, make: Callable[[], T]) -> T:
        """A value derived from this frame alone (its street, lanes, candidates, stereo noise),
        made by ``make()`` on the first ask and kept with the frame: placement asks for the same
        ones object after object. ``key`` names it; ``make`` must depend on the frame and the key
        only, so that what is kept never depends on who asked first."""
        if key not in self._derived:
            self._derived[key] = make()
        return self._derived[key]

    def made(self, key: tuple) -> Any:
        """The value :meth:`derived` made for ``key``, None when nothing asked for it."""
        return self._derived.get(key)

    @property
    def shape(self) -> tuple[int, int]:
        return self.depth.shape

    def to_optical(self, points_v: np.ndarray) -> np.ndarray:
        """(N, 3) vehicle-frame points -> (N, 3) optical-frame points."""
        m = self.camera.optical_from_vehicle
        return np.asarray(points_v, float) @ m[:3, :3].T + m[:3, 3]

    def rect_points(self, r0: int, r1: int, c0: int, c1: int, with_pixels: bool = False,
                    only: np.ndarray | None = None, stride: int = 1) -> tuple[np.ndarray, ...]:
        """Vehicle-frame points (N, 3) and labels (N,) of valid pixels in rows r0:r1, cols c0:c1
        (and their (rows, cols) when ``with_pixels``); ``only``: a (256,) bool table of the
        label ids wanted (the others are not back-projected); ``stride``: every stride-th row
        and column only."""
        H, W = self.depth.shape
        r0, r1, c0, c1 = max(r0, 0), min(r1, H), max(c0, 0), min(c1, W)
        if r1 <= r0 or c1 <= c0:
            empty = np.empty(0, np.int64)
            return (np.empty((0, 3)), np.empty(0, np.uint8)) + ((empty, empty) if with_pixels else ())
        sub = self.depth[r0:r1:stride, c0:c1:stride]
        labels = self.label_ids[r0:r1:stride, c0:c1:stride]
        valid = np.isfinite(sub)
        if only is not None:
            valid &= only[labels]
        v, u = np.nonzero(valid)
        z = sub[valid].astype(np.float64)  # (a boolean mask reads in np.nonzero's order, cheaper)
        v, u = v * stride + r0, u * stride + c0
        cam = self.camera
        optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
        m = cam.vehicle_from_optical
        out = (optical @ m[:3, :3].T + m[:3, 3], labels[valid])
        return out + ((v, u) if with_pixels else ())

    def box_rect(self, corners_v: np.ndarray, pad: int = 1) -> tuple[int, int, int, int] | None:
        """Pixel rectangle (r0, r1, c0, c1) holding the projection of points in front of the camera."""
        opt = self.to_optical(corners_v)
        if (opt[:, 2] <= 0.1).any():
            return None
        uv = self.camera.project(opt)
        return (int(np.floor(uv[:, 1].min())) - pad, int(np.ceil(uv[:, 1].max())) + pad + 1,
                int(np.floor(uv[:, 0].min())) - pad, int(np.ceil(uv[:, 0].max())) + pad + 1)

    @cached_property
    def cloud(self) -> PointCloud:
        """The valid-depth pixels as 3D points."""
        return point_cloud(self.depth, self.label_ids, self.camera)


def make_frame(depth: np.ndarray, label_ids: np.ndarray, camera: Camera, labelled: bool = True,
               photo: np.ndarray | None = None) -> Frame:
    return Frame(camera, depth, label_ids, labelled, photo)
