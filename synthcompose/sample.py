"""Synthetic Cityscapes image sets of a straight street, with exactly known geometry.

Each frame is a procedurally drawn street scene (:class:`StreetScene`) ray-cast analytically,
one ray per pixel centre, in vectorised NumPy. The result is written in the exact Cityscapes
layout (see :mod:`synthcompose.dataset`), so the demo and the tests can run on data whose
depth, labels and instances are known exactly.

Scene, in the vehicle frame V (ISO 8855: x forward, y left, z up; metres; road surface z = 0)::

        building row        | sidewalk |   road (|y| <= w)   | sidewalk |   building row
    y = w + s + ...   w + s |  z = k   | w                -w |  z = k   | -w - s
                            ^ kerb face (label sidewalk), height k

* road: plane z = 0 for ``|y| <= road_half_width`` and over a cross street spanning
  ``crossing = (x0, x1)``; dashed centre line, solid parking-lane lines, a stop line.
* sidewalks: plane z = ``kerb_height`` elsewhere; their vertical kerb faces are sidewalk too.
* buildings: rows of boxes from ``|y| = road_half_width + sidewalk_width`` outwards, broken by
  the cross street; optionally a row across the far end of the street.
* parked cars (instances 26000 + k), poles (label id 17, no instances), pedestrians
  (instances 24000 + k) as boxes and vertical cylinders.
* the ego vehicle's bonnet covers the bottom ~4-6 % of the rows.

Rays: pixel (u, v) (integer = pixel centre) has optical-frame direction
``((u - u0) / fx, (v - v0) / fy, 1)``, so the ray parameter of a hit *is* its depth (optical z).
Sky and ego vehicle have infinite depth and disparity 0; about 2 % of the other pixels get
disparity 0 too (stereo holes). Everything random comes from the ``rng`` handed to
:func:`random_scene` (and the scene's ``noise_seed``), so a seed gives byte-identical files.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .camera import Camera
from .dataset import ImageSetId
from .fileio import write_json, write_png
from .geometry import depth_to_disparity
from .labels import INSTANCE_FACTOR, KNOWN_IDS, colorize, label_id

Vec3 = tuple[float, float, float]
RGB = tuple[int, int, int]

#: fraction of valid pixels whose disparity is set to 0 (stereo holes)
HOLE_FRACTION = 0.02
#: box textures understood by the renderer
TEXTURES = ("plain", "facade", "car_body", "glass")

_ROAD, _SIDEWALK, _SKY, _EGO = (label_id(n) for n in ("road", "sidewalk", "sky", "ego vehicle"))
_POLE = label_id("pole")

# primitive ids in the id buffer
_PID_EGO, _PID_SKY, _PID_ROAD, _PID_SIDEWALK, _PID_KERB = -2, -1, 0, 1, 2
_PID_FIRST_OBJECT = 3


# ====================================================================== scene description
@dataclass(frozen=True)
class Box:
    """An axis-aligned box in the vehicle frame V.

    lo, hi       : minimum and maximum corner (x, y, z), metres in V
    label        : Cityscapes class name of every pixel it covers
    instance_id  : value in gtFine_instanceIds: ``label_id * 1000 + k`` for instance classes
                   (several boxes of one object share it), the plain label id otherwise
    color        : base albedo, sRGB 0-255
    texture      : one of :data:`TEXTURES`; ``facade`` draws a window grid using
                   ``floor_height`` and ``window_spacing`` (metres)
    """

    lo: Vec3
    hi: Vec3
    label: str
    instance_id: int
    color: RGB = (128, 128, 128)
    texture: str = "plain"
    floor_height: float = 3.2
    window_spacing: float = 2.6

    def __post_init__(self) -> None:
        if not all(a < b for a, b in zip(self.lo, self.hi)):
            raise ValueError(f"box corners must satisfy lo < hi on every axis: {self.lo} {self.hi}")
        lid = label_id(self.label)
        if self.instance_id != lid and self.instance_id // INSTANCE_FACTOR != lid:
            raise ValueError(f"instance id {self.instance_id} does not belong to class {self.label!r}")
        if self.texture not in TEXTURES:
            raise ValueError(f"unknown texture {self.texture!r}; known: {TEXTURES}")


@dataclass(frozen=True)
class Pole:
    """A vertical cylinder (label ``pole``, instance id = label id 17), metres in V.

    x, y    : axis position; radius; height above ``base_z`` (its bottom, the ground there).
    """

    x: float
    y: float
    radius: float
    height: float
    base_z: float
    color: RGB = (98, 102, 100)


@dataclass(frozen=True)
class StreetScene:
    """One synthetic street frame: camera plus geometry in the vehicle frame V (metres).

    road_half_width  : the road is ``|y| <= road_half_width`` (plus the cross street)
    kerb_height      : sidewalk top height above the road (0 when there is no road)
    sidewalk_width   : sidewalks span ``road_half_width < |y| <= road_half_width + sidewalk_width``
    boxes, poles     : the solid objects (buildings, cars, pedestrians; poles)
    has_road         : False: no road anywhere, the whole ground is sidewalk
    crossing         : (x0, x1) x-range of a cross street (road for every y), or None
    ego_rows         : rows of the bonnet at the image centre column (fewer at the sides)
    lane_dash        : centre-line dash length, gap and phase (metres)
    parking_lane     : width of the parking lane along each kerb (solid line at its edge)
    sun              : unit vector towards the sun in V
    noise_seed       : seed of the image noise, cloud pattern and disparity holes
    """

    camera: Camera
    road_half_width: float
    kerb_height: float
    sidewalk_width: float
    boxes: tuple[Box, ...]
    poles: tuple[Pole, ...]
    has_road: bool = True
    crossing: tuple[float, float] | None = None
    ego_rows: int = 0
    lane_dash: tuple[float, float, float] = (3.0, 6.0, 0.0)
    parking_lane: float = 2.2
    sun: Vec3 = (0.3, 0.4, 0.866)
    noise_seed: int = 0

    # ------------------------------------------------------------------ ground plan
    def in_crossing(self, x: np.ndarray) -> np.ndarray:
        """Bool array: x (metres in V) lies within the cross street's x-range."""
        x = np.asarray(x)
        if self.crossing is None:
            return np.zeros(x.shape, bool)
        return (x >= self.crossing[0]) & (x <= self.crossing[1])

    def is_road(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bool array (broadcast shape of x, y): the ground at (x, y) in V is road."""
        x, y = np.broadcast_arrays(np.asarray(x), np.asarray(y))
        if not self.has_road:
            return np.zeros(x.shape, bool)
        return (np.abs(y) <= self.road_half_width) | self.in_crossing(x)

    def ground_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Ground height z (metres, V) at ground-plan points (x, y): 0 on road, kerb height else.

        Ignores objects standing on the ground (cars, poles, buildings' volumes).
        """
        road = self.is_road(x, y)
        return np.where(road, 0.0, self.kerb_height)

    def surface_label(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Class name of the ground plan at (x, y) in V: ``'road'``, ``'sidewalk'`` or
        ``'building'`` (the blocks behind the sidewalks). Returns a ``<U8`` string array of the
        broadcast shape of x and y (0-d for scalars; ``str(...)`` gives the name)."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        out = np.full(x.shape, "building", "<U8")
        walk = (np.abs(y) <= self.road_half_width + self.sidewalk_width) | self.in_crossing(x)
        out[walk] = "sidewalk"
        out[self.is_road(x, y)] = "road"
        return out


# ====================================================================== random scenes
_FACADES: tuple[RGB, ...] = (
    (196, 184, 160), (214, 206, 188), (172, 162, 150), (152, 96, 76), (204, 192, 146),
    (182, 181, 178), (160, 168, 174), (208, 172, 144), (226, 220, 206), (128, 122, 116),
)
_CAR_PAINT: tuple[RGB, ...] = (
    (188, 190, 194), (34, 35, 39), (226, 226, 222), (40, 54, 92), (138, 30, 32),
    (96, 99, 102), (58, 78, 68), (150, 150, 155),
)
_CLOTHES: tuple[RGB, ...] = ((40, 42, 60), (30, 30, 32), (120, 40, 40), (70, 90, 60), (150, 140, 120),
                              (60, 70, 110), (180, 180, 185))


def _jitter(rng: np.random.Generator, color: RGB, amount: int) -> RGB:
    c = np.clip(np.array(color) + rng.integers(-amount, amount + 1, 3), 0, 255)
    return (int(c[0]), int(c[1]), int(c[2]))


def _pick(rng: np.random.Generator, items: tuple[RGB, ...]) -> RGB:
    return items[int(rng.integers(len(items)))]


def random_camera(rng: np.random.Generator, width: int, height: int) -> Camera:
    """A Cityscapes-like camera for a ``width`` x ``height`` image (intrinsics scale with width)."""
    s = width / 2048.0
    fx = 2262.5 * s * (1.0 + rng.uniform(-0.004, 0.004))
    return Camera(
        fx=round(fx, 4), fy=round(fx * (1.0 + rng.uniform(0.0, 0.002)), 4),
        u0=round(width / 2 + (50.0 + rng.uniform(-6.0, 6.0)) * s, 4),
        v0=round(height / 2 + rng.uniform(-3.0, 5.0) * s, 4),
        baseline=round(rng.uniform(0.209, 0.22), 6),
        x=round(1.7 + rng.uniform(-0.03, 0.03), 6), y=round(0.1 + rng.uniform(-0.03, 0.03), 6),
        z=round(1.22 + rng.uniform(-0.03, 0.03), 6),
        yaw=round(rng.uniform(-0.02, 0.02), 6), pitch=round(rng.uniform(0.03, 0.05), 6),
        roll=round(rng.uniform(-0.005, 0.005), 6), width=int(width), height=int(height))


def _building_row(rng: np.random.Generator, side: int, x_from: float, x_to: float, y_front: float,
                  base_z: float, extend_to: float | None) -> list[Box]:
    """Abutting building boxes along x in [x_from, x_to] on one side (side = +1 left, -1 right).

    The last box reaches ``extend_to`` instead of ``x_to`` when given (street to the horizon).
    """
    boxes: list[Box] = []
    depth = 40.0  # deep blocks: rays through the cross street never see behind them
    x = x_from
    while x < x_to - 1e-6:
        length = rng.uniform(8.0, 22.0)
        end = x + length
        if x_to - end < 5.0:
            end = x_to
        far = extend_to if (end >= x_to and extend_to is not None) else end
        y0, y1 = sorted((side * y_front, side * (y_front + depth)))
        boxes.append(Box((x, y0, base_z), (far, y1, base_z + rng.uniform(8.0, 20.0)), "building",
                         label_id("building"), _jitter(rng, _pick(rng, _FACADES), 8), "facade",
                         floor_height=rng.uniform(2.9, 3.5), window_spacing=rng.uniform(2.2, 3.2)))
        x = end
    return boxes


def _segment_hits_rect(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Does the 2D segment a-b pass through the axis-aligned rectangle [lo, hi]?"""
    t = np.linspace(0.0, 1.0, 400)[:, None]
    p = a + t * (b - a)
    return bool(np.any(np.all((p >= lo) & (p <= hi), axis=1)))


def _car_boxes(rng: np.random.Generator, xc: float, yc: float, ground: float, facing: int,
               instance: int) -> list[Box]:
    """A parked car as body, cabin and four wheel boxes, centred at (xc, yc), nose to ``facing``."""
    length, width, height = rng.uniform(3.9, 4.6), rng.uniform(1.72, 1.86), rng.uniform(1.4, 1.56)
    paint = _jitter(rng, _pick(rng, _CAR_PAINT), 6)
    body_lo, body_top = ground + 0.3, ground + 0.62 * height
    boxes = [Box((xc - length / 2, yc - width / 2, body_lo), (xc + length / 2, yc + width / 2, body_top),
                 "car", instance, paint, "car_body")]
    c0, c1 = -0.30 * length, 0.24 * length  # cabin set back towards the rear
    if facing < 0:
        c0, c1 = -c1, -c0
    boxes.append(Box((xc + c0, yc - width / 2 + 0.07, body_top), (xc + c1, yc + width / 2 - 0.07, ground + height),
                     "car", instance, paint, "glass"))
    for wx in (-1, 1):
        for wy in (-1, 1):
            cx, cy = xc + wx * (length / 2 - 0.82), yc + wy * (width / 2 - 0.13)
            boxes.append(Box((cx - 0.33, cy - 0.11, ground), (cx + 0.33, cy + 0.11, ground + 0.62),
                             "car", instance, (26, 26, 28)))
    return boxes


def _person_boxes(rng: np.random.Generator, xc: float, yc: float, ground: float, instance: int) -> list[Box]:
    """A standing pedestrian as legs, torso and head boxes."""
    h = rng.uniform(1.6, 1.88)
    legs, torso = _pick(rng, _CLOTHES), _jitter(rng, _pick(rng, _CLOTHES), 10)
    skin = _jitter(rng, (196, 160, 136), 20)
    return [
        Box((xc - 0.12, yc - 0.17, ground), (xc + 0.12, yc + 0.17, ground + 0.47 * h), "person", instance, legs),
        Box((xc - 0.14, yc - 0.23, ground + 0.47 * h), (xc + 0.14, yc + 0.23, ground + 0.83 * h),
            "person", instance, torso),
        Box((xc - 0.10, yc - 0.09, ground + 0.85 * h), (xc + 0.10, yc + 0.09, ground + h), "person", instance, skin),
    ]


def random_scene(rng: np.random.Generator, width: int, height: int, *, road: bool = True) -> StreetScene:
    """Draw a street scene for a ``width`` x ``height`` image.

    The same ``rng`` state gives the same scene; ``road=False`` draws the same random numbers
    but turns the whole ground into a flat sidewalk (kerb height 0, no ``road`` pixel at all).
    At least one pole stands at the near corner of the cross street with road behind it, and no
    parked car hides it, so occlusion of road by a pole is always present.
    """
    camera = random_camera(rng, width, height)
    w = float(rng.uniform(4.2, 6.0))
    kerb = float(rng.uniform(0.12, 0.15)) if road else 0.0
    walk = float(rng.uniform(3.0, 4.0))
    xc0 = float(rng.uniform(24.0, 40.0))
    xc1 = xc0 + float(rng.uniform(10.0, 16.0))
    x_end = float(rng.uniform(130.0, 220.0))
    end_row = bool(rng.random() < 0.6)
    ego_rows = max(1, round(height * rng.uniform(0.04, 0.06)))
    az, el = rng.uniform(0.0, 2 * math.pi), rng.uniform(0.5, 0.9)
    sun = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    dash = (3.0, 6.0, float(rng.uniform(0.0, 9.0)))

    boxes: list[Box] = []
    for side in (1, -1):
        extend = None if end_row else 3000.0
        boxes += _building_row(rng, side, -25.0, xc0, w + walk, kerb, None)
        boxes += _building_row(rng, side, xc1, x_end, w + walk, kerb, extend)
    if end_row:
        boxes.append(Box((x_end, -150.0, 0.0), (x_end + 25.0, 150.0, float(rng.uniform(12.0, 26.0))), "building",
                         label_id("building"), _jitter(rng, _pick(rng, _FACADES), 8), "facade",
                         floor_height=float(rng.uniform(2.9, 3.5)), window_spacing=float(rng.uniform(2.2, 3.2))))

    # poles: 1-2 at the near corners of the cross street, the rest along the kerbs
    poles: list[Pole] = []
    corner_sides = [1, -1] if rng.random() < 0.4 else [int(rng.choice([1, -1]))]
    for side in corner_sides:
        poles.append(Pole(xc0 - float(rng.uniform(0.5, 1.0)), side * (w + float(rng.uniform(0.35, 0.6))),
                          float(rng.uniform(0.06, 0.1)), float(rng.uniform(3.6, 4.8)), kerb))
    n_poles = int(rng.integers(2, 5))
    for _ in range(200):
        if len(poles) >= n_poles:
            break
        side = int(rng.choice([1, -1]))
        px = float(rng.uniform(7.0, 75.0))
        if xc0 - 4 <= px <= xc1 + 2 or any(abs(px - p.x) < 4.0 for p in poles):
            continue
        poles.append(Pole(px, side * (w + float(rng.uniform(0.35, 0.6))), float(rng.uniform(0.06, 0.1)),
                          float(rng.uniform(3.6, 4.8)), kerb))
    corner = poles[:len(corner_sides)]

    # parked cars along the kerbs, in their side's direction of travel (right-hand traffic)
    car_id = label_id("car") * INSTANCE_FACTOR
    n_cars = int(rng.integers(2, 6))
    placed: list[tuple[float, float, float]] = []  # (x_min, x_max, side)
    cam_xy = np.array([camera.x, camera.y])
    for _ in range(400):
        if len(placed) >= n_cars:
            break
        side = int(rng.choice([1, -1]))
        xc, yoff = float(rng.uniform(6.0, 85.0)), float(rng.uniform(0.15, 0.35))
        half_len, half_wid = 2.35, 0.95  # conservative footprint for the checks
        x0, x1 = xc - half_len, xc + half_len
        if x1 > xc0 - 5.0 and x0 < xc1 + 3.0:
            continue  # no parking at the crossing
        if any(s == side and x0 < b + 1.0 and x1 > a - 1.0 for a, b, s in placed):
            continue
        yc = side * (w - yoff - half_wid)
        lo, hi = np.array([x0, yc - half_wid]), np.array([x1, yc + half_wid])
        if any(_segment_hits_rect(cam_xy, np.array([p.x, p.y]), lo - p.radius, hi + p.radius) for p in corner):
            continue  # keep the corner poles in full view
        boxes += _car_boxes(rng, xc, yc, 0.0, -side, car_id + len(placed))
        placed.append((x0, x1, side))

    # 0-2 pedestrians on the sidewalks
    person_id = label_id("person") * INSTANCE_FACTOR
    n_people, people = int(rng.integers(0, 3)), 0
    for _ in range(200):
        if people >= n_people:
            break
        side = int(rng.choice([1, -1]))
        px, py = float(rng.uniform(8.0, 60.0)), side * (w + float(rng.uniform(0.9, walk - 0.5)))
        if xc0 - 3 <= px <= xc1 + 1 or any(abs(px - p.x) < 2.0 for p in poles):
            continue
        boxes += _person_boxes(rng, px, py, kerb, person_id + people)
        people += 1

    return StreetScene(camera=camera, road_half_width=w, kerb_height=kerb, sidewalk_width=walk,
                       boxes=tuple(boxes), poles=tuple(poles), has_road=road, crossing=(xc0, xc1),
                       ego_rows=int(ego_rows), lane_dash=dash, sun=sun,
                       noise_seed=int(rng.integers(0, 2**62)))


# ====================================================================== ray casting
@dataclass(eq=False)
class _Buffers:
    """Per-pixel ray and hit data, all (H, W). Directions are in V with optical z = 1."""

    origin: np.ndarray  # (3,) float64 camera centre in V
    d: tuple[np.ndarray, np.ndarray, np.ndarray]  # dx, dy, dz float32
    depth: np.ndarray  # float32, inf = no hit
    pid: np.ndarray  # int16 primitive id
    face: np.ndarray  # int8: 2*axis + (1 if normal points to +axis else 0)


def _rays(camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(H, W) float32 x, y, z components in V of every pixel-centre ray (optical z = 1)."""
    a = ((np.arange(camera.width) - camera.u0) / camera.fx).astype(np.float32)[None, :]
    b = ((np.arange(camera.height) - camera.v0) / camera.fy).astype(np.float32)[:, None]
    m = camera.vehicle_from_optical[:3, :3].astype(np.float32)
    dx, dy, dz = (m[i, 0] * a + m[i, 1] * b + m[i, 2] for i in range(3))
    return dx, dy, dz


def _screen_rect(camera: Camera, lo: np.ndarray, hi: np.ndarray) -> tuple[slice, slice] | None:
    """Pixel rows/columns that can see the box [lo, hi] (V), or None if it is all behind."""
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)], float)
    m = camera.optical_from_vehicle
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


