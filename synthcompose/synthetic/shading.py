"""Shading of a ray-cast frame: procedural albedos (asphalt and markings, paving, facades,
car bodies, glass), sky gradient and clouds, the default light (sky ambient + sun Lambert) or a
:class:`~.light.SceneLight`, contact shadows, haze, the ego vehicle's bonnet.
"""
from __future__ import annotations

import cv2
import numpy as np

from .light import light_shade, light_tint
from .raycast import PID_EGO, PID_FIRST_OBJECT, PID_KERB, PID_ROAD, PID_SIDEWALK, PID_SKY, Buffers
from .scene import Box, StreetScene
from .streets import StreetKind, zebra_paint


def _hash01(ix: np.ndarray, iy: np.ndarray, salt: int) -> np.ndarray:
    """Deterministic per-cell value noise in [0, 1) (float32) from integer cell coordinates."""
    h = (ix.astype(np.int64).astype(np.uint32) * np.uint32(0x9E3779B1)) ^ \
        (iy.astype(np.int64).astype(np.uint32) * np.uint32(0x85EBCA77)) ^ np.uint32(salt & 0xFFFFFFFF)
    h ^= h >> np.uint32(15)
    h *= np.uint32(0x2C1B3C6D)
    h ^= h >> np.uint32(12)
    h *= np.uint32(0x297A2D39)
    h ^= h >> np.uint32(15)
    return (h >> np.uint32(8)).astype(np.float32) / np.float32(1 << 24)


def _cell_noise(a: np.ndarray, b: np.ndarray, size: float, salt: int) -> np.ndarray:
    """Value noise in [-1, 1) on a grid of ``size`` metres over surface coordinates a, b."""
    return _hash01(np.floor(a / size), np.floor(b / size), salt) * 2 - 1


def _road_albedo(scene: StreetScene, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 3) asphalt colour with markings at road points (x, y) = (a, b) in the street frame."""
    base = 88 + 7 * _cell_noise(x, y, 0.04, 1) + 4 * _cell_noise(x, y, 1.7, 2)
    rgb = np.stack([base, base + 1, base + 3], axis=1)
    w, ay = scene.road_half_width, np.abs(y)
    crossing = scene.street_in_crossing(x)
    dash, gap, phase = scene.lane_dash
    paint = (ay <= 0.07) & (np.mod(x - phase, dash + gap) < dash) & ~crossing
    if not scene.centre_line:
        paint[:] = False
    paint |= (np.abs(ay - (w - scene.parking_lane)) <= 0.06) & ~crossing
    if scene.street_kind is not None:
        paint |= StreetKind.of(scene.street_kind).bay_lines(x, y, w) & ~crossing
        paint |= zebra_paint(x, y, scene.zebra, w)
    if scene.crossing is not None:
        xc0 = scene.crossing[0]
        paint |= (x >= xc0 - 2.6) & (x <= xc0 - 2.1) & (y <= 0) & (y >= -(w - scene.parking_lane))
    white = 212 + 10 * _cell_noise(x, y, 0.05, 3)
    rgb[paint] = white[paint, None]
    return rgb


def _sidewalk_albedo(scene: StreetScene, x: np.ndarray, y: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(N, 3) paving colour at street-frame points (x, y) = (a, b): tiles of 0.3 m with grout
    lines faded with distance, kerbstones."""
    tile = 0.3
    base = 156 + 7 * _cell_noise(x, y, tile, 4) + 4 * _cell_noise(x, y, 0.03, 5)
    fx = scene.camera.fx
    fu, fv = np.mod(x / tile, 1.0), np.mod(y / tile, 1.0)
    edge = np.minimum(np.minimum(fu, 1 - fu), np.minimum(fv, 1 - fv)) * tile
    grout = (edge < 0.01) * np.clip(0.012 * fx / depth - 0.6, 0, 1)
    base = base * (1 - 0.18 * grout)
    rgb = np.stack([base + 2, base, base - 4], axis=1)
    if scene.has_road:
        w = scene.road_half_width
        kerbstone = (np.abs(y) - w < 0.16) & (np.abs(y) > w) & ~scene.street_in_crossing(x)
        if scene.street_end is not None:  # the kerb across the street's end
            kerbstone |= (np.abs(y) <= w) & (x - scene.street_end < 0.16)
        rgb[kerbstone] = (178 + 5 * _cell_noise(x, y, 1.0, 6))[kerbstone, None]
    return rgb


