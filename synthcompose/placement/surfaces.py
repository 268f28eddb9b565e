"""Stage 2b - surfaces of a frame without labels (the test split): road and sidewalk from the
disparity and the photo.

1. **The road's profile.** A camera without roll sees the ground of one image row at one
   disparity: the ground profile d_g(v). It starts from the camera's own ground plane (z = 0 in
   V) and is refined row by row by the strongest disparity near it (the road is the widest
   surface of a street's lower image), then smoothed by a robust low-order fit, so slopes and
   the pitch of the car are followed; then the road's bends off that quadratic (a dip before a
   junction, a crest) are followed from the car's own lane ahead, smoothed over metres.
2. **Heights.** A pixel of disparity d on row v lies h = H (1 - d_g(v) / d) above the ground
   (H: the camera's height): a kerb's 10-15 cm is a 10 % step in disparity at any depth, well
   above the matcher's noise. The height map is median-filtered over a few pixels.
3. **Road**: level pixels (|h| within the noise band at their depth) whose colour is the road's
   (a robust colour model of the level ground in front of the car) and that connect to it.
   A cast shadow changes the light, not the ground: the car's own lane ahead, level and
   continuous in height with the ground in front of the car, is road in whatever light, so
   where it runs into a band of another light (sun beyond a shadow, or shadow beyond sun) that
   light's road colour is modelled from it too.
   **Sidewalk**: flat pixels 5-35 cm above the road (even along the row too: not ground that
   climbs into a parked car; of the road's colour, a kerb above the road of their own row too:
   not a side street climbing away), not green (grass), in regions beside the
   road; and the flat ground beyond a kerb found across the street (kerbs.py: the step up
   from the gutter, which a road's camber hides from the height over the profile) at the
   footway's height, unless as saturated as grass (no road beyond that kerb either); and a
   sunlit stretch of a footway found in the shade (yellower than the shaded road as grass is,
   but no more saturated) where it joins that footway; less a strip along the row narrower
   than a footway between the road and grass (a kerb's top, a verge's edge: strips.py).
   **Terrain**: a grass verge or island - flat, up a kerb above the road, yellow-green
   and more saturated than it (or as saturated as grass), beside the road (a sign may stand there, a person does not walk there).
   Everything else is 0 (unlabelled).

Deterministic: the same disparity and photo give the same labels (the checker recomputes them).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.geometry.depth import nearest_in_row
from synthcompose.io.files import decode_disparity
from synthcompose.labels import label_id

from .ground_profile import LANE_HALF, ground_profile, level_with_row_road, plane_disparity, road_tilt
from .kerbs import beyond_kerbs
from .kerbs_ahead import kerb_ahead
from .noise import measure_sigma
from .road_colour import road_coloured, road_models, road_region, saturation_by_value
from .strips import kerb_strips, verges

ROAD, SIDEWALK, TERRAIN = label_id("road"), label_id("sidewalk"), label_id("terrain")
#: work at this fraction of the full resolution (heights and colours are smooth; labels are upsampled)
SCALE = 0.5
#: sidewalk: raised this much above the road, metres
KERB_MIN, KERB_MAX = 0.05, 0.35
#: a walkable surface beside the road that is not raised: the sidewalk too when its colour is not the road's
LEVEL_SIDEWALK = True
#: a patch with road this close (working pixels) on both sides along its row lies in the road
ENCLOSED_PX = 24
#: level, not road-coloured ground with road on both sides within this along its row is paint
#: on the carriageway, not a footway (metres)
PAINT_M = 1.5
#: level ground: within this height of the road profile (or the noise band), metres
LEVEL_BAND = 0.05
#: grass: green, more saturated than the road by this much, or yellower (LAB b*) by this much
GRASS_SATURATION, GRASS_YELLOW = 18, 5
#: a grass shoulder level with the road: at least this much greener (LAB a*) than the road
GRASS_GREEN = 6
#: a grass verge: at most this OpenCV hue (yellow-green, not the cyan cast of dark asphalt)
#: and at least this much more saturated than the road
VERGE_HUE_MAX, VERGE_SATURATION = 65, 5
#: a sidewalk touches the road within this many working pixels
TOUCH_PX = 4
#: the foot of an object: the ground this far (metres) above a pixel, at its depth, stands up
FOOT_REACH = 0.6
#: the car's own lane ahead (within LANE_HALF of the camera's line), 4 m to
#: LANE_REACH ahead, level and continuous from the seed, is carriageway, sunlit or in shadow
LANE_REACH = 40.0


@dataclass(frozen=True)
class Surfaces:
    """Labels found for a frame without labels, and how."""

    labels: np.ndarray  # (H, W) uint8: ROAD, SIDEWALK, TERRAIN or 0
    profile: np.ndarray  # (H,) ground disparity per row (NaN above the horizon)
    sigma_d: float  # the matcher's noise measured on the level ground, pixels

    def to_dict(self) -> dict:
        return {"source": "none: road and sidewalk found from the disparity and the photo",
                "road_share": round(float((self.labels == ROAD).mean()), 4),
                "sidewalk_share": round(float((self.labels == SIDEWALK).mean()), 4),
                "terrain_share": round(float((self.labels == TERRAIN).mean()), 4),
                "sigma_disparity_px": round(self.sigma_d, 4)}


def find_surfaces(disparity_png: np.ndarray, rgb: np.ndarray, camera: Camera) -> Surfaces:
    """Road and sidewalk labels of a frame from its Cityscapes disparity (uint16 PNG values)
    and photo (H, W, 3 uint8 RGB)."""
    H, W = disparity_png.shape
    w, h = int(round(W * SCALE)), int(round(H * SCALE))
    d_full = decode_disparity(disparity_png)
    d_full[disparity_png <= 1] = np.nan
    # nearest-neighbour subsampling keeps holes holes and does not blend across borders
    step = int(round(1 / SCALE))
    dsub = d_full[::step, ::step][:h, :w]  # full-resolution disparity at the working pixels
    disp = dsub * SCALE
    sub = replace(camera, fx=camera.fx * SCALE, fy=camera.fy * SCALE, u0=camera.u0 * SCALE,
                  v0=camera.v0 * SCALE, width=w, height=h)
    plane = plane_disparity(sub, np.arange(h), w)
    ratio = ground_profile(disp, plane, sub)
    ground_d = plane * ratio[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        height = camera.z * (1.0 - ground_d / disp)
    height = np.where(np.isfinite(height) & (ground_d > 0), height, np.nan).astype(np.float32)
    height -= road_tilt(height, dsub, sub, camera.fx * camera.baseline)
    filled = np.where(np.isnan(height), 10.0, height).astype(np.float32)
    smooth = cv2.medianBlur(filled, 5)
    smooth[np.isnan(height)] = np.nan
    # the matcher's noise on the level ground, and the band it allows at each depth
    level0 = np.abs(smooth) < LEVEL_BAND
    sigma = measure_sigma(dsub, level0, step=4, stride=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = camera.fx * camera.baseline / dsub
    band = np.maximum(LEVEL_BAND, 3.0 * camera.z * z * sigma / (camera.fx * camera.baseline))
    level = np.abs(smooth) < band
    # horizontal, not the face of a car or a wall: a vertical surface climbs by one pixel's
    # size (z / fy) per row, a horizontal one not at all
    k = 3
    climb = np.full((h, w), np.inf, np.float32)
    climb[k:-k] = np.abs(smooth[2 * k:] - smooth[:-2 * k]) / (2 * k)
    flat = climb < 0.25 * z / sub.fy + 0.01
    raised = (smooth >= np.maximum(KERB_MIN, band)) & (smooth <= KERB_MAX) & flat
    # even along the row too: a footway is flat both ways, but the disparity of a car bleeding
    # onto the ground at its foot, or a kerb's face smeared by the matcher, climbs across it
    # (by more than the noise band over 2k pixels)
    left = np.full((h, w), np.nan, np.float32)
    right = np.full((h, w), np.nan, np.float32)
    left[:, k:] = right[:, :-k] = np.abs(smooth[:, k:] - smooth[:, :-k])
    # over 2k pixels; where one side has no depth (a hole, the image's edge), twice the other's
    both = np.where(np.isnan(left), 2 * right, np.where(np.isnan(right), 2 * left, left + right))
    even = ~(both >= band)
    small = cv2.resize(rgb, (w, h), interpolation=cv2.INTER_AREA)
    lab = cv2.GaussianBlur(cv2.cvtColor(small, cv2.COLOR_RGB2LAB).astype(np.float32), (0, 0), 2.0)
    hsv = cv2.cvtColor(small, cv2.COLOR_RGB2HSV)
    seed = _seed(level, z)
    # grass is green against the road: Cityscapes photos are greenish grey all over, so the
    # test is relative to the saturation of the level ground in front of the car
    s_road = float(np.median(hsv[..., 1][seed])) if seed.any() else 40.0
    b_road = float(np.median(lab[..., 2][seed])) if seed.any() else 132.0
    a_road = float(np.median(lab[..., 1][seed])) if seed.any() else 128.0
    hue_green = (hsv[..., 0] >= 25) & (hsv[..., 0] <= 95)
    # the road is kept off grass by saturation alone, pixel by pixel: sunlight is yellower than
    # the skylight of a shadow, so sunlit asphalt beside a shaded seed is b* units yellower,
    # never greener (and a sunlit paving's saturated grit keeps the road off it); and against
    # the seed's saturation at the pixel's own brightness: a dark pixel's hue saturation grows
    # with the camera's noise and black level (leverkusen_000057: the road 35 in the sun, 51-57
    # in the trees' shadows, a bus bay in shade 67). The footway's and the verge's tests below
    # keep the seed's median: read by brightness, dark terrain under trees passed for footway
    # (dusseldorf_000020's footway precision 0.74 to 0.70)
    grass_px = hue_green & (hsv[..., 1] >= saturation_by_value(hsv, seed, s_road) + GRASS_SATURATION)
    lane = _lane(level & ~grass_px, seed & ~grass_px, z, sub)
    models = road_models(lab, seed & ~grass_px, lane)
    road = road_region(level & ~grass_px, (seed | lane) & ~grass_px, lab, models)
    # a footway's and a verge's grass test reads saturation as a region has it: a paving's
    # joints and grit scatter single pixels over it (a median of 5 pixels leaves them out and
    # keeps a verge's edge where it is; a mean would spread the verge's saturation onto the
    # footway beside it)
    sat = cv2.medianBlur(hsv[..., 1], 5)
    green = hue_green & ((sat >= s_road + GRASS_SATURATION) | (lab[..., 2] >= b_road + GRASS_YELLOW))
    grass = hue_green & (sat >= s_road + GRASS_SATURATION)
    # level ground with road on both sides along its row is the road's (lane markings, patches)
    road |= level & ~road & _between(road, ENCLOSED_PX)
    # the foot of a car or a wall (its fattened disparity reads as raised ground) is none
    foot = _object_foot(smooth, z, sub.fy)
    # the ground beyond a kerb seen across the street (a low kerb over a cambered road leaves
    # the footway inside the level band: kerbs.py) is no road, and at the footway's height it
    # is footway unless it is as saturated as grass (paving may be as grey as the asphalt, or
    # a few b* units yellower)
    with np.errstate(invalid="ignore"):
        across = -(np.arange(w)[None, :] - sub.u0) * z / sub.fx  # metres left of the camera's line
    beyond, kerbside = beyond_kerbs(smooth, flat, z, across, band)
    kerbside &= ~grass & ~foot
    # and beyond a kerb across the view ahead (kerbs_ahead.py: where the street ends at a cross
    # street's far footway); its face spans rows, so that footway touches the road only across it
    with np.errstate(invalid="ignore", divide="ignore"):
        over_plane = camera.z * (1.0 - plane / disp)  # over the camera's own ground plane
    past, ahead = kerb_ahead(over_plane.astype(np.float32), flat, z, across, band)
    beyond |= past
    ahead &= ~green & ~foot
    road &= ~beyond
    # raised over the profile but level with the road of its own row, in the road's colour: a
    # side street or a bus bay climbing away from the profile is carriageway (a footway stands
    # a kerb above the road beside it)
    coloured = road_coloured(lab, models)
    climbing = coloured & level_with_row_road(smooth, road, band)
    side = ((raised & ~green & even & ~climbing) | kerbside) & ~road & ~foot
    if LEVEL_SIDEWALK:  # level with the road but not of its colour, flat, beside it (paving)
        side |= level & flat & even & ~green & ~road & ~foot & ~coloured
    side = cv2.morphologyEx(side.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    side = cv2.morphologyEx(side, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    # a sidewalk lies beside the road, not inside it: raised or paved patches with road on both
    # sides along the row (a traffic island's noise, a manhole) are left out
    enclosed = _between(road, ENCLOSED_PX)  # the road is final from here
    side &= ~enclosed
    # level ground (no kerb) with road within PAINT_M on both sides along its row is paint on
    # the carriageway (an arrow, a hatched area): a footway level with the road lies beside it
    with np.errstate(invalid="ignore", divide="ignore"):
        paint_reach = np.nan_to_num(PAINT_M * sub.fx / z, nan=0.0)
    side &= ~(level & _between(road, np.maximum(paint_reach, ENCLOSED_PX)))
    # beside the road: touching it (a kerb between them), not across grass or a wall
    near_road = cv2.dilate(road.astype(np.uint8), np.ones((2 * TOUCH_PX + 1,) * 2, np.uint8)).astype(bool)
    side = _beside(side, near_road)
    # a sunlit stretch of a footway found in shade: raised and flat like it, a few b* units
    # yellower than the (shaded) road but no more saturated (sunlight, not grass), and joined to
    # it; alone, such ground may be sunlit asphalt that the profile reads raised far off
    sunlit = raised & green & ~grass & ~road & ~foot & ~enclosed
    side = _joined(side, sunlit)
    ahead = cv2.morphologyEx(ahead.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    side |= ahead & ~road
    # a strip narrower than a footway between the road and a verge is a kerb's top and the
    # verge's edge, no footway (strips.py)
    verge_grass = verges(grass & flat & (raised | level) & ~foot, hsv[..., 2], seed, z)
    side &= ~kerb_strips(side, verge_grass, z, sub.fx, sub.u0)
    # a grass verge or island: flat ground up a kerb beside the road, yellow-green and more
    # saturated than the road (level green is left out: sunlit asphalt and a crossing's
    # paving read as yellower too, and a sign must not stand on the carriageway)
    verge_hue = hue_green & (hsv[..., 0] <= VERGE_HUE_MAX)
    verdant = verge_hue & (lab[..., 2] >= b_road + GRASS_YELLOW) & (sat >= s_road + VERGE_SATURATION)
    # or as saturated as grass, if not yellower (dull grass, a strip under fallen leaves)
    verdant |= grass & verge_hue
    verge = raised & verdant & ~road & ~side & ~foot & ~enclosed
    # or a grass shoulder level with the road (no kerb: a country road's verge): as saturated
    # as grass and greener than the road (chlorophyll: a* below the asphalt's neutral grey;
    # sunlit asphalt and paving read yellower, never greener); without a kerb between them the
    # colours' blur is their only border: the road's edge pixels are left to it
    lush = grass & verge_hue & (lab[..., 1] <= a_road - GRASS_GREEN)
    road_edge = cv2.dilate(road.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    verge |= level & flat & even & lush & ~road_edge & ~side & ~foot & ~enclosed
    verge = cv2.morphologyEx(verge.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    verge = _beside(verge, near_road)
    small_labels = np.zeros((h, w), np.uint8)
    small_labels[road] = ROAD
    small_labels[side] = SIDEWALK
    small_labels[verge] = TERRAIN
    labels = cv2.resize(small_labels, (W, H), interpolation=cv2.INTER_NEAREST)
    labels[disparity_png <= 1] = 0
    return Surfaces(labels, ratio, float(sigma))


def _beside(mask: np.ndarray, near_road: np.ndarray, least: int = 200) -> np.ndarray:
    """The connected regions of ``mask`` (at least ``least`` pixels) that touch ``near_road``."""
    n, comp = cv2.connectedComponents(mask.astype(np.uint8), connectivity=4)
    if n <= 1:
        return mask.astype(bool)
    touches = np.zeros(n, bool)
    touches[np.unique(comp[near_road & mask])] = True
    touches &= np.bincount(comp.ravel(), minlength=n) >= least
    touches[0] = False
    return touches[comp]


def _joined(found: np.ndarray, more: np.ndarray, least: int = 200) -> np.ndarray:
    """``found`` with the pixels of ``more`` whose 4-connected region of ``found | more`` holds
    at least ``least`` pixels of ``found``."""
    more = cv2.morphologyEx(more.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)).astype(bool)
    n, comp = cv2.connectedComponents((found | more).astype(np.uint8), connectivity=4)
    if n <= 1:
        return found
    keep = np.bincount(comp[found], minlength=n) >= least
    keep[0] = False
    return found | (more & keep[comp])


def _object_foot(height: np.ndarray, z: np.ndarray, fy: float) -> np.ndarray:
    """(h, w) bool: pixels at the foot of something standing (a car, a wall, a person): the
    pixel FOOT_REACH metres above them in the image (at their depth) is 0.4-2.5 m high and at
    about their depth."""
    h, w = height.shape
    v, u = np.nonzero(np.isfinite(height) & np.isfinite(z) & (height > -0.2) & (height < 0.5))
    zz = z[v, u]
    up = np.clip(v - np.clip(np.rint(FOOT_REACH * fy / zz), 2, 80).astype(np.int64), 0, h - 1)
    above_h, above_z = height[up, u], z[up, u]
    with np.errstate(invalid="ignore"):
        hit = (above_h >= 0.4) & (above_h <= 2.5) & (np.abs(above_z - zz) < 0.1 * zz)
    out = np.zeros((h, w), bool)
    out[v[hit], u[hit]] = True
    return out


def _between(mask: np.ndarray, reach) -> np.ndarray:
    """(h, w) bool: pixels with a ``mask`` pixel within ``reach`` pixels (a number, or one per
    pixel) to the left and to the right along their row."""
    left, right = nearest_in_row(mask)  # -1 and W where there is none: too far from any pixel
    cols = np.arange(mask.shape[1], dtype=np.int32)
    return (left >= 0) & (right < mask.shape[1]) & (cols - left <= reach) & (right - cols <= reach)


def _seed(level: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Level ground 6-15 m ahead of the car, in the central columns: the road the car is on."""
    h, w = level.shape
    cols = np.arange(w)[None, :]
    return level & (z >= 6) & (z <= 15) & (np.abs(cols - w / 2) < 0.15 * w)


