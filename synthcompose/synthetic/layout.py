"""Random street scenes: :func:`random_scene` draws a :class:`~.scene.StreetScene` (camera,
street cross-section, building rows, poles, parked cars, pedestrians) from a random generator.

The same generator state gives the same scene; the options (heading, grade, camber, road,
corner poles, light) do not change which random numbers are drawn.
"""
from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from synthcompose.camera import Camera
from synthcompose.labels import INSTANCE_FACTOR, label_id

from .light import SceneLight
from .scene import RGB, Box, Pole, StreetScene
from .streets import StreetKind, rotation_z

#: accepted ranges of the :func:`random_scene` options
#: (the heading limit keeps a corner of the cross street in view for ``occluding_pole``)
MAX_HEADING_DEG, MAX_SLOPE, MAX_CAMBER = 28.0, 0.15, 0.08


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
               instance: int, rotation: tuple[float, ...] | None = None, nose: int = 0) -> list[Box]:
    """A parked car as body, cabin and four wheel boxes, centred at (xc, yc), nose to ``facing``.

    ``ground`` is the surface height at (xc, yc); ``rotation`` (about that point) tilts the car
    so that its wheels stand on a graded or cambered road plane.
    """
    length, width, height = rng.uniform(3.9, 4.6), rng.uniform(1.72, 1.86), rng.uniform(1.4, 1.56)
    paint = _jitter(rng, _pick(rng, _CAR_PAINT), 6)
    pose = {} if rotation is None else {"rotation": rotation, "pivot": (xc, yc, ground)}
    body_lo, body_top = ground + 0.3, ground + 0.62 * height
    boxes = [Box((xc - length / 2, yc - width / 2, body_lo), (xc + length / 2, yc + width / 2, body_top),
                 "car", instance, paint, "car_body", nose=nose, **pose)]
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


