"""Analytic ray casting of a :class:`~.scene.StreetScene`, one ray per pixel centre, in NumPy.

Rays: pixel (u, v) (integer = pixel centre) has optical-frame direction
``((u - u0) / fx, (v - v0) / fy, 1)``, so the ray parameter of a hit *is* its depth (optical z).
Rays are turned into T and intersected there (boxes: in their own frame). Sky and ego vehicle

The result is a z-buffer of :class:`Buffers`: depth, primitive id and face per pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.camera import Camera

from .scene import Box, Pole, StreetScene

# primitive ids in the id buffer
PID_EGO, PID_SKY, PID_ROAD, PID_SIDEWALK, PID_KERB = -2, -1, 0, 1, 2
PID_FIRST_OBJECT = 3


@dataclass(eq=False)
class Buffers:
    """Per-pixel ray and hit data, all (H, W). Origin and directions are in the street frame T,
    directions scaled to optical z = 1 (so the ray parameter is the depth)."""

    origin: np.ndarray  # (3,) float64 camera centre in T
    d: tuple[np.ndarray, np.ndarray, np.ndarray]  # da, db, dz float32
    depth: np.ndarray  # float32, inf = no hit
    pid: np.ndarray  # int16 primitive id
    face: np.ndarray  # int8: 2*axis + (1 if normal points to +axis else 0), in T (ground: 5)


def _rays(camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(H, W) float32 x, y, z components in V of every pixel-centre ray (optical z = 1)."""
    a = ((np.arange(camera.width) - camera.u0) / camera.fx).astype(np.float32)[None, :]
    b = ((np.arange(camera.height) - camera.v0) / camera.fy).astype(np.float32)[:, None]
    m = camera.vehicle_from_optical[:3, :3].astype(np.float32)
    dx, dy, dz = (m[i, 0] * a + m[i, 1] * b + m[i, 2] for i in range(3))
    return dx, dy, dz


def street_rays(scene: StreetScene) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Camera centre (float64) and pixel rays (float32) in the street frame T."""
    cam = scene.camera
    dx, dy, dz = _rays(cam)
    if scene.street_is_vehicle_frame:
        return cam.position.astype(np.float64), (dx, dy, dz)
    origin = scene.points_to_street(cam.position.astype(np.float64)[None])[0]
    c, s = np.float32(math.cos(scene.street_heading)), np.float32(math.sin(scene.street_heading))
    return origin, (c * dx + s * dy, c * dy - s * dx, dz)


def _screen_rect(camera: Camera, lo: np.ndarray, hi: np.ndarray,
                 vehicle_from_local: np.ndarray | None = None) -> tuple[slice, slice] | None:
    """Pixel rows/columns that can see the box [lo, hi] of a local frame (V unless
    ``vehicle_from_local``, a 4x4 transform, says otherwise), or None if it is all behind."""
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)], float)
    m = camera.optical_from_vehicle
    if vehicle_from_local is not None:
        m = m @ vehicle_from_local
    pts = corners @ m[:3, :3].T + m[:3, 3]
    near = 1e-3
    keep = [p for p in pts if p[2] >= near]
    for i in range(8):
        for k in range(3):
            j = i | (1 << k)
            if j != i:
                zi, zj = pts[i, 2] - near, pts[j, 2] - near
                if zi * zj < 0:
                    keep.append(pts[i] + (pts[j] - pts[i]) * (zi / (zi - zj)))
    if not keep:
        return None
    q = np.array(keep)
    u = camera.fx * q[:, 0] / q[:, 2] + camera.u0
    v = camera.fy * q[:, 1] / q[:, 2] + camera.v0
    c0, c1 = max(0, math.floor(u.min()) - 1), min(camera.width, math.ceil(u.max()) + 2)
    r0, r1 = max(0, math.floor(v.min()) - 1), min(camera.height, math.ceil(v.max()) + 2)
    if c0 >= c1 or r0 >= r1:
        return None
    return slice(r0, r1), slice(c0, c1)


def _commit(buf: Buffers, rect: tuple[slice, slice], t: np.ndarray, hit: np.ndarray, pid: int,
            face: np.ndarray | int) -> None:
    """Z-buffer update inside ``rect``: keep hits nearer than what is there."""
    depth = buf.depth[rect]
    win = hit & (t < depth)
    depth[win] = t[win]
    buf.pid[rect][win] = pid
    buf.face[rect][win] = face[win] if isinstance(face, np.ndarray) else face


def _ground_planes(scene: StreetScene) -> list[tuple[float, float, object, int]]:
    """The ground as planes z = c + slope*a + q*b, each with the region (a, b) -> bool where
    it is the surface: [(c, q, region, pid)]. The cambered road is two planes meeting at the
    centre line plus the cross street's plane beyond the kerb lines."""
    w, k, c0 = scene.road_half_width, scene.kerb_height, scene.crown_z
    edge = c0 - scene.camber * w
    if scene.camber == 0.0:
        road = [(c0, 0.0, scene.street_is_road, PID_ROAD)]
    else:
        road = [(c0, -scene.camber, lambda a, b: (b >= 0) & (b <= w) & scene.street_before_end(a), PID_ROAD),
                (c0, scene.camber, lambda a, b: (b < 0) & (b >= -w) & scene.street_before_end(a), PID_ROAD),
                (edge, 0.0, lambda a, b: (np.abs(b) > w) & scene.street_in_crossing(a), PID_ROAD)]
        if not scene.has_road:
            road = []
    walk = (edge + k, 0.0, lambda a, b: ~scene.street_is_road(a, b), PID_SIDEWALK)
    return road + [walk]


