"""How an inserted object's shadow and contact read next to the photo's own: the measures the
sun and the ground contact are judged by (the look's other measures: :mod:`synthcompose.look.measures`).

* :func:`under` - the ground right under an object's bottom edge against the ground a little
  further down: a real car darkens the road at its foot (ratio below 1);
* :func:`under_edge` - how sharply the ground brightens below the object's bottom edge, per row
  (real cars and inserted ones alike);
* :func:`outline` - straight lines in the ratio output / input near an inserted object, the
  edges of a shadow receiver ("a faint box on the road"), in units of the object's width;
* :func:`real_shadow_orientation` and :func:`shadow_orientation` - the orientation on the
  ground plan of the photo's own shadow edges, and the direction the inserted shadow is thrown
  in, for the angle between them (:func:`axis_angle`); :func:`cast_shadow_fit` the direction
  and length of the sun's cast shadow alone (the output against the same batch rendered
  without a sun);
* :func:`read_sun_labels` - the sunny / overcast labels, by eye, of a set of frames.

All work on full-frame arrays as written (sRGB uint8, masks as bool).
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from synthcompose.colour import LUM, SRGB8_TO_LINEAR

#: rows under the object's lowest pixel: the band at its foot, the reference band further down
UNDER_NEAR, UNDER_FAR = (2, 8), (20, 40)
#: the share of the object's width (its middle) whose columns are measured
UNDER_MIDDLE = 0.6
#: rows under the object's lowest pixel whose brightening :func:`under_edge` measures
EDGE_ROWS = 60
#: the outline measure's settings: ratio blur (pixels), scale to 8 bits, Canny thresholds, the
#: objects grown by (pixels), probabilistic Hough (threshold, shortest line, largest gap)
OUTLINE_BLUR, OUTLINE_SCALE, OUTLINE_CANNY = 1.0, 200.0, (4, 8)
OUTLINE_GROW, OUTLINE_HOUGH = 5, (30, 60, 3)
#: the cast shadow: ground at most this bright against the sun-less render, within this many
#: metres of the object's footprint (a car's shadow at a 15-degree sun reaches 6 m)
CAST_DARKER, CAST_REACH = 0.85, 8.0
#: the cast shadow lengths tried (metres)
CAST_LENGTHS = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.5, 8.0)


def _luminance(rgb: np.ndarray) -> np.ndarray:
    return cv2.LUT(rgb, SRGB8_TO_LINEAR) @ LUM.astype(np.float32)


def annotated(mask: np.ndarray) -> np.ndarray:
    """The object's mask as Cityscapes' annotators draw a vehicle: its polygon runs under the
    body from tyre to tyre, so the dark gap under a car is the car's. The mask's convex hull."""
    ys, xs = np.nonzero(mask)
    out = np.zeros(mask.shape, np.uint8)
    if len(xs) >= 3:
        hull = cv2.convexHull(np.column_stack([xs, ys]).astype(np.int32))
        cv2.fillConvexPoly(out, hull, 1)
    return out.astype(bool) | mask


def _bottom_columns(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(the columns of the middle :data:`UNDER_MIDDLE` of the object's width, (W,) its lowest
    row per column, -1 where none); None for fewer than 20 pixels."""
    ys, xs = np.nonzero(mask)
    if len(xs) < 20:
        return None
    x0, x1 = int(xs.min()), int(xs.max())
    pad = (1.0 - UNDER_MIDDLE) / 2 * (x1 - x0 + 1)
    bottom = np.full(mask.shape[1], -1)
    np.maximum.at(bottom, xs, ys)
    return np.arange(int(math.ceil(x0 + pad)), int(math.floor(x1 - pad)) + 1), bottom


