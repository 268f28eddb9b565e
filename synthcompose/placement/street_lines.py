"""Lines along the street, on the ground plan: the street's axis and the kerb and marking
lines parallel to it (``street.py`` describes the road frame (a, s) they are measured in).

The axis ``y = b x + q x^2`` is the one that lines the kerb and marking points up: the most
metres of lines covered, per 0.2 m across (a grid of slopes and bends), then refined by least
squares on the strongest lines as parallel curves. A line is a peak of the points' offset
``s`` covered over at least a few metres of ``a``; a marking is solid when seen over
``SOLID_RUN`` metres without a break, else dashed; two thin lines a rail gauge apart are tram
rails, not lane lines.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: the street is seen over this range of a (metres ahead of the vehicle's origin)
NEAR, FAR = 3.0, 48.0
#: lateral extent of the street model, metres
SPAN = 16.0
#: histogram bins: across (metres) and along (metres)
S_BIN, A_BIN = 0.1, 1.0
#: a line must be seen over this many metres of a (kerbs, markings)
MIN_KERB_COVER, MIN_MARK_COVER = 4.0, 3.0
#: a marking seen over this run of metres without a break is solid
SOLID_RUN = 6.0
#: a line's offset near the camera is measured over its nearest this many metres (metres)
NEAR_STRETCH = 6.0
#: tram rails: two thin lines this far apart (metres)
RAIL_GAUGE = (1.3, 1.65)
#: at most this many points go into the axis search, all within this many metres ahead (the
#: street the ego vehicle is on, not the kerbs of a junction further on)
AXIS_POINTS, AXIS_FAR = 3000, 30.0
#: the street's axis is turned at most this much from the ego vehicle's heading (tan, 27 deg)
MAX_SLOPE = 0.5


@dataclass(frozen=True)
class StreetLine:
    """A line along the street: ``offset`` s (metres, left positive), ``kind`` (``kerb``,
    ``solid``, ``dashed``), where it is seen along the street (``start``, ``end``, metres of a)
    and over how many metres (``cover``)."""

    offset: float
    kind: str
    start: float
    end: float
    cover: float
    near: float | None = None  # its offset over its nearest NEAR_STRETCH metres (a curving street)

    @property
    def near_offset(self) -> float:
        return self.offset if self.near is None else self.near

    def to_dict(self) -> dict:
        return {"offset_m": round(self.offset, 3), "kind": self.kind, "from_m": round(self.start, 1),
                "to_m": round(self.end, 1)}


def to_road(xy: np.ndarray, b: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """(a, s) of (N, 2) ground-plan points against the axis y = b x + q x^2: a = x, s the
    offset across the axis (y off the axis, times the cosine of its heading)."""
    x, y = xy[:, 0], xy[:, 1]
    return x, (y - b * x - q * x * x) * np.cos(np.arctan(b + 2 * q * x))


def coverage_(a: np.ndarray, s: np.ndarray, s_bin: float = S_BIN, grow: int = 1) -> tuple[np.ndarray, float]:
    """(S, A) bool occupancy of (a, s) points in bins across and along the street (grown by
    ``grow`` bins across), and the s of bin 0."""
    s0 = -SPAN - 0.5 * FAR * 0.8
    n_s = int(2 * -s0 / s_bin) + 1
    n_a = int((FAR + 10) / A_BIN) + 1
    si = np.clip(((s - s0) / s_bin).astype(np.int64), 0, n_s - 1)
    ai = np.clip((a / A_BIN).astype(np.int64), 0, n_a - 1)
    occ = np.zeros((n_s, n_a), bool)
    occ[si, ai] = True
    if grow:
        g = occ.copy()
        for k in range(1, grow + 1):
            g[k:] |= occ[:-k]
            g[:-k] |= occ[k:]
        occ = g
    return occ, s0


def axis_(points: np.ndarray) -> tuple[float, float]:
    """The axis (b, q) that lines the kerb and marking points up along the street: the most
    metres of lines covered, squared per 0.2 m of s (long lines count most)."""
    if len(points) < 20:
        return 0.0, 0.0
    if len(points) > AXIS_POINTS:
        points = points[:: int(math.ceil(len(points) / AXIS_POINTS))]

    def score(b: float, q: float) -> float:
        a, s = to_road(points, b, q)
        occ, _ = coverage_(a, s, 0.2, 0)
        cover = occ.sum(axis=1).astype(np.float64)
        # the ego vehicle drives along its street: a turned axis must line up clearly more
        return float((cover * cover).sum()) * (1.0 - 0.2 * abs(b) / MAX_SLOPE)

    slopes = np.linspace(-MAX_SLOPE, MAX_SLOPE, 31)
    best_b = max(slopes, key=lambda b: score(b, 0.0))
    fine = [(b, q) for b in best_b + np.linspace(-0.04, 0.04, 9) for q in np.linspace(-0.004, 0.004, 9)]
    b, q = max(fine, key=lambda bq: score(*bq))
    return _refine(points, float(b), float(q))


def _refine(points: np.ndarray, b: float, q: float, iterations: int = 2) -> tuple[float, float]:
    """The axis refined by least squares: the strongest lines (points within 0.25 m of each)
    as parallel curves y = b x + q x^2 + c_k, one offset each, the axis shared."""
    for _ in range(iterations):
        lines = [ln for ln in lines_(points, b, q, SOLID_RUN, "any") if ln.cover >= SOLID_RUN][:6]
        if not lines:
            break
        _, s = to_road(points, b, q)
        rows, ys = [], []
        for k, ln in enumerate(lines):
            near = np.abs(s - ln.offset) < 0.25
            x = points[near, 0]
            rows.append(np.column_stack([x, x * x] + [np.full(len(x), float(j == k)) for j in range(len(lines))]))
            ys.append(points[near, 1])
        A, y = np.concatenate(rows), np.concatenate(ys)
        if len(y) < 20:
            break
        # the bend only where lines are seen over a long stretch, else the slope alone
        bend = len(lines) >= 2 and A[:, 0].max() - A[:, 0].min() >= 25.0
        if not bend:
            A, q = np.delete(A, 1, axis=1), 0.0
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        b = float(np.clip(coef[0], -MAX_SLOPE, MAX_SLOPE))
        if bend:
            q = float(np.clip(coef[1], -0.005, 0.005))
    return b, q


def lines_(points: np.ndarray, b: float, q: float, min_cover: float, kind: str | None) -> list[StreetLine]:
    """Peaks of the points' offset s, each covered over at least ``min_cover`` metres of a."""
    if len(points) < 10:
        return []
    a, s = to_road(points, b, q)
    occ, s0 = coverage_(a, s)
    cover = occ.sum(axis=1) * A_BIN
    out: list[StreetLine] = []
    taken = np.zeros(len(cover), bool)
    for i in np.argsort(-cover, kind="stable"):
        if cover[i] < min_cover:
            break
        if taken[max(0, i - 6):i + 7].any():  # within 0.6 m of a stronger line
            continue
        taken[i] = True
        centre = s0 + (i + 0.5) * S_BIN
        near = np.abs(s - centre) <= 0.15
        offset = float(np.median(s[near])) if near.any() else centre
        cols = np.flatnonzero(occ[i])
        run = _longest_run(cols)
        start = float(cols.min() * A_BIN)
        first = near & (a <= start + NEAR_STRETCH)
        out.append(StreetLine(offset, kind or ("solid" if run * A_BIN >= SOLID_RUN else "dashed"),
                              start, float((cols.max() + 1) * A_BIN), float(cover[i]),
                              float(np.median(s[first])) if first.sum() >= 3 else None))
    return out


def _longest_run(cols: np.ndarray, gap: int = 1) -> int:
    """Longest run of bins in sorted ``cols`` with breaks of at most ``gap`` bins."""
    if not len(cols):
        return 0
    breaks = np.flatnonzero(np.diff(cols) > gap + 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(cols) - 1]])
    return int((cols[ends] - cols[starts] + 1).max())


def drop_rails(lines: list[StreetLine]) -> list[StreetLine]:
    """Lane lines less the pairs of tram rails (two lines a rail gauge apart, neither dashed)."""
    rails = set()
    for i, m in enumerate(lines):
        for j, n in enumerate(lines):
            if i < j and RAIL_GAUGE[0] <= abs(m.offset - n.offset) <= RAIL_GAUGE[1] and "dashed" not in (m.kind, n.kind):
                rails |= {i, j}
    return [m for k, m in enumerate(lines) if k not in rails]