def _commit(buf: _Buffers, rect: tuple[slice, slice], t: np.ndarray, hit: np.ndarray, pid: int,
            face: np.ndarray | int) -> None:
    """Z-buffer update inside ``rect``: keep hits nearer than what is there."""
    depth = buf.depth[rect]
    win = hit & (t < depth)
    depth[win] = t[win]
    buf.pid[rect][win] = pid
    buf.face[rect][win] = face[win] if isinstance(face, np.ndarray) else face


def _cast_ground(scene: StreetScene, buf: _Buffers) -> None:
    """Road plane, sidewalk top plane and kerb faces, over the whole image."""
    ox, oy, oz = (float(c) for c in buf.origin)
    dx, dy, dz = buf.d
    full = (slice(None), slice(None))
    w, k = np.float32(scene.road_half_width), np.float32(scene.kerb_height)
    with np.errstate(divide="ignore", invalid="ignore"):
        for height, pid in ((0.0, _PID_ROAD), (scene.kerb_height, _PID_SIDEWALK)):
            t = np.where(dz < 0, np.float32(height - oz) / dz, np.float32(np.inf))
            road = scene.is_road(ox + t * dx, oy + t * dy)
            hit = np.isfinite(t) & (road if pid == _PID_ROAD else ~road)
            _commit(buf, full, t, hit, pid, 5)
        if not scene.has_road or scene.kerb_height <= 0:
            return
        # kerb faces along the road (y = +-w, facing the road) and the far side of the crossing
        for sign in (1, -1):
            t = np.float32(sign * w - oy) / dy
            z, x = oz + t * dz, ox + t * dx
            hit = (sign * dy > 0) & (z >= 0) & (z <= k) & ~scene.in_crossing(x)
            _commit(buf, full, t, hit, _PID_KERB, 2 if sign > 0 else 3)
        if scene.crossing is not None:
            t = np.float32(scene.crossing[1] - ox) / dx
            z, y = oz + t * dz, oy + t * dy
            hit = (dx > 0) & (z >= 0) & (z <= k) & (np.abs(y) > w)
            _commit(buf, full, t, hit, _PID_KERB, 0)


