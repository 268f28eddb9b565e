"""The light of one photo (:class:`LightEstimate`), its record, and the constants the cues share."""
from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field

import cv2
import numpy as np

from synthcompose.colour import LUM as _LUM
from synthcompose.colour import SRGB8_TO_LINEAR
from synthcompose.labels import category_ids, label_ids

LUM = _LUM  # Rec. 709 luminance weights of linear RGB
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

GROUND_IDS = label_ids("ground", "road", "sidewalk", "parking", "rail track")
ROAD_ID, SIDEWALK_ID, SKY_ID = label_ids("road", "sidewalk", "sky")
#: things standing on the ground that cast shadows (static, dynamic, constructions, objects,
#: vegetation, humans, vehicles)
OCCLUDER_IDS = tuple(sorted(label_ids("static", "dynamic", "vegetation")
                            + category_ids("construction", "object", "human", "vehicle")))
#: surface classes whose albedo is locally constant enough for the shading pairs
SHADING_IDS = label_ids("road", "sidewalk", "building", "wall", "fence", "guard rail", "pole", "traffic light",
                        "traffic sign", "car", "truck", "bus", "caravan", "trailer", "train")
FINE_IDS = tuple(i for i in SHADING_IDS if i not in GROUND_IDS)

LEVEL_LUT = SRGB8_TO_LINEAR


@dataclass(frozen=True)
class Lighting:
    """Light in the frame's vehicle coordinates, linear RGB, scaled so that an up-facing,
    unshadowed surface receives ``sky_rgb + sun_rgb * sun_direction.z`` (1.0 by default)."""

    sun_direction: tuple[float, float, float]
    sun_rgb: tuple[float, float, float]
    sky_rgb: tuple[float, float, float]
    ground_rgb: tuple[float, float, float]

    @classmethod
    def daylight(cls, elevation_deg: float = 50.0, azimuth_deg: float = 135.0,
                 sun_fraction: float = 0.35) -> "Lighting":
        """Overcast-leaning daylight; ``sun_fraction`` of up-facing light comes from the sun."""
        el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
        d = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
        sun = sun_fraction / max(d[2], 0.05)
        sky = 1.0 - sun_fraction
        return cls(d, (sun,) * 3, (sky,) * 3, (0.25 * sky,) * 3)

    def to_dict(self) -> dict:
        return {k: list(getattr(self, k)) for k in ("sun_direction", "sun_rgb", "sky_rgb", "ground_rgb")}


def unit_vector(c) -> np.ndarray:
    """Colour scaled to luminance 1 (neutral when it has none)."""
    c = np.maximum(np.asarray(c, np.float64), 1e-6)
    y = float(c @ LUM)
    return c / y if y > 1e-6 else np.ones(3)


def sun_direction_of(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def round_to(v, nd: int = 4):
    if isinstance(v, dict):
        return {str(k): round_to(x, nd) for k, x in v.items()}
    if isinstance(v, (list, tuple, np.ndarray)):
        return [round_to(x, nd) for x in v]
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
        return tuple(float(v) for v in sun_direction_of(self.sun_azimuth_deg, self.sun_elevation_deg))

    @property
    def sky_share(self) -> float:
        """Share of an up-facing unshadowed surface's irradiance from the sky (1 overcast)."""
        return 1.0 - self.sun_fraction

    def to_lighting(self, exposure: float = 1.0) -> Lighting:
        """The renderer's light: an up-facing unshadowed surface gets ``exposure`` (luminance);
        1 is the :class:`Lighting` convention, ``self.exposure`` matches the photo's brightness."""
        f = self.sun_fraction if self.sunny else 0.0
        sky = exposure * (1.0 - f) * unit_vector(self.sky_rgb)
        ground = exposure * self.ground_ratio * (1.0 - f) * unit_vector(self.ground_rgb)
        # without a sun its direction only sizes the ground planes for shadows: straight up
        d = sun_direction_of(self.sun_azimuth_deg, self.sun_elevation_deg) if self.sunny else np.array([0.0, 0.0, 1.0])
        sun = exposure * f / max(d[2], 0.05) * unit_vector(self.sun_rgb)
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
        luminance smoothed over 5x5 pixels), of every unlabelled one (id 0) against the road's
        level, 1 elsewhere; None when not sunny."""
        if not self.sunny or self.shadow_log_ratio >= 0 or not self.ground_levels:
            return None
        mask = np.ones(label_ids.shape, np.float32)
        if self.ground_shadowed:
            mask[np.isin(label_ids, GROUND_IDS)] = 0.0
            return mask
        lum = cv2.blur(LEVEL_LUT[rgb] @ LUM.astype(np.float32), (5, 5))
        levels = dict(self.ground_levels)
        for label, level in self.ground_levels:
            sel = label_ids == label
            mask[sel] = self._ramp(np.log(np.maximum(lum[sel], 1e-6)), level)
        # pixels no label names (a frame without labels: no disparity - the left image's border
        # the right camera does not see - or ground the surfaces left out) are read against the
        # road's level: an inserted shadow falls on them only where they are lit, not in full
        # wherever the labels stop (a shadow cut along the disparity's straight border, specks
        # in the found road's holes)
        if ROAD_ID in levels:
            sel = label_ids == 0
            mask[sel] = self._ramp(np.log(np.maximum(lum[sel], 1e-6)), levels[ROAD_ID])
        return mask

    def to_dict(self) -> dict:
        """JSON-ready record of the estimate."""
        return {
            "mode": "estimate",
            "sunny": self.sunny,
            "sun_azimuth_deg": round_to(self.sun_azimuth_deg, 1), "sun_elevation_deg": round_to(self.sun_elevation_deg, 1),
            "sun_fraction": round_to(self.sun_fraction, 3), "sky_share": round_to(self.sky_share, 3),
            "sky_rgb": round_to(self.sky_rgb), "sun_rgb": round_to(self.sun_rgb), "ground_rgb": round_to(self.ground_rgb),
            "ground_ratio": round_to(self.ground_ratio, 3), "exposure": round_to(self.exposure, 3),
            "confidence": round_to(self.confidence, 3),
            "ground_levels": {str(k): round_to(v, 5) for k, v in self.ground_levels},
            "shadow_log_ratio": round_to(self.shadow_log_ratio, 3), "ground_shadowed": self.ground_shadowed,
            "evidence": list(self.evidence), "fallback": not self.evidence,
            "cues": round_to(self.cues),
        }


def fixed_record(lighting: Lighting, **params) -> dict:
    """The record of a fixed (manifest) light: the manifest's keys and the light they give."""
    return {**{k: v for k, v in params.items() if v is not None}, "mode": "fixed", **lighting.to_dict()}


def camera_noise_seed(seed: int, key: str) -> int:
    """Seed of the camera-match noise of one image set: a function of (seed, image set) only."""
    return int(np.random.default_rng([int(seed), zlib.crc32(key.encode()), 0x6E6F6973]).integers(2**31))
