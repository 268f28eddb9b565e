"""Synthetic Cityscapes image sets of a straight street, with exactly known geometry.

Each frame is a procedurally drawn street scene (:class:`StreetScene`) ray-cast analytically,
one ray per pixel centre, in vectorised NumPy. The result is written in the exact Cityscapes
layout (see :mod:`synthcompose.dataset`), so the demo and the tests can run on data whose
depth, labels and instances are known exactly.

Frames. The scene is laid out in a *street frame* T (metres): ``a`` along the street (away
from the camera), ``b`` across it (to the left), ``z`` up and equal to the vehicle frame's z.
T is the vehicle frame V (ISO 8855: x forward, y left, z up) turned by ``street_heading`` about
z and shifted by ``street_origin``: ``(x, y) = street_origin + Rz(street_heading) (a, b)``.
By default T = V (heading 0, origin 0): the street runs along x. Cross-section, in T::

        building row        | sidewalk |   road (|b| <= w)   | sidewalk |   building row
    b = w + s + ...   w + s |  kerb k  | w                -w |  kerb k  | -w - s
                            ^ kerb face (label sidewalk), height k

Ground height (exact, piecewise planar), with grade ``slope``, cross-fall ``camber`` and the
centre-line height ``crown_z`` at a = 0::

    road (|b| <= w)           z = crown_z + slope * a - camber * |b|
    cross street, |b| > w     z = crown_z + slope * a - camber * w      (the road edge height)
    sidewalk (elsewhere)      z = crown_z + slope * a - camber * w + k  (flat across)

* road: ``|b| <= road_half_width`` and the cross street spanning ``crossing = (a0, a1)`` (every
  b); dashed centre line, solid parking-lane lines, a stop line, all in T.
* sidewalks: everything else; their vertical kerb faces (b = +-w, and a = a1 at the far side
  of the cross street) are sidewalk too.
* buildings: rows of vertical boxes from ``|b| = road_half_width + sidewalk_width`` outwards,
  broken by the cross street; optionally a row across the far end of the street. On a graded
  street their bases sink to the lowest ground under them (the ground hides the rest).
* parked cars (instances 26000 + k, tilted with the road surface under them), poles (label id
  17, no instances), pedestrians (instances 24000 + k, upright) as boxes and vertical cylinders
  standing on the true ground.
* the ego vehicle's bonnet covers the bottom ~4-6 % of the rows.

Rays: pixel (u, v) (integer = pixel centre) has optical-frame direction
``((u - u0) / fx, (v - v0) / fy, 1)``, so the ray parameter of a hit *is* its depth (optical z).
Rays are turned into T and intersected there (boxes: in their own frame). Sky and ego vehicle
have infinite depth and disparity 0; about 2 % of the other pixels get disparity 0 too (stereo
holes). Everything random comes from the ``rng`` handed to :func:`random_scene` (and the
scene's ``noise_seed``), so a seed gives byte-identical files.
"""
from __future__ import annotations

import dataclasses
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
#: accepted ranges of the :func:`random_scene` options
#: (the heading limit keeps a corner of the cross street in view for ``occluding_pole``)
MAX_HEADING_DEG, MAX_SLOPE, MAX_CAMBER = 28.0, 0.15, 0.08

_ROAD, _SIDEWALK, _SKY, _EGO = (label_id(n) for n in ("road", "sidewalk", "sky", "ego vehicle"))
_POLE = label_id("pole")

# primitive ids in the id buffer
_PID_EGO, _PID_SKY, _PID_ROAD, _PID_SIDEWALK, _PID_KERB = -2, -1, 0, 1, 2
_PID_FIRST_OBJECT = 3


# ====================================================================== scene description
@dataclass(frozen=True)
class Box:
    """A box in the street frame T, axis-aligned unless ``rotation`` is given.

    lo, hi       : minimum and maximum corner (a, b, z), metres, in the box's own frame B
    label        : Cityscapes class name of every pixel it covers
    instance_id  : value in gtFine_instanceIds: ``label_id * 1000 + k`` for instance classes
                   (several boxes of one object share it), the plain label id otherwise
    color        : base albedo, sRGB 0-255
    texture      : one of :data:`TEXTURES`; ``facade`` draws a window grid using
                   ``floor_height`` and ``window_spacing`` (metres)
    rotation     : None (B = T) or 9 floats, the row-major rotation R of B into T about
                   ``pivot``: ``p_T = pivot + R @ (p_B - pivot)`` (used to tilt parked cars
                   with the road surface; several boxes of one car share R and pivot)
    pivot        : (a, b, z) in T, the fixed point of ``rotation``
    """

    lo: Vec3
    hi: Vec3
    label: str
    instance_id: int
    color: RGB = (128, 128, 128)
    texture: str = "plain"
    floor_height: float = 3.2
    window_spacing: float = 2.6
    rotation: tuple[float, ...] | None = None
    pivot: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not all(a < b for a, b in zip(self.lo, self.hi)):
            raise ValueError(f"box corners must satisfy lo < hi on every axis: {self.lo} {self.hi}")
        lid = label_id(self.label)
        if self.instance_id != lid and self.instance_id // INSTANCE_FACTOR != lid:
            raise ValueError(f"instance id {self.instance_id} does not belong to class {self.label!r}")
        if self.texture not in TEXTURES:
            raise ValueError(f"unknown texture {self.texture!r}; known: {TEXTURES}")
        if self.rotation is not None:
            r = np.asarray(self.rotation, float)
            if r.shape != (9,) or not np.allclose(r.reshape(3, 3) @ r.reshape(3, 3).T, np.eye(3), atol=1e-9) \
                    or np.linalg.det(r.reshape(3, 3)) < 0:
                raise ValueError("rotation must be 9 floats of a proper rotation matrix (row-major)")

    @property
    def matrix(self) -> np.ndarray | None:
        """4x4 T-from-B transform, or None when B = T."""
        if self.rotation is None:
            return None
        r = np.asarray(self.rotation, float).reshape(3, 3)
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = np.asarray(self.pivot, float) - r @ np.asarray(self.pivot, float)
        return m

    def corners(self) -> np.ndarray:
        """(8, 3) corners in the street frame T."""
        lo, hi = np.array(self.lo, float), np.array(self.hi, float)
        c = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)], float)
        m = self.matrix
        return c if m is None else c @ m[:3, :3].T + m[:3, 3]

    def contains(self, p: np.ndarray) -> np.ndarray:
        """Bool (N,): street-frame points p (N, 3) inside the box (boundary included)."""
        p = np.asarray(p, float)
        m = self.matrix
        if m is not None:
            p = (p - m[:3, 3]) @ m[:3, :3]  # T -> B
        return np.all((p >= np.array(self.lo)) & (p <= np.array(self.hi)), axis=1)


