"""The street a frame shows, on the ground plan: its axis, kerb lines, lane markings,
carriageways, lanes, crossings, and which way traffic goes in each lane.

Everything here is in the vehicle frame's ground plan (V: x forward, y left, metres) and in a
*road frame* that follows the street the camera drives on: ``a`` along the street (its x),
``s`` across it (left positive), measured from an axis ``y = b x + q x^2`` through the
vehicle's own ground point (so the ego vehicle is at s = 0, the street may be turned and
gently curved). Lines that run along the street - kerbs, lane lines - are lines of constant
``s``; the axis is the one that makes them so (the sharpest histogram of the kerb and marking
points across it).

1. **Lines**: kerb lines (where the road meets other ground, ``road.surface_edges``) and lane
   markings (bright thin lines in the photo, ``markings.py``), each a peak of the points'
   offset ``s`` covered over at least a few metres of ``a``; a marking is *solid* when seen
   over 6 m without a break, else *dashed*. Two thin lines 1.3-1.6 m apart along the road are
   tram rails, not lane lines.
2. **Carriageways**: the ego carriageway between the nearest kerb line on each side (or where
   its road ends: the ground under and behind a car is hidden, not off the road); beyond a
   kerb, another carriageway where road runs between two kerb lines (a dual road's other half).
3. **Centre and direction** (``traffic.py`` for the lanes): the centre of a two-way
   carriageway is the lane marking left of the ego vehicle nearest to the middle between its
   kerbs, or that middle without one; with no marking left of the ego vehicle and the ego
   vehicle not right of the middle, the street is one-way (the ego vehicle drives with it).
4. **Crossings**: zebra stripes (``markings.py``) spread over at least 3 m across the
   carriageway within a few metres along it.

Built once per frame and cached; the placement and the checker read the same street.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .markings import find_markings
from .road import surface_edges
from .street_lines import (
    AXIS_FAR,
    FAR,
    MIN_KERB_COVER,
    MIN_MARK_COVER,
    NEAR,
    NEAR_STRETCH,
    S_BIN,
    SOLID_RUN,
    SPAN,
    StreetLine,
    axis_,
    coverage_,
    drop_rails,
    lines_,
    to_road,
)

#: the ego vehicle's lane reaches this far to each side of it (a centre line is beyond it), and
#: its place across the street is taken this far ahead (metres)
EGO_HALF_LANE, EGO_AHEAD = 0.8, 8.0
#: a centre line leaves at least this much room for the oncoming lane (metres); a solid line
#: counts this much farther from the middle than a dashed one
ONCOMING_LANE, SOLID_PENALTY = 2.5, 1.5
#: a two-way street without a centre marking: the ego vehicle is at least this far right of
#: the middle, and the carriageway at least this wide
TWO_WAY_OFFSET, TWO_WAY_WIDTH = 0.6, 5.0
#: zebra stripes repeat across the street every this many metres
ZEBRA_PERIOD = 1.0
#: a ground cell is hidden where what the camera sees this far above it (metres) is nearer than
#: this share of its own depth
HIDDEN_OVER, HIDDEN_NEARER = 0.5, 0.95
#: the ego carriageway's kerbs: the nearest kerb line on each side seen this near
KERB_NEAR = 18.0


@dataclass(frozen=True)
class Carriageway:
    """One carriageway across the street: kerb offsets ``right`` < ``left`` (s, metres; where
    no kerb is seen, where its road ends), the lane markings inside, its ``centre`` line (a
    two-way carriageway) or None (one-way), and ``side``: 0 the ego vehicle's, +1 beyond its
    left kerb, -1 beyond its right kerb (a dual road's other half)."""

    right: float
    left: float
    markings: tuple[StreetLine, ...]
    centre: float | None
    side: int
    centre_source: str  # "marking", "middle", "one-way"

    def contains(self, s: float, margin: float = 0.0) -> bool:
        return self.right - margin <= s <= self.left + margin

    def to_dict(self) -> dict:
        return {"right_m": round(self.right, 3), "left_m": round(self.left, 3),
                "centre_m": None if self.centre is None else round(self.centre, 3),
                "centre_source": self.centre_source, "side": self.side,
                "markings": [m.to_dict() for m in self.markings]}


@dataclass(frozen=True)
class Crossing:
    """A zebra crossing: along the street from ``start`` to ``end`` (a, metres), across the
    carriageway from ``right`` to ``left`` (s, metres)."""

    start: float
    end: float
    right: float
    left: float

    def contains(self, a: float, s: float) -> bool:
        return self.start <= a <= self.end and self.right <= s <= self.left


@dataclass(frozen=True)
class Street:
    """The street of one frame (see the module docstring). Axis ``y = b x + q x^2`` in V (x
    from the vehicle's origin); ``lines`` every line found; ``carriageways`` the ego's first."""

    b: float
    q: float
    lines: tuple[StreetLine, ...]
    carriageways: tuple[Carriageway, ...]
    crossings: tuple[Crossing, ...]
    ego_offset: float = 0.0  # the ego vehicle's place across the street, EGO_AHEAD ahead (s, metres)

    def heading(self, a) -> np.ndarray | float:
        """Direction of the street at ``a`` (radians in V, pointing away from the camera)."""
        return np.arctan(self.b + 2 * self.q * np.asarray(a, float))

    def to_road(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """(a, s) of (N, 2) ground-plan points (V): along and across the street."""
        return to_road(np.atleast_2d(np.asarray(xy, float)), self.b, self.q)

    def to_plan(self, a: float, s: float) -> np.ndarray:
        """(2,) ground-plan point (V) of road-frame (a, s)."""
        t = float(self.heading(a))
        y0 = self.b * a + self.q * a * a
        return np.array([a - s * math.sin(t), y0 + s * math.cos(t)])

    @property
    def ego(self) -> Carriageway:
        return self.carriageways[0]

    def carriageway_at(self, s: float, margin: float = 0.3) -> Carriageway | None:
        return next((c for c in self.carriageways if c.contains(s, margin)), None)

    def crossing_at(self, a: float, s: float) -> Crossing | None:
        return next((c for c in self.crossings if c.contains(a, s)), None)

    def to_dict(self) -> dict:
        return {"axis": {"b": round(self.b, 5), "q": round(self.q, 6)}, "ego_offset_m": round(self.ego_offset, 3),
                "carriageways": [c.to_dict() for c in self.carriageways],
                "crossings": [[round(v, 2) for v in (c.start, c.end, c.right, c.left)] for c in self.crossings]}


def find_street(frame: Frame, hand: int = 1) -> Street:
    """The frame's street (cached on the frame) for right-hand (``hand`` = +1) or left-hand
    (-1) traffic: the centre line is on the side of the ego vehicle its oncoming traffic
    drives on."""
    key = ("street", hand)
    return frame.derived(key, lambda: _build(frame, hand))


def _window(xy: np.ndarray, cam_x: float) -> np.ndarray:
    x = xy[:, 0] - cam_x
    return xy[(x >= NEAR) & (x <= FAR) & (np.abs(xy[:, 1]) <= SPAN + 0.4 * x)]


def _build(frame: Frame, hand: int) -> Street:
    road_ids = np.array([label_id("road")])
    kerbs = _window(surface_edges(frame, road_ids), frame.camera.x)
    marks = _window(find_markings(frame).lines, frame.camera.x)
    both = np.concatenate([kerbs, marks])
    b, q = axis_(both[both[:, 0] - frame.camera.x <= AXIS_FAR])
    kerb_lines = lines_(kerbs, b, q, MIN_KERB_COVER, "kerb")
    road = _road_profile(frame, b, q)
    crossings = _crossings(find_markings(frame).zebra, b, q,
                           _carriageways(kerb_lines, [], road, hand, _ego_path(frame.camera, b, q))[0])
    if crossings:  # a zebra's stripes are no lane lines
        a = marks[:, 0]
        marks = marks[~np.any([(a >= c.start - 0.5) & (a <= c.end + 0.5) for c in crossings], axis=0)]
    mark_lines = drop_rails(lines_(marks, b, q, MIN_MARK_COVER, None))
    ego = _ego_path(frame.camera, b, q)
    carriageways = _carriageways(kerb_lines, mark_lines, road, hand, ego)
    crossings = [Crossing(c.start, c.end, carriageways[0].right, carriageways[0].left) for c in crossings]
    return Street(b, q, tuple(sorted(kerb_lines + mark_lines, key=lambda l: l.offset)), tuple(carriageways),
                  tuple(crossings), ego(EGO_AHEAD))


@dataclass(frozen=True)
class _RoadProfile:
    """Share of the street's length (a bins 6-30 m) with road seen at each offset s, of the
    length the camera sees there (inside the image, and not under or behind something nearer:
    the road runs on under a car ahead)."""

    share: np.ndarray
    s0: float
    seen: np.ndarray  # cells inside the image per offset

    def at(self, lo: float, hi: float) -> float:
        i0, i1 = int((lo - self.s0) / S_BIN), int((hi - self.s0) / S_BIN)
        seg = self.share[max(i0, 0):max(i1, i0 + 1)]
        return float(seg.mean()) if len(seg) else 0.0

    def extent(self, side: int, limit: float = 0.25) -> tuple[float, bool]:
        """Where the road seen from s = 0 towards ``side`` (+1 left, -1 right) ends, and whether
        it ends where the camera stops seeing it (not where the road does)."""
        i = int(-self.s0 / S_BIN)
        while 0 < i < len(self.share) - 1 and (abs(self.s0 + i * S_BIN) < 1.0 or self.share[i] >= limit):
            i += side
        return self.s0 + i * S_BIN, bool(self.seen[i] < 3)


def _road_profile(frame: Frame, b: float, q: float) -> _RoadProfile:
    road = frame.label_ids[::4, ::4] == label_id("road")
    v, u = np.nonzero(road & np.isfinite(frame.depth[::4, ::4]))
    from .markings import ground_

    xy = _window(ground_(frame, v * 4, u * 4), frame.camera.x)
    a, s = to_road(xy, b, q)
    near = (a >= 6) & (a <= 30)
    occ, s0 = coverage_(a[near], s[near], S_BIN, 0)
    # the cells the camera sees: their centres on the ground plane inside the image
    cells_s = s0 + (np.arange(occ.shape[0]) + 0.5) * S_BIN
    cells_a = np.arange(6, 31) + 0.5
    aa, ss = np.meshgrid(cells_a, cells_s)
    t = np.arctan(b + 2 * q * aa)
    x = aa - ss * np.sin(t)
    y = b * aa + q * aa * aa + ss * np.cos(t)
    opt = frame.to_optical(np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]))
    with np.errstate(invalid="ignore", divide="ignore"):
        uv = frame.camera.project(opt)
    H, W = frame.shape

    def in_image(at: np.ndarray) -> np.ndarray:
        return np.isfinite(at).all(axis=1) & (at[:, 0] >= 0) & (at[:, 0] < W) & (at[:, 1] >= 0) & (at[:, 1] < H)

    inside = (opt[:, 2] > 1.0) & in_image(uv)
    # a cell under or behind something (a car ahead, a parked row) is not seen either: what the
    # camera sees at it, or HIDDEN_OVER above it, is nearer than the cell; nor is one where the
    # matcher measured neither
    over = frame.to_optical(np.column_stack([x.ravel(), y.ravel(), np.full(x.size, HIDDEN_OVER)]))
    with np.errstate(invalid="ignore", divide="ignore"):
        up = frame.camera.project(over)
    hidden = np.zeros(len(opt), bool)
    holes = inside.copy()
    for pts, at in ((opt, uv), (over, up)):
        ok = inside & in_image(at)
        iu, iv = (np.where(ok, at[:, k], 0).astype(np.int64) for k in (0, 1))
        d = np.where(ok, frame.depth[iv, iu], np.inf)
        hidden |= ok & (d < HIDDEN_NEARER * pts[:, 2])
        holes &= ~np.isfinite(d)
    visible = ((inside & ~hidden & ~holes).reshape(aa.shape) | occ[:, 6:31]).sum(axis=1)
    share = occ[:, 6:31].sum(axis=1) / np.maximum(visible, 1)
    # (a road hidden all along ends there: "unseen" is the image's edge, not a car's back)
    return _RoadProfile(np.where(visible >= 3, share, 0.0), s0, inside.reshape(aa.shape).sum(axis=1))