def _box_albedo(box: Box, p: np.ndarray, face: np.ndarray, y_center_sign: float) -> np.ndarray:
    """(N, 3) colour of box surface points p (N, 3, in the box's frame) on faces ``face`` (N,)."""
    color = np.array(box.color, np.float32)
    n = len(p)
    rgb = np.broadcast_to(color, (n, 3)).copy()
    axis = face // 2
    lo, hi = np.array(box.lo), np.array(box.hi)
    s = np.where(axis == 0, p[:, 1] - lo[1], p[:, 0] - lo[0])  # horizontal coordinate on the face
    zz = p[:, 2] - lo[2]
    top = hi[2] - lo[2]
    if box.texture == "facade":
        fl = np.floor(zz / box.floor_height)
        fz = zz / box.floor_height - fl
        col = np.floor(s / box.window_spacing)
        fs = s / box.window_spacing - col
        grain = 1 + 0.035 * _cell_noise(s, zz, 0.12, 7)
        rgb *= grain[:, None]
        vertical = axis != 2
        window = vertical & (fl >= 1) & (fz > 0.32) & (fz < 0.78) & (fs > 0.3) & (fs < 0.7) & (zz < top - 0.9)
        sill = vertical & (fl >= 1) & (fz > 0.28) & (fz <= 0.32) & (fs > 0.28) & (fs < 0.72) & (zz < top - 0.9)
        # about half of the buildings have shop windows on the ground floor, the rest small ones
        shops = bool(_hash01(np.floor(lo[:1] * 10), np.floor(lo[1:2] * 10), 10)[0] < 0.5)
        if shops:
            shop = vertical & (fl == 0) & (fz > 0.15) & (fz < 0.8) & (fs > 0.1) & (fs < 0.9)
        else:
            shop = vertical & (fl == 0) & (fz > 0.4) & (fz < 0.78) & (fs > 0.3) & (fs < 0.7)
        shade = _hash01(fl + 7 * (face + 1), col, 8)
        glass = np.stack([62 + 58 * shade, 70 + 58 * shade, 80 + 60 * shade], axis=1)
        rgb[window | shop] = glass[window | shop]
        rgb[sill] = np.minimum(color * 1.18, 255)
        rgb[vertical & (zz > top - 0.45)] *= 0.82  # cornice
        rgb[vertical & (zz < 0.35)] *= 0.7  # plinth
        rgb[axis == 2] = (96, 92, 90)  # roofs
    elif box.texture == "car_body":
        rgb[zz < 0.14 * top] = (40, 40, 42)  # sills and bumpers
        ends = axis == 0
        lamp_y = np.minimum(p[:, 1] - lo[1], hi[1] - p[:, 1])
        lamp = ends & (zz > 0.55 * top) & (zz < 0.8 * top) & (lamp_y < 0.32)
        # cars on the right (y < 0) face +x, on the left -x, unless their nose says: rear lamps are red
        nose = box.nose or (1 if y_center_sign < 0 else -1)
        rear = (face == 0) if nose > 0 else (face == 1)
        rgb[lamp & rear] = (170, 28, 30)
        rgb[lamp & ~rear] = (215, 212, 200)
        plate = ends & (zz > 0.25 * top) & (zz < 0.45 * top) & (np.abs(p[:, 1] - (lo[1] + hi[1]) / 2) < 0.26)
        rgb[plate] = (220, 220, 215)
    elif box.texture == "glass":
        length = np.where(axis == 0, hi[1] - lo[1], hi[0] - lo[0])
        pillar = (np.minimum(s, length - s) < 0.12) | (zz > top - 0.06)
        glass = (axis != 2) & ~pillar
        rgb[glass] = (44, 50, 58)
    return rgb


def _sky_rgb(buf: Buffers, idx: np.ndarray, clouds: np.ndarray) -> np.ndarray:
    """(N, 3) overcast sky gradient by elevation plus soft cloud brightness."""
    dx, dy, dz = (c.ravel()[idx] for c in buf.d)
    e = dz / np.sqrt(dx * dx + dy * dy + dz * dz)  # sine of the elevation
    f = np.clip((e + 0.02) / 0.3, 0, 1)[:, None]
    horizon, zenith = np.array([206, 210, 215], np.float32), np.array([158, 176, 202], np.float32)
    return horizon * (1 - f) + zenith * f + clouds.ravel()[idx, None]


