"""A sunny street's opening to the sun: :func:`open_to_the_sun`.

The generated streets are canyons of abutting houses (8-20 m high, 7-10 m from the centre
line). Under a sun from across the street (:func:`~.light.sunny_light`), the houses on the
sun's side put the whole road in their shade, as in a real street, except where the row has a
gap: a yard or a driveway between two houses, with low buildings at its back. Through it the
sun lights a patch of road whose two edges, the shadows of the houses' vertical corners, run
along the sun's azimuth: the long straight shadow edges on level road a person (and the ground
plan, :mod:`synthcompose.lighting.plansun`) reads the sun from on the sunny street frames.

The gap is placed so that the lit patch crosses the road's centre line 8-14 m ahead of the
camera; it draws its random numbers from its own generator, so the rest of the scene (and every
scene without it) is unchanged.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .scene import StreetScene

#: where the lit patch crosses the centre line (metres ahead, street frame a) and its length
#: there (the gap is longer by what the houses beside it hide of an oblique sun)
PATCH_AHEAD, GAP_LENGTH = (8.0, 14.0), (6.0, 10.0)
#: the yard behind the gap: its back buildings stand this far behind the facade line and are
#: this high (metres); low enough that their shade (at the sunny suns' 18 degrees at most
#: 5 x cot 18 = 15.4 m) stays in the yard
YARD_DEPTH, YARD_BACK_HEIGHT = 18.0, (3.0, 5.0)
#: the near building rows start here along the street (layout.random_scene)
ROW_START = -25.0


def open_to_the_sun(scene: StreetScene, rng: np.random.Generator) -> StreetScene:
    """``scene`` with a gap in the near building row on the sun's side (see the module
    docstring); ``scene`` itself where it has no light, the sun is not across the street
    (within 20 degrees of its axis: the patch would land far away) or no gap fits before the
    cross street."""
    light = scene.light
    if light is None or light.sun_fraction <= 0.0:
        return scene
    az = math.radians(light.sun_azimuth_deg) - scene.street_heading  # in the street frame
    across = math.sin(az)
    if abs(across) < math.sin(math.radians(20.0)):
        return scene
    side = 1 if across > 0 else -1
    front = scene.road_half_width + scene.sidewalk_width
    cross_start = scene.crossing[0] if scene.crossing is not None else math.inf
    row = [b for b in scene.boxes if b.label == "building" and b.rotation is None and b.lo[0] < cross_start
           and abs((b.lo[1] if side > 0 else b.hi[1]) - side * front) < 1e-6]
    if not row:
        return scene
    # a ray from the centre line to the sun crosses the facade line at a + front * cot(az) and
    # climbs above the houses beside the gap only after ``clear`` metres more along the street:
    # the gap reaches that far beyond the lit stretch, towards the sun
    ahead = math.cos(az) / abs(across)
    tallest = max(b.hi[2] for b in row) - min(b.lo[2] for b in row)
    run = max(tallest / math.tan(math.radians(light.sun_elevation_deg)) - front / abs(across), 0.0)
    clear = run * abs(math.cos(az))
    lit = float(rng.uniform(*GAP_LENGTH))
    entry = float(rng.uniform(*PATCH_AHEAD)) + front * ahead
    g0, g1 = (entry - lit / 2, entry + lit / 2 + clear) if ahead >= 0 else (entry - lit / 2 - clear, entry + lit / 2)
    g0, g1 = max(g0, ROW_START + 4.0), min(g1, cross_start - 4.0)
    if g1 - g0 < 4.0:
        return scene
    if not any(b.lo[0] < g1 and b.hi[0] > g0 for b in row):
        return scene
    boxes = []
    for box in scene.boxes:
        if not any(box is b for b in row) or box.hi[0] <= g0 or box.lo[0] >= g1:
            boxes.append(box)
            continue
        if box.lo[0] < g0:
            boxes.append(dataclasses.replace(box, hi=(g0, box.hi[1], box.hi[2])))
        if box.hi[0] > g1:
            boxes.append(dataclasses.replace(box, lo=(g1, box.lo[1], box.lo[2])))
    # the yard's back: low buildings across its far end
    some = row[0]
    base = float(min(scene.sidewalk_height(g0), scene.sidewalk_height(g1)))
    y0, y1 = sorted((side * (front + YARD_DEPTH), side * (front + YARD_DEPTH + 20.0)))
    boxes.append(dataclasses.replace(some, lo=(g0 - 1.0, y0, base),
                                     hi=(g1 + 1.0, y1, base + float(rng.uniform(*YARD_BACK_HEIGHT)))))
    return dataclasses.replace(scene, boxes=tuple(boxes))