def _ego_path(camera, b: float, q: float):
    """The ego vehicle's offset across the street at distance ``a`` along it, driving on as it
    heads (V's x) up to ``EGO_AHEAD`` and no farther: where the street turns, the lines near
    the camera are judged against it; a line first seen far is judged against the ego
    vehicle's place ``EGO_AHEAD`` ahead (a camera turned off the street's direction, at a
    bend or turning, would otherwise drive off its street on paper)."""
    def at(a: float) -> float:
        return float(to_road(np.array([[min(a, EGO_AHEAD), camera.y]]), b, q)[1][0])
    return at


def _side_of(line: StreetLine, ego) -> float:
    """The line's offset across the street from the ego vehicle's path, where it is first seen."""
    return line.near_offset - ego(line.start + NEAR_STRETCH / 2)


def _carriageways(kerbs: list[StreetLine], marks: list[StreetLine], road: _RoadProfile,
                  hand: int, ego) -> list[Carriageway]:
    def nearest(side: int) -> float | None:
        lines = [k for k in kerbs if side * _side_of(k, ego) > EGO_HALF_LANE]
        near = [k for k in lines if k.start <= KERB_NEAR] or lines  # seen near, else as far as seen
        return min((k.offset for k in near), key=abs, default=None)

    left, right = nearest(1), nearest(-1)
    # no kerb seen on a side: where the road ends; where the camera does not see that far
    # (a street turned away), as far as the other kerb (a street is about symmetric)
    for side in (1, -1):
        if (left if side > 0 else right) is None:
            edge, unseen = road.extent(side)
            other = right if side > 0 else left
            if unseen and other is not None:
                edge = side * max(abs(edge), abs(other))
            left, right = (edge, right) if side > 0 else (left, edge)
    out = [_ego(right, left, [m for m in marks if right + 0.4 < m.offset < left - 0.4], hand, ego)]
    # beyond a kerb: other carriageways, road between two kerb lines (a dual road's other half)
    offsets = sorted(k.offset for k in kerbs)
    for lo, hi in zip(offsets, offsets[1:]):
        if hi - lo < 2.5 or (lo < left and hi > right) or road.at(lo, hi) < 0.2:
            continue
        if lo >= left or hi <= right:
            side = 1 if lo >= left else -1
            inside = tuple(m for m in marks if lo + 0.4 < m.offset < hi - 0.4)
            out.append(Carriageway(lo, hi, inside, None, side, "one-way"))
    return out