def _cast_box(box: Box, pid: int, buf: _Buffers, camera: Camera) -> None:
    """Slab test of one box over the pixels of its screen rectangle."""
    lo, hi = np.array(box.lo), np.array(box.hi)
    rect = _screen_rect(camera, lo, hi)
    if rect is None:
        return
    t_near = np.full(buf.depth[rect].shape, -np.inf, np.float32)
    t_far = np.full(t_near.shape, np.inf, np.float32)
    face = np.zeros(t_near.shape, np.int8)
    with np.errstate(divide="ignore", invalid="ignore"):
        for axis in range(3):
            d = buf.d[axis][rect]
            inv = np.float32(1.0) / d
            o = buf.origin[axis]
            t1, t2 = np.float32(lo[axis] - o) * inv, np.float32(hi[axis] - o) * inv
            tmin, tmax = np.minimum(t1, t2), np.maximum(t1, t2)
            later = tmin > t_near
            t_near = np.where(later, tmin, t_near)
            face = np.where(later, np.int8(2 * axis) + (d < 0).astype(np.int8), face)
            t_far = np.minimum(t_far, tmax)
    _commit(buf, rect, t_near, (t_near <= t_far) & (t_near > 0), pid, face)


def _cast_pole(pole: Pole, pid: int, buf: _Buffers, camera: Camera) -> None:
    """Ray / vertical cylinder side intersection (float64 for a stable discriminant)."""
    r = pole.radius
    rect = _screen_rect(camera, np.array([pole.x - r, pole.y - r, pole.base_z]),
                        np.array([pole.x + r, pole.y + r, pole.base_z + pole.height]))
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


