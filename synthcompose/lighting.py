"""Stage 3b - lighting: estimate the light of each photo from the photo, its labels and depth.

No neural network: a low-order physical model fitted to the pixels, in linear light. The light
is the renderer's model (``shaders/lit.glsl``, :class:`synthcompose.render.Lighting`)::

    E(n) = ambient(n) + sun * max(0, n.l) * visible,   ambient(n) = mix(ground, sky, 0.5 + 0.5 n_z)

scaled so that an up-facing, unshadowed surface receives 1 (luminance). Cues, on a grid about
700 cells wide (cells of 3x3 pixels at 2048x1024; depth: the mean of a cell's known pixels;
normals: from the cells 1 and 2 apart, or, on the objects' faces (not the ground), where those
cross an edge - narrow faces, cells next to a corner - from the cell's centre pixel and the
photo's pixels 1 and 2 apart, so that a coarser grid does not lose the faces the shading needs):

* **cast shadows on the ground** (road, sidewalk, parking; up-facing cells only, none within
  half a metre of something standing, which is dark from ambient occlusion alone, no lane
  markings or kerbstones - bright and narrower than 1.75 m on the ground plan): the log
  luminance of each class is fitted by two levels, lit and a shared step down ``delta`` into
  shadow (EM, with an outlier component). A clear second level (gain >= 0.05 nats per sample,
  at least 30 % darker) means sunlight; ``exp(delta)`` is the sky's share of the light on
  up-facing ground, ``1 - exp(delta)`` the sun's. Without such shadows the light is ambient
  only (an overcast sky) - unless all the ground in view is lit: the
  shading pairs show a clear sun (:data:`LIT_GROUND_MIN_GAIN`) whose best direction (within
  :data:`LIT_GROUND_MARGIN`) the geometry says leaves the ground samples it can tell about lit
  (none predicted in shadow; at least :data:`LIT_GROUND_KNOWN` of them known), or, where the
  geometry cannot tell (the sun behind the camera), whose sunlit pairs reach down to the ground
  (:data:`LIT_PAIRS_LOW`: the sun reaches the feet of the walls and cars in view). Then the sun
  is that direction and the sky's share the pairs' fit. Failing that, where no ground lies a
  shadow step above its class's median (it is all lit, or all shadow), the casters' shadows
  may still show the sun (below). Failing that too, a clear shading sun whose sunlit pairs all
  stand above the ground (:data:`LIT_PAIRS_LOW`), and that the geometry does not see light
  the ground, lights the walls beyond the street's shadow: the sun is that direction, and all
  the ground in view is in shadow (``ground_shadowed``: an object standing on it gets the sky
  alone, as it would under an overcast sky, but a sunny day's sky).
* **shadows of the casters in view** (the sun ahead of the camera: the ground is nearly all
  lit, the shadows of cars, poles and people, falling towards the camera, too small a share for
  two levels, and no wall faces the sun for the shading): every point of what stands in view
  (below :data:`CASTER_MAX_HEIGHT` over its ground) throws its shadow, for a sun direction, onto
  a ground-plan map of the ground in view (log luminance against its class's median; ground
  under a car's body or at a caster's foot, dark from contact shadow alone, left out). A
  direction (elevation up to :data:`CASTER_MAX_ELEVATION`) whose shadows land on dark ground
  (:data:`CASTER_MIN_AGREEMENT`, :data:`CASTER_MIN_DARK`) is the sun; the step down where they
  land is the shadow's.
* **shading of surface pairs** (the sun's direction): pairs of nearby cells of one class on
  the two faces of a convex edge (car tops and sides, building corners, kerbs, poles), of one
  chromaticity (so a lamp or a window next to the edge does not count), whose normals (from the
  depth) differ. Their brightness ratio cancels the albedo and is fitted, with a robust loss,
  by the model over a grid of sun directions, sky shares and ground bounces; a pair may lie in a
  cast shadow instead (ambient only, at a small cost). Pairs are weighed so that no image region
  (one near car) outweighs the rest, and by class (:data:`PAIR_CLASS_WEIGHT`: building corners
  count most, cars, with lamps and trims, less, kerbs, too small for good normals, least).
* **straight shadow edges on the ground** (the sun's azimuth, where the ground has two levels):
  the shading of walls facing across the street tells little more than how far the sun stands
  to one side for its height, so a range of directions fits it about as well. The shadow of
  something vertical (a building's corner, a pole, a car's corner) has a straight edge along
  the sun's azimuth, whether or not the caster is in view. The edges between lit and shadowed
  ground are put on the ground plan (within 30 m), and the longest straight one that is at
  least :data:`LINE_MIN_LENGTH` long and off the street's axis and its normal (kerbs, roof
  lines and building ends throw edges along those) gives the azimuth, up to its half turn:
  the direction is then the best along it whose shading is within :data:`LINE_MARGIN` of the
  best.
* **shadows predicted from the geometry** (a weak tie-breaker): a height map of everything
  standing on the ground gives each ground sample's horizon towards each azimuth; a sun
  direction predicts which samples lie in shadow, where the visible scene can tell (paths that
  leave the view, or pass over occluders cut by the image top, are unknown). Agreement with the
  dark samples adds to the direction's score.
* **colour** (grey world on the ground): the ground's colour in shadow is the sky's, lit minus
  shadow the sun's; without shadows the ground's colour is the ambient colour.
* **real shadows**: the lit level of each ground class and the shadow step are kept, so that
  :meth:`LightEstimate.sun_visibility` / :meth:`LightEstimate.sun_mask` tell where the sun
  reaches the real ground (an inserted object standing in a real shadow gets no sun, and its
  own shadow darkens only sunlit ground).

``exposure`` is recorded as well: the lit road's luminance against a typical asphalt albedo
(:data:`ROAD_ALBEDO`; sidewalk against :data:`SIDEWALK_ALBEDO`), the irradiance the photo's
exposure implies. It is applied only where the manifest asks for it (``match_exposure``).
"""
from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import cv2
import numpy as np

from .camera import Camera
from .colour import srgb_to_linear
from .placement.noise import measure_sigma
from .render import Lighting

#: Rec. 709 luminance weights of linear RGB
LUM = np.array([0.2126, 0.7152, 0.0722])
#: typical albedo of asphalt and of sidewalk paving (linear luminance): the exposure reference
ROAD_ALBEDO, SIDEWALK_ALBEDO = 0.10, 0.25
#: limits of the recorded exposure
EXPOSURE_RANGE = (0.2, 3.0)
#: a sun needs cast shadows on the ground: two brightness levels whose fit gains this many nats
#: per sample over one level, the shadow darker than this (log ratio: -0.35 = 30 % darker)
MIN_TWO_LEVEL_GAIN, MAX_SHADOW_LOG_RATIO = 0.05, -0.35
#: without shadows on the ground, a sun needs the shading to gain this many nats per pair, at a
#: direction that leaves the ground in view lit and scores within the margin of the best one
LIT_GROUND_MIN_GAIN, LIT_GROUND_MARGIN, LIT_GROUND_KNOWN = 1.0, 0.05, 0.15
#: where the geometry cannot tell (the sun behind the camera), the ground counts as lit when the
#: pairs the sun lights reach down to it: the lowest tenth of them below this height (metres)
LIT_PAIRS_LOW = 0.4
#: weight of the geometric shadow agreement against the shading cue in the direction's score
SHADOW_AGREEMENT_WEIGHT = 0.1

GROUND_IDS = (6, 7, 8, 9, 10)  # ground, road, sidewalk, parking, rail track
ROAD_ID, SIDEWALK_ID, SKY_ID = 7, 8, 23
#: things standing on the ground that cast shadows (static, dynamic, constructions, objects,
#: vegetation, humans, vehicles)
OCCLUDER_IDS = (4, 5, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33)
#: surface classes whose albedo is locally constant enough for the shading pairs
SHADING_IDS = (7, 8, 11, 12, 13, 14, 17, 19, 20, 26, 27, 28, 29, 30, 31)
_FINE_IDS = tuple(i for i in SHADING_IDS if i not in GROUND_IDS)

_LUT = srgb_to_linear(np.arange(256) / 255.0).astype(np.float32)


def _unit(c) -> np.ndarray:
    """Colour scaled to luminance 1 (neutral when it has none)."""
    c = np.maximum(np.asarray(c, np.float64), 1e-6)
    y = float(c @ LUM)
    return c / y if y > 1e-6 else np.ones(3)


def _direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def _r(v, nd: int = 4):
    if isinstance(v, dict):
        return {str(k): _r(x, nd) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_r(x, nd) for x in v]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return round(float(v), nd)
    return v