def _bay_cars(rng: np.random.Generator, plan: StreetScene, kind: StreetKind, corner: list[Pole],
              cam_xy: np.ndarray, first_id: int) -> list[Box]:
    """Cars in about 85 % of the bays along both kerbs (none at the crossings), nosed in at the
    layout's angle along their side's direction."""
    boxes: list[Box] = []
    w, xc0, xc1 = plan.road_half_width, plan.crossing[0], plan.crossing[1]
    k = 0
    for side in (1, -1):
        for a, b in kind.bay_centres(side, w, 6.0, 70.0):
            if rng.random() > 0.85 or (a > xc0 - 6.0 and a < xc1 + 4.0):
                continue
            if plan.zebra is not None and plan.zebra[0] - 4.0 < a < plan.zebra[1] + 4.0:
                continue
            lo, hi = np.array([a - 2.4, b - 2.4]), np.array([a + 2.4, b + 2.4])
            if any(_segment_hits_rect(cam_xy, np.array([p.x, p.y]), lo - p.radius, hi + p.radius) for p in corner):
                continue
            ground = plan.crown_z + plan.slope * a - plan.camber * min(abs(b), w)
            tilt = _ground_rotation(plan.slope, -plan.camber * side)
            boxes += _car_boxes(rng, a, b, ground, 1, first_id + k, rotation_z(kind.yaw(side), tilt), 1)
            k += 1
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
                 occluding_pole: bool = True, light: "SceneLight | None" = None,
                 street: str | None = None) -> StreetScene:
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

    street      : None, or a street kind of :mod:`.streets` (``two-way``, ``one-way``, ``angled``,
                  ``perpendicular``, ``zebra``): the street laid out as traffic uses it (the
                  ego vehicle in its lane, parking strips or bays, the parked cars facing their
                  side's direction, a zebra crossing); None draws it as earlier versions.

    None (and 0) keep the flat street along x, with outputs identical to earlier versions.
    The ground is at height 0 under V's origin. Random numbers drawn do not depend on the
    options, so one seed gives the same layout (in street coordinates) for any of them.
    """
    heading = math.radians(_option(heading_deg, "heading_deg", MAX_HEADING_DEG))
    grade = _option(slope, "slope", MAX_SLOPE)
    fall = _option(camber, "camber", MAX_CAMBER) if road else 0.0
    kind = StreetKind.of(street)
    plan, draws = _street_plan(rng, width, height, road, heading, grade, fall, kind)
    boxes = _buildings(rng, plan, draws)
    poles, n_corner = _poles(rng, plan, occluding_pole)
    camera = plan.camera
    cam_xy = np.array([float(v) for v in plan.to_street(camera.x, camera.y)])
    boxes += _parked_cars(rng, plan, kind, poles[:n_corner], cam_xy)
    boxes += _pedestrians(rng, plan, poles)
    if not occluding_pole:
        poles = poles[n_corner:]
    scene = dataclasses.replace(plan, boxes=tuple(boxes), poles=tuple(poles), lane_dash=draws.dash, sun=draws.sun,
                                noise_seed=int(rng.integers(0, 2**62)))
    if light is not None:  # optional light control (SceneLight)
        scene = dataclasses.replace(scene, sun=light.direction, light=light)
    return scene


class _Draws(NamedTuple):
    """What the street plan drew besides the plan itself."""

    x_end: float  # where the far building rows end
    end_row: bool  # a building row across the street's end
    dash: tuple[float, float, float]  # the lane marking's dash, gap and phase
    sun: tuple[float, float, float]  # the default shading's sun direction


def _street_plan(rng: np.random.Generator, width: int, height: int, road: bool, heading: float, grade: float,
                 fall: float, kind: "StreetKind | None") -> tuple[StreetScene, _Draws]:
    """The camera and the street's cross-section, crossing and frame (no boxes, no poles yet)."""
    camera = random_camera(rng, width, height)
    w = float(rng.uniform(4.2, 6.0))
    if kind is not None:
        w = kind.half_width(w)
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
    ego_b = camera.y if kind is None else kind.ego_b(camera.y)  # the camera's place across the street
    if heading != 0.0 or ego_b != camera.y:
        c, s = math.cos(heading), math.sin(heading)
        origin = (camera.x - (c * camera.x - s * ego_b), camera.y - (s * camera.x + c * ego_b))
    traffic = {} if kind is None else {"parking_lane": kind.depth, "centre_line": not kind.one_way,
                                       "street_kind": kind.name, "zebra": kind.zebra_range(xc0)}
    plan = StreetScene(camera=camera, road_half_width=w, kerb_height=kerb, sidewalk_width=walk, boxes=(), poles=(),
                       has_road=road, crossing=(xc0, xc1), ego_rows=int(ego_rows), street_heading=heading,
                       street_origin=origin, slope=grade, camber=fall, **traffic)
    a_o, b_o = (float(v) for v in plan.to_street(0.0, 0.0))
    plan = dataclasses.replace(plan, crown_z=fall * abs(b_o) - grade * a_o + 0.0)
    return plan, _Draws(x_end, end_row, dash, sun)


def _buildings(rng: np.random.Generator, plan: StreetScene, draws: _Draws) -> list[Box]:
    """The building rows on both sides, before and after the crossing, and the end row."""
    w, walk, (xc0, xc1), grade, fall = (plan.road_half_width, plan.sidewalk_width, plan.crossing, plan.slope,
                                        plan.camber)
    x_end = draws.x_end
    boxes: list[Box] = []
    after = xc1 + (0.05 if grade != 0.0 else 0.0)  # keep facades off the far kerb's plane
    for side in (1, -1):
        extend = None if draws.end_row else 3000.0
        boxes += _building_row(rng, side, -25.0, xc0, w + walk, plan, None)
        boxes += _building_row(rng, side, after, x_end, w + walk, plan, extend)
    if draws.end_row:
        base = float(min(plan.road_edge_height(x_end), plan.road_edge_height(x_end + 25.0)))
        rise = abs(grade) * 25.0 + abs(fall) * w
        boxes.append(Box((x_end, -150.0, base), (x_end + 25.0, 150.0, base + float(rng.uniform(12.0, 26.0)) + rise),
                         "building", label_id("building"), _jitter(rng, _pick(rng, _FACADES), 8), "facade",
                         floor_height=float(rng.uniform(2.9, 3.5)), window_spacing=float(rng.uniform(2.2, 3.2))))
    return boxes


def _poles(rng: np.random.Generator, plan: StreetScene, occluding_pole: bool) -> tuple[list[Pole], int]:
    """The poles and how many of them (the first) stand at the near corners of the cross street;
    the rest along the kerbs."""
    w, (xc0, xc1), grade, heading = plan.road_half_width, plan.crossing, plan.slope, plan.street_heading

    def pole_at(a: float, b: float, radius: float, tall: float) -> Pole:
        # sidewalk: the ground under the pole only varies along a
        return Pole(a, b, radius, tall, float(plan.sidewalk_height(a)) - radius * abs(grade))

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
    return poles, len(corner_sides)


def _parked_cars(rng: np.random.Generator, plan: StreetScene, kind: "StreetKind | None", corner: list[Pole],
                 cam_xy: np.ndarray) -> list[Box]:
    """Parked cars along the kerbs (or in bays), in their side's direction of travel (right-hand
    traffic), none at the crossings, none hiding a corner pole."""
    w, (xc0, xc1), grade, fall = plan.road_half_width, plan.crossing, plan.slope, plan.camber
    boxes: list[Box] = []
    car_id = label_id("car") * INSTANCE_FACTOR
    n_cars = int(rng.integers(2, 6))
    placed: list[tuple[float, float, float]] = []  # (x_min, x_max, side)
    if kind is not None and kind.parking != "parallel":
        n_cars = 0  # bays instead
        boxes += _bay_cars(rng, plan, kind, corner, cam_xy, car_id)
    for _ in range(400):
        if len(placed) >= n_cars:
            break
        side = int(rng.choice([1, -1]))
        xc, yoff = float(rng.uniform(6.0, 85.0)), float(rng.uniform(0.15, 0.35))
        half_len, half_wid = 2.35, 0.95  # conservative footprint for the checks
        x0, x1 = xc - half_len, xc + half_len
        if x1 > xc0 - 5.0 and x0 < xc1 + 3.0:
            continue  # no parking at the crossing
        if plan.zebra is not None and x1 > plan.zebra[0] - 3.0 and x0 < plan.zebra[1] + 3.0:
            continue  # nor at a zebra crossing
        if any(s == side and x0 < b + 1.0 and x1 > a - 1.0 for a, b, s in placed):
            continue
        yc = side * (w - yoff - half_wid)
        lo, hi = np.array([x0, yc - half_wid]), np.array([x1, yc + half_wid])
        if any(_segment_hits_rect(cam_xy, np.array([p.x, p.y]), lo - p.radius, hi + p.radius) for p in corner):
            continue  # keep the corner poles in full view
        # the car stands on its half of the road: the plane z = crown + grade*a - fall*side*b
        ground = plan.crown_z + grade * xc - fall * abs(yc)
        facing = -side if kind is None else kind.direction(side)
        boxes += _car_boxes(rng, xc, yc, ground, facing, car_id + len(placed),
                            _ground_rotation(grade, -fall * side), 0 if kind is None else facing)
        placed.append((x0, x1, side))
    return boxes


def _pedestrians(rng: np.random.Generator, plan: StreetScene, poles: list[Pole]) -> list[Box]:
    """0-2 pedestrians on the sidewalks, away from the crossing and the poles."""
    w, walk, (xc0, xc1) = plan.road_half_width, plan.sidewalk_width, plan.crossing
    boxes: list[Box] = []
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
    return boxes