def _ego(right: float, left: float, marks: list[StreetLine], hand: int, ego) -> Carriageway:
    """The ego carriageway: its centre line (on the oncoming traffic's side of the ego
    vehicle: left for right-hand traffic, ``hand`` = +1), or one-way with the ego vehicle."""
    middle = (left + right) / 2
    # a centre line has the ego vehicle's lane on one side and a whole lane of oncoming traffic
    # on the other (a line closer to the kerb bounds a parking strip or a cycle lane)
    kerb = left if hand > 0 else right
    beyond = [m for m in marks if hand * _side_of(m, ego) > EGO_HALF_LANE and abs(kerb - m.offset) >= ONCOMING_LANE]
    beyond = [m for m in beyond if m.cover >= SOLID_RUN] or beyond  # seen over a stretch: not a stripe
    if beyond:
        # nearest to the middle; a dashed line before a solid one (a centre line is mostly
        # dashed, the line in front of parking bays or along a cycle lane solid)
        centre = min(beyond, key=lambda m: abs(m.offset - middle) + (SOLID_PENALTY if m.kind == "solid" else 0.0))
        return Carriageway(right, left, tuple(marks), centre.offset, 0, "marking")
    if hand * (middle - ego(EGO_AHEAD)) >= TWO_WAY_OFFSET and left - right >= TWO_WAY_WIDTH:
        return Carriageway(right, left, tuple(marks), middle, 0, "middle")
    return Carriageway(right, left, tuple(marks), None, 0, "one-way")


