"""Street kinds for :func:`~.layout.random_scene`'s ``street`` option: streets laid out as
traffic uses them, so that tests of placement's traffic sense (lanes, headings, parked rows,
crossings) run on generated frames.

=================  ==============================================================================
``two-way``        the ego vehicle in the right lane (1.6 m right of the dashed centre line),
                   parallel parking strips behind solid lines along both kerbs, the parked cars
                   facing their side's direction (right: away from the camera, left: towards it)
``one-way``        no centre line, the ego vehicle in the middle, every parked car facing away
``angled``         two-way, parking bays at 45 degrees along both kerbs (bay lines drawn), the
                   cars nosed in forward along their side's direction
``perpendicular``  two-way, bays at 90 degrees along both kerbs, cars nosed in towards the kerb
``zebra``          two-way with a zebra crossing (0.5 m stripes along the street, 4 m long) before
                   the cross street
=================  ==============================================================================

Without the option (None) the street is drawn as in earlier versions: the same random numbers,
byte-identical frames. With it, the street's half-width is widened where its lanes and bays
need the room (a deterministic change, no draw).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

STREET_KINDS = ("two-way", "one-way", "angled", "perpendicular", "zebra")
#: a moving lane's width in the generated streets, metres
LANE = 3.2
#: the ego vehicle stands this far right of the centre line on a two-way street, metres
EGO_OFFSET = 1.6
#: parking depth from the kerb (metres) and the cars' angle to the street (degrees) per layout
BAYS = {"parallel": (2.2, 0.0), "angled": (4.6, 45.0), "perpendicular": (5.2, 90.0)}
#: bays along the street every this many metres per layout
BAY_SPACING = {"angled": 3.4, "perpendicular": 2.6}
#: a zebra crossing's length along the street and its stripes' width and period across, metres
ZEBRA_LENGTH, ZEBRA_STRIPE, ZEBRA_PERIOD = 4.0, 0.5, 1.0


@dataclass(frozen=True)
class StreetKind:
    """How a generated street is used by traffic (see the module docstring)."""

    name: str
    one_way: bool
    parking: str
    zebra: bool

    @classmethod
    def of(cls, name: str | None) -> "StreetKind | None":
        if name is None:
            return None
        if name not in STREET_KINDS:
            raise ValueError(f"street must be one of {STREET_KINDS} or None, not {name!r}")
        parking = name if name in ("angled", "perpendicular") else "parallel"
        return cls(name, name == "one-way", parking, name == "zebra")

    @property
    def depth(self) -> float:
        """The parking strip's depth from the kerb, metres."""
        return BAYS[self.parking][0]

    @property
    def angle(self) -> float:
        """The parked cars' angle to the street, radians."""
        return math.radians(BAYS[self.parking][1])

    def half_width(self, drawn: float) -> float:
        """The road's half-width: the one drawn, widened to hold a lane and the parking."""
        return max(drawn, LANE + self.depth)

    def ego_b(self, camera_y: float) -> float:
        """The ego vehicle's position across the street (street frame b, metres)."""
        return camera_y if self.one_way else camera_y - EGO_OFFSET

    def direction(self, side: int) -> int:
        """The traffic direction along the kerb of ``side`` (+1 left, -1 right): +1 along a."""
        return 1 if self.one_way else -side

    def yaw(self, side: int) -> float:
        """A parked car's heading in the street frame (radians) along the kerb of ``side``: its
        side's direction, turned into its bay by the layout's angle (nose towards the kerb)."""
        d = self.direction(side)
        return (0.0 if d > 0 else math.pi) + d * side * self.angle

    def bay_centres(self, side: int, width: float, lo: float, hi: float) -> list[tuple[float, float]]:
        """(a, b) centres (at half the bays' depth) of the bays along the kerb of ``side``
        between a = lo and hi: every bay spacing from a = 0."""
        if self.parking == "parallel":
            return []
        step = BAY_SPACING[self.parking]
        b = side * (width - self.depth / 2)
        return [(float(a), b) for a in np.arange(math.ceil(lo / step) * step, hi, step)]

    def bay_lines(self, a: np.ndarray, b: np.ndarray, width: float) -> np.ndarray:
        """Bool: road points (a, b) on a line (0.1 m wide) dividing two bays: half-way between
        bay centres, along the cars' axis, from the kerb to the bays' depth."""
        if self.parking == "parallel":
            return np.zeros(np.shape(a), bool)
        step = BAY_SPACING[self.parking]
        side = np.where(b >= 0, 1, -1)
        into = width - np.abs(b)
        cot = np.where(side > 0, 1.0 / math.tan(self.yaw(1)), 1.0 / math.tan(self.yaw(-1)))
        cot = np.where(np.abs(cot) < 1e-9, 0.0, cot)
        pos = np.mod(a + side * (into - self.depth / 2) * cot - step / 2 + 0.05, step)
        return (into >= 0) & (into <= self.depth) & (pos < 0.1 / math.sin(self.angle))

    def zebra_range(self, crossing_start: float) -> tuple[float, float] | None:
        """The zebra crossing's a-range (before the cross street), or None."""
        if not self.zebra:
            return None
        start = crossing_start - 9.0
        return (start, start + ZEBRA_LENGTH)


def zebra_paint(a: np.ndarray, b: np.ndarray, zebra: tuple[float, float] | None, width: float) -> np.ndarray:
    """Bool: road points (a, b) on a zebra crossing's stripes."""
    if zebra is None:
        return np.zeros(np.shape(a), bool)
    return (a >= zebra[0]) & (a <= zebra[1]) & (np.abs(b) <= width - 0.3) & \
        (np.mod(b, ZEBRA_PERIOD) < ZEBRA_STRIPE)


def rotation_z(yaw: float, tilt: tuple[float, ...] | None) -> tuple[float, ...]:
    """Row-major rotation: turned by ``yaw`` about z, then tilted by ``tilt`` (a row-major
    rotation, or None for a level road)."""
    c, s = math.cos(yaw), math.sin(yaw)
    r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    if tilt is not None:
        r = np.asarray(tilt, float).reshape(3, 3) @ r
    return tuple(float(v) for v in r.ravel())