def under(rgb: np.ndarray, mask: np.ndarray, ground: np.ndarray, others: np.ndarray | None = None) -> float | None:
    """Median luminance (linear) of the ground :data:`UNDER_NEAR` rows below the object's lowest
    pixel, per column of the middle :data:`UNDER_MIDDLE` of its width, over that :data:`UNDER_FAR`
    rows below; None without enough ground in both bands. ``mask``: the object's pixels as
    annotated (a real car's instance mask; an inserted one's :func:`annotated`); ``ground``: the
    pixels that are ground (labels or found surfaces); ``others``: pixels of any object, kept
    out of the bands."""
    found = _bottom_columns(mask)
    if found is None or len(found[0]) < 3:
        return None
    cols, bottom = found
    H = mask.shape[0]
    y = _luminance(rgb)
    blocked = others if others is not None else mask
    near, far = [], []
    for c in cols:
        b = bottom[c]
        if b < 0:
            continue
        for (lo, hi), acc in ((UNDER_NEAR, near), (UNDER_FAR, far)):
            rows = np.arange(b + lo, min(b + hi + 1, H))
            rows = rows[ground[rows, c] & ~blocked[rows, c]]
            acc.extend(y[rows, c].tolist())
    n_need = 3 * len(cols)
    if len(near) < n_need or len(far) < n_need:
        return None
    return float(np.median(near) / max(np.median(far), 1e-6))