def _crossings(zebra: np.ndarray, b: float, q: float, ego: Carriageway) -> list[Crossing]:
    """Zebra crossings: stripes over at least 2.5 m across the ego carriageway within 3 m
    along it, one every ZEBRA_PERIOD (the stripes' positions across agree modulo the period),
    across the ego vehicle's lane and on both sides of it."""
    if len(zebra) < 20:
        return []
    a, s = to_road(zebra, b, q)
    inside = (s >= ego.right - 0.5) & (s <= ego.left + 0.5)
    a, s = a[inside], s[inside]
    out: list[Crossing] = []
    for a0 in np.arange(NEAR, FAR, 1.0):
        sel = (a >= a0) & (a < a0 + 3.0)
        if len(np.unique(np.floor(s[sel] / 0.5))) < 5:
            continue
        phase = np.exp(2j * np.pi * s[sel] / ZEBRA_PERIOD)
        if abs(phase.mean()) < 0.4:
            continue
        # across the ego vehicle's lane too, stripes on both sides of it
        if not (np.abs(s[sel]) < 1.5).any() or s[sel].min() > -1.0 or s[sel].max() < 1.0:
            continue
        if out and a0 <= out[-1].end:
            out[-1] = Crossing(out[-1].start, a0 + 3.0, ego.right, ego.left)
        else:
            out.append(Crossing(a0, a0 + 3.0, ego.right, ego.left))
    # each crossing as long as its stripes are seen (a zebra is 3-6 m long)
    found = []
    for c in out:
        lo, hi = np.percentile(a[(a >= c.start) & (a <= c.end)], [5, 95])
        if hi - lo <= 8.0:
            found.append(Crossing(float(lo), float(hi), ego.right, ego.left))
    return found