def cast_ground(scene: StreetScene, buf: Buffers) -> None:
    """Road planes, sidewalk top plane and kerb faces, over the whole image (exact planes)."""
    oa, ob, oz = (float(c) for c in buf.origin)
    da, db, dz = buf.d
    full = (slice(None), slice(None))
    w, k, g = np.float32(scene.road_half_width), np.float32(scene.kerb_height), scene.slope
    with np.errstate(divide="ignore", invalid="ignore"):
        for c0, q, region, pid in _ground_planes(scene):
            # oz + t dz = c0 + g (oa + t da) + q (ob + t db); entering from above: den < 0
            den = dz - g * da - q * db
            t = np.where(den < 0, np.float32(c0 + g * oa + q * ob - oz) / den, np.float32(np.inf))
            hit = np.isfinite(t) & region(oa + t * da, ob + t * db)
            _commit(buf, full, t, hit, pid, 5)
        if not scene.has_road or scene.kerb_height <= 0:
            return
        # kerb faces along the road (b = +-w, facing the road) and the far side of the crossing
        for sign in (1, -1):
            t = np.float32(sign * w - ob) / db
            z, a = oz + t * dz, oa + t * da
            bottom = scene.road_edge_height(a)
            hit = (sign * db > 0) & (z >= bottom) & (z <= bottom + k) & ~scene.street_in_crossing(a) \
                & scene.street_before_end(a)
            _commit(buf, full, t, hit, PID_KERB, 2 if sign > 0 else 3)
        # across the view: the far side of the crossing (beside the street), and the street's end
        # (across its road: a T-junction's far kerb; the road's camber under it)
        for a_face, across in ((None if scene.crossing is None else scene.crossing[1], lambda b: np.abs(b) > w),
                               (scene.street_end, lambda b: np.abs(b) <= w)):
            if a_face is None:
                continue
            t = np.float32(a_face - oa) / da
            z, b = oz + t * dz, ob + t * db
            bottom = scene.crown_z + scene.slope * a_face - scene.camber * np.minimum(np.abs(b), w)
            top = float(scene.sidewalk_height(a_face))
            hit = (da > 0) & (z >= bottom) & (z <= top) & across(b)
            _commit(buf, full, t, hit, PID_KERB, 0)


def cast_box(box: Box, pid: int, buf: Buffers, camera: Camera, v_from_t: np.ndarray | None) -> None:
    """Slab test of one box over the pixels of its screen rectangle (in the box's own frame)."""
    lo, hi = np.array(box.lo), np.array(box.hi)
    t_from_b = box.matrix
    m = t_from_b if v_from_t is None else v_from_t if t_from_b is None else v_from_t @ t_from_b
    rect = _screen_rect(camera, lo, hi, m)
    if rect is None:
        return
    if t_from_b is None:
        origin, dirs = buf.origin, [buf.d[axis][rect] for axis in range(3)]
    else:  # rays into B: p_B = R^T (p_T - t)
        r = t_from_b[:3, :3]
        origin = r.T @ (buf.origin - t_from_b[:3, 3])
        rd = r.astype(np.float32)
        dirs = [rd[0, i] * buf.d[0][rect] + rd[1, i] * buf.d[1][rect] + rd[2, i] * buf.d[2][rect] for i in range(3)]
    t_near = np.full(buf.depth[rect].shape, -np.inf, np.float32)
    t_far = np.full(t_near.shape, np.inf, np.float32)
    face = np.zeros(t_near.shape, np.int8)
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis in range(3):
            d = dirs[axis]
            inv = np.float32(1.0) / d
            o = origin[axis]
            t1, t2 = np.float32(lo[axis] - o) * inv, np.float32(hi[axis] - o) * inv
            tmin, tmax = np.minimum(t1, t2), np.maximum(t1, t2)
            later = tmin > t_near
            t_near = np.where(later, tmin, t_near)
            face = np.where(later, np.int8(2 * axis) + (d < 0).astype(np.int8), face)
            t_far = np.minimum(t_far, tmax)
    _commit(buf, rect, t_near, (t_near <= t_far) & (t_near > 0), pid, face)


def cast_pole(pole: Pole, pid: int, buf: Buffers, camera: Camera, v_from_t: np.ndarray | None) -> None:
    """Ray / vertical cylinder side intersection (float64 for a stable discriminant)."""
    r = pole.radius
    rect = _screen_rect(camera, np.array([pole.x - r, pole.y - r, pole.base_z]),
                        np.array([pole.x + r, pole.y + r, pole.base_z + pole.height]), v_from_t)
    if rect is None:
        return
    dx, dy, dz = (c[rect].astype(np.float64) for c in buf.d)
    fx, fy = buf.origin[0] - pole.x, buf.origin[1] - pole.y
    a = dx * dx + dy * dy
    b = fx * dx + fy * dy
    c = fx * fx + fy * fy - r * r
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-b - np.sqrt(disc)) / a
    z = buf.origin[2] + t * dz
    hit = (disc >= 0) & (t > 0) & (z >= pole.base_z) & (z <= pole.base_z + pole.height)
    _commit(buf, rect, t.astype(np.float32), hit, pid, 6)


def ego_mask(height: int, width: int, ego_rows: int) -> np.ndarray:
    """(H, W) bool: the bonnet, ``ego_rows`` tall at the centre column, 35 % less at the sides."""
    u = (np.arange(width) - width / 2) / (width / 2)
    top = height - ego_rows + np.rint(0.35 * ego_rows * u * u).astype(int)
    return np.arange(height)[:, None] >= top[None, :]

