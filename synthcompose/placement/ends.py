"""Where the ego vehicle's street ends ahead: a wall across its whole carriageway near ahead (a
T-junction seen head-on: the house across the cross street).

The street's axis is fitted to lines that run along it; at a T-junction seen head-on the street
the objects would stand in runs across the view, and the lines found along the view are short
stretches of paint and stereo noise. Vehicles' headings there would come from the wrong street
(a car facing a house front), so where its street ends ahead the carriageway is no lane: a
vehicle there stands on the street across it, along the kerbs seen there
(``traffic.street_lane``, ``traffic.side_street_spot``), or nowhere.

Measured by what stands: points 0.5-3 m above the road (per metre along the street, the road's
median height there) within ``END_NEAR`` ahead across at least ``END_SHARE`` of the
carriageway's width. Vehicles and people ahead cover a lane's width at most; parked rows stand
at its edges (on the development set: 1.0 on leverkusen_000045, at most 0.8 on the others, a
van, people and a sign at a crossing on leverkusen_000037).
"""
from __future__ import annotations

import numpy as np

from synthcompose.geometry.depth import Frame

from .street import Street, heights_over_road

#: a wall this near ahead (metres along the street) ...
END_NEAR = 20.0
#: ... across this share of the ego carriageway's width ends the street
END_SHARE = 0.9
#: what stands: this high above the road (metres)
STANDING = (0.5, 3.0)
#: a metre of the street has a road height with at least this many road points
MIN_ROAD_POINTS = 30


def street_ends(frame: Frame, street: Street) -> bool:
    """Whether the ego carriageway's street ends within END_NEAR ahead (cached per street)."""
    return frame.derived(("street_ends", id(street)), lambda: _ends(frame, street))


def _ends(frame: Frame, street: Street) -> bool:
    found = heights_over_road(frame, street, far=END_NEAR + 1, min_points=MIN_ROAD_POINTS)
    if found is None:
        return False
    _, _, a, s, h = found
    cw = street.ego
    sel = (h >= STANDING[0]) & (h <= STANDING[1]) & (a > 0.0) & (a <= END_NEAR) & (s >= cw.right) & (s <= cw.left)
    width = cw.left - cw.right
    if width <= 0 or not sel.any():
        return False
    covered = np.unique(np.floor((s[sel] - cw.right) / 0.25).astype(np.int64))
    return bool(len(covered) * 0.25 >= END_SHARE * width)