@dataclass(frozen=True)
class LightEstimate:
    """The light of one photo, in the vehicle frame (ISO 8855), linear RGB.

    sunny              : a sun was found (cast shadows on the ground, or a clear shading sun
                         that leaves all the ground in view lit, or all in shadow), else ambient
                         light only
    sun_azimuth_deg    : towards the sun, from x (forward) to y (left); best fit even when not sunny
    sun_elevation_deg  : above the horizon
    sun_fraction       : share of an up-facing unshadowed surface's irradiance from the sun
                         (0 when not sunny); the sky's share is ``1 - sun_fraction``
    sky_rgb, sun_rgb, ground_rgb : colours (luminance 1) of the ambient light from above, of the
                         sun and of the light bounced from the ground
    ground_ratio       : ambient from below over ambient from above
    exposure           : irradiance of an up-facing lit surface implied by the photo's
                         brightness (lit road / :data:`ROAD_ALBEDO`); 1 = the renderer's nominal
    confidence         : 0..1, how clearly the ground decides sunny against not sunny
    ground_levels      : ((label id, lit linear luminance), ...) of the ground classes, and
    shadow_log_ratio   : log(shadow / lit) on them: where an inserted object's ground is in a
                         real shadow (:meth:`sun_visibility`)
    ground_shadowed    : the sun does not reach the ground in view (it lights the walls above):
                         all of it is in shadow, whatever its brightness
    evidence           : the cues the estimate rests on ("ground": lit and shadowed ground
                         samples, "shading": surface pairs, "sky": the sky's colour); empty: none
                         was found and the estimate is the fallback (an overcast grey sky)
    cues               : diagnostics of each cue (recorded)
    """

    sunny: bool
    sun_azimuth_deg: float
    sun_elevation_deg: float
    sun_fraction: float
    sky_rgb: tuple[float, float, float]
    sun_rgb: tuple[float, float, float]
    ground_rgb: tuple[float, float, float]
    ground_ratio: float
    exposure: float
    confidence: float
    ground_levels: tuple[tuple[int, float], ...] = ()
    shadow_log_ratio: float = 0.0
    ground_shadowed: bool = False
    evidence: tuple[str, ...] = ()
    cues: dict = field(default_factory=dict, compare=False, hash=False)

    @property
    def sun_direction(self) -> tuple[float, float, float]:
        return tuple(float(v) for v in _direction(self.sun_azimuth_deg, self.sun_elevation_deg))

    @property
    def sky_share(self) -> float:
        """Share of an up-facing unshadowed surface's irradiance from the sky (1 overcast)."""
        return 1.0 - self.sun_fraction

    def to_lighting(self, exposure: float = 1.0) -> Lighting:
        """The renderer's light: an up-facing unshadowed surface gets ``exposure`` (luminance);
        1 is the :class:`Lighting` convention, ``self.exposure`` matches the photo's brightness."""
        f = self.sun_fraction if self.sunny else 0.0
        sky = exposure * (1.0 - f) * _unit(self.sky_rgb)
        ground = exposure * self.ground_ratio * (1.0 - f) * _unit(self.ground_rgb)
        # without a sun its direction only sizes the ground planes for shadows: straight up
        d = _direction(self.sun_azimuth_deg, self.sun_elevation_deg) if self.sunny else np.array([0.0, 0.0, 1.0])
        sun = exposure * f / max(d[2], 0.05) * _unit(self.sun_rgb)
        t = lambda c: tuple(float(v) for v in c)  # noqa: E731
        return Lighting(t(d), t(sun), t(sky), t(ground))

    def sun_visibility(self, label: int, linear_rgb) -> float:
        """How much sun reaches ground of class ``label`` whose photo colour (linear RGB) is
        ``linear_rgb``: 1 lit, 0 in a real cast shadow (from its brightness between the lit and
        the shadow level), 1 when not sunny or the class was not measured; 0 on any ground
        under a sun that does not reach it (``ground_shadowed``)."""
        if not self.sunny or self.shadow_log_ratio >= 0:
            return 1.0
        if self.ground_shadowed and int(label) in GROUND_IDS:
            return 0.0
        levels = dict(self.ground_levels)
        if int(label) not in levels:
            return 1.0
        y = float(np.asarray(linear_rgb, np.float64) @ LUM)
        return float(self._ramp(np.log(max(y, 1e-6)), levels[int(label)]))

    def _ramp(self, loglum, level: float):
        """0 at the shadow level, 1 at the lit level, linear over the middle half of the step
        in log luminance (so that the ground's texture does not modulate the sun)."""
        t = (loglum - (math.log(level) + self.shadow_log_ratio)) / -self.shadow_log_ratio
        return np.clip((t - 0.25) / 0.5, 0.0, 1.0)

    def sun_mask(self, rgb: np.ndarray, label_ids: np.ndarray) -> np.ndarray | None:
        """(H, W) float32: :meth:`sun_visibility` of every ground pixel of the photo (its
        luminance smoothed over 5x5 pixels), 1 elsewhere; None when not sunny."""
        if not self.sunny or self.shadow_log_ratio >= 0 or not self.ground_levels:
            return None
        mask = np.ones(label_ids.shape, np.float32)
        if self.ground_shadowed:
            mask[np.isin(label_ids, GROUND_IDS)] = 0.0
            return mask
        lum = cv2.blur(_LUT[rgb] @ LUM.astype(np.float32), (5, 5))
        for label, level in self.ground_levels:
            sel = label_ids == label
            mask[sel] = self._ramp(np.log(np.maximum(lum[sel], 1e-6)), level)
        return mask

    def to_dict(self) -> dict:
        """JSON-ready record of the estimate."""
        return {
            "mode": "estimate",
            "sunny": self.sunny,
            "sun_azimuth_deg": _r(self.sun_azimuth_deg, 1), "sun_elevation_deg": _r(self.sun_elevation_deg, 1),
            "sun_fraction": _r(self.sun_fraction, 3), "sky_share": _r(self.sky_share, 3),
            "sky_rgb": _r(self.sky_rgb), "sun_rgb": _r(self.sun_rgb), "ground_rgb": _r(self.ground_rgb),
            "ground_ratio": _r(self.ground_ratio, 3), "exposure": _r(self.exposure, 3),
            "confidence": _r(self.confidence, 3),
            "ground_levels": {str(k): _r(v, 5) for k, v in self.ground_levels},
            "shadow_log_ratio": _r(self.shadow_log_ratio, 3), "ground_shadowed": self.ground_shadowed,
            "evidence": list(self.evidence), "fallback": not self.evidence,
            "cues": _r(self.cues),
        }


def fixed_record(lighting: Lighting, **params) -> dict:
    """The record of a fixed (manifest) light: the manifest's keys and the light they give."""
    return {**{k: v for k, v in params.items() if v is not None}, "mode": "fixed", **lighting.to_dict()}


def camera_noise_seed(seed: int, key: str) -> int:
    """Seed of the camera-match noise of one image set: a function of (seed, image set) only."""
    return int(np.random.default_rng([int(seed), zlib.crc32(key.encode()), 0x6E6F6973]).integers(2**31))


# ============================================================== the working grid
@dataclass(eq=False)
class _Grid:
    """The photo reduced to cells of ``f`` x ``f`` pixels (mean linear colour)."""

    f: int
    lin: np.ndarray  # (h, w, 3) float32 linear RGB
    lum: np.ndarray  # (h, w) float32
    label: np.ndarray  # (h, w) uint8, the cell's label (pure cells only are used)
    pure: np.ndarray  # (h, w) bool: one label, finite depth throughout, nothing clipped
    points: np.ndarray  # (h, w, 3) float64 vehicle-frame point at the cell centre (nan unknown)
    normals: np.ndarray  # (h, w, 3) unit normals facing the camera (nan where not planar)


def _cell_reduce(a: np.ndarray, f: int, op) -> np.ndarray:
    """Min (``cv2.erode``) or max (``cv2.dilate``) of ``a`` over each f x f cell, (h, w)."""
    h, w = a.shape[0] // f, a.shape[1] // f
    if f == 1:
        return a[:h, :w].copy()
    # the kernel's anchor (f // 2) puts cell (i, j)'s pixels exactly under output i*f + f//2
    out = op(np.ascontiguousarray(a[: h * f, : w * f]), np.ones((f, f), np.uint8),
             borderType=cv2.BORDER_REPLICATE)
    return out[f // 2:: f, f // 2:: f][:h, :w]


def _cell_mean(a: np.ndarray, f: int) -> np.ndarray:
    """Mean of ``a`` (float32) over each f x f cell, (h, w)."""
    h, w = a.shape[0] // f, a.shape[1] // f
    a = a[: h * f, : w * f]
    return cv2.resize(a, (w, h), interpolation=cv2.INTER_AREA) if f > 1 else a.copy()


def _grid(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera, work_width: int,
          smooth: int = 1) -> _Grid:
    H, W = label_ids.shape
    f = max(1, int(round(W / work_width)))
    h, w = H // f, W // f
    lin = _cell_mean(cv2.LUT(rgb, _LUT), f)
    lab_min, lab_max = _cell_reduce(label_ids, f, cv2.erode), _cell_reduce(label_ids, f, cv2.dilate)
    # depth of a cell: the mean of its known depths (stereo leaves holes), if half are known
    d = depth.astype(np.float32, copy=False)
    known = np.isfinite(d)
    n_known = np.rint(_cell_mean(known.astype(np.float32), f) * (f * f))
    dmin = _cell_reduce(np.where(known, d, np.float32(np.inf)), f, cv2.erode)
    dmax = _cell_reduce(np.where(known, d, np.float32(-np.inf)), f, cv2.dilate)
    dsum = _cell_mean(np.where(known, d, np.float32(0.0)), f).astype(np.float64) * (f * f)
    clipped = _cell_reduce(cv2.max(cv2.max(rgb[..., 0], rgb[..., 1]), rgb[..., 2]), f, cv2.dilate) >= 250
    pure = (lab_min == lab_max) & (2 * n_known >= f * f) & (dmax <= dmin * 1.04 + 0.02) & ~clipped
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.where(2 * n_known >= f * f, dsum / np.maximum(n_known, 1), np.nan).astype(np.float64)
    if smooth > 1:
        z = _smoothed_depth(z, lab_min, lab_min == lab_max, smooth)
    uc = (np.arange(w) * f + (f - 1) / 2.0)[None, :]
    vc = (np.arange(h) * f + (f - 1) / 2.0)[:, None]
    opt = np.stack([(uc - camera.u0) * z / camera.fx, (vc - camera.v0) * z / camera.fy, z], axis=-1)
    m = camera.vehicle_from_optical
    pts = opt @ m[:3, :3].T + m[:3, 3]
    normals = _normals(pts, lab_min, pure, camera)
    if f > 1:  # a face narrower than 5 cells, or a cell within 2 of a corner: at pixel scale
        rr, cc = np.nonzero(pure & np.isnan(normals[..., 0]) & np.isin(lab_min, _FINE_IDS))
        normals[rr, cc] = _fine_normals(rr * f + f // 2, cc * f + f // 2, label_ids, d, camera)
    lum = (lin @ LUM.astype(np.float32)).astype(np.float32)
    return _Grid(f, lin, lum, lab_min, pure, pts, normals)


#: a frame whose disparity errs by more than this (pixels, :func:`noise.measure_sigma` on its
#: ground) came from a real matcher: its cells are averaged over SMOOTH x SMOOTH before the
#: normals are taken; exact disparity (1/256 px coding, measured at the floor) keeps its cells
NOISY_SIGMA_D, SMOOTH = 0.15, 3


def smoothing_for(depth: np.ndarray, label_ids: np.ndarray, camera: Camera) -> tuple[int, float]:
    """(cells to average, the frame's measured disparity error in pixels)."""
    fb = camera.fx * camera.baseline
    with np.errstate(divide="ignore"):
        disparity = np.where(np.isfinite(depth), fb / depth, np.nan).astype(np.float32)
    sigma = measure_sigma(disparity, np.isin(label_ids, GROUND_IDS))
    return (SMOOTH if sigma > NOISY_SIGMA_D else 1), sigma


def _smoothed_depth(z: np.ndarray, label: np.ndarray, one_label: np.ndarray, cells: int) -> np.ndarray:
    """Cell depths with their disparity (1 / z) averaged over the ``cells`` x ``cells`` cells
    of the same label around each cell. Real stereo (semi-global matching) errs by a few tenths
    of a pixel of disparity, about the same everywhere, so the depth error grows with z^2: at
    20 m, +-0.2 px is +-17 cm along the ray, while neighbouring cells 3 px apart are 3 cm apart
    on the ground - the normals from cell differences are noise. On a plane the disparity is an
    affine function of the pixel, so its average over cells is the plane's own disparity at
    their centroid: planes stay planar and the noise drops by about the window's width."""
    known = np.isfinite(z) & one_label
    disp = np.where(known, 1.0 / np.where(known, z, 1.0), 0.0).astype(np.float32)
    out = z.copy()
    k = (cells, cells)
    for lab in np.unique(label[known]):
        m = (known & (label == lab)).astype(np.float32)
        num = cv2.boxFilter(disp * m, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT)
        den = cv2.boxFilter(m, -1, k, normalize=False, borderType=cv2.BORDER_CONSTANT)
        sel = m > 0
        out[sel] = 1.0 / np.maximum(num[sel] / den[sel], 1e-6)
    return out


def _normals(p: np.ndarray, label: np.ndarray, pure: np.ndarray, camera: Camera) -> np.ndarray:
    """Normals from differences of cell points 1 and 2 cells apart; nan where the surface is not
    locally planar (creases, depth edges), where the two disagree or where labels change."""
    h, w, _ = p.shape
    out = np.full((h, w, 3), np.nan, np.float32)
    if h < 5 or w < 5:
        return out
    # one plane per coordinate, relative to the camera (unknown cells fail `pure` anyway)
    rel = np.nan_to_num(p - camera.position, nan=0.0).astype(np.float32)
    P = [np.ascontiguousarray(rel[..., i]) for i in range(3)]
    c = (slice(2, h - 2), slice(2, w - 2))

    def sh(dr: int, dc: int) -> tuple[slice, slice]:
        return slice(2 + dr, h - 2 + dr), slice(2 + dc, w - 2 + dc)

    ok = pure[c].copy()
    lab0 = label[c]
    for dr in range(-2, 3):
        for dc in (-2, -1, 0, 1, 2):
            if (dr == 0) != (dc == 0):
                ok &= pure[sh(dr, dc)] & (label[sh(dr, dc)] == lab0)
    p0 = [q[c] for q in P]
    normals = []
    for k in (1, 2):
        du, dv = [], []
        for q, q0 in zip(P, p0):
            qa, qb, qc, qd = q[sh(0, k)], q[sh(0, -k)], q[sh(k, 0)], q[sh(-k, 0)]
            du.append(qa - qb)
            dv.append(qc - qd)
            if q is P[0]:
                dev_u, dev_v = (qa + qb - 2 * q0) ** 2, (qc + qd - 2 * q0) ** 2
            else:
                dev_u += (qa + qb - 2 * q0) ** 2
                dev_v += (qc + qd - 2 * q0) ** 2
        # collinearity along each axis: a crease or a depth edge bends it
        for dev, span in ((dev_u, du), (dev_v, dv)):
            ok &= np.sqrt(dev) <= 0.08 * np.sqrt(span[0] ** 2 + span[1] ** 2 + span[2] ** 2) + 1e-3
        n = [du[1] * dv[2] - du[2] * dv[1], du[2] * dv[0] - du[0] * dv[2], du[0] * dv[1] - du[1] * dv[0]]
        norm = np.maximum(np.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2), 1e-12)
        normals.append([v / norm for v in n])
    n1, n2 = normals
    ok &= np.abs(n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]) >= math.cos(math.radians(10))
    # facing the camera: against the point's offset from it
    sign = np.where(n2[0] * p0[0] + n2[1] * p0[1] + n2[2] * p0[2] > 0, np.float32(-1.0), np.float32(1.0))
    sign[~ok] = np.nan
    out[c] = np.stack([v * sign for v in n2], axis=-1)
    return out