@dataclass(frozen=True)
class Pole:
    """A vertical cylinder (label ``pole``, instance id = label id 17), metres in the street frame T.

    x, y    : axis position (street coordinates a, b); radius; height above ``base_z`` (its
              bottom, the ground there; sunk by ``radius * |slope|`` so no gap shows).
    """

    x: float
    y: float
    radius: float
    height: float
    base_z: float
    color: RGB = (98, 102, 100)


@dataclass(frozen=True)
class StreetScene:
    """One synthetic street frame: camera plus geometry in the street frame T (metres).

    road_half_width  : the road is ``|b| <= road_half_width`` (plus the cross street)
    kerb_height      : sidewalk top height above the road edge (0 when there is no road)
    sidewalk_width   : sidewalks span ``road_half_width < |b| <= road_half_width + sidewalk_width``
    boxes, poles     : the solid objects (buildings, cars, pedestrians; poles), in T
    has_road         : False: no road anywhere, the whole ground is sidewalk
    crossing         : (a0, a1) a-range of a cross street (road for every b), or None
    ego_rows         : rows of the bonnet at the image centre column (fewer at the sides)
    lane_dash        : centre-line dash length, gap and phase (metres)
    parking_lane     : width of the parking lane along each kerb (solid line at its edge)
    sun              : unit vector towards the sun in V
    noise_seed       : seed of the image noise, cloud pattern and disparity holes
    street_heading   : radians; the street direction in V is (cos, sin) of it
    street_origin    : (x, y) in V of the street frame's origin
    slope            : longitudinal grade dz/da (rise over run)
    camber           : cross-fall of the road: it falls by ``camber * |b|`` from the centre line
    crown_z          : height of the centre line at a = 0 (so that the ground is 0 under V's origin)

    Public geometry methods take and return vehicle-frame V coordinates unless named otherwise.
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
    street_heading: float = 0.0
    street_origin: tuple[float, float] = (0.0, 0.0)
    slope: float = 0.0
    camber: float = 0.0
    crown_z: float = 0.0
    light: "SceneLight | None" = None  # optional light control (see SceneLight); None: the default shading

    # ------------------------------------------------------------------ frames
    @property
    def street_is_vehicle_frame(self) -> bool:
        """True when T = V (no heading, no shift): coordinates pass through untouched."""
        return self.street_heading == 0.0 and tuple(self.street_origin) == (0.0, 0.0)

    @property
    def vehicle_from_street(self) -> np.ndarray:
        """4x4 transform of street-frame points into V."""
        c, s = math.cos(self.street_heading), math.sin(self.street_heading)
        m = np.eye(4)
        m[:2, :2] = [[c, -s], [s, c]]
        m[:2, 3] = self.street_origin
        return m

    def to_street(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """V ground-plan coordinates (x, y) -> street coordinates (a, b) (broadcast arrays)."""
        x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
        if self.street_is_vehicle_frame:
            return x, y
        c, s = math.cos(self.street_heading), math.sin(self.street_heading)
        dx, dy = x - self.street_origin[0], y - self.street_origin[1]
        return c * dx + s * dy, -s * dx + c * dy

    def to_vehicle(self, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Street coordinates (a, b) -> V ground-plan coordinates (x, y) (broadcast arrays)."""
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        if self.street_is_vehicle_frame:
            return a, b
        c, s = math.cos(self.street_heading), math.sin(self.street_heading)
        return self.street_origin[0] + c * a - s * b, self.street_origin[1] + s * a + c * b

    def points_to_vehicle(self, p: np.ndarray) -> np.ndarray:
        """(N, 3) street-frame points -> (N, 3) V points."""
        p = np.asarray(p, float)
        m = self.vehicle_from_street
        return p @ m[:3, :3].T + m[:3, 3]

    def points_to_street(self, p: np.ndarray) -> np.ndarray:
        """(N, 3) V points -> (N, 3) street-frame points."""
        p = np.asarray(p, float)
        m = self.vehicle_from_street
        return (p - m[:3, 3]) @ m[:3, :3]

    # ------------------------------------------------------------------ ground plan, street frame
    def street_in_crossing(self, a: np.ndarray) -> np.ndarray:
        """Bool array: street coordinate a lies within the cross street's a-range."""
        a = np.asarray(a)
        if self.crossing is None:
            return np.zeros(a.shape, bool)
        return (a >= self.crossing[0]) & (a <= self.crossing[1])

    def street_is_road(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Bool array: the ground at street coordinates (a, b) is road."""
        a, b = np.broadcast_arrays(np.asarray(a), np.asarray(b))
        if not self.has_road:
            return np.zeros(a.shape, bool)
        return (np.abs(b) <= self.road_half_width) | self.street_in_crossing(a)

    def road_edge_height(self, a: np.ndarray) -> np.ndarray:
        """Height of the road at its edges |b| = w (and over the cross street) at street a."""
        return self.crown_z + self.slope * np.asarray(a) - self.camber * self.road_half_width

    def sidewalk_height(self, a: np.ndarray) -> np.ndarray:
        """Height of the sidewalk top at street a (flat across the street)."""
        return self.road_edge_height(a) + self.kerb_height

    def street_ground_height(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """True ground height z at street coordinates (a, b) (see the module docstring)."""
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        road = self.street_is_road(a, b)
        z = self.crown_z + self.slope * a - self.camber * np.minimum(np.abs(b), self.road_half_width)
        return z + np.where(road, 0.0, self.kerb_height)

    def street_ground_normal(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(..., 3) unit upward ground normals in T at street coordinates (a, b) (the kerb faces,
        a set of measure zero, are ignored)."""
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        on_camber = np.abs(b) <= self.road_half_width
        dzdb = np.where(on_camber, -self.camber * np.sign(b), 0.0)
        n = np.stack([np.full(a.shape, -self.slope), -dzdb, np.ones(a.shape)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def street_surface_label(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """:meth:`surface_label` at street coordinates (a, b)."""
        a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
        out = np.full(a.shape, "building", "<U8")
        walk = (np.abs(b) <= self.road_half_width + self.sidewalk_width) | self.street_in_crossing(a)
        out[walk] = "sidewalk"
        out[self.street_is_road(a, b)] = "road"
        return out

    # ------------------------------------------------------------------ ground plan, vehicle frame
    def in_crossing(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bool array: V point (x, y) lies within the cross street's a-range."""
        return self.street_in_crossing(self.to_street(x, y)[0])

    def is_road(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Bool array (broadcast shape of x, y): the ground at (x, y) in V is road."""
        return self.street_is_road(*self.to_street(x, y))

    def ground_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """True ground height z (metres, V) at ground-plan points (x, y) of V: the road surface
        (graded and cambered) on road, the sidewalk top elsewhere.

        Ignores objects standing on the ground (cars, poles, buildings' volumes).
        """
        return self.street_ground_height(*self.to_street(x, y))

    def ground_normal(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(..., 3) unit upward ground normals in V at ground-plan points (x, y) of V."""
        n = self.street_ground_normal(*self.to_street(x, y))
        if self.street_is_vehicle_frame:
            return n
        return n @ self.vehicle_from_street[:3, :3].T

    def surface_label(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Class name of the ground plan at (x, y) in V: ``'road'``, ``'sidewalk'`` or
        ``'building'`` (the blocks behind the sidewalks). Returns a ``<U8`` string array of the
        broadcast shape of x and y (0-d for scalars; ``str(...)`` gives the name)."""
        return self.street_surface_label(*self.to_street(x, y))

    def road_direction(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(..., 2) unit vectors in V of the street's direction at ground-plan points (x, y):
        horizontal, along the kerbs, pointing away from the camera. Constant (straight street)."""
        shape = np.broadcast_shapes(np.shape(x), np.shape(y))
        d = np.array([math.cos(self.street_heading), math.sin(self.street_heading)])
        return np.broadcast_to(d, shape + (2,)).copy()

    def inside_objects(self, points: np.ndarray) -> np.ndarray:
        """Bool (N,): V points (N, 3) inside any box or pole of the scene (boundary included)."""
        p = self.points_to_street(np.asarray(points, float).reshape(-1, 3))
        hit = np.zeros(len(p), bool)
        for box in self.boxes:
            hit |= box.contains(p)
        for pole in self.poles:
            r = np.hypot(p[:, 0] - pole.x, p[:, 1] - pole.y)
            hit |= (r <= pole.radius) & (p[:, 2] >= pole.base_z) & (p[:, 2] <= pole.base_z + pole.height)
        return hit


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
                  plan: StreetScene, extend_to: float | None) -> list[Box]:
    """Abutting building boxes along a in [x_from, x_to] on one side (side = +1 left, -1 right).

    The last box reaches ``extend_to`` instead of ``x_to`` when given (street to the horizon).
    Each box's base is the lowest sidewalk height under it; its height is drawn above the
    highest one (they differ on a graded street).
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
        base = float(min(plan.sidewalk_height(x), plan.sidewalk_height(far)))
        rise = abs(plan.slope) * (far - x)
        boxes.append(Box((x, y0, base), (far, y1, base + rng.uniform(8.0, 20.0) + rise), "building",
                         label_id("building"), _jitter(rng, _pick(rng, _FACADES), 8), "facade",
                         floor_height=rng.uniform(2.9, 3.5), window_spacing=rng.uniform(2.2, 3.2)))
        x = end
    return boxes


def _segment_hits_rect(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
    """Does the 2D segment a-b pass through the axis-aligned rectangle [lo, hi]?"""
    t = np.linspace(0.0, 1.0, 400)[:, None]
    p = a + t * (b - a)
    return bool(np.any(np.all((p >= lo) & (p <= hi), axis=1)))


def _ground_rotation(slope: float, dzdb: float) -> tuple[float, ...] | None:
    """Row-major rotation taking z to the normal of the plane z = slope*a + dzdb*b + c and x to
    its steepest-along-a direction (None for a level plane): a body standing on that plane."""
    if slope == 0.0 and dzdb == 0.0:
        return None
    e1 = np.array([1.0, 0.0, slope]) / math.hypot(1.0, slope)
    e3 = np.array([-slope, -dzdb, 1.0])
    e3 /= np.linalg.norm(e3)
    e2 = np.cross(e3, e1)
    return tuple(float(v) for v in np.column_stack([e1, e2, e3]).ravel())


def _car_boxes(rng: np.random.Generator, xc: float, yc: float, ground: float, facing: int,
               instance: int, rotation: tuple[float, ...] | None = None) -> list[Box]:
    """A parked car as body, cabin and four wheel boxes, centred at (xc, yc), nose to ``facing``.

    ``ground`` is the surface height at (xc, yc); ``rotation`` (about that point) tilts the car
    so that its wheels stand on a graded or cambered road plane.
    """
    length, width, height = rng.uniform(3.9, 4.6), rng.uniform(1.72, 1.86), rng.uniform(1.4, 1.56)
    paint = _jitter(rng, _pick(rng, _CAR_PAINT), 6)
    pose = {} if rotation is None else {"rotation": rotation, "pivot": (xc, yc, ground)}
    body_lo, body_top = ground + 0.3, ground + 0.62 * height
    boxes = [Box((xc - length / 2, yc - width / 2, body_lo), (xc + length / 2, yc + width / 2, body_top),
                 "car", instance, paint, "car_body", **pose)]
    c0, c1 = -0.30 * length, 0.24 * length  # cabin set back towards the rear
    if facing < 0:
        c0, c1 = -c1, -c0
    boxes.append(Box((xc + c0, yc - width / 2 + 0.07, body_top), (xc + c1, yc + width / 2 - 0.07, ground + height),
                     "car", instance, paint, "glass", **pose))
    for wx in (-1, 1):
        for wy in (-1, 1):
            cx, cy = xc + wx * (length / 2 - 0.82), yc + wy * (width / 2 - 0.13)
            boxes.append(Box((cx - 0.33, cy - 0.11, ground), (cx + 0.33, cy + 0.11, ground + 0.62),
                             "car", instance, (26, 26, 28), **pose))
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


def _visible_low(plan: StreetScene, pole: Pole) -> bool:
    """Is the lowest half metre of the pole inside the image, clear of its borders and the bonnet?"""
    cam = plan.camera
    pts = plan.points_to_vehicle(np.array([[pole.x, pole.y, pole.base_z + h] for h in (0.05, 0.25, 0.5)]))
    m = cam.optical_from_vehicle
    q = pts @ m[:3, :3].T + m[:3, 3]
    if (q[:, 2] < 1.0).any():
        return False
    u = cam.fx * q[:, 0] / q[:, 2] + cam.u0
    v = cam.fy * q[:, 1] / q[:, 2] + cam.v0
    return bool(np.all((u >= 0.03 * cam.width) & (u <= 0.97 * cam.width) & (v >= 0)
                       & (v <= cam.height - 2 * plan.ego_rows)))


def _option(value: float | None, name: str, limit: float) -> float:
    if value is None:
        return 0.0
    value = float(value)
    if not math.isfinite(value) or abs(value) > limit:
        raise ValueError(f"{name} must be a finite number within +-{limit}, got {value}")
    return value


def random_scene(rng: np.random.Generator, width: int, height: int, *, road: bool = True,
                 heading_deg: float | None = None, slope: float | None = None, camber: float | None = None,
                 occluding_pole: bool = True, light: "SceneLight | None" = None) -> StreetScene:
    """Draw a street scene for a ``width`` x ``height`` image.

    light : optional :class:`SceneLight` (a known sun, ambient colour, cast shadows, shading in
            linear light); None keeps the default shading. It draws no random numbers.

    The same ``rng`` state gives the same scene; ``road=False`` draws the same random numbers
    but turns the whole ground into a sidewalk (kerb height 0, no camber, no ``road`` pixel).

    heading_deg : the street's direction in V, degrees (|.| <= 28; ~5-25 looks like a car turned
                  relative to the street). The street frame is turned about the camera's ground
                  point, so the camera stays where it is: over the road, near its centre line.
    slope       : longitudinal grade rise/run along the street (|.| <= 0.15, e.g. -0.06..0.06).
                  A graded street always ends in a building row across it.
    camber      : cross-fall of the road (|.| <= 0.08, e.g. 0.02..0.03): the road falls by
                  ``camber * |b|`` from the centre line to the kerbs.
    occluding_pole : True: at least one pole stands at a near corner of the cross street, low in
                  the image, with cross-street road right behind it and no parked car hiding it,
                  so occlusion of road by a pole is always present (with a heading, a corner
                  pole out of view moves to the other corner; ValueError if neither is in view,
                  which did not happen in 800 scenes at +-28 deg).
                  False: those corner poles are left out (the rest of the scene is unchanged).

    None (and 0) keep the flat street along x, with outputs identical to earlier versions.
    The ground is at height 0 under V's origin. Random numbers drawn do not depend on the
    options, so one seed gives the same layout (in street coordinates) for any of them.
    """
    heading = math.radians(_option(heading_deg, "heading_deg", MAX_HEADING_DEG))
    grade = _option(slope, "slope", MAX_SLOPE)
    fall = _option(camber, "camber", MAX_CAMBER) if road else 0.0

    camera = random_camera(rng, width, height)
    w = float(rng.uniform(4.2, 6.0))
    kerb = float(rng.uniform(0.12, 0.15)) if road else 0.0
    walk = float(rng.uniform(3.0, 4.0))
    xc0 = float(rng.uniform(24.0, 40.0))
    xc1 = xc0 + float(rng.uniform(10.0, 16.0))
    x_end = float(rng.uniform(130.0, 220.0))
    end_row = bool(rng.random() < 0.6) or grade != 0.0  # graded: no building rows to the horizon
    ego_rows = max(1, round(height * rng.uniform(0.04, 0.06)))
    az, el = rng.uniform(0.0, 2 * math.pi), rng.uniform(0.5, 0.9)
    sun = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    dash = (3.0, 6.0, float(rng.uniform(0.0, 9.0)))

    # street frame: turned about the camera's ground point; ground height 0 under V's origin
    origin = (0.0, 0.0)
    if heading != 0.0:
        c, s = math.cos(heading), math.sin(heading)
        origin = (camera.x - (c * camera.x - s * camera.y), camera.y - (s * camera.x + c * camera.y))
    plan = StreetScene(camera=camera, road_half_width=w, kerb_height=kerb, sidewalk_width=walk, boxes=(), poles=(),
                       has_road=road, crossing=(xc0, xc1), ego_rows=int(ego_rows), street_heading=heading,
                       street_origin=origin, slope=grade, camber=fall)
    a_o, b_o = (float(v) for v in plan.to_street(0.0, 0.0))
    plan = dataclasses.replace(plan, crown_z=fall * abs(b_o) - grade * a_o + 0.0)

    boxes: list[Box] = []
    after = xc1 + (0.05 if grade != 0.0 else 0.0)  # keep facades off the far kerb's plane
    for side in (1, -1):
        extend = None if end_row else 3000.0
        boxes += _building_row(rng, side, -25.0, xc0, w + walk, plan, None)
        boxes += _building_row(rng, side, after, x_end, w + walk, plan, extend)
    if end_row:
        base = float(min(plan.road_edge_height(x_end), plan.road_edge_height(x_end + 25.0)))
        rise = abs(grade) * 25.0 + abs(fall) * w
        boxes.append(Box((x_end, -150.0, base), (x_end + 25.0, 150.0, base + float(rng.uniform(12.0, 26.0)) + rise),
                         "building", label_id("building"), _jitter(rng, _pick(rng, _FACADES), 8), "facade",
                         floor_height=float(rng.uniform(2.9, 3.5)), window_spacing=float(rng.uniform(2.2, 3.2))))

    def pole_at(a: float, b: float, radius: float, tall: float) -> Pole:
        # sidewalk: the ground under the pole only varies along a
        return Pole(a, b, radius, tall, float(plan.sidewalk_height(a)) - radius * abs(grade))

    # poles: 1-2 at the near corners of the cross street, the rest along the kerbs
    poles: list[Pole] = []
    corner_sides = [1, -1] if rng.random() < 0.4 else [int(rng.choice([1, -1]))]
    for side in corner_sides:
        pa, pb = xc0 - float(rng.uniform(0.5, 1.0)), side * (w + float(rng.uniform(0.35, 0.6)))
        radius, tall = float(rng.uniform(0.06, 0.1)), float(rng.uniform(3.6, 4.8))
        poles.append(pole_at(pa, pb, radius, tall))
    if occluding_pole and heading != 0.0 and not any(_visible_low(plan, p) for p in poles):
        poles = [dataclasses.replace(p, y=-p.y) for p in poles]  # the other corner
        if not any(_visible_low(plan, p) for p in poles):
            raise ValueError(f"no corner pole in view at heading {math.degrees(heading):.1f} deg")
    n_poles = int(rng.integers(2, 5))
    for _ in range(200):
        if len(poles) >= n_poles:
            break
        side = int(rng.choice([1, -1]))
        px = float(rng.uniform(7.0, 75.0))
        if xc0 - 4 <= px <= xc1 + 2 or any(abs(px - p.x) < 4.0 for p in poles):
            continue
        py = side * (w + float(rng.uniform(0.35, 0.6)))
        radius, tall = float(rng.uniform(0.06, 0.1)), float(rng.uniform(3.6, 4.8))
        poles.append(pole_at(px, py, radius, tall))
    corner = poles[:len(corner_sides)]

    # parked cars along the kerbs, in their side's direction of travel (right-hand traffic)
    car_id = label_id("car") * INSTANCE_FACTOR
    n_cars = int(rng.integers(2, 6))
    placed: list[tuple[float, float, float]] = []  # (x_min, x_max, side)
    cam_xy = np.array([float(v) for v in plan.to_street(camera.x, camera.y)])
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
        # the car stands on its half of the road: the plane z = crown + grade*a - fall*side*b
        ground = plan.crown_z + grade * xc - fall * abs(yc)
        boxes += _car_boxes(rng, xc, yc, ground, -side, car_id + len(placed),
                            _ground_rotation(grade, -fall * side))
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
        ground = float(min(plan.sidewalk_height(px - 0.14), plan.sidewalk_height(px + 0.14)))
        boxes += _person_boxes(rng, px, py, ground, person_id + people)
        people += 1

    if not occluding_pole:
        poles = poles[len(corner_sides):]
    scene = dataclasses.replace(plan, boxes=tuple(boxes), poles=tuple(poles), lane_dash=dash, sun=sun,
                                noise_seed=int(rng.integers(0, 2**62)))
    if light is not None:  # optional light control (SceneLight)
        scene = dataclasses.replace(scene, sun=light.direction, light=light)
    return scene


# ====================================================================== ray casting
@dataclass(eq=False)
class _Buffers:
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


def _street_rays(scene: StreetScene) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
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


def _commit(buf: _Buffers, rect: tuple[slice, slice], t: np.ndarray, hit: np.ndarray, pid: int,
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
        road = [(c0, 0.0, scene.street_is_road, _PID_ROAD)]
    else:
        road = [(c0, -scene.camber, lambda a, b: (b >= 0) & (b <= w), _PID_ROAD),
                (c0, scene.camber, lambda a, b: (b < 0) & (b >= -w), _PID_ROAD),
                (edge, 0.0, lambda a, b: (np.abs(b) > w) & scene.street_in_crossing(a), _PID_ROAD)]
        if not scene.has_road:
            road = []
    walk = (edge + k, 0.0, lambda a, b: ~scene.street_is_road(a, b), _PID_SIDEWALK)
    return road + [walk]


def _cast_ground(scene: StreetScene, buf: _Buffers) -> None:
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
            hit = (sign * db > 0) & (z >= bottom) & (z <= bottom + k) & ~scene.street_in_crossing(a)
            _commit(buf, full, t, hit, _PID_KERB, 2 if sign > 0 else 3)
        if scene.crossing is not None:
            t = np.float32(scene.crossing[1] - oa) / da
            z, b = oz + t * dz, ob + t * db
            bottom = float(scene.road_edge_height(scene.crossing[1]))
            hit = (da > 0) & (z >= bottom) & (z <= bottom + k) & (np.abs(b) > w)
            _commit(buf, full, t, hit, _PID_KERB, 0)


def _cast_box(box: Box, pid: int, buf: _Buffers, camera: Camera, v_from_t: np.ndarray | None) -> None:
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


def _cast_pole(pole: Pole, pid: int, buf: _Buffers, camera: Camera, v_from_t: np.ndarray | None) -> None:
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
    """(N, 3) asphalt colour with markings at road points (x, y) = (a, b) in the street frame."""
    base = 88 + 7 * _cell_noise(x, y, 0.04, 1) + 4 * _cell_noise(x, y, 1.7, 2)
    rgb = np.stack([base, base + 1, base + 3], axis=1)
    w, ay = scene.road_half_width, np.abs(y)
    crossing = scene.street_in_crossing(x)
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
        kerbstone = (np.abs(y) - scene.road_half_width < 0.16) & ~scene.street_in_crossing(x)
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


def _shade(scene: StreetScene, buf: _Buffers, ego: np.ndarray, rng: np.random.Generator,
           sunlit: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 3) float32 colour 0-255 before noise: albedo x (sky ambient + sun Lambert), haze.
    With a scene light, ``sunlit`` (H * W bool, when given) receives where the sun reaches."""
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
    sun = np.array(scene.sun, np.float64)
    if not scene.street_is_vehicle_frame:  # shading happens in the street frame
        sun = scene.vehicle_from_street[:3, :3].T @ sun
    sun = sun.astype(np.float32)
    haze = np.array([204, 208, 213], np.float32)
    if scene.light is not None:  # optional light control (SceneLight)
        haze = _light_tint(scene, haze)

    # car/person ground footprints darken the ground under and around them (contact shadow)
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

    def lit(idx: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> None:
        if scene.light is not None:  # optional light control (SceneLight)
            col = _light_shade(scene, albedo, normal, points(idx), sun,
                               None if sunlit is None else (sunlit, idx))
        else:
            light = 0.7 + 0.2 * normal[:, 2] + 0.32 * np.maximum(normal @ sun, 0)
            col = albedo * light[:, None]
        fog = (1 - np.exp(-depth[idx] / np.float32(700.0)))[:, None]
        rgb[idx] = col * (1 - fog) + haze * fog

    def points(idx: np.ndarray) -> np.ndarray:
        t = depth[idx]
        return np.stack([buf.origin[i] + t * buf.d[i].ravel()[idx] for i in range(3)], axis=1)

    def face_normals(idx: np.ndarray, rotation: np.ndarray | None = None) -> np.ndarray:
        face = buf.face.ravel()[idx].astype(np.int64)
        n = np.zeros((len(idx), 3), np.float32)
        n[np.arange(len(idx)), face // 2] = np.where(face % 2 == 1, 1.0, -1.0)
        return n if rotation is None else n @ rotation.T.astype(np.float32)

    # sky
    clouds = cv2.resize(rng.standard_normal((6, 12)).astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC) * 5
    idx = groups[_PID_SKY]
    rgb[idx] = _sky_rgb(buf, idx, clouds)
    if scene.light is not None:  # optional light control (SceneLight)
        rgb[idx] = _light_tint(scene, rgb[idx])
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
        if p == _PID_KERB:
            normal = face_normals(idx)
        else:
            normal = scene.street_ground_normal(pt[:, 0].astype(np.float64), pt[:, 1].astype(np.float64))
            normal = normal.astype(np.float32)
            ao = np.ones(len(idx), np.float32)
            for x0, y0, x1, y1 in feet.values():
                ddx = np.maximum(np.maximum(x0 - pt[:, 0], pt[:, 0] - x1), 0)
                ddy = np.maximum(np.maximum(y0 - pt[:, 1], pt[:, 1] - y1), 0)
                ao *= 1 - 0.55 * np.exp(-(ddx * ddx + ddy * ddy) / np.float32(0.1))
            albedo *= ao[:, None]
        lit(idx, albedo, normal)
    # objects
    for i, box in enumerate(scene.boxes):
        idx = groups[_PID_FIRST_OBJECT + i]
        if len(idx):
            face = buf.face.ravel()[idx].astype(np.int64)
            m, pt = box.matrix, points(idx)
            if m is not None:  # street frame -> the box's frame
                pt = ((pt - m[:3, 3]) @ m[:3, :3]).astype(np.float32)
            albedo = _box_albedo(box, pt, face, float(np.sign(box.lo[1] + box.hi[1])))
            lit(idx, albedo, face_normals(idx, None if m is None else m[:3, :3]))
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
    return _render(scene)


def _render(scene: StreetScene, sunlit: np.ndarray | None = None) -> dict[str, np.ndarray]:
    cam = scene.camera
    h, w = cam.height, cam.width
    origin, dirs = _street_rays(scene)
    v_from_t = None if scene.street_is_vehicle_frame else scene.vehicle_from_street
    buf = _Buffers(origin=origin, d=dirs,
                   depth=np.full((h, w), np.inf, np.float32), pid=np.full((h, w), _PID_SKY, np.int16),
                   face=np.zeros((h, w), np.int8))
    _cast_ground(scene, buf)
    for i, box in enumerate(scene.boxes):
        _cast_box(box, _PID_FIRST_OBJECT + i, buf, cam, v_from_t)
    for j, pole in enumerate(scene.poles):
        _cast_pole(pole, _PID_FIRST_OBJECT + len(scene.boxes) + j, buf, cam, v_from_t)
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
    rgb = _shade(scene, buf, ego, rng, sunlit)
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


def render_scene_sunlit(scene: StreetScene) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """:func:`render_scene`'s arrays (the same bytes) and the ground truth of the sun: (H, W)
    bool, True where the scene light's sun reaches the surface seen (facing it, no box or pole
    in the way); all False without a sun (no :class:`SceneLight`, or ``sun_fraction`` 0)."""
    cam = scene.camera
    sunlit = np.zeros(cam.height * cam.width, bool)
    arrays = _render(scene, sunlit)
    if scene.light is None or scene.light.sun_fraction <= 0.0:
        sunlit[:] = False
    return arrays, sunlit.reshape(cam.height, cam.width)


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


# ====================================================================== optional light control
# Everything below is used only when a scene carries a :class:`SceneLight` (random_scene(...,
# light=...)); scenes without one are shaded exactly as above.
@dataclass(frozen=True)
class SceneLight:
    """A known light for a synthetic frame, in the renderer's model (shaders/lit.glsl).

    Shading is in linear light: ``albedo * (ambient(n) + sun * max(0, n.l) * visible)`` with
    ``ambient(n) = mix(ground, sky, 0.5 + 0.5 n_z)``, sun visibility ray-cast against every box
    and pole (cast shadows) when ``shadows``. :meth:`lighting` gives the same light as a
    :class:`synthcompose.render.Lighting`, the ground truth an estimate is compared with.

    sun_azimuth_deg, sun_elevation_deg : towards the sun, vehicle frame V (azimuth from x to y)
    sun_fraction : share of an up-facing surface's irradiance coming from the sun (0: overcast)
    intensity    : irradiance of an up-facing unshadowed surface (1: the Lighting convention)
    sky_tint     : colour of the ambient light (scaled to luminance 1)
    sun_tint     : colour of the sunlight (scaled to luminance 1)
    ground_ratio : ambient from below (ground bounce) over ambient from above
    shadows      : cast shadows of boxes and poles
    """

    sun_azimuth_deg: float = 135.0
    sun_elevation_deg: float = 45.0
    sun_fraction: float = 0.6
    intensity: float = 1.0
    sky_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    sun_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    ground_ratio: float = 0.3
    shadows: bool = True

    def __post_init__(self) -> None:
        if not 0.0 <= self.sun_fraction < 1.0:
            raise ValueError("sun_fraction must be in [0, 1)")
        if not 2.0 <= self.sun_elevation_deg <= 90.0:
            raise ValueError("sun_elevation_deg must be in [2, 90]")
        if self.intensity <= 0 or min(self.sky_tint) <= 0 or min(self.sun_tint) <= 0:
            raise ValueError("intensity and tints must be positive")

    @property
    def direction(self) -> Vec3:
        """Unit vector towards the sun in V."""
        el, az = math.radians(self.sun_elevation_deg), math.radians(self.sun_azimuth_deg)
        return (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))

    @staticmethod
    def _unit_luminance(rgb: tuple[float, float, float]) -> np.ndarray:
        c = np.asarray(rgb, np.float64)
        return c / float(c @ np.array([0.2126, 0.7152, 0.0722]))

    def rgb(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(sky, ground, sun) linear RGB irradiances: sky + sun * sin(elevation) = intensity
        (in luminance) on an up-facing surface; sun is the irradiance facing the sun."""
        k = 1.0 - self.sun_fraction
        sky = self.intensity * k * self._unit_luminance(self.sky_tint)
        sun = self.intensity * self.sun_fraction / math.sin(math.radians(self.sun_elevation_deg)) \
            * self._unit_luminance(self.sun_tint)
        return sky, self.ground_ratio * sky, sun

    def lighting(self):
        """The same light as a :class:`synthcompose.render.Lighting`."""
        from .render import Lighting

        sky, ground, sun = self.rgb()
        t = lambda c: tuple(float(v) for v in c)  # noqa: E731
        return Lighting(t(self.direction), t(sun), t(sky), t(ground))


def _lin(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def _sun_visibility(scene: StreetScene, p: np.ndarray, sun: np.ndarray) -> np.ndarray:
    """(N,) 1.0 where street-frame points p (N, 3) see the sun (direction ``sun``, T), 0.0
    where a box or pole is in the way."""
    vis = np.ones(len(p), np.float32)
    if sun[2] <= 1e-3 or not len(p):
        return vis
    p = p.astype(np.float64)
    for box in scene.boxes:
        m = box.matrix
        q, d = (p, sun) if m is None else ((p - m[:3, 3]) @ m[:3, :3], sun @ m[:3, :3])
        lo, hi = np.array(box.lo), np.array(box.hi)
        if d[2] <= 1e-6:
            continue
        # candidates: below the top, within the box's footprint swept away from the sun
        reach = np.maximum(hi[2] - q[:, 2], 0.0) / d[2]
        sel = q[:, 2] < hi[2]
        for ax in (0, 1):
            shift = -d[ax] * reach
            sel &= (q[:, ax] >= lo[ax] + np.minimum(shift, 0.0) - 1e-6) & (q[:, ax] <= hi[ax] + np.maximum(shift, 0.0) + 1e-6)
        idx = np.nonzero(sel)[0]
        if not len(idx):
            continue
        qq = q[idx]
        t0, t1 = np.full(len(idx), -np.inf), np.full(len(idx), np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            for ax in range(3):
                if abs(d[ax]) < 1e-12:
                    inside = (qq[:, ax] >= lo[ax]) & (qq[:, ax] <= hi[ax])
                    t0 = np.where(inside, t0, np.inf)
                    continue
                a, b = (lo[ax] - qq[:, ax]) / d[ax], (hi[ax] - qq[:, ax]) / d[ax]
                t0, t1 = np.maximum(t0, np.minimum(a, b)), np.minimum(t1, np.maximum(a, b))
        vis[idx[(t0 <= t1) & (t1 > 1e-3)]] = 0.0
    for pole in scene.poles:
        dxy = math.hypot(sun[0], sun[1])
        reach = np.maximum(pole.base_z + pole.height - p[:, 2], 0.0) / sun[2]
        fx, fy = p[:, 0] - pole.x, p[:, 1] - pole.y
        near = (np.hypot(fx, fy) <= reach * dxy + pole.radius) & (p[:, 2] < pole.base_z + pole.height)
        idx = np.nonzero(near)[0]
        if not len(idx) or dxy < 1e-9:
            continue
        fx, fy = fx[idx], fy[idx]
        a = dxy * dxy
        b = fx * sun[0] + fy * sun[1]
        c = fx * fx + fy * fy - pole.radius ** 2
        disc = b * b - a * c
        with np.errstate(invalid="ignore"):
            t = (-b - np.sqrt(disc)) / a
            t_far = (-b + np.sqrt(disc)) / a
        t = np.maximum(t, 0.0)
        z = p[idx, 2] + t * sun[2]
        hit = (disc >= 0) & (t_far > 1e-3) & (z >= pole.base_z) & (z <= pole.base_z + pole.height)
        vis[idx[hit]] = 0.0
    return vis


def _light_shade(scene: StreetScene, albedo: np.ndarray, normal: np.ndarray, pts: np.ndarray,
                 sun: np.ndarray, sunlit: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(N, 3) sRGB 0-255 colour of surface points lit by ``scene.light`` (linear-light shading).
    ``sunlit`` (bool array, indices of the points in it), when given, receives where the sun
    reaches the points."""
    light = scene.light
    sky, ground, sun_rgb = (c.astype(np.float32) for c in light.rgb())
    n = normal.astype(np.float32)
    ndl = np.maximum(n @ sun.astype(np.float32), 0.0)
    if light.shadows:
        lit_idx = np.nonzero(ndl > 0)[0]
        vis = np.zeros(len(n), np.float32)
        vis[lit_idx] = _sun_visibility(scene, pts[lit_idx] + 0.02 * n[lit_idx], sun.astype(np.float64))
        ndl = ndl * vis
    if sunlit is not None:
        sunlit[0][sunlit[1]] = ndl > 0
    up = (0.5 + 0.5 * n[:, 2:3])
    irradiance = ground * (1 - up) + sky * up + sun_rgb * ndl[:, None]
    return (_srgb(_lin(albedo / 255.0) * irradiance) * 255.0).astype(np.float32)


def _light_tint(scene: StreetScene, color: np.ndarray) -> np.ndarray:
    """Sky and haze colours (sRGB 0-255) under ``scene.light``: tinted by the ambient colour
    and scaled with its intensity."""
    tint = SceneLight._unit_luminance(scene.light.sky_tint) * scene.light.intensity
    return (_srgb(_lin(color / 255.0) * tint.astype(np.float32)) * 255.0).astype(np.float32)
