"""The frame's own parked cars: along which kerbs of the ego carriageway they stand, and how
(parallel to the kerb, angled or perpendicular in bays).

Vehicle points are the labelled vehicles of a labelled frame, or, on a frame without labels,
the points 0.4-1.5 m above the road at their distance along the street that are neither road
nor sidewalk (a car's body: below, the ground; above, mostly walls and trees). A kerb has a
parked row where such points stand within ``ROW_REACH`` of it (and on the carriageway, not
beyond the other kerb) over at least ``MIN_ROW`` metres of the street (a car driving by is seen
over a few metres, mostly its rear), in blobs whose nearest point is within ``KERB_TOUCH`` of
the kerb (a car driving in the lane beside the row is a blob of its own, farther in). The row's depth
is how far its road-facing side stands from the kerb (per metre of the street the farthest
point, the median over the row): a parallel row is about a car's width deep, a row of bays a
car's length. Bays are angled or perpendicular by the main axis of the row's blobs (the points
on a 0.25 m grid, connected: one or a few cars each) against the street, perpendicular where
the blobs do not tell.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from synthcompose.geometry.depth import Frame
from synthcompose.labels import label_id

from .markings import ground_
from .rules import label_mask
from .street import Street, heights_over_road, to_road

VEHICLES = ("car", "truck", "bus", "caravan", "trailer")
#: a row's cars stand within this far into the carriageway from the kerb and this far beyond it
#: (on the kerb), metres
ROW_REACH, ROW_BEYOND = 6.0, 1.0
#: a parked row covers at least this many metres of the street
MIN_ROW = 6.0
#: deeper than this (metres from the kerb), a row stands in bays
PARALLEL_DEPTH = 3.0
#: a parked car's nearest point stands within this of the kerb (metres: its gap to the kerb,
#: a door's mirror, the stereo's spread at 40 m)
KERB_TOUCH = 1.2
#: vehicle bodies on a frame without labels: this high above the road, metres
BODY = (0.4, 1.5)


@dataclass(frozen=True)
class ParkedRow:
    """The real parked row along one kerb (``side`` -1 right, +1 left): metres of the street
    it covers, its layout (``parallel``, ``angled``, ``perpendicular``), the cars' angle to
    the street (degrees, 0 parallel) and its depth from the kerb (metres)."""

    side: int
    cover: float
    layout: str
    angle_deg: float
    depth: float


def parked_rows(frame: Frame, street: Street) -> dict[int, ParkedRow]:
    """The parked rows along the ego carriageway's kerbs (cached on the frame, per street)."""
    key = ("parked_rows", id(street))
    return frame.derived(key, lambda: _rows(frame, street))