def shade(scene: StreetScene, buf: Buffers, ego: np.ndarray, rng: np.random.Generator,
          sunlit: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 3) float32 colour 0-255 before noise: albedo x (sky ambient + sun Lambert), haze.
    With a scene light, ``sunlit`` (H * W bool, when given) receives where the sun reaches."""
    cam = scene.camera
    h, w = cam.height, cam.width
    pid = buf.pid.ravel()
    order = np.argsort(pid, kind="stable")
    n_obj = len(scene.boxes) + len(scene.poles)
    bounds = np.searchsorted(pid[order], np.arange(PID_EGO, PID_FIRST_OBJECT + n_obj + 1))
    groups = {p: order[bounds[i]:bounds[i + 1]] for i, p in enumerate(range(PID_EGO, PID_FIRST_OBJECT + n_obj))}
    sh = _Shader(scene, buf, sunlit, h * w)
    # sky
    clouds = cv2.resize(rng.standard_normal((6, 12)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC) * 5
    idx = groups[PID_SKY]
    sh.rgb[idx] = _sky_rgb(buf, idx, clouds)
    if scene.light is not None:  # optional light control (SceneLight)
        sh.rgb[idx] = light_tint(scene, sh.rgb[idx])
    _shade_ground(sh, groups)
    _shade_objects(sh, groups)
    return _ego_bonnet(sh.rgb.reshape(h, w, 3), ego, scene)


class _Shader:
    """The colours being shaded (``rgb``, per pixel) and how a pixel is lit: the sun (in the
    street frame), the haze, the scene's light."""

    def __init__(self, scene: StreetScene, buf: Buffers, sunlit: np.ndarray | None, n_pix: int) -> None:
        self.scene, self.buf, self.sunlit = scene, buf, sunlit
        self.rgb = np.zeros((n_pix, 3), np.float32)
        self.depth = buf.depth.ravel()
        sun = np.array(scene.sun, np.float64)
        if not scene.street_is_vehicle_frame:  # shading happens in the street frame
            sun = scene.vehicle_from_street[:3, :3].T @ sun
        self.sun = sun.astype(np.float32)
        self.haze = np.array([204, 208, 213], np.float32)
        if scene.light is not None:  # optional light control (SceneLight)
            self.haze = light_tint(scene, self.haze)

    def lit(self, idx: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> None:
        scene = self.scene
        if scene.light is not None:  # optional light control (SceneLight)
            col = light_shade(scene, albedo, normal, self.points(idx), self.sun,
                              None if self.sunlit is None else (self.sunlit, idx))
        else:
            light = 0.7 + 0.2 * normal[:, 2] + 0.32 * np.maximum(normal @ self.sun, 0)
            col = albedo * light[:, None]
        fog = (1 - np.exp(-self.depth[idx] / np.float32(700.0)))[:, None]
        self.rgb[idx] = col * (1 - fog) + self.haze * fog

    def points(self, idx: np.ndarray) -> np.ndarray:
        t = self.depth[idx]
        return np.stack([self.buf.origin[i] + t * self.buf.d[i].ravel()[idx] for i in range(3)], axis=1)

    def face_normals(self, idx: np.ndarray, rotation: np.ndarray | None = None) -> np.ndarray:
        face = self.buf.face.ravel()[idx].astype(np.int64)
        n = np.zeros((len(idx), 3), np.float32)
        n[np.arange(len(idx)), face // 2] = np.where(face % 2 == 1, 1.0, -1.0)
        return n if rotation is None else n @ rotation.T.astype(np.float32)


def _feet(scene: StreetScene) -> dict[int, list[float]]:
    """The ground footprint (x0, y0, x1, y1) of each car and person standing on the ground: the
    ground darkens under and around them (contact shadow)."""
    feet: dict[int, list[float]] = {}
    for box in scene.boxes:
        if box.label not in ("car", "person"):
            continue
        if box.rotation is not None:  # tilted car: its frame's ground is at the pivot
            ground = box.pivot[2]
        else:
            ground = float(scene.street_ground_height((box.lo[0] + box.hi[0]) / 2, (box.lo[1] + box.hi[1]) / 2))
        if box.lo[2] <= ground + 0.05:
            f = feet.setdefault(box.instance_id, [np.inf, np.inf, -np.inf, -np.inf])
            f[:] = [min(f[0], box.lo[0]), min(f[1], box.lo[1]), max(f[2], box.hi[0]), max(f[3], box.hi[1])]
    return feet


def _shade_ground(sh: _Shader, groups: dict) -> None:
    """Road, sidewalk and kerb faces, darkened around the feet of what stands on them."""
    scene, buf, depth = sh.scene, sh.buf, sh.depth
    feet = _feet(scene)
    for p in (PID_ROAD, PID_SIDEWALK, PID_KERB):
        idx = groups[p]
        if not len(idx):
            continue
        pt = sh.points(idx)
        if p == PID_ROAD:
            albedo = _road_albedo(scene, pt[:, 0], pt[:, 1])
        elif p == PID_SIDEWALK:
            albedo = _sidewalk_albedo(scene, pt[:, 0], pt[:, 1], depth[idx])
        else:
            along = np.where(buf.face.ravel()[idx] // 2 == 0, pt[:, 1], pt[:, 0])
            g = 170 + 6 * _cell_noise(along, pt[:, 2], 1.0, 9)
            albedo = np.stack([g, g, g - 3], axis=1)
        if p == PID_KERB:
            normal = sh.face_normals(idx)
        else:
            normal = scene.street_ground_normal(pt[:, 0].astype(np.float64), pt[:, 1].astype(np.float64))
            normal = normal.astype(np.float32)
            ao = np.ones(len(idx), np.float32)
            for x0, y0, x1, y1 in feet.values():
                ddx = np.maximum(np.maximum(x0 - pt[:, 0], pt[:, 0] - x1), 0)
                ddy = np.maximum(np.maximum(y0 - pt[:, 1], pt[:, 1] - y1), 0)
                ao *= 1 - 0.55 * np.exp(-(ddx * ddx + ddy * ddy) / np.float32(0.1))
            albedo *= ao[:, None]
        sh.lit(idx, albedo, normal)


def _shade_objects(sh: _Shader, groups: dict) -> None:
    """The boxes (buildings, cars, people) and the poles."""
    scene = sh.scene
    for i, box in enumerate(scene.boxes):
        idx = groups[PID_FIRST_OBJECT + i]
        if len(idx):
            face = sh.buf.face.ravel()[idx].astype(np.int64)
            m, pt = box.matrix, sh.points(idx)
            if m is not None:  # street frame -> the box's frame
                pt = ((pt - m[:3, 3]) @ m[:3, :3]).astype(np.float32)
            albedo = _box_albedo(box, pt, face, float(np.sign(box.lo[1] + box.hi[1])))
            sh.lit(idx, albedo, sh.face_normals(idx, None if m is None else m[:3, :3]))
    for j, pole in enumerate(scene.poles):
        idx = groups[PID_FIRST_OBJECT + len(scene.boxes) + j]
        if len(idx):
            pt = sh.points(idx)
            n = np.zeros((len(idx), 3), np.float32)
            n[:, 0], n[:, 1] = (pt[:, 0] - pole.x) / pole.radius, (pt[:, 1] - pole.y) / pole.radius
            albedo = np.broadcast_to(np.array(pole.color, np.float32), (len(idx), 3)).copy()
            albedo[pt[:, 2] - pole.base_z < 0.3] *= 0.7
            sh.lit(idx, albedo, n)


def _ego_bonnet(rgb: np.ndarray, ego: np.ndarray, scene: StreetScene) -> np.ndarray:
    """The ego bonnet: dark paint with a faint sky reflection towards its top edge."""
    h = rgb.shape[0]
    rows = np.arange(h, dtype=np.float32)[:, None]
    top = np.argmax(ego, axis=0).astype(np.float32)[None, :]
    refl = np.exp(-np.maximum(rows - top, 0) / max(scene.ego_rows * 0.35, 1.0))
    bonnet = 26 + 34 * refl
    for c, off in enumerate((0, 2, 6)):
        rgb[..., c] = np.where(ego, bonnet + off, rgb[..., c])
    return rgb