def under_edge(rgb: np.ndarray, mask: np.ndarray, ground: np.ndarray, others: np.ndarray | None = None) -> float | None:
    """How sharply the ground brightens below an object's bottom edge: per column of the middle
    :data:`UNDER_MIDDLE` of its width, the ground's luminance over :data:`EDGE_ROWS` rows below
    its lowest pixel over that of the last third of them; the largest rise per row of the
    columns' median profile (in units of the far ground). The same for a real car and an
    inserted one: the outline measure finds a line where this rise runs straight along the
    car's bottom (its Canny thresholds are a rise of about 0.005 per pixel); None without
    enough ground below."""
    found = _bottom_columns(mask)
    if found is None:
        return None
    cols, bottom = found
    H = mask.shape[0]
    y = _luminance(rgb)
    blocked = others if others is not None else mask
    profiles = []
    for c in cols:
        rows = np.arange(bottom[c] + 1, bottom[c] + 1 + EDGE_ROWS)
        if bottom[c] < 0 or rows[-1] >= H:
            continue
        if (ground[rows, c] & ~blocked[rows, c]).mean() < 0.9:
            continue
        far = float(np.median(y[rows[2 * EDGE_ROWS // 3:], c]))
        profiles.append(y[rows, c] / max(far, 1e-6))
    if len(profiles) < 10:
        return None
    p = np.median(np.array(profiles), axis=0)
    return float(np.max(p[2:] - p[:-2]) / 2)


def outline(src: np.ndarray, out: np.ndarray, masks: list[np.ndarray],
            others: np.ndarray | None = None) -> list[float | None]:
    """Per object (``masks``: each inserted object's pixels, as annotated: :func:`annotated`),
    the summed length of the straight lines in the ratio output / input near it (their midpoint
    within half its width of its box) over its width; None for an empty mask. The ratio is
    blurred (:data:`OUTLINE_BLUR`),
    scaled by :data:`OUTLINE_SCALE` to 8 bits, Canny (:data:`OUTLINE_CANNY`) outside the objects
    grown by :data:`OUTLINE_GROW`, probabilistic Hough (:data:`OUTLINE_HOUGH`). ``others``: more
    inserted pixels that are no object's instance (a sign's post, labelled ``pole`` apart from
    its plate): left out with the objects, but measured near none."""
    ratio = _luminance(out) / np.maximum(_luminance(src), 1e-4)
    ratio = cv2.GaussianBlur(ratio.astype(np.float32), (0, 0), OUTLINE_BLUR)
    img = np.clip(ratio * OUTLINE_SCALE, 0, 255).astype(np.uint8)
    edges = cv2.Canny(img, *OUTLINE_CANNY)
    objects = np.zeros(src.shape[:2], np.uint8)
    for m in masks:
        objects |= m.astype(np.uint8)
    if others is not None:
        objects |= others.astype(np.uint8)
    k = 2 * OUTLINE_GROW + 1
    grown = cv2.dilate(objects, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) > 0
    edges[grown] = 0
    t, length, gap = OUTLINE_HOUGH
    found = cv2.HoughLinesP(edges, 1, math.pi / 180, threshold=t, minLineLength=length, maxLineGap=gap)
    lines = [] if found is None else [np.ravel(s).astype(np.float64) for s in found]
    result = []
    for m in masks:
        ys, xs = np.nonzero(m)
        if not len(xs):
            result.append(None)
            continue
        x0, x1, y0, y1 = xs.min(), xs.max(), ys.min(), ys.max()
        width = float(x1 - x0 + 1)
        reach = width / 2
        total = 0.0
        for xa, ya, xb, yb in lines:
            mx, my = (xa + xb) / 2, (ya + yb) / 2
            if x0 - reach <= mx <= x1 + reach and y0 - reach <= my <= y1 + reach:
                total += math.hypot(xb - xa, yb - ya)
        result.append(total / width)
    return result


def shadow_orientation(src: np.ndarray, out: np.ndarray, mask: np.ndarray, footprint: np.ndarray,
                       plan_uv: tuple[np.ndarray, np.ndarray], plan_xy, darker: float = 0.9) -> float | None:
    """Azimuth (degrees, from x towards y, mod 360) in which the inserted object's shadow is
    thrown on the ground plan: from its footprint's centre to the centre of the ground it darkens
    (output / input luminance below ``darker``, outside its own pixels), or None. ``plan_uv``:
    the plan's pixel coordinates (u, v) per cell (:class:`~synthcompose.lighting.plan.GroundPlan`);
    ``plan_xy(rows, cols)``: their vehicle-frame positions; ``footprint``: (x, y) of the object's
    ground point."""
    u, v = plan_uv
    H, W = mask.shape
    inside = (u >= 0) & (v >= 0) & (u <= W - 1) & (v <= H - 1)
    ui = np.clip(np.rint(u), 0, W - 1).astype(np.int64)
    vi = np.clip(np.rint(v), 0, H - 1).astype(np.int64)
    ratio = _luminance(out) / np.maximum(_luminance(src), 1e-4)
    grown = cv2.dilate(mask.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
    dark = inside & (ratio[vi, ui] < darker) & ~grown[vi, ui]
    rows, cols = np.nonzero(dark)
    if len(rows) < 20:
        return None
    weight = (1.0 - ratio[vi[rows, cols], ui[rows, cols]])
    xy = plan_xy(rows, cols)
    centre = (xy * weight[:, None]).sum(axis=0) / weight.sum()
    d = centre - np.asarray(footprint[:2], float)
    if np.hypot(*d) < 0.2:
        return None
    return float(math.degrees(math.atan2(d[1], d[0])) % 360.0)


def on_plan(corners: np.ndarray, plan, camera) -> np.ndarray:
    """(N, 2) where ground points ``corners`` (N, 3, vehicle frame) lie on the ground plan: the
    plan puts what a pixel sees at its ray's crossing with the road plane, so a footway's points
    (raised over that plane) land farther out along their rays. Parallel planes map by a
    homothety from the camera's foot: directions on the footway are kept, positions are not, so
    a footprint on a footway must be moved the same way before its shadow is fitted on the plan."""
    a, b, c = plan.plane  # z = a + b (x - x_c) + c (y - y_c): a under the camera
    eye = np.array([camera.x, camera.y, camera.z], float)
    d = np.asarray(corners, float) - eye
    t = (a - camera.z) / (d[:, 2] - b * d[:, 0] - c * d[:, 1])
    return (eye + t[:, None] * d)[:, :2]


def cast_shadow_fit(sunless: np.ndarray, out: np.ndarray, masks: list[np.ndarray], footprints: list[np.ndarray],
                    plan, darker: float = CAST_DARKER, reach: float = CAST_REACH) -> list[tuple[float, float, float] | None]:
    """Each object's cast shadow on the ground plan, fitted: (azimuth in degrees from x towards
    y, mod 360, in which the shadow is thrown; its length in metres; the fit's intersection over
    union), or None where too little of it is seen; one per object of ``masks`` (its pixels) and
    ``footprints`` (its (4, 2) ground corners).

    The cast shadow is the ground the sun darkens: the output over ``sunless`` (the same image
    set, objects and light but the sun's share given to the sky: their occlusion shadow alone)
    below ``darker``. Seen are the plan's cells inside the image, off every object's pixels
    (grown by 3), within ``reach`` metres of the object's footprint and nearer to it than to any
    other's. The shadow a box throws is the convex hull of its footprint and the footprint moved
    by L along the shadow's azimuth (L: its height over tan(elevation)); the azimuth and L whose
    hull best matches the dark cells seen (3 degrees, 0.25-8 m) are the fit. Measured this way
    the occlusion shadow (darkest on the ground between the object and the camera, whatever the
    sun) does not count, and the direction is not the object's own shape (a high sun's short
    shadow is a thin band along the footprint's sunless sides)."""
    H, W = out.shape[:2]
    ratio = _luminance(out) / np.maximum(_luminance(sunless), 1e-4)
    objects = np.zeros((H, W), np.uint8)
    for m in masks:
        objects |= m.astype(np.uint8)
    grown = cv2.dilate(objects, np.ones((7, 7), np.uint8)) > 0
    centres = np.array([np.asarray(f, float).mean(axis=0) for f in footprints]).reshape(-1, 2)
    return [_fit_cast(ratio, grown, np.asarray(f, float), k, centres, plan, darker, reach)
            for k, f in enumerate(footprints)]


def _fit_cast(ratio: np.ndarray, grown: np.ndarray, corners: np.ndarray, k: int, centres: np.ndarray, plan,
              darker: float, reach: float) -> tuple[float, float, float] | None:
    """:func:`cast_shadow_fit` of object ``k`` (footprint ``corners``; ``centres``: every
    object's footprint centre) on the frame's ratio and grown objects' pixels."""
    H, W = ratio.shape
    u, v = plan.u, plan.v
    x0, y0 = plan.origin
    cell = float(np.hypot(*(plan.xy(np.array([1]), np.array([0]))[0] - plan.xy(np.array([0]), np.array([0]))[0])))
    centre = centres[k]
    # a window of the plan around the object
    r0 = max(int((centre[0] - reach - x0) / cell), 0)
    r1 = min(int((centre[0] + reach - x0) / cell) + 1, u.shape[0])
    c0 = max(int((y0 - centre[1] - reach) / cell), 0)
    c1 = min(int((y0 - centre[1] + reach) / cell) + 1, u.shape[1])
    if r1 - r0 < 2 or c1 - c0 < 2:
        return None
    uw, vw = u[r0:r1, c0:c1], v[r0:r1, c0:c1]
    inside = plan.valid[r0:r1, c0:c1] & (uw >= 0) & (vw >= 0) & (uw <= W - 1) & (vw <= H - 1)
    ui = np.clip(np.rint(uw), 0, W - 1).astype(np.int64)
    vi = np.clip(np.rint(vw), 0, H - 1).astype(np.int64)
    rows, cols = np.mgrid[r0:r1, c0:c1]
    xy = plan.xy(rows.ravel(), cols.ravel()).reshape(rows.shape + (2,))
    dist = np.hypot(xy[None, ..., 0] - centres[:, 0, None, None], xy[None, ..., 1] - centres[:, 1, None, None])
    seen = inside & ~grown[vi, ui] & (dist.argmin(axis=0) == k) & (dist[k] <= reach)
    dark = seen & (ratio[vi, ui] < darker)
    if dark.sum() < 20:
        return None

    def raster(points: np.ndarray) -> np.ndarray:
        """Cells of the window inside the convex hull of ground points (N, 2)."""
        rc = np.column_stack([(y0 - points[:, 1]) / cell - 0.5 - c0, (points[:, 0] - x0) / cell - 0.5 - r0])
        hull = cv2.convexHull(np.rint(rc).astype(np.int32))
        img = np.zeros(seen.shape, np.uint8)
        cv2.fillConvexPoly(img, hull, 1)
        return img.astype(bool)

    best = None
    n_dark = float(dark.sum())
    for az in np.arange(0.0, 360.0, 3.0):
        step = np.array([math.cos(math.radians(az)), math.sin(math.radians(az))])
        for length in CAST_LENGTHS:
            pred = raster(np.concatenate([corners, corners + length * step])) & seen
            inter = float((pred & dark).sum())
            iou = inter / (n_dark + float(pred.sum()) - inter)
            if best is None or iou > best[2]:
                best = (float(az), float(length), iou)
    return best


def axis_angle(a_deg: float, b_deg: float) -> float:
    """Angle (degrees, 0-90) between two orientations taken mod 180."""
    d = abs(a_deg - b_deg) % 180.0
    return float(min(d, 180.0 - d))


def read_sun_labels(path: str | Path) -> dict[str, str]:
    """frame prefix (``city_seq``) -> "sunny" / "overcast", from lines ``sunny name name ...``
    (``#`` comments); frames not listed are ambiguous."""
    out: dict[str, str] = {}
    for line in Path(path).read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        kind, *names = line.split()
        if kind not in ("sunny", "overcast"):
            raise ValueError(f"{path}: a line starts with {kind!r}, expected 'sunny' or 'overcast'")
        for n in names:
            out[n] = kind
    return out