def _fine_normals(r: np.ndarray, c: np.ndarray, label_ids: np.ndarray, depth: np.ndarray,
                  camera: Camera) -> np.ndarray:
    """(N, 3) normals at pixels (r, c) from the photo's own pixels 1 and 2 apart, with the tests
    of :func:`_normals`; nan where they fail (or too near the image border)."""
    H, W = label_ids.shape
    out = np.full((len(r), 3), np.nan, np.float32)
    idx = np.nonzero((r >= 2) & (r < H - 2) & (c >= 2) & (c < W - 2))[0]
    r, c = r[idx], c[idx]
    # a pixel's vehicle-frame point is z * (col_ray[u] + row_ray[v]) + t
    m = camera.vehicle_from_optical
    col_ray = (((np.arange(W) - camera.u0) / camera.fx)[:, None] * m[:3, 0]).astype(np.float32)
    row_ray = (((np.arange(H) - camera.v0) / camera.fy)[:, None] * m[:3, 1] + m[:3, 2]).astype(np.float32)
    lab0 = label_ids[r, c]
    ok = np.ones(len(r), bool)

    def point(dr: int, dc: int) -> np.ndarray:  # relative to the camera's position
        nonlocal ok
        z = depth[r + dr, c + dc]
        ok &= np.isfinite(z) & (label_ids[r + dr, c + dc] == lab0)
        return np.where(np.isfinite(z), z, 0)[:, None] * (col_ray[c + dc] + row_ray[r + dr])

    p0 = point(0, 0)
    normals = []
    for k in (1, 2):
        a_u, b_u, a_v, b_v = point(0, k), point(0, -k), point(k, 0), point(-k, 0)
        du, dv = a_u - b_u, a_v - b_v
        for a, b, span in ((a_u, b_u, du), (a_v, b_v, dv)):
            ok &= np.linalg.norm(a + b - 2 * p0, axis=-1) <= 0.08 * np.linalg.norm(span, axis=-1) + 1e-3
        n = np.cross(du, dv)
        normals.append(n / np.maximum(np.linalg.norm(n, axis=-1), 1e-12)[:, None])
    n1, n2 = normals
    ok &= np.abs(np.sum(n1 * n2, axis=-1)) >= math.cos(math.radians(10))
    n2 = np.where((np.sum(n2 * p0, axis=-1) > 0)[:, None], -n2, n2)  # facing the camera
    out[idx] = np.where(ok[:, None], n2, np.nan)
    return out


# ============================================================== cue 1: cast shadows on the ground
CELL = 0.25  # height-map cell, metres
UNSEEN_TOP = 20.0  # metres: what an occluder cut by the image top may reach
EDGE_MARGIN_DEG = 4.0  # sun elevation margin around a predicted shadow edge
_MARCH = np.concatenate([np.arange(1, 33) * CELL, 8.0 + np.arange(1, 45) * 2 * CELL]).astype(np.float32)  # to 30 m
_PAD = int(math.ceil(30.0 / CELL)) + 2


@dataclass(eq=False)
class _ShadowCue:
    """Ground samples, and their occluders' horizons computed per azimuth on demand."""

    samples: np.ndarray  # (N, 3) vehicle points of ground cells
    rel: np.ndarray  # (N,) log luminance minus its class median (clipped)
    lin: np.ndarray  # (N, 3) linear colour
    cls: np.ndarray  # (N,) label
    maps: tuple[np.ndarray, np.ndarray, int, int]  # flat height maps (seen, unseen tops raised), nx, ny
    cells: tuple[np.ndarray, np.ndarray]  # (N, 1) float32 map coordinates of the samples
    view: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # distances to / unit vectors of the borders
    top: float  # height (m) above which nothing is assumed to stand
    ground: np.ndarray | None = None  # (h, w) bool grid: the ground cells sampled from (no markings)
    cache: dict = field(default_factory=dict)

    def horizons(self, az_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N,) tangents of the occluders' horizon towards ``az_deg`` (as seen, with unseen tops
        raised) and how far (m) the path stays inside the camera's view."""
        key = round(az_deg % 360.0, 3)
        if key not in self.cache:
            self.cache[key] = _march(self, math.radians(key))
        return self.cache[key]

    def shadowed(self, az_deg: float, el_deg: float) -> tuple[np.ndarray, np.ndarray]:
        """Bool (N,) pairs (shadowed, known) for that sun: a sample is known when a seen occluder
        is in the way, or when the path to the sun stays in view until it has risen above
        everything, unseen tops of occluders included."""
        horizon, horizon_hi, seen = self.horizons(az_deg)
        tan_el = math.tan(math.radians(el_deg))
        # a few degrees of margin: near a predicted shadow's edge the state is not known
        shadow = horizon > math.tan(math.radians(min(el_deg + EDGE_MARGIN_DEG, 89.0)))
        lit_tan = math.tan(math.radians(max(el_deg - EDGE_MARGIN_DEG, 1.0)))
        need = np.minimum((self.top - self.samples[:, 2]) / tan_el, _MARCH[-1])
        return shadow, shadow | ((horizon_hi <= lit_tan) & (seen >= need))


def _march(cue: _ShadowCue, a: float, steps: np.ndarray | None = None):
    """Horizon tangents of the samples towards azimuth ``a`` (radians) over the march steps."""
    hm, hm_hi, nx, ny = cue.maps
    fx0, fy0 = cue.cells
    dz0 = cue.samples[:, 2].astype(np.float32)[:, None]
    march = _MARCH if steps is None else steps
    ca, sa = np.float32(math.cos(a)), np.float32(math.sin(a))
    cells = march / np.float32(CELL)
    ix = (fx0 + ca * cells[None, :]).astype(np.int32)  # >= 0 by the map's border: a floor
    iy = (fy0 + sa * cells[None, :]).astype(np.int32)
    flat = np.clip(ix, 0, nx - 1) * ny + np.clip(iy, 0, ny - 1)
    rise = hm[flat] - dz0
    if steps is not None:
        return rise
    inv = (1.0 / march)[None, :]
    horizon = (rise * inv).max(axis=1)
    horizon_hi = ((hm_hi[flat] - dz0) * inv).max(axis=1)
    # how far the path stays inside the camera's view wedge (analytically)
    f_left, f_right, e_left, e_right = cue.view
    seen = np.full(len(dz0), float(march[-1]))
    for f0, rate in ((f_left, -(e_left[0] * sa - e_left[1] * ca)), (f_right, e_right[0] * sa - e_right[1] * ca)):
        if rate < 0:
            seen = np.minimum(seen, np.maximum(f0, 0.0) / -rate)
        seen = np.where(f0 < 0, 0.0, seen)
    return horizon, horizon_hi, seen