def _ego_mask(height: int, width: int, ego_rows: int) -> np.ndarray:
    """(H, W) bool: the bonnet, ``ego_rows`` tall at the centre column, 35 % less at the sides."""
    u = (np.arange(width) - width / 2) / (width / 2)
    top = height - ego_rows + np.rint(0.35 * ego_rows * u * u).astype(int)
    return np.arange(height)[:, None] >= top[None, :]


# ====================================================================== shading
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
    """(N, 3) asphalt colour with markings at road points (x, y) in V."""
    base = 88 + 7 * _cell_noise(x, y, 0.04, 1) + 4 * _cell_noise(x, y, 1.7, 2)
    rgb = np.stack([base, base + 1, base + 3], axis=1)
    w, ay = scene.road_half_width, np.abs(y)
    crossing = scene.in_crossing(x)
    dash, gap, phase = scene.lane_dash
    paint = (ay <= 0.07) & (np.mod(x - phase, dash + gap) < dash) & ~crossing
    paint |= (np.abs(ay - (w - scene.parking_lane)) <= 0.06) & ~crossing
    if scene.crossing is not None:
        xc0 = scene.crossing[0]
        paint |= (x >= xc0 - 2.6) & (x <= xc0 - 2.1) & (y <= 0) & (y >= -(w - scene.parking_lane))
    white = 212 + 10 * _cell_noise(x, y, 0.05, 3)
    rgb[paint] = white[paint, None]
    return rgb