def _lane(level: np.ndarray, seed: np.ndarray, z: np.ndarray, cam: Camera) -> np.ndarray:
    """The car's own lane ahead: level pixels within LANE_HALF of the camera's line, 4 m to
    LANE_REACH ahead, continuous in height with the seed (a cast shadow changes the light, not
    the ground's height, so the lane runs on through it). ``cam``: the working camera."""
    h, w = level.shape
    u = np.arange(w)[None, :]
    with np.errstate(invalid="ignore"):
        lane = level & (np.abs((u - cam.u0) * z / cam.fx) < LANE_HALF) & (z >= 4) & (z <= LANE_REACH)
    joined = cv2.morphologyEx(lane.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    n, comp = cv2.connectedComponents(joined, connectivity=4)
    keep = np.zeros(n, bool)
    keep[np.unique(comp[seed & lane])] = True
    keep[0] = False
    return keep[comp] & lane


def frame_for(image_set, depth: np.ndarray | None = None):
    """(placement Frame, Surfaces or None) of an image set: its own labels where it has them,
    else the surfaces found here. The pipeline and the checker build frames the same way."""
    from synthcompose.geometry.depth import disparity_to_depth, make_frame

    cam = image_set.camera
    if depth is None:
        depth = disparity_to_depth(image_set.disparity, cam)
    if image_set.labelled:
        return make_frame(depth, image_set.label_ids, cam, photo=image_set.rgb), None
    found = find_surfaces(image_set.disparity, image_set.rgb, cam)
    return make_frame(depth, found.labels, cam, labelled=False, photo=image_set.rgb), found