def _height_map(g: _Grid, label_ids: np.ndarray, depth: np.ndarray, camera: Camera, occluder_ids):
    """Max height of occluder points per ground-plan cell (V frame), 3x3 dilated: as seen, and
    raised to at least :data:`UNSEEN_TOP` (or 8 m more) where the occluder runs out of the top of
    the image (its top is unseen)."""
    H, W = depth.shape
    step = max(1, W // 512)
    v, u = np.mgrid[0:H:step, 0:W:step]
    z = depth[v, u]
    lab = label_ids[v, u]
    keep = np.isfinite(z) & np.isin(lab, occluder_ids)
    top = np.zeros(z.shape, bool)
    top[:2] = True
    v, u, z, top = v[keep], u[keep], z[keep].astype(np.float64), top[keep]
    opt = np.column_stack([(u - camera.u0) * z / camera.fx, (v - camera.v0) * z / camera.fy, z])
    m = camera.vehicle_from_optical
    p = opt @ m[:3, :3].T + m[:3, 3]
    # the map, with a border of _PAD empty cells so that any march from a sample stays inside
    x0, y0 = camera.x - 10.0 - _PAD * CELL, camera.y - 50.0 - _PAD * CELL
    nx, ny = int(110.0 / CELL) + 2 * _PAD, int(100.0 / CELL) + 2 * _PAD
    ix = np.floor((p[:, 0] - x0) / CELL).astype(np.int64)
    iy = np.floor((p[:, 1] - y0) / CELL).astype(np.int64)
    inside = (ix >= _PAD) & (ix < nx - _PAD) & (iy >= _PAD) & (iy < ny - _PAD)
    maps = []
    for hz in (p[:, 2], np.where(top, np.maximum(p[:, 2] + 8.0, UNSEEN_TOP), p[:, 2])):
        hm = np.full(nx * ny, -1e4, np.float32)
        order = np.argsort(hz[inside], kind="stable")  # the highest point of a cell is written last
        hm[(ix[inside] * ny + iy[inside])[order]] = hz[inside][order].astype(np.float32)
        maps.append(cv2.dilate(hm.reshape(nx, ny), np.ones((3, 3), np.uint8)))
    return maps, (x0, y0)


def _view_edges(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Ground-plan unit vectors of the image's left and right borders (2 degrees inside)."""
    left = math.atan(camera.u0 / camera.fx) - math.radians(2.0)
    right = -math.atan((camera.width - 1 - camera.u0) / camera.fx) + math.radians(2.0)
    return (np.array([math.cos(camera.yaw + left), math.sin(camera.yaw + left)]),
            np.array([math.cos(camera.yaw + right), math.sin(camera.yaw + right)]))


MARKING_WIDTH = 1.75  # metres: brighter ground narrower than this is paint or kerbstone, not sunlight
_PLAN_CELL = 0.25


def _markings(g: _Grid, rr: np.ndarray, cc: np.ndarray, camera: Camera) -> np.ndarray:
    """Bool per ground cell (rr, cc): part of a bright structure narrower than
    :data:`MARKING_WIDTH` on the ground plan (lane markings, kerbstones) - a white top-hat of the
    log luminance, per class, on a plan grid. Lit patches are wider and stay."""
    out = np.zeros(len(rr), bool)
    pts, cls = g.points[rr, cc], g.label[rr, cc]
    ll = np.log(np.maximum(g.lum[rr, cc], 1e-6)).astype(np.float32)
    ix = np.floor((pts[:, 0] - camera.x + 5.0) / _PLAN_CELL).astype(np.int64)
    iy = np.floor((pts[:, 1] - camera.y + 50.0) / _PLAN_CELL).astype(np.int64)
    nx, ny = int(55.0 / _PLAN_CELL), int(100.0 / _PLAN_CELL)
    inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
    k = int(round(MARKING_WIDTH / _PLAN_CELL)) | 1
    kernel = np.ones((k, k), np.uint8)
    for c in np.unique(cls):
        sel = np.nonzero(inside & (cls == c))[0]
        flat = ix[sel] * ny + iy[sel]
        total = np.bincount(flat, weights=ll[sel], minlength=nx * ny)
        count = np.bincount(flat, minlength=nx * ny)
        plan = np.where(count > 0, total / np.maximum(count, 1), 1e4).astype(np.float32).reshape(nx, ny)
        opened = cv2.dilate(np.where(plan < 1e3, cv2.erode(plan, kernel), -1e4).astype(np.float32), kernel)
        tophat = ll[sel] - opened.ravel()[flat]
        out[sel] = (tophat > 0.3) & (opened.ravel()[flat] > -1e3)
    return out


@dataclass(frozen=True, eq=False)
class _Occluders:
    """The height maps of everything standing on the ground, and the camera's view borders."""

    maps: tuple[np.ndarray, np.ndarray, int, int]  # flat maps (seen, unseen tops raised), nx, ny
    origin: tuple[float, float]  # (x, y) of cell (0, 0) in V
    edges: tuple[np.ndarray, np.ndarray]  # unit vectors of the image's left and right borders
    top: float  # height (m) above which nothing is assumed to stand

    @classmethod
    def build(cls, g: _Grid, label_ids: np.ndarray, depth: np.ndarray, camera: Camera) -> "_Occluders":
        (hm, hm_hi), origin = _height_map(g, label_ids, depth, camera, OCCLUDER_IDS)
        finite = hm_hi[hm_hi > -1e3]
        top = float(min(np.max(finite), 25.0)) if finite.size else 0.0
        return cls((hm.ravel(), hm_hi.ravel(), hm.shape[0], hm.shape[1]), origin, _view_edges(camera), top)

    def cue(self, pts: np.ndarray, camera: Camera, lin: np.ndarray | None = None,
            cls: np.ndarray | None = None) -> _ShadowCue:
        """Shadow queries for vehicle-frame points ``pts`` (N, 3)."""
        (x0, y0), (e_left, e_right) = self.origin, self.edges
        rel_x, rel_y = pts[:, 0] - camera.x, pts[:, 1] - camera.y
        n = len(pts)
        return _ShadowCue(
            pts, np.zeros(n), np.zeros((n, 3)) if lin is None else lin, np.zeros(n, np.uint8) if cls is None else cls,
            self.maps,
            (np.clip((pts[:, 0] - x0) / CELL, 0, None).astype(np.float32)[:, None],
             np.clip((pts[:, 1] - y0) / CELL, 0, None).astype(np.float32)[:, None]),
            (-(e_left[0] * rel_y - e_left[1] * rel_x), e_right[0] * rel_y - e_right[1] * rel_x, e_left, e_right),
            self.top)


def _ground_cells(g: _Grid, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Cells of pure ground (:data:`GROUND_IDS`) with a point and some light, facing up (not kerb
    faces; nan normals fail too), within 45 m of the camera on the ground plan; and every
    cell's distance from the camera on the ground plan."""
    dist = np.hypot(g.points[..., 0] - camera.x, g.points[..., 1] - camera.y)
    ground = g.pure & np.isin(g.label, GROUND_IDS) & np.isfinite(g.points[..., 0]) & (g.lum > 1e-4)
    ground &= (g.normals[..., 2] > 0.9) & (dist < 45.0)
    return ground, dist


def _shadow_cue(g: _Grid, occ: _Occluders, camera: Camera, max_samples: int = 2000) -> _ShadowCue | None:
    ground, _ = _ground_cells(g, camera)
    ground &= np.abs(g.points[..., 1] - camera.y) < 48.0
    rr, cc = np.nonzero(ground)
    if len(rr) < 200:
        return None
    keep = ~_markings(g, rr, cc, camera)
    rr, cc = rr[keep], cc[keep]
    if len(rr) < 200:
        return None
    unmarked = np.zeros(ground.shape, bool)
    unmarked[rr, cc] = True
    if len(rr) > max_samples:  # even spread, deterministic
        pick = np.linspace(0, len(rr) - 1, max_samples).astype(np.int64)
        rr, cc = rr[pick], cc[pick]
    pts, cls = g.points[rr, cc], g.label[rr, cc]
    cue = occ.cue(pts, camera)
    # samples with an occluder within half a metre (under cars, at wall feet) are dark from
    # ambient occlusion whatever the sun does: left out
    near = np.zeros(len(rr), bool)
    for a in np.radians(np.arange(0.0, 360.0, 30.0)):
        near |= (_march(cue, a, _MARCH[:2]) > 0.15).any(axis=1)
    keep = ~near
    if keep.sum() < 150:
        return None
    pts, cls, rr, cc = pts[keep], cls[keep], rr[keep], cc[keep]
    cue = occ.cue(pts, camera, g.lin[rr, cc].astype(np.float64), cls)
    loglum = np.log(g.lum[rr, cc])
    rel = np.empty(len(rr))
    for k in np.unique(cls):
        sel = cls == k
        rel[sel] = loglum[sel] - np.median(loglum[sel])
    cue.rel = np.clip(rel, -2.5, 1.5)  # (markings are gone; an outlier component takes the rest)
    cue.ground = unmarked
    return cue


@dataclass(frozen=True)
class _Mixture:
    """Two brightness levels of the ground: lit (per class) and shadowed (shared log ratio)."""

    delta: float  # log(shadow / lit)
    share: float  # share of samples in shadow
    sigma: float
    gain: float  # log-likelihood gain per sample over one level
    posterior: np.ndarray  # (N,) probability of each sample being in shadow


_OUTLIER = 0.04 / 4.0  # density of the uniform outlier component over rel in [-2.5, 1.5]


def _mixture(cue: _ShadowCue, iterations: int = 30) -> _Mixture:
    """EM fit of a lit level mu_c per class, a shared shadow step delta, a shared width and a
    uniform outlier component to the ground samples' log luminance; the best of a few starts."""
    r, cls = cue.rel, cue.cls
    classes, inv = np.unique(cls, return_inverse=True)

    def dens(x, m, s):
        return np.exp(-0.5 * ((x - m) / s) ** 2) / (s * math.sqrt(2 * math.pi))

    def fit(delta: float, share: float):
        mu = np.array([np.quantile(r[inv == j], 1.0 - share / 2) for j in range(len(classes))])
        sigma = 0.1
        for _ in range(iterations):
            m = mu[inv]
            p_lit = (1 - share) * dens(r, m, sigma)
            p_sh = share * dens(r, m + delta, sigma)
            tot = p_lit + p_sh + _OUTLIER
            w_lit, w_sh = p_lit / tot, p_sh / tot
            for j in range(len(classes)):
                sel = inv == j
                den = w_lit[sel].sum() + w_sh[sel].sum()
                if den > 1e-9:
                    mu[j] = (w_lit[sel] @ r[sel] + w_sh[sel] @ (r[sel] - delta)) / den
            m = mu[inv]
            if w_sh.sum() > 1e-6:
                delta = float(min(w_sh @ (r - m) / w_sh.sum(), 0.0))
            share = float(np.clip(w_sh.sum() / (w_lit.sum() + w_sh.sum()), 1e-3, 1 - 1e-3))
            var = (w_lit @ (r - m) ** 2 + w_sh @ (r - m - delta) ** 2) / max(w_lit.sum() + w_sh.sum(), 1e-9)
            sigma = float(np.clip(math.sqrt(var), 0.03, 1.0))
        m = mu[inv]
        p_lit = (1 - share) * dens(r, m, sigma)
        p_sh = share * dens(r, m + delta, sigma)
        ll = float(np.log(p_lit + p_sh + _OUTLIER).mean())
        return ll, delta, share, sigma, p_sh / np.maximum(p_lit + p_sh, 1e-300)

    best = max((fit(d0, s0) for d0, s0 in ((-0.3, 0.3), (-0.7, 0.15), (-1.2, 0.1), (-1.2, 0.4))),
               key=lambda t: t[0])
    ll2, delta, share, sigma, post = best
    # one level per class, same outlier model
    mu1 = np.array([np.median(r[inv == j]) for j in range(len(classes))])[inv]
    s1 = float(np.clip(np.sqrt(np.mean((r - mu1) ** 2)), 0.03, 1.0))
    ll1 = float(np.log(dens(r, mu1, s1) + _OUTLIER).mean())
    return _Mixture(delta, share, sigma, ll2 - ll1, post)


def _shadow_score(cue: _ShadowCue, mix: _Mixture, shadow: np.ndarray, known: np.ndarray) -> float:
    """Log-likelihood ratio (nats per ground sample) of the predicted shadow mask against
    shadows that could be anywhere: > 0 where the prediction agrees with the dark samples.
    Samples whose state the visible scene cannot tell count zero."""
    q = np.clip(mix.posterior, 0.02, 0.98)
    a = np.clip(np.log(q / mix.share), -3.0, 3.0)
    b = np.clip(np.log((1 - q) / (1 - mix.share)), -3.0, 3.0)
    return float(np.where(known, np.where(shadow, a, b), 0.0).sum() / len(q))


# ============================================================== cue 2: shading of surface pairs
@dataclass(eq=False)
class _PairCue:
    n1: np.ndarray  # (N, 3)
    n2: np.ndarray
    y: np.ndarray  # (N,) log luminance ratio 1 / 2
    label: np.ndarray  # (N,) class of the pair
    rc: np.ndarray  # (N, 4) grid cells (row, col) of both ends
    weight: np.ndarray  # (N,) so that no one object (image region) outweighs the rest
    z: np.ndarray  # (N,) height (vehicle frame: above the ground under the camera) of the lower end
    terms: dict = field(default_factory=dict)  # direction-free terms of _pair_fit, float32


def _pair_cue(g: _Grid, max_pairs: int = 6000) -> _PairCue | None:
    ok = g.pure & np.isfinite(g.normals[..., 0]) & np.isin(g.label, SHADING_IDS) & (g.lum > 1e-4)
    h, w = ok.shape
    n1s, n2s, ys, labs, rcs = [], [], [], [], []
    loglum = np.log(np.maximum(g.lum, 1e-6))
    nx, ny, nz = (np.ascontiguousarray(g.normals[..., i]) for i in range(3))
    cos20 = np.float32(math.cos(math.radians(20)))
    for d in (2, 3, 5):
        for dr, dc in ((0, d), (d, 0), (d, d), (d, -d)):
            a = (slice(max(0, -dr), h - max(0, dr)), slice(max(0, -dc), w - max(0, dc)))
            b = (slice(a[0].start + dr, a[0].stop + dr), slice(a[1].start + dc, a[1].stop + dc))
            both = ok[a] & ok[b] & (g.label[a] == g.label[b])
            both &= nx[a] * nx[b] + ny[a] * ny[b] + nz[a] * nz[b] < cos20
            idx = np.nonzero(both)
            if not len(idx[0]):
                continue
            ia = (idx[0] + a[0].start, idx[1] + a[1].start)
            ib = (ia[0] + dr, ia[1] + dc)
            na, nb = g.normals[ia], g.normals[ib]
            la, lb = loglum[ia], loglum[ib]
            dpq = g.points[ib] - g.points[ia]
            gap = np.linalg.norm(dpq, axis=-1)
            keep = gap < 1.0
            # convex edges only (each point behind the other's tangent plane): one object's
            # faces; a concave corner is as often two buildings meeting, with two albedos
            keep &= (np.sum(dpq * na, axis=-1) < -0.01 * gap) & (np.sum(-dpq * nb, axis=-1) < -0.01 * gap)
            keep &= np.abs(la - lb) < 1.8  # no light makes more of a step
            # shading keeps the colour (nearly: sun and sky differ); a change of
            # chromaticity is a change of paint (lamps, plates, trims)
            ca = g.lin[ia] / np.maximum(g.lin[ia].sum(axis=-1, keepdims=True), 1e-6)
            cb = g.lin[ib] / np.maximum(g.lin[ib].sum(axis=-1, keepdims=True), 1e-6)
            keep &= np.abs(ca - cb).max(axis=-1) < 0.1
            if keep.any():
                n1s.append(na[keep])
                n2s.append(nb[keep])
                ys.append(la[keep] - lb[keep])
                labs.append(g.label[ia][keep])
                rcs.append(np.column_stack([ia[0][keep], ia[1][keep], ib[0][keep], ib[1][keep]]))
    if not ys:
        return None
    n1, n2, y = np.concatenate(n1s), np.concatenate(n2s), np.concatenate(ys)
    lab, rc = np.concatenate(labs), np.concatenate(rcs)
    if len(y) < 30:
        return None
    # regions of 1/32 of the grid width: each counts at most like PAIRS_PER_REGION pairs, and
    # keeps at most PAIRS_KEPT_PER_REGION of its pairs (evenly spread: its mean speaks for it)
    side = max(4, w // 32)
    region = (rc[:, 0] // side) * (w // side + 1) + rc[:, 1] // side
    order = np.argsort(region, kind="stable")
    counts = np.bincount(region)
    first = np.cumsum(counts) - counts
    rank = np.empty(len(y), np.int64)
    rank[order] = np.arange(len(y)) - first[region[order]]
    total = counts[region]
    keep = (rank * PAIRS_KEPT_PER_REGION) % total < PAIRS_KEPT_PER_REGION
    if keep.sum() > max_pairs:
        keep[np.nonzero(keep)[0][np.linspace(0, keep.sum() - 1, keep.sum() - max_pairs).astype(np.int64)]] = False
    n1, n2, y, lab, rc, region, total = (v[keep] for v in (n1, n2, y, lab, rc, region, total))
    kept = np.bincount(region)[region]
    weight = np.minimum(total, PAIRS_PER_REGION) / kept * PAIR_CLASS_WEIGHT[lab]
    z = np.fmin(g.points[rc[:, 0], rc[:, 1], 2], g.points[rc[:, 2], rc[:, 3], 2])
    return _PairCue(n1, n2, y, lab, rc, weight, z)


PAIRS_PER_REGION = 6
PAIRS_KEPT_PER_REGION = 24
#: trust in each class's pairs, measured with benchmarks/eval_lighting.py (sun within 20 degrees
#: of the truth; the windows' colour change keeps them out of building pairs): building corners
#: are the best cue; a car's faces often change paint or carry lamps, so cars weigh a quarter;
#: kerbs (road / sidewalk pairs) weigh little: a kerb's face is a few pixels high, its normal from
#: the depth is poor and its pairs pull the fit away from the sun (at full weight they halved the
#: share of suns found within 20 degrees)
PAIR_CLASS_WEIGHT = np.ones(256)
PAIR_CLASS_WEIGHT[[7, 8]] = 0.05
PAIR_CLASS_WEIGHT[[26, 27, 28, 29, 30, 31]] = 0.25
_KS = np.array([0.85, 0.7, 0.55, 0.42, 0.3, 0.2])  # sky shares tried with a sun
_GAMMAS = np.array([0.15, 0.3, 0.5])  # ground bounce ratios tried
_SCALE = 0.15  # robust loss scale (log units)
_SHADOWED_PAIR = 0.5  # loss for explaining a pair as lying in a cast shadow (ambient only)


def _rho(res: np.ndarray) -> np.ndarray:
    return np.log1p((res / _SCALE) ** 2)


def _pair_none(cue: _PairCue) -> tuple[np.ndarray, float]:
    """Per-pair losses of the best ambient-only model, and its ground ratio."""
    best = None
    for gm in _GAMMAS:
        h1 = gm + (1 - gm) * (0.5 + 0.5 * cue.n1[:, 2])
        h2 = gm + (1 - gm) * (0.5 + 0.5 * cue.n2[:, 2])
        loss = _rho(cue.y - np.log(h1 / h2))
        if best is None or loss @ cue.weight < best[0] @ cue.weight:
            best = (loss, float(gm))
    return best


def _pair_sun(t: dict, az_deg: float, el_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The sun's light on each end of the pairs (float32 terms ``t`` of :func:`_pair_fit`),
    relative to an up-facing surface's."""
    d = _direction(az_deg, el_deg).astype(np.float32)
    return np.maximum(t["n1"] @ d, 0) / d[2], np.maximum(t["n2"] @ d, 0) / d[2]


def _pair_fit(cue: _PairCue, none: np.ndarray, az_deg: float, el_deg: float) -> tuple[float, float, float]:
    """(gain in nats per pair over the ambient-only model, sky share, ground ratio) of the best
    sunny model for that sun direction. A pair may instead lie in a cast shadow (ambient only,
    at a small extra cost), so shadowed objects do not speak against the sun."""
    t = cue.terms
    if not t:  # the sky's part of each end's light, k * ambient(n), for every (k, ground ratio)
        k, gm = _KS[:, None, None], _GAMMAS[None, :, None]
        for name, n in (("kh1", cue.n1), ("kh2", cue.n2)):
            t[name] = (k * (gm + (1 - gm) * (0.5 + 0.5 * n[:, 2])[None, None, :])).astype(np.float32)
        t["sun_share"] = (1 - _KS[:, None, None]).astype(np.float32)
        t["n1"], t["n2"], t["y"] = cue.n1.astype(np.float32), cue.n2.astype(np.float32), cue.y.astype(np.float32)
    s1, s2 = _pair_sun(t, az_deg, el_deg)
    e1 = np.maximum(t["kh1"] + t["sun_share"] * s1, np.float32(1e-4))
    e2 = np.maximum(t["kh2"] + t["sun_share"] * s2, np.float32(1e-4))
    loss = _rho(t["y"] - np.log(e1 / e2))
    loss = np.minimum(loss, (none + _SHADOWED_PAIR).astype(np.float32)).astype(np.float64) @ cue.weight
    i, j = np.unravel_index(int(np.argmin(loss)), loss.shape)
    return float((none @ cue.weight - loss[i, j]) / cue.weight.sum()), float(_KS[i]), float(_GAMMAS[j])


# ============================================================== cue: the shadows of the casters in view
CASTER_MAX_HEIGHT = 6.0  # metres above their ground: the caster points used (lower parts of walls)
CASTER_POINTS = 1500  # at most, evenly spread over the casters
_CAST_CELL = 0.2  # ground-plan cell of the landing map, metres
_CAST_NEAR = 0.6  # metres: ground this near a caster's foot is dark from contact shadow alone
#: a caster sun needs this agreement (mean over the caster points) and this many points whose
#: shadow lands on dark ground
CASTER_MIN_AGREEMENT, CASTER_MIN_DARK = 0.015, 25
#: only for ground without a brighter level: at most this share of the ground samples lies a
#: shadow step above their class's median (which is then the lit level, not the shadow's)
CASTER_MAX_BRIGHT = 0.004
#: degrees: above this the shadows lie at the casters' feet for any azimuth
CASTER_MAX_ELEVATION = 70.0


@dataclass(eq=False)
class _CasterCue:
    """Points of the things standing in view, with their height above their own ground, and a
    ground-plan map of the ground in view (log luminance against its class's level): for a sun
    direction, where each point's shadow lands and how dark the ground there is."""

    xy: np.ndarray  # (P, 2) float32 plan position of the caster points
    height: np.ndarray  # (P,) float32 above the ground under them
    rel: np.ndarray  # (nx * ny,) float32 log luminance of the ground cell minus its class level; nan unseen
    origin: tuple[float, float]
    shape: tuple[int, int]

    def landings(self, az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
        """(D, P) rel of the ground where each point's shadow lands, nan where that ground is not
        in view (hidden, out of the picture, near a caster's foot)."""
        az, el = np.radians(np.atleast_1d(az_deg)), np.radians(np.atleast_1d(el_deg))
        run = (self.height[None, :] / np.tan(el)[:, None]).astype(np.float32)
        lx = self.xy[None, :, 0] - run * np.cos(az).astype(np.float32)[:, None]
        ly = self.xy[None, :, 1] - run * np.sin(az).astype(np.float32)[:, None]
        nx, ny = self.shape
        ix = np.floor((lx - self.origin[0]) / _CAST_CELL).astype(np.int32)
        iy = np.floor((ly - self.origin[1]) / _CAST_CELL).astype(np.int32)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        flat = np.where(inside, ix * ny + iy, 0)
        return np.where(inside, self.rel[flat], np.nan)

    def score(self, az_deg, el_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per direction (D,): the agreement (mean over the points of +1 for a shadow landing on
        dark ground, -1 on lit ground, 0 out of view), the number of points landing on dark
        ground, and the median darkness (log ratio to the class level) where they land dark."""
        r = self.landings(az_deg, el_deg)
        seen = np.isfinite(r)
        e = np.where(seen, np.clip((-np.where(seen, r, 0.0) - 0.25) / 0.1, -1.0, 1.0), 0.0)
        dark = e > 0.5
        step = np.array([float(np.median(r[i][dark[i]])) if dark[i].any() else 0.0 for i in range(len(r))])
        return e.sum(axis=1) / e.shape[1], dark.sum(axis=1), step


def _caster_cue(g: _Grid, camera: Camera) -> _CasterCue | None:
    ground, d_here = _ground_cells(g, camera)
    standing = np.isin(g.label, OCCLUDER_IDS)
    # ground seen below something standing that is not clearly nearer than it (under a car's
    # body, at its foot) is dark from contact shadow alone
    caster = standing & np.isfinite(d_here)
    d_above = np.minimum.accumulate(np.where(caster, d_here, np.inf), axis=0)  # nearest above, per column
    under = d_above < d_here + _CAST_NEAR
    ground &= ~under
    rr, cc = np.nonzero(ground)
    if len(rr) < 200:
        return None
    gp, cls = g.points[rr, cc], g.label[rr, cc]
    ll = np.log(g.lum[rr, cc])
    rel = np.empty(len(rr), np.float32)
    for k in np.unique(cls):
        sel = cls == k
        rel[sel] = ll[sel] - np.median(ll[sel])
    x0, y0 = float(gp[:, 0].min()) - 1.0, float(gp[:, 1].min()) - 1.0
    nx = int((gp[:, 0].max() - x0) / _CAST_CELL) + 2
    ny = int((gp[:, 1].max() - y0) / _CAST_CELL) + 2
    ix = ((gp[:, 0] - x0) / _CAST_CELL).astype(np.int64)
    iy = ((gp[:, 1] - y0) / _CAST_CELL).astype(np.int64)
    flat = ix * ny + iy
    count = np.bincount(flat, minlength=nx * ny)
    total = np.bincount(flat, weights=rel, minlength=nx * ny)
    zsum = np.bincount(flat, weights=gp[:, 2], minlength=nx * ny)
    plan = np.where(count > 0, total / np.maximum(count, 1), np.nan).astype(np.float32)
    # ground height under everything: the nearest ground seen, on a coarser plan
    k = 5
    cx, cy = nx // k + 1, ny // k + 1
    cflat = (ix // k) * cy + iy // k
    ccount = np.bincount(cflat, minlength=cx * cy)
    cz = (np.bincount(cflat, weights=gp[:, 2], minlength=cx * cy) / np.maximum(ccount, 1)).reshape(cx, cy)
    unknown = (ccount == 0).reshape(cx, cy).astype(np.uint8)
    _, lab = cv2.distanceTransformWithLabels(unknown, cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL)
    known_idx = np.flatnonzero(unknown.ravel() == 0)
    # labels number the zero pixels in raster order (1-based)
    zmap = cz.ravel()[known_idx[np.clip(lab.ravel() - 1, 0, len(known_idx) - 1)]].reshape(cx, cy)

    occ = g.pure & standing & np.isfinite(g.points[..., 0])
    orr, occ_c = np.nonzero(occ)
    op = g.points[orr, occ_c]
    ox = np.clip(((op[:, 0] - x0) / _CAST_CELL).astype(np.int64) // k, 0, cx - 1)
    oy = np.clip(((op[:, 1] - y0) / _CAST_CELL).astype(np.int64) // k, 0, cy - 1)
    h = op[:, 2] - zmap[ox, oy]
    # ground under anything standing (a car's body: seen below it) or near its foot is left
    # out: dark from contact shadow alone
    foot = h < 3.0
    fx = ((op[foot, 0] - x0) / _CAST_CELL).astype(np.int64)
    fy = ((op[foot, 1] - y0) / _CAST_CELL).astype(np.int64)
    inside = (fx >= 0) & (fx < nx) & (fy >= 0) & (fy < ny)
    near = np.zeros((nx, ny), np.uint8)
    near[fx[inside], fy[inside]] = 1
    r = int(round(_CAST_NEAR / _CAST_CELL))
    near = cv2.dilate(near, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    plan[near.ravel() > 0] = np.nan
    keep = (h > 0.2) & (h < CASTER_MAX_HEIGHT) & (np.hypot(op[:, 0] - camera.x, op[:, 1] - camera.y) < 45.0)
    op, h = op[keep], h[keep]
    if len(h) < 20:
        return None
    if len(h) > CASTER_POINTS:
        pick = np.linspace(0, len(h) - 1, CASTER_POINTS).astype(np.int64)
        op, h = op[pick], h[pick]
    return _CasterCue(op[:, :2].astype(np.float32), h.astype(np.float32), plan, (x0, y0), (nx, ny))


def _caster_sun(cue: _CasterCue, coarse: list):
    """A sun found from the shadows of the casters in view, for ground without a clear second
    brightness level (the sun ahead of the camera: the shadows of cars, poles and people fall
    towards it, a small share of the ground): (agreement, azimuth, elevation, shadow log ratio),
    or None. The best coarse direction, refined, must land at least :data:`CASTER_MIN_DARK` of
    the points on dark ground and score :data:`CASTER_MIN_AGREEMENT`."""
    # a high sun puts the shadows at the casters' feet, whatever its azimuth: not judged
    az = np.array([c[1] for c in coarse if c[2] <= CASTER_MAX_ELEVATION])
    el = np.array([c[2] for c in coarse if c[2] <= CASTER_MAX_ELEVATION])
    agree, dark, step = cue.score(az, el)
    i = int(np.argmax(agree))
    best = (float(agree[i]), float(az[i]), float(el[i]), float(step[i]), int(dark[i]))
    faz, fel = np.meshgrid(best[1] + np.arange(-10.0, 10.1, 5.0),
                           np.clip(best[2] + np.arange(-8.0, 8.1, 4.0), 8.0, CASTER_MAX_ELEVATION), indexing="ij")
    faz, fel = faz.ravel() % 360.0, fel.ravel()
    agree, dark, step = cue.score(faz, fel)
    j = int(np.argmax(agree))
    if agree[j] > best[0]:
        best = (float(agree[j]), float(faz[j]), float(fel[j]), float(step[j]), int(dark[j]))
    if best[0] < CASTER_MIN_AGREEMENT or best[4] < CASTER_MIN_DARK:
        return None
    return best[:4]


# ============================================================== cue: straight shadow edges on the ground
#: a straight edge between lit and shadowed ground at least this long (metres, on the ground
#: plan) and off the street's axis and its normal by more than LINE_AXIS_BAND degrees is the
#: shadow of something vertical: it runs along the sun's azimuth
LINE_MIN_LENGTH, LINE_AXIS_BAND = 3.0, 10.0
#: the shading gain a direction along such an edge may lose against the best direction
LINE_MARGIN = 0.3
_LINE_BIN = 0.25  # metres: offset and length bins of the edge search
_LINE_MAX_DIST = 30.0  # metres: edges farther from the camera are too coarse on the plan
_LINE_GAP = 3  # empty bins bridged along an edge


def _street_axis(g: _Grid) -> float:
    """Direction (degrees, mod 180) of the street: normal to the walls' most common facing (the
    vehicle's heading when no wall is in view)."""
    sub = (slice(None, None, 2), slice(None, None, 2))  # every other cell is plenty
    normals = g.normals[sub]
    sel = g.pure[sub] & np.isin(g.label[sub], (11, 12)) & (np.abs(normals[..., 2]) < 0.3)  # building, wall
    if sel.sum() < 50:
        return 0.0
    n = normals[sel]
    h = np.bincount(np.round(np.degrees(np.arctan2(n[:, 1], n[:, 0]))).astype(np.int64) % 180,
                    minlength=180).astype(np.float64)
    h = np.convolve(np.concatenate([h[-2:], h, h[:2]]), np.ones(5), "valid")
    return float((np.argmax(h) + 90) % 180)


def _shadow_line(g: _Grid, camera: Camera, cue: _ShadowCue, mix: _Mixture) -> tuple[float, float]:
    """The longest straight edge between lit and shadowed ground on the ground plan, off the
    street's axis and its normal by more than :data:`LINE_AXIS_BAND` (kerbs, roof lines,
    building ends): (direction in degrees mod 180, length in metres); length 0 without one."""
    lengths = _shadow_line_lengths(g, camera, cue, mix)
    i = int(np.argmax(lengths))
    if lengths[i] <= 0:
        return 0.0, 0.0
    # a straight edge keeps much of its length a few degrees either side: the centre of the
    # directions that keep most of it
    off = np.arange(-10, 11)
    near = lengths[(i + off) % 180]
    w = np.where(near >= 0.85 * lengths[i], near, 0.0)
    return float((i + off @ w / w.sum()) % 180.0), float(lengths[i])


def _shadow_line_lengths(g: _Grid, camera: Camera, cue: _ShadowCue, mix: _Mixture) -> np.ndarray:
    """(180,) per ground-plan direction (degrees, mod 180): the length (metres) of the longest
    straight edge between lit and shadowed ground along it, 0 within :data:`LINE_AXIS_BAND` of
    the street's axis or its normal; measured every other degree, and every degree within 11 of
    the longest (0 where not measured)."""
    rr, cc = np.nonzero(cue.ground)
    near = np.hypot(g.points[rr, cc, 0] - camera.x, g.points[rr, cc, 1] - camera.y) < _LINE_MAX_DIST
    rr, cc = rr[near], cc[near]
    if len(rr) < 200:
        return np.zeros(180)
    # each class's threshold half a shadow step below its lit level (from the mixture's samples)
    loglum = np.log(np.maximum(g.lum[rr, cc], 1e-6))
    sample_log = np.log(np.maximum(cue.lin @ LUM, 1e-6))
    cls = g.label[rr, cc]
    shade = np.full(g.lum.shape, np.nan, np.float32)
    for k in np.unique(cls):
        lit = (cue.cls == k) & (mix.posterior < 0.5)
        if lit.sum() < 20:
            continue
        sel = cls == k
        shade[rr[sel], cc[sel]] = loglum[sel] < float(np.median(sample_log[lit])) + mix.delta / 2
    valid = np.isfinite(shade)
    weight = cv2.GaussianBlur(valid.astype(np.float32), (0, 0), 1.0)
    smooth = cv2.GaussianBlur(np.where(valid, shade, 0.0).astype(np.float32), (0, 0), 1.0) / np.maximum(weight, 1e-6)
    # the shadowed side's cells next to lit ones: an edge one cell thick
    lit_cells = ((smooth < 0.5) & valid).astype(np.uint8)
    edge = valid & (smooth >= 0.5) & (weight > 0.6) & \
        (cv2.dilate(lit_cells, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))) > 0)
    xy = g.points[edge][:, :2]
    xy = xy[np.isfinite(xy).all(axis=1)]
    out = np.zeros(180)
    if len(xy) < 20:
        return out
    xy = xy - xy.mean(axis=0)
    street = _street_axis(g)

    def measure(phi: int) -> None:
        off = min(abs(phi - street) % 180, 180 - abs(phi - street) % 180)
        if off <= LINE_AXIS_BAND or abs(off - 90) <= LINE_AXIS_BAND:
            return
        a = math.radians(phi)
        along = xy[:, 0] * math.cos(a) + xy[:, 1] * math.sin(a)
        across = -xy[:, 0] * math.sin(a) + xy[:, 1] * math.cos(a)
        r = np.floor(across / _LINE_BIN).astype(np.int64)
        t = np.floor(along / _LINE_BIN).astype(np.int64)
        r -= r.min()
        t -= t.min()
        span = int(t.max()) + 1
        cells = np.unique(r * span + t)  # occupied (offset, along) bins, sorted
        cr, ct = cells // span, cells % span
        # runs of occupied bins along one offset, gaps of up to _LINE_GAP bins bridged (a far edge
        # crosses the rows of cells sparsely)
        start = np.ones(len(cells), bool)
        start[1:] = (cr[1:] != cr[:-1]) | (ct[1:] - ct[:-1] > _LINE_GAP + 1)
        run = np.cumsum(start) - 1
        first = ct[start]
        last = np.zeros(int(run[-1]) + 1, np.int64)
        last[run] = ct  # the last write of each run is its largest bin
        out[phi] = float((last - first + 1).max()) * _LINE_BIN

    for phi in range(0, 180, 2):  # every other degree, then every degree round the longest
        measure(phi)
    best = int(np.argmax(out))
    for phi in range(best - 11, best + 12):
        if phi % 2:
            measure(phi % 180)
    return out


def _along_line(phi: float, top: float, pairs: _PairCue, none: np.ndarray, evidence):
    """The direction of best ``evidence`` (its score, azimuth, elevation, info) whose azimuth lies
    along a straight shadow edge (``phi`` or ``phi + 180``, within 4 degrees) and whose shading
    gain is within :data:`LINE_MARGIN` of the best (``top``) and whose evidence is positive; None
    if there is none. Elevations every 10 degrees, then 2.5 and 5 degrees either side of the best."""
    best = None

    def consider(a: float, e: float) -> None:
        nonlocal best
        if _pair_fit(pairs, none, a, e)[0] < top - LINE_MARGIN:
            return
        score, info = evidence(a, e)
        if score > (0.0 if best is None else best[0]):
            best = (score, a, e, info)

    for a0 in (phi, phi + 180.0):
        for a in a0 + np.arange(-4.0, 4.1, 2.0):
            for e in np.arange(10.0, 80.1, 10.0):
                consider(float(a % 360.0), float(e))
    if best is not None:
        a, e = best[1], best[2]
        for de in (-5.0, -2.5, 2.5, 5.0):
            consider(a, float(np.clip(e + de, 8.0, 85.0)))
    return best


# ============================================================== the estimate
def estimate_lighting(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera,
                      work_width: int = 700) -> LightEstimate:
    """Estimate the light of one photo.

    rgb (H, W, 3) uint8 sRGB; label_ids (H, W) uint8 Cityscapes ids (or labels found from the
    geometry); depth (H, W) float metres, inf where unknown; ``camera`` the frame's camera.
    Deterministic: the same inputs give the same estimate.
    """
    smooth, sigma_d = smoothing_for(depth, label_ids, camera)
    g = _grid(rgb, label_ids, depth, camera, work_width, smooth)
    occ = _Occluders.build(g, label_ids, depth, camera)
    shadow = _shadow_cue(g, occ, camera)
    pairs = _pair_cue(g)
    mix = _mixture(shadow) if shadow is not None else None
    none, gm_none = _pair_none(pairs) if pairs is not None else (None, 0.3)
    cues: dict = {"grid": [int(g.lum.shape[1]), int(g.lum.shape[0])], "stereo_sigma_px": sigma_d,
                  "depth_smoothing_cells": smooth,
                  "ground_samples": 0 if shadow is None else int(len(shadow.rel)),
                  "shading_pairs": 0 if pairs is None else int(len(pairs.y))}
    entropy = 0.05
    if mix is not None:
        cues.update({"ground_two_levels_gain": mix.gain, "ground_shadow_log_ratio": mix.delta,
                     "ground_shadow_share": mix.share})
        q = float(np.clip(mix.share, 1e-3, 1 - 1e-3))
        entropy = max(-(q * math.log(q) + (1 - q) * math.log(1 - q)), 0.05)

    def evidence(az: float, el: float) -> tuple[float, dict]:
        # shading gain (nats per pair) plus the geometric shadow agreement in units of what a
        # perfect prediction would score (the entropy of the shadowed share), weakly
        sd = 0.0
        if shadow is not None:
            sd = _shadow_score(shadow, mix, *shadow.shadowed(az, el)) / entropy
        sh, k, gm = 0.0, 1.0, gm_none
        if pairs is not None:
            sh, k, gm = _pair_fit(pairs, none, az, el)
        return sh + SHADOW_AGREEMENT_WEIGHT * sd, {
            "shadow_agreement": sd, "shading_gain": sh, "shading_sky_share": k, "shading_ground_ratio": gm}

    # coarse grid on the shading alone; the best few directions, and a finer grid around the
    # best of them, with the shadow agreement too
    coarse = []
    for az in np.arange(0.0, 360.0, 15.0):
        for el in (15.0, 25.0, 35.0, 45.0, 55.0, 65.0, 78.0):
            coarse.append((_pair_fit(pairs, none, az, el)[0] if pairs is not None else 0.0, float(az), el))
    coarse.sort(key=lambda t: -t[0])
    best = (-np.inf, 0.0, 45.0, {})
    for _, az, el in coarse[:6]:
        e, info = evidence(az, el)
        if e > best[0]:
            best = (e, az, el, info)
    _, az0, el0, _ = best
    for az in az0 + np.arange(-10.0, 10.1, 5.0):
        for el in np.clip(el0 + np.arange(-8.0, 8.1, 4.0), 8.0, 85.0):
            e, info = evidence(float(az % 360.0), float(el))
            if e > best[0]:
                best = (e, float(az % 360.0), float(el), info)
    score, az, el, info = best
    cues.update(info)
    cues["direction_score"] = score

    # Is there a sun? Cast shadows on the ground say so reliably; without them, only a clear
    # shading sun that leaves the ground in view lit (module docstring).
    strength = 0.0
    two_levels = False
    if mix is not None:
        two_levels = bool(mix.gain >= MIN_TWO_LEVEL_GAIN and mix.delta <= MAX_SHADOW_LOG_RATIO
                          and 0.01 <= mix.share <= 0.95 and mix.share * len(mix.posterior) >= 25)
        strength = float(np.clip(mix.gain / 0.25, 0, 1) * np.clip((-mix.delta - 0.2) / 0.5, 0, 1))
        if not 0.01 <= mix.share <= 0.95:
            strength = 0.0
    line_sun = None
    if two_levels and pairs is not None:
        # a straight shadow edge off the street's axes runs along the sun's azimuth: it decides
        # between directions the shading barely tells apart
        phi, length = _shadow_line(g, camera, shadow, mix)
        cues["shadow_line"] = [phi, length]
        if length >= LINE_MIN_LENGTH:
            line_sun = _along_line(phi, coarse[0][0], pairs, none, evidence)
    if line_sun is not None:
        score, az, el, info = line_sun
        cues.update(info)
        cues["direction_score"] = score
    cues["shadow_line_sun"] = line_sun is not None
    sunny = bool(two_levels and score > 0.0)
    # without two levels, a sun may still show: tried in turn, a shading sun that leaves all the
    # ground in view lit, the casters' shadows, a shading sun that leaves it all in shadow
    lit_ground = cast = shaded = None
    if not two_levels and shadow is not None and pairs is not None:
        lit_ground = _lit_ground_sun(shadow, pairs, none, coarse)
    if not two_levels and lit_ground is None and shadow is not None \
            and np.mean(shadow.rel > -MAX_SHADOW_LOG_RATIO) <= CASTER_MAX_BRIGHT:
        casters = _caster_cue(g, camera)
        if casters is not None:
            cast = _caster_sun(casters, coarse)
    if not two_levels and lit_ground is None and cast is None and shadow is not None and pairs is not None:
        shaded = _shaded_ground_sun(shadow, pairs, none, coarse)
    if lit_ground is not None or shaded is not None:
        # the shading shows a sun (and the ground in view all lit, or all in shadow)
        sunny = True
        gain, az, el, k, gm = lit_ground or shaded
        info = {"shadow_agreement": 0.0, "shading_gain": gain, "shading_sky_share": k, "shading_ground_ratio": gm}
        cues.update(info)
        strength = float(np.clip((gain - LIT_GROUND_MIN_GAIN) / LIT_GROUND_MIN_GAIN, 0, 1))
    if cast is not None:
        # the casters in view throw their shadows where that sun puts them
        sunny = True
        agreement, az, el, cast_step = cast
        gain, k, gm = _pair_fit(pairs, none, az, el) if pairs is not None else (0.0, math.exp(cast_step), gm_none)
        info = {"shadow_agreement": 0.0, "shading_gain": gain, "shading_sky_share": k, "shading_ground_ratio": gm}
        cues.update(info)
        cues["caster_agreement"] = agreement
        strength = float(np.clip(agreement / (2 * CASTER_MIN_AGREEMENT), 0, 1))
    cues["lit_ground_sun"] = lit_ground is not None
    cues["caster_sun"] = cast is not None
    cues["shaded_ground_sun"] = shaded is not None
    if not sunny:
        delta = 0.0
    elif lit_ground is not None or shaded is not None:  # a shadow's step: the sky's share of the light
        delta = math.log((lit_ground or shaded)[3])
    elif cast is not None:  # the casters' shadows against the lit ground around them
        delta = cast[3]
    else:
        delta = _core_step(shadow, mix)
    cues["ground_shadow_core_log_ratio"] = delta
    sun_fraction = float(np.clip(1.0 - math.exp(delta), 0.0, 0.95)) if sunny else 0.0
    confidence = strength if sunny else ((1.0 - strength) if mix is not None else 0.3)
    cues["shadow_evidence"] = strength

    # colours, levels and exposure from the ground (grey world)
    sky_rgb = sun_rgb = ground_rgb = np.ones(3)
    exposure, levels = 1.0, ()
    if shadow is not None:
        in_shadow = mix.posterior > 0.5 if sunny and lit_ground is None and cast is None and shaded is None \
            else np.zeros(len(shadow.rel), bool)
        lo, hi = np.quantile(shadow.rel, [0.03, 0.9])
        typical = (shadow.rel >= lo) & (shadow.rel <= hi)  # not markings, not deep holes
        lit = ~in_shadow & typical
        # under a shaded-ground sun all the ground is in shadow: its lit levels are the shadow's
        # over the sky's share
        lit_scale = 1.0 if shaded is None else 1.0 / shaded[3]
        lit_col = _class_mean(shadow, lit)
        ground_rgb = _unit(lit_col)
        if in_shadow.sum() >= 10:
            shade_col = _class_mean(shadow, in_shadow & typical)
            sky_rgb = _unit(shade_col)
            # lit / shadow of the same surfaces, per channel, = 1 + sun / sky
            ratio = _class_ratio(shadow, lit, in_shadow & typical)
            sun_rgb = _unit(np.maximum(sky_rgb * (ratio - 1.0), 1e-3))
        else:
            sky_rgb = sun_rgb = ground_rgb
        levels = tuple((int(k), lit_scale * float(np.median(shadow.lin[lit & (shadow.cls == k)] @ LUM)))
                       for k in np.unique(shadow.cls) if (lit & (shadow.cls == k)).sum() >= 20)
        exposure, reference = _exposure(shadow, lit, lit_scale)
        cues["exposure_reference"] = reference
    sky = g.pure & (g.label == SKY_ID)
    evidence = tuple(name for name, cue in (("ground", shadow), ("shading", pairs)) if cue is not None)
    if sky.sum() >= 50:
        evidence += ("sky",)
        cues["sky_pixels_linear_rgb"] = [float(v) for v in g.lin[sky].mean(axis=0)]
        if shadow is None:  # no ground in view: the sky's colour
            sky_rgb = sun_rgb = ground_rgb = _unit(g.lin[sky].mean(axis=0))
    return LightEstimate(
        sunny=sunny, sun_azimuth_deg=float(az % 360.0), sun_elevation_deg=float(el), sun_fraction=sun_fraction,
        sky_rgb=tuple(float(v) for v in sky_rgb), sun_rgb=tuple(float(v) for v in sun_rgb),
        ground_rgb=tuple(float(v) for v in ground_rgb), ground_ratio=float(info["shading_ground_ratio"]),
        exposure=float(exposure), confidence=float(confidence), ground_levels=levels,
        shadow_log_ratio=float(delta) if sunny else 0.0, ground_shadowed=shaded is not None, evidence=evidence,
        cues=cues)


def _lit_ground_sun(shadow: _ShadowCue, pairs: _PairCue, none: np.ndarray, coarse: list):
    """A sun for ground without cast shadows in view: (shading gain, azimuth, elevation, sky
    share, ground ratio), or None. Only where the shading shows a clear sun (gain >=
    :data:`LIT_GROUND_MIN_GAIN`) and its best direction, within :data:`LIT_GROUND_MARGIN`, is one
    for which the geometry predicts none of the ground samples it can tell about (at least
    :data:`LIT_GROUND_KNOWN` of them) in shadow: then no shadow is expected in view. Failing
    that, one for which the geometry can hardly tell (the sun behind the camera) and sees no
    shadow, whose sunlit shading pairs reach down to the ground (:func:`_lit_pairs_low`): the
    sun reaches the feet of what stands in view. A best direction that puts the ground in view
    in shadow means ambient light only (module docstring)."""

    def lit(az: float, el: float) -> bool:  # the geometry tells, and sees no shadow
        shadowed, known = shadow.shadowed(az, el)
        return known.mean() >= LIT_GROUND_KNOWN and shadowed[known].mean() <= 0.05

    def lit_unseen(az: float, el: float) -> bool:
        # the geometry cannot tell (the sun behind the camera; no seen sample predicted in
        # shadow): the sunlit pairs reach down to the ground
        shadowed, known = shadow.shadowed(az, el)
        if known.mean() >= LIT_GROUND_KNOWN or (known.any() and shadowed[known].mean() > 0.05):
            return False
        return _lit_pairs_low(pairs, none, az, el) <= LIT_PAIRS_LOW

    return _shading_sun(pairs, none, coarse, (lit, lit_unseen))


def _shaded_ground_sun(shadow: _ShadowCue, pairs: _PairCue, none: np.ndarray, coarse: list):
    """A sun whose light does not reach the ground in view (low beyond the buildings on its
    side): (shading gain, azimuth, elevation, sky share, ground ratio), or None. Only for ground
    of one level that the other rules left: the shading shows a clear sun (gain >=
    :data:`LIT_GROUND_MIN_GAIN`) whose best direction, within :data:`LIT_GROUND_MARGIN`, lights
    no pair near the ground (:func:`_lit_pairs_low` above :data:`LIT_PAIRS_LOW`) and no ground
    sample the geometry can tell about."""

    def shaded(az: float, el: float) -> bool:
        shadowed, known = shadow.shadowed(az, el)
        if (known & ~shadowed).mean() > 0.05:  # the geometry sees ground it lights
            return False
        return _lit_pairs_low(pairs, none, az, el) > LIT_PAIRS_LOW

    return _shading_sun(pairs, none, coarse, (shaded,))


def _shading_sun(pairs: _PairCue, none: np.ndarray, coarse: list, tests):
    """A clear shading sun that passes a test: the best coarse direction (gain, azimuth,
    elevation; best first) within :data:`LIT_GROUND_MARGIN` of the best and at least
    :data:`LIT_GROUND_MIN_GAIN` that passes the first test any passes, refined on a 5 degree grid
    among the directions passing that test: (gain, azimuth, elevation, sky share, ground ratio),
    or None."""
    top = coarse[0][0]
    if top < LIT_GROUND_MIN_GAIN:
        return None
    margin = [c for c in coarse if c[0] >= max(LIT_GROUND_MIN_GAIN, top - LIT_GROUND_MARGIN)]
    for test in tests:
        found = next(((gain, az0, el0) for gain, az0, el0 in margin if test(az0, el0)), None)
        if found is not None:
            break
    if found is None:
        return None
    best = found
    _, az0, el0 = found
    for az in az0 + np.arange(-10.0, 10.1, 5.0):
        for el in np.clip(el0 + np.arange(-8.0, 8.1, 4.0), 8.0, 85.0):
            gain = _pair_fit(pairs, none, float(az % 360.0), float(el))[0]
            if gain > best[0] and test(float(az % 360.0), float(el)):
                best = (gain, float(az % 360.0), float(el))
    gain, k, gm = _pair_fit(pairs, none, best[1], best[2])
    return gain, best[1], best[2], k, gm


def _lit_pairs_low(pairs: _PairCue, none: np.ndarray, az: float, el: float) -> float:
    """Height (m) of the lowest tenth of the pairs that the sun from (az, el) lights (its model
    explains them clearly better than ambient light, and it makes their two ends differ): near 0
    when the sun reaches the feet of the walls and cars, so the ground around them; higher when
    the ground in view lies in the shadow of what stands beyond it (inf without such pairs)."""
    _, k, gm = _pair_fit(pairs, none, az, el)
    t = pairs.terms
    i, j = int(np.argmin(np.abs(_KS - k))), int(np.argmin(np.abs(_GAMMAS - gm)))
    s1, s2 = _pair_sun(t, az, el)
    ambient = np.log(t["kh1"][i, j] / t["kh2"][i, j])
    sun = np.log((t["kh1"][i, j] + (1 - k) * s1) / (t["kh2"][i, j] + (1 - k) * s2))
    lit = (np.abs(sun - ambient) > 0.4) & (_rho(t["y"] - sun) + 0.5 < none)
    return float(np.quantile(pairs.z[lit], 0.1)) if lit.sum() >= 20 else math.inf


def _core_step(cue: _ShadowCue, mix: _Mixture) -> float:
    """log(shadow / lit) from the samples the mixture is sure of (median of each class's
    shadow core minus median of its lit core): cells straddling a shadow's edge, half lit,
    would pull the mixture's mean step towards 0."""
    steps, weights = [], []
    for k in np.unique(cue.cls):
        sh = (cue.cls == k) & (mix.posterior > 0.9)
        lit = (cue.cls == k) & (mix.posterior < 0.1)
        if sh.sum() >= 10 and lit.sum() >= 10:
            steps.append(float(np.median(cue.rel[sh]) - np.median(cue.rel[lit])))
            weights.append(min(int(sh.sum()), int(lit.sum())))
    return float(np.average(steps, weights=weights)) if steps else mix.delta


def _class_mean(cue: _ShadowCue, mask: np.ndarray) -> np.ndarray:
    """Mean linear colour over the samples in ``mask``, each class scaled to its own luminance
    (so that a bright sidewalk and a dark road weigh alike)."""
    acc, wsum = np.zeros(3), 0.0
    for k in np.unique(cue.cls[mask]):
        sel = mask & (cue.cls == k)
        c = cue.lin[sel].mean(axis=0)
        y = float(c @ LUM)
        if y > 1e-6:
            acc += c / y * sel.sum()
            wsum += sel.sum()
    return acc / wsum if wsum else np.ones(3)


def _class_ratio(cue: _ShadowCue, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3,) per-channel ratio of the mean colours of samples ``a`` over samples ``b``, within
    each class (same albedo), averaged over the classes in log."""
    logs, weights = [], []
    for k in np.unique(cue.cls):
        sa, sb = a & (cue.cls == k), b & (cue.cls == k)
        if sa.sum() >= 10 and sb.sum() >= 10:
            logs.append(np.log(np.maximum(cue.lin[sa].mean(axis=0), 1e-6) / np.maximum(cue.lin[sb].mean(axis=0), 1e-6)))
            weights.append(min(int(sa.sum()), int(sb.sum())))
    return np.exp(np.average(logs, axis=0, weights=weights)) if logs else np.ones(3)


def _exposure(cue: _ShadowCue, mask: np.ndarray, scale: float = 1.0) -> tuple[float, str]:
    """Irradiance of lit ground from the samples in ``mask`` (their luminance times ``scale``)
    against the typical albedo of road, else sidewalk; and which of them."""
    for cls, albedo, name in ((ROAD_ID, ROAD_ALBEDO, "road"), (SIDEWALK_ID, SIDEWALK_ALBEDO, "sidewalk")):
        sel = mask & (cue.cls == cls)
        if sel.sum() >= 100:
            y = scale * float(np.median(cue.lin[sel] @ LUM))
            return float(np.clip(y / albedo, *EXPOSURE_RANGE)), name
    return 1.0, "none"


# ============================================================== compare-lighting
def _label(img: np.ndarray, text: str) -> np.ndarray:
    """The image with a caption bar on top."""
    h, w = img.shape[:2]
    scale = max(w / 1400.0, 0.45)
    bar = np.full((int(34 * scale) + 8, w, 3), 24, np.uint8)
    cv2.putText(bar, text, (8, bar.shape[0] - int(10 * scale) - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.8 * scale,
                (235, 235, 235), max(1, int(round(1.6 * scale))), cv2.LINE_AA)
    return np.concatenate([bar, img], axis=0)


def _describe(record: dict) -> str:
    lt = record.get("lighting", {})
    if lt.get("mode") == "estimate":
        if lt.get("sunny"):
            return (f"estimated: sun az {lt['sun_azimuth_deg']:.0f} el {lt['sun_elevation_deg']:.0f} deg, "
                    f"{100 * lt['sun_fraction']:.0f}% sun{', the ground in shadow' if lt.get('ground_shadowed') else ''}, "
                    f"confidence {lt['confidence']:.2f}")
        return f"estimated: no sun (ambient only), confidence {lt['confidence']:.2f}"
    d = lt.get("sun_direction", [0, 0, 1])
    el = math.degrees(math.asin(max(-1.0, min(1.0, d[2]))))
    return f"fixed: sun az {math.degrees(math.atan2(d[1], d[0])):.0f} el {el:.0f} deg"


def compare_lighting(manifest, out_dir, limit: int | None = None) -> list[dict]:
    """For each image set the manifest selects (at most ``limit``): run the pipeline with the
    fixed light (the manifest's, or the default daylight) and with the estimated light - same
    placement, same seed - and write under ``out_dir``:

    * ``<frame>_fixed_vs_estimated.png`` : output with the fixed light | with the estimated light
    * ``<frame>_before_after.png``       : input | output with the estimated light
    * ``<frame>_zoom.png``               : input | fixed | estimated, cropped around the objects

    The two full outputs go to ``out_dir/fixed`` and ``out_dir/estimated``. Returns one entry
    per image set (its status and the PNGs written).
    """
    from dataclasses import replace
    from pathlib import Path

    from .batch import select
    from .fileio import read_json, read_png, write_png
    from .pipeline import Pipeline

    out_dir = Path(out_dir).resolve()
    ids, weights, _ = select(manifest)
    ids = ids[:limit] if limit else ids
    sun_keys = ("sun_elevation_deg", "sun_azimuth_deg", "sun_fraction")
    given = manifest.raw.get("lighting", {})
    fixed_raw = {"mode": "fixed", **{k: given[k] for k in sun_keys if k in given}}
    keep = {k: given[k] for k in ("camera_match",) if k in given}
    variants = {
        "fixed": replace(manifest, output=out_dir / "fixed", lighting_mode="fixed",
                         raw={**manifest.raw, "lighting": {**fixed_raw, **keep}}),
        "estimated": replace(manifest, output=out_dir / "estimated", lighting_mode="estimate",
                             raw={**manifest.raw, "lighting": {"mode": "estimate", **keep}}),
    }
    for name, m in variants.items():
        with Pipeline(m, weights) as pipe:
            for ident in ids:
                pipe.process(ident)
    results = []
    for ident in ids:
        entry: dict = {"image_set": ident.key, "written": []}
        records = {name: ident.path(m.output, "record") for name, m in variants.items()}
        if not all(p.is_file() for p in records.values()):
            entry["status"] = "failed"
            results.append(entry)
            continue
        rec = {name: read_json(p) for name, p in records.items()}
        entry["status"] = rec["estimated"].get("status")
        if entry["status"] != "done":
            results.append(entry)
            continue
        src = read_png(ident.path(manifest.dataset, "rgb"), "rgb8")
        out = {name: read_png(ident.path(m.output, "rgb"), "rgb8") for name, m in variants.items()}
        name = ident.key.replace("/", "_")
        pairs = {
            "fixed_vs_estimated": (_label(out["fixed"], "fixed light - " + _describe(rec["fixed"])),
                                   _label(out["estimated"], _describe(rec["estimated"]))),
            "before_after": (_label(src, "input"), _label(out["estimated"], "output, " + _describe(rec["estimated"]))),
        }
        changed = np.any(out["estimated"] != src, axis=2) | np.any(out["fixed"] != src, axis=2)
        ys, xs = np.nonzero(changed)
        if len(xs):
            h, w = src.shape[:2]
            pad = 40
            x0, x1 = max(int(xs.min()) - pad, 0), min(int(xs.max()) + pad + 1, w)
            y0, y1 = max(int(ys.min()) - pad, 0), min(int(ys.max()) + pad + 1, h)
            zoom = 2 if (x1 - x0) < w / 3 else 1
            crop = [cv2.resize(a[y0:y1, x0:x1], None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)
                    for a in (src, out["fixed"], out["estimated"])]
            pairs["zoom"] = tuple(_label(c, t) for c, t in zip(crop, ("input", "fixed", "estimated")))
        for kind, imgs in pairs.items():
            path = out_dir / f"{name}_{kind}.png"
            gap = np.full((imgs[0].shape[0], 6, 3), 255, np.uint8)
            row = [imgs[0]]
            for img in imgs[1:]:
                row += [gap, img]
            write_png(path, np.concatenate(row, axis=1))
            entry["written"].append(str(path))
        entry["lighting"] = rec["estimated"]["lighting"]
        results.append(entry)
    return results