def _vehicle_points(frame: Frame, street: Street) -> tuple[np.ndarray, np.ndarray]:
    """(a, s) of the frame's vehicle points (every 4th pixel)."""
    lab = frame.label_ids[::4, ::4]
    finite = np.isfinite(frame.depth[::4, ::4])
    if frame.labelled:
        v, u = np.nonzero(label_mask([label_id(n) for n in VEHICLES])[lab] & finite)
        xy = ground_(frame, v * 4, u * 4)
        return to_road(xy, street.b, street.q)
    found = heights_over_road(frame, street, far=80.0)
    if found is None:
        return np.empty(0), np.empty(0)
    v, u, a, s, h = found
    body = (h >= BODY[0]) & (h <= BODY[1]) & ~label_mask([label_id("road"), label_id("sidewalk")])[lab[v // 4, u // 4]]
    return a[body], s[body]


def _rows(frame: Frame, street: Street) -> dict[int, ParkedRow]:
    a, s = _vehicle_points(frame, street)
    ego = street.ego
    out: dict[int, ParkedRow] = {}
    for side, kerb in ((-1, ego.right), (+1, ego.left)):
        inward = -side * (s - kerb)  # metres from the kerb into the carriageway
        # on a frame without labels a wall or a hedge beyond the kerb stands as high as a car
        beyond = ROW_BEYOND if frame.labelled else -0.2
        # a car parked along this kerb stands on the carriageway: points beyond the other kerb
        # (a car park, the other side's row seen on its kerb) are no car of this row
        reach = min(ROW_REACH, ego.left - ego.right)
        sel = (inward >= -beyond) & (inward <= reach) & (a >= 5.0) & (a <= 40.0)
        if sel.sum() < 10:
            continue
        # the row is the blobs that reach the kerb: a car driving in the lane beside the row
        # (or the bus beyond it) is a blob of its own farther in, and no parked car
        sel[sel] = _at_kerb(a[sel], s[sel], inward[sel])
        if sel.sum() < 10:
            continue
        bins = a[sel].astype(np.int64)
        counts = np.bincount(bins, minlength=41)
        covered = np.flatnonzero(counts >= 3)
        # a row: cars over MIN_ROW metres of the street, at least two of them (one car is
        # a car driving by as well)
        if len(covered) < 3 or covered[-1] - covered[0] + 1 < MIN_ROW or _blobs(a[sel], s[sel]) < 2:
            continue
        farthest = np.full(41, -np.inf)
        np.maximum.at(farthest, bins, inward[sel])
        depth = float(np.median(farthest[covered]))
        if depth <= PARALLEL_DEPTH:
            out[side] = ParkedRow(side, float(len(covered)), "parallel", 0.0, max(depth, 0.0))
            continue
        angle = _layout_angle(a[sel], s[sel])
        layout = "angled" if 30 <= angle <= 65 else "perpendicular"
        out[side] = ParkedRow(side, float(len(covered)), layout, angle if layout == "angled" else 90.0, depth)
    return out


def make_grid(a: np.ndarray, s: np.ndarray, cell: float = 0.25) -> tuple[int, np.ndarray]:
    """The row's points on a ``cell`` grid (a, s), connected: (count + 1, component labels)."""
    i, j = _cells(a, s, cell)
    grid = np.zeros((int(i.max()) + 1, int(j.max()) + 1), np.uint8)
    grid[i, j] = 1
    return cv2.connectedComponents(grid, connectivity=8)


def _cells(a: np.ndarray, s: np.ndarray, cell: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Each point's grid cell (row along a, column along s)."""
    return ((a - a.min()) / cell).astype(np.int64), ((s - s.min()) / cell).astype(np.int64)


def _at_kerb(a: np.ndarray, s: np.ndarray, inward: np.ndarray) -> np.ndarray:
    """(N,) bool: the points of the blobs (make_grid's, at least 12 cells) whose nearest point
    stands within KERB_TOUCH of the kerb (``inward``: metres from it into the carriageway)."""
    n, comp = make_grid(a, s)
    label = comp[_cells(a, s)]
    cells = np.bincount(comp.ravel(), minlength=n)
    nearest = np.full(n, np.inf)
    np.minimum.at(nearest, label, inward)
    keep = (cells >= 12) & (nearest <= KERB_TOUCH)
    keep[0] = False
    return keep[label]


def _blobs(a: np.ndarray, s: np.ndarray) -> int:
    """How many blobs of at least 12 cells (a car or a few) the row's points make."""
    n, comp = make_grid(a, s)
    return int((np.bincount(comp.ravel(), minlength=n)[1:] >= 12).sum())


def _layout_angle(a: np.ndarray, s: np.ndarray) -> float:
    """Median angle (degrees, 0-90) of the main axes of the row's blobs against the street."""
    n, comp = make_grid(a, s)
    angles = []
    for k in range(1, n):
        pi, pj = np.nonzero(comp == k)
        if len(pi) < 12:
            continue
        cov = np.cov(np.stack([pi, pj]).astype(float))
        w, vec = np.linalg.eigh(cov)
        main = vec[:, 1]
        angles.append(math.degrees(math.atan2(abs(main[1]), abs(main[0]))))
    return float(np.median(angles)) if len(angles) >= 2 else 0.0
