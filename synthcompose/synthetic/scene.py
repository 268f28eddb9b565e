"""Scene description of a synthetic street frame: :class:`StreetScene`, :class:`Box`, :class:`Pole`.

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
  of the cross street) are sidewalk too. With ``street_end`` the street's road ends there (a
  T-junction seen head-on): its kerb face runs across the whole width and the ground beyond is
  footway.
* buildings: rows of vertical boxes from ``|b| = road_half_width + sidewalk_width`` outwards,
  broken by the cross street; optionally a row across the far end of the street. On a graded
  street their bases sink to the lowest ground under them (the ground hides the rest).
* parked cars (instances 26000 + k, tilted with the road surface under them), poles (label id
  17, no instances), pedestrians (instances 24000 + k, upright) as boxes and vertical cylinders
  standing on the true ground.
* the ego vehicle's bonnet covers the bottom ~4-6 % of the rows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from synthcompose.camera import Camera
from synthcompose.labels import INSTANCE_FACTOR, label_id

if TYPE_CHECKING:
    from .light import SceneLight

Vec3 = tuple[float, float, float]
RGB = tuple[int, int, int]

#: box textures understood by the renderer
TEXTURES = ("plain", "facade", "car_body", "glass")


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
    nose         : a ``car_body`` box's front (head lamps; rear lamps at the other end): +1 at
                   +a of its frame, -1 at -a, 0 as earlier versions drew it (by its side of the
                   street: right +a, left -a)
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
    nose: int = 0  # a car body's front: +1 towards +a of its frame, -1 towards -a; 0 by its side (right: +a)

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
    centre_line      : the dashed centre line is drawn
    street_kind      : None, or a :mod:`.streets` kind (one-way, bays, zebra crossing)
    zebra            : (a0, a1) of a zebra crossing over the road, or None
    street_end       : the street ends at this a (a T-junction seen head-on: ``crossing`` up to it,
                       a kerb face across the whole width there and footway beyond), or None
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
    centre_line: bool = True  # the dashed centre line is drawn (not on a one-way street)
    street_kind: str | None = None  # streets.StreetKind's name: lanes, bays and crossings as traffic uses them
    zebra: tuple[float, float] | None = None  # a zebra crossing's a-range, or None
    street_end: float | None = None  # the street's road ends at this a (a T-junction), or None

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
        return ((np.abs(b) <= self.road_half_width) & self.street_before_end(a)) | self.street_in_crossing(a)

    def street_before_end(self, a: np.ndarray) -> np.ndarray:
        """Bool array: street coordinate a lies before the street's end (everywhere without one)."""
        a = np.asarray(a)
        return np.ones(a.shape, bool) if self.street_end is None else a < self.street_end

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
        if self.street_end is not None:  # the far footway across the end, as deep as the side ones
            walk |= (a >= self.street_end) & (a <= self.street_end + self.sidewalk_width)
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