def _sidewalk_albedo(scene: StreetScene, x: np.ndarray, y: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(N, 3) paving colour: tiles of 0.3 m with grout lines faded with distance, kerbstones."""
    tile = 0.3
    base = 156 + 7 * _cell_noise(x, y, tile, 4) + 4 * _cell_noise(x, y, 0.03, 5)
    fx = scene.camera.fx
    fu, fv = np.mod(x / tile, 1.0), np.mod(y / tile, 1.0)
    edge = np.minimum(np.minimum(fu, 1 - fu), np.minimum(fv, 1 - fv)) * tile
    grout = (edge < 0.01) * np.clip(0.012 * fx / depth - 0.6, 0, 1)
    base = base * (1 - 0.18 * grout)
    rgb = np.stack([base + 2, base, base - 4], axis=1)
    if scene.has_road:
        kerbstone = (np.abs(y) - scene.road_half_width < 0.16) & ~scene.in_crossing(x)
        rgb[kerbstone] = (178 + 5 * _cell_noise(x, y, 1.0, 6))[kerbstone, None]
    return rgb


def _box_albedo(box: Box, p: np.ndarray, face: np.ndarray, y_center_sign: float) -> np.ndarray:
    """(N, 3) colour of box surface points p (N, 3, V) on faces ``face`` (N,)."""
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
        # cars on the right (y < 0) face +x, on the left -x: rear lamps are red
        rear = (face == 0) if y_center_sign < 0 else (face == 1)
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


def _sky_rgb(buf: _Buffers, idx: np.ndarray, clouds: np.ndarray) -> np.ndarray:
    """(N, 3) overcast sky gradient by elevation plus soft cloud brightness."""
    dx, dy, dz = (c.ravel()[idx] for c in buf.d)
    e = dz / np.sqrt(dx * dx + dy * dy + dz * dz)  # sine of the elevation
    f = np.clip((e + 0.02) / 0.3, 0, 1)[:, None]
    horizon, zenith = np.array([206, 210, 215], np.float32), np.array([158, 176, 202], np.float32)
    return horizon * (1 - f) + zenith * f + clouds.ravel()[idx, None]


def _shade(scene: StreetScene, buf: _Buffers, ego: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(H, W, 3) float32 colour 0-255 before noise: albedo x (sky ambient + sun Lambert), haze."""
    cam = scene.camera
    h, w = cam.height, cam.width
    n_pix = h * w
    rgb = np.zeros((n_pix, 3), np.float32)
    pid = buf.pid.ravel()
    order = np.argsort(pid, kind="stable")
    n_obj = len(scene.boxes) + len(scene.poles)
    bounds = np.searchsorted(pid[order], np.arange(_PID_EGO, _PID_FIRST_OBJECT + n_obj + 1))
    groups = {p: order[bounds[i]:bounds[i + 1]] for i, p in enumerate(range(_PID_EGO, _PID_FIRST_OBJECT + n_obj))}
    depth = buf.depth.ravel()
    sun = np.array(scene.sun, np.float32)
    haze = np.array([204, 208, 213], np.float32)

    # car/person ground footprints darken the ground under and around them (contact shadow)
    feet: dict[int, list[float]] = {}
    for box in scene.boxes:
        if box.label in ("car", "person") and box.lo[2] <= scene.kerb_height + 0.05:
            f = feet.setdefault(box.instance_id, [np.inf, np.inf, -np.inf, -np.inf])
            f[:] = [min(f[0], box.lo[0]), min(f[1], box.lo[1]), max(f[2], box.hi[0]), max(f[3], box.hi[1])]

    def lit(idx: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> None:
        light = 0.7 + 0.2 * normal[:, 2] + 0.32 * np.maximum(normal @ sun, 0)
        col = albedo * light[:, None]
        fog = (1 - np.exp(-depth[idx] / np.float32(700.0)))[:, None]
        rgb[idx] = col * (1 - fog) + haze * fog

    def points(idx: np.ndarray) -> np.ndarray:
        t = depth[idx]
        return np.stack([buf.origin[i] + t * buf.d[i].ravel()[idx] for i in range(3)], axis=1)

    def face_normals(idx: np.ndarray) -> np.ndarray:
        face = buf.face.ravel()[idx].astype(np.int64)
        n = np.zeros((len(idx), 3), np.float32)
        n[np.arange(len(idx)), face // 2] = np.where(face % 2 == 1, 1.0, -1.0)
        return n

    # sky
    clouds = cv2.resize(rng.standard_normal((6, 12)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC) * 5
    idx = groups[_PID_SKY]
    rgb[idx] = _sky_rgb(buf, idx, clouds)
    # ground
    for p in (_PID_ROAD, _PID_SIDEWALK, _PID_KERB):
        idx = groups[p]
        if not len(idx):
            continue
        pt = points(idx)
        if p == _PID_ROAD:
            albedo = _road_albedo(scene, pt[:, 0], pt[:, 1])
        elif p == _PID_SIDEWALK:
            albedo = _sidewalk_albedo(scene, pt[:, 0], pt[:, 1], depth[idx])
        else:
            along = np.where(buf.face.ravel()[idx] // 2 == 0, pt[:, 1], pt[:, 0])
            g = 170 + 6 * _cell_noise(along, pt[:, 2], 1.0, 9)
            albedo = np.stack([g, g, g - 3], axis=1)
        if p != _PID_KERB:
            ao = np.ones(len(idx), np.float32)
            for x0, y0, x1, y1 in feet.values():
                ddx = np.maximum(np.maximum(x0 - pt[:, 0], pt[:, 0] - x1), 0)
                ddy = np.maximum(np.maximum(y0 - pt[:, 1], pt[:, 1] - y1), 0)
                ao *= 1 - 0.55 * np.exp(-(ddx * ddx + ddy * ddy) / np.float32(0.1))
            albedo *= ao[:, None]
        lit(idx, albedo, face_normals(idx))
    # objects
    for i, box in enumerate(scene.boxes):
        idx = groups[_PID_FIRST_OBJECT + i]
        if len(idx):
            face = buf.face.ravel()[idx].astype(np.int64)
            albedo = _box_albedo(box, points(idx), face, float(np.sign(box.lo[1] + box.hi[1])))
            lit(idx, albedo, face_normals(idx))
    for j, pole in enumerate(scene.poles):
        idx = groups[_PID_FIRST_OBJECT + len(scene.boxes) + j]
        if len(idx):
            pt = points(idx)
            n = np.zeros((len(idx), 3), np.float32)
            n[:, 0], n[:, 1] = (pt[:, 0] - pole.x) / pole.radius, (pt[:, 1] - pole.y) / pole.radius
            albedo = np.broadcast_to(np.array(pole.color, np.float32), (len(idx), 3)).copy()
            albedo[pt[:, 2] - pole.base_z < 0.3] *= 0.7
            lit(idx, albedo, n)
    # ego bonnet: dark paint with a faint sky reflection towards its top edge
    rgb = rgb.reshape(h, w, 3)
    rows = np.arange(h, dtype=np.float32)[:, None]
    top = np.argmax(ego, axis=0).astype(np.float32)[None, :]
    refl = np.exp(-np.maximum(rows - top, 0) / max(scene.ego_rows * 0.35, 1.0))
    bonnet = 26 + 34 * refl
    for c, off in enumerate((0, 2, 6)):
        rgb[..., c] = np.where(ego, bonnet + off, rgb[..., c])
    return rgb


# ====================================================================== public entry points
def render_scene(scene: StreetScene) -> dict[str, np.ndarray]:
    """Ray-cast a scene. Returns (H, W from ``scene.camera``):

    rgb          : (H, W, 3) uint8 sRGB, shaded with image noise
    label_ids    : (H, W) uint8 Cityscapes label ids
    instance_ids : (H, W) uint16, label_id*1000+k for cars/persons, plain label id elsewhere
    depth        : (H, W) float32 exact optical-frame depth in metres; inf on sky and ego vehicle
                   (the stereo holes of ``disparity`` keep their true depth here)
    disparity    : (H, W) uint16 Cityscapes encoding of ``depth``, 0 on sky, ego and ~2 % holes
    """
    cam = scene.camera
    h, w = cam.height, cam.width
    buf = _Buffers(origin=cam.position.astype(np.float64), d=_rays(cam),
                   depth=np.full((h, w), np.inf, np.float32), pid=np.full((h, w), _PID_SKY, np.int16),
                   face=np.zeros((h, w), np.int8))
    _cast_ground(scene, buf)
    for i, box in enumerate(scene.boxes):
        _cast_box(box, _PID_FIRST_OBJECT + i, buf, cam)
    for j, pole in enumerate(scene.poles):
        _cast_pole(pole, _PID_FIRST_OBJECT + len(scene.boxes) + j, buf, cam)
    ego = _ego_mask(h, w, scene.ego_rows)
    buf.depth[ego] = np.inf
    buf.pid[ego] = _PID_EGO

    # labels and instances through per-primitive lookup tables
    n_obj = len(scene.boxes) + len(scene.poles)
    lut_label = np.zeros(_PID_FIRST_OBJECT + n_obj + 2, np.uint8)
    lut_inst = np.zeros(len(lut_label), np.uint16)
    base = {_PID_EGO: _EGO, _PID_SKY: _SKY, _PID_ROAD: _ROAD, _PID_SIDEWALK: _SIDEWALK, _PID_KERB: _SIDEWALK}
    for p, lid in base.items():
        lut_label[p], lut_inst[p] = lid, lid  # negative ids index from the end
    for i, box in enumerate(scene.boxes):
        lut_label[_PID_FIRST_OBJECT + i] = label_id(box.label)
        lut_inst[_PID_FIRST_OBJECT + i] = box.instance_id
    for j in range(len(scene.poles)):
        lut_label[_PID_FIRST_OBJECT + len(scene.boxes) + j] = _POLE
        lut_inst[_PID_FIRST_OBJECT + len(scene.boxes) + j] = _POLE
    label_ids = lut_label[buf.pid]
    instance_ids = lut_inst[buf.pid]

    rng = np.random.default_rng(scene.noise_seed)
    rgb = _shade(scene, buf, ego, rng)
    sigma = 0.45 * w / 2048 + 0.15
    rgb = cv2.GaussianBlur(rgb, (0, 0), sigma)
    rgb += rng.standard_normal((h, w, 3), dtype=np.float32) * np.float32(1.6)
    rgb += rng.standard_normal((h, w, 1), dtype=np.float32) * np.float32(1.4)
    rgb8 = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)

    depth = buf.depth
    disparity = depth_to_disparity(depth, cam)
    disparity[rng.random((h, w), dtype=np.float32) < HOLE_FRACTION] = 0
    return {"rgb": rgb8, "label_ids": label_ids, "instance_ids": instance_ids,
            "depth": depth, "disparity": disparity}


def write_image_set(root: Path, ident: ImageSetId, scene: StreetScene, arrays: dict[str, np.ndarray]) -> None:
    """Write the six Cityscapes files of one rendered frame under ``root``.

    leftImg8bit (RGB), gtFine_labelIds (8-bit), gtFine_instanceIds (16-bit), gtFine_color
    (RGBA), disparity (16-bit) and camera JSON (``scene.camera.to_dict()``).
    """
    cam = scene.camera
    shape = (cam.height, cam.width)
    expected = {"rgb": (np.uint8, shape + (3,)), "label_ids": (np.uint8, shape),
                "instance_ids": (np.uint16, shape), "disparity": (np.uint16, shape)}
    for key, (dtype, shp) in expected.items():
        arr = arrays[key]
        if arr.dtype != dtype or arr.shape != shp:
            raise ValueError(f"{key} must be {np.dtype(dtype).name} {shp}, found {arr.dtype} {arr.shape}")
    if not KNOWN_IDS[arrays["label_ids"]].all():
        raise ValueError("label_ids holds ids that Cityscapes does not define")
    root = Path(root)
    write_png(ident.path(root, "rgb"), arrays["rgb"])
    write_png(ident.path(root, "labelIds"), arrays["label_ids"])
    write_png(ident.path(root, "instanceIds"), arrays["instance_ids"])
    write_png(ident.path(root, "color"), colorize(arrays["label_ids"]))
    write_png(ident.path(root, "disparity"), arrays["disparity"])
    write_json(ident.path(root, "camera"), cam.to_dict())


def make_sample(out_root: Path, count: int = 3, width: int = 2048, height: int = 1024, seed: int = 0,
                split: str = "train", city: str = "synthtown") -> list[ImageSetId]:
    """Render and write ``count`` image sets ``<city>_000000_<frame:06d>`` under ``out_root``.

    Frame i uses ``np.random.default_rng([seed, i])``: the same arguments give byte-identical
    files, and frames do not depend on ``count``. Returns the ids written, in order.
    """
    if count < 0 or seed < 0:
        raise ValueError("count and seed must be non-negative")
    out_root = Path(out_root)
    idents: list[ImageSetId] = []
    for i in range(count):
        scene = random_scene(np.random.default_rng([seed, i]), width, height)
        ident = ImageSetId(split, city, f"{0:06d}", f"{i:06d}")
        write_image_set(out_root, ident, scene, render_scene(scene))
        idents.append(ident)
    return idents