def heights_over_road(frame: Frame, street: Street, far: float, min_points: int = 1, step: int = 4
                      ) -> tuple[np.ndarray, ...] | None:
    """Every ``step``-th pixel with a depth as (v, u, a, s, h): its place along and across the
    street and its height over the road there (per metre of a up to ``far``, the median height
    of the road's points, where at least ``min_points`` of them; between and beyond, the
    nearest such metres' heights interpolated); None where no metre has road."""
    v, u = np.nonzero(np.isfinite(frame.depth[::step, ::step]))
    v, u = v * step, u * step
    cam = frame.camera
    z = frame.depth[v, u].astype(np.float64)
    optical = np.column_stack([(u - cam.u0) * z / cam.fx, (v - cam.v0) * z / cam.fy, z])
    m = cam.vehicle_from_optical
    p = optical @ m[:3, :3].T + m[:3, 3]
    a, s = to_road(p[:, :2], street.b, street.q)
    road = frame.label_ids[v, u] == label_id("road")
    n = int(far) + 1
    bins = np.clip(a.astype(np.int64), 0, n - 1)
    heights = np.full(n, np.nan)
    for i in np.unique(bins[road]):
        here = road & (bins == i)
        if here.sum() >= min_points:
            heights[i] = np.median(p[here, 2])
    known = np.flatnonzero(np.isfinite(heights))
    if not len(known):
        return None
    return v, u, a, s, p[:, 2] - np.interp(np.arange(n), known, heights[known])[bins]
