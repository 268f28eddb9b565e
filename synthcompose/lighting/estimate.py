"""The estimate: the cues weighed into one :class:`LightEstimate` (see the package's doc)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.camera import Camera

from . import lines, plansun
from .casters import CASTER_MAX_BRIGHT, CASTER_MIN_AGREEMENT, caster_cue, sun_from_casters
from .colours import ground_colours
from .grid import make_grid, smoothing_for
from .ground_suns import lit_ground_sun, shaded_ground_sun
from .light import (
    EXPOSURE_RANGE,
    LIT_GROUND_MIN_GAIN,
    MAX_SHADOW_LOG_RATIO,
    MIN_TWO_LEVEL_GAIN,
    ROAD_ALBEDO,
    ROAD_ID,
    SHADOW_AGREEMENT_WEIGHT,
    SKY_ID,
    LightEstimate,
    unit_vector,
)
from .lines import along_line, find_shadow_line
from .pairs import PairCue, pair_cue, pair_fit, pair_none
from .plan import completed_labels
from .shadows import Mixture, Occluders, ShadowCue, fit_mixture, shadow_cue, shadow_score
from .solar import SunSite

#: the sun's elevation (degrees, at least) when the ground's shadows show a sun but no cue its
#: direction
UNSURE_ELEVATION = 70.0
#: without shading pairs to confirm them, two ground levels mean a sun only this clearly (the
#: strength: gain and depth of the shadow step, 0..1); weaker ones are dark paving, wet patches
UNCONFIRMED_STRENGTH = 0.3


def estimate_lighting(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera,
                      work_width: int = 700, labelled: bool = True,
                      completed: np.ndarray | None = None, site: SunSite | None = None) -> LightEstimate:
    """Estimate the light of one photo.

    rgb (H, W, 3) uint8 sRGB; label_ids (H, W) uint8 Cityscapes ids (or, ``labelled`` False,
    the surfaces found from the geometry: completed here with the level ground and what stands
    on it, :func:`~.plan.completed_labels`); depth (H, W) float metres, inf where unknown;
    ``camera`` the frame's camera; ``completed``: those completed labels where the caller has
    them already; ``site``: where the photo was taken and which way the camera points (its
    vehicle file, :class:`~.solar.SunSite`), which bounds where the sun can stand
    (:func:`.plansun.direction`). The completed labels serve the ground plan (:mod:`.plansun`) only: the other
    cues keep the found surfaces (on the completed ones their two-level and shading cues called
    3 of 7 overcast street frames sunny, on the found ones 1).
    Deterministic: the same inputs give the same estimate.
    """
    if completed is None:
        completed = label_ids if labelled else completed_labels(label_ids, depth, camera)
    smooth, sigma_d = smoothing_for(depth, label_ids, camera)
    g = make_grid(rgb, label_ids, depth, camera, work_width, smooth)
    c = _Cues.measure(g, label_ids, depth, camera)
    cues: dict = {"grid": [int(g.lum.shape[1]), int(g.lum.shape[0])], "stereo_sigma_px": sigma_d,
                  "depth_smoothing_cells": smooth,
                  "ground_samples": 0 if c.shadow is None else int(len(c.shadow.rel)),
                  "shading_pairs": 0 if c.pairs is None else int(len(c.pairs.y))}
    if c.mix is not None:
        cues.update({"ground_two_levels_gain": c.mix.gain, "ground_shadow_log_ratio": c.mix.delta,
                     "ground_shadow_share": c.mix.share})
    coarse = c.coarse()
    sun = _two_level_sun(g, camera, c, coarse, cues)
    _other_suns(g, camera, c, coarse, cues, sun)
    # the shadow edges on the ground plan: where they show a sun, they decide, and the sun lies
    # along their directions (plansun)
    ps, _, _ = plansun.measure(rgb, completed, depth, camera, labelled)
    cues["plan"] = ps.to_dict()
    plan_dir = None
    if ps.sunny:  # its casters: what stands, labelled or found from the depth
        cg = g if labelled else make_grid(rgb, completed, depth, camera, work_width, smooth)
        plan_dir = plansun.direction(ps, caster_cue(cg, camera), c.evidence, site)
    if plan_dir is not None:
        _plan_sun(c, cues, sun, ps, plan_dir, site)
    delta = _shadow_step(c, sun, ps, plan_dir)
    cues["ground_shadow_core_log_ratio"] = delta
    if sun.sunny and not cues["sun_direction_sure"] and not sun.one_level:
        # the shadows show a sun but nothing shows where (the plan's edges give an axis, but no
        # caster its side and height): a high sun, whose shadow falls short and under the
        # object, is the least wrong guess (a shadow thrown the wrong way is seen)
        sun.el = max(sun.el, UNSURE_ELEVATION)
        if site is not None:  # the side of the axis where the sun can stand highest
            sun.az = unsure_side(site, sun.az)
            cues["sun_side_by_site"] = True
    if sun.sunny and site is not None:  # never higher than the sun stands there on any day
        there = site.elevations(sun.az)
        if len(there):
            sun.el = float(np.clip(sun.el, there.min(), there.max()))
        cues["site"] = {"latitude": site.latitude, "heading": site.heading,
                        "compass_azimuth": round(site.compass(sun.az), 1),
                        "elevations": [round(float(there.min()), 1), round(float(there.max()), 1)] if len(there) else None}
    sun_fraction = float(np.clip(1.0 - math.exp(delta), 0.0, 0.95)) if sun.sunny else 0.0
    confidence = sun.strength if sun.sunny else ((1.0 - sun.strength) if c.mix is not None else 0.3)
    cues["shadow_evidence"] = sun.strength

    # colours, levels and exposure from the ground (grey world)
    sky_rgb = sun_rgb = ground_rgb = np.ones(3)
    exposure, levels = 1.0, ()
    if c.shadow is not None:
        in_shadow = c.mix.posterior > 0.5 if sun.sunny and not sun.one_level else np.zeros(len(c.shadow.rel), bool)
        # under a shaded-ground sun all the ground is in shadow: its lit levels are the shadow's
        # over the sky's share
        lit_scale = 1.0 if sun.shaded is None else 1.0 / sun.shaded[3]
        sky_rgb, sun_rgb, ground_rgb, levels, exposure, reference = ground_colours(c.shadow, in_shadow, lit_scale)
        cues["exposure_reference"] = reference
    if plan_dir is not None:  # the plan's own lit and shadowed ground
        sky_rgb, sun_rgb, ground_rgb = plansun.colours(ps, delta)
        levels = ps.levels
        road = dict(levels).get(ROAD_ID)
        if road is not None:
            exposure = float(np.clip(road / ROAD_ALBEDO, *EXPOSURE_RANGE))
    if sun.sunny:
        levels = kinds_in_shade(levels, delta)
    sky = g.pure & (g.label == SKY_ID)
    evidence = tuple(name for name, cue in (("ground", c.shadow), ("shading", c.pairs)) if cue is not None)
    if ps.edge_length > 0 and "ground" not in evidence:
        evidence += ("ground",)
    if sky.sum() >= 50:
        evidence += ("sky",)
        cues["sky_pixels_linear_rgb"] = [float(v) for v in g.lin[sky].mean(axis=0)]
        if c.shadow is None:  # no ground in view: the sky's colour
            sky_rgb = sun_rgb = ground_rgb = unit_vector(g.lin[sky].mean(axis=0))
    return LightEstimate(
        sunny=sun.sunny, sun_azimuth_deg=float(sun.az % 360.0), sun_elevation_deg=float(sun.el),
        sun_fraction=sun_fraction, sky_rgb=tuple(float(v) for v in sky_rgb), sun_rgb=tuple(float(v) for v in sun_rgb),
        ground_rgb=tuple(float(v) for v in ground_rgb), ground_ratio=float(sun.info["shading_ground_ratio"]),
        exposure=float(exposure), confidence=float(confidence), ground_levels=levels,
        shadow_log_ratio=float(delta) if sun.sunny else 0.0, ground_shadowed=sun.shaded is not None,
        evidence=evidence, cues=cues)


def kinds_in_shade(levels, log_ratio: float) -> tuple:
    """The ground kinds' lit levels ((label id, linear luminance), ...) as the sun mask reads
    them, where the sun's shadow is ``log_ratio`` (log(shadow / lit)) under it: a kind measured
    darker than the road's shadow lies in shadow, and its lit level is put that step above it.

    No paving, verge or parking is darker than the asphalt beside it in the shade. Where both
    are sunlit, the development frames' footways are 0.9-1.6 times as bright as their road
    (leverkusen_000031, 32, 34, 35, 47); those measured below the road's shadow, 0.14-0.39 of
    its lit level (000033, 38, 41, 50, 55, 56), lie in the shade of houses or trees, the sun
    reaching only the road (000038 at full size: a footway in the houses' shade all along, 0.014
    against the road's 0.093; read as its lit level, the person standing there was sunlit and
    threw a sun shadow)."""
    road = dict(levels).get(ROAD_ID)
    if road is None or log_ratio >= 0.0:
        return tuple(levels)
    shade = road * math.exp(log_ratio)
    return tuple((k, v * math.exp(-log_ratio) if k != ROAD_ID and v < shade else v) for k, v in levels)


def unsure_side(site: SunSite, azimuth: float) -> float:
    """Where no cue tells on which side of its axis the sun stands: of ``azimuth`` and the
    opposite one, the side where the sun can stand highest at the photo's site (its shadows the
    shortest: thrown the wrong way, the least seen); ``azimuth`` where both reach as high.

    Seen from Germany a sun behind a camera heading east can stand at most ~23 degrees high late
    in the day, one ahead of it ~38 in the morning (leverkusen_000052): the fallback's 70
    degrees clipped to the side's highest gave a shadow 2.4 times its caster's height, thrown
    towards whichever side came first."""
    def highest(az: float) -> float:
        e = site.elevations(az)
        return float(e.max()) if len(e) else -1.0
    other = (azimuth + 180.0) % 360.0
    return other if highest(other) > highest(azimuth) + 0.5 else azimuth


@dataclass(frozen=True, eq=False)
class _Cues:
    """What the photo's grid gives: the ground's shadow samples and their two-level mixture, the
    shading pairs, and how well a sun from a direction explains them (:meth:`evidence`)."""

    shadow: ShadowCue | None
    pairs: PairCue | None
    mix: Mixture | None
    none: np.ndarray | None  # the pairs' misfit under ambient light alone
    gm_none: float  # their ground ratio so
    entropy: float  # of the shadowed share: what a perfect shadow prediction scores

    @classmethod
    def measure(cls, g, label_ids: np.ndarray, depth: np.ndarray, camera: Camera) -> "_Cues":
        occ = Occluders.build(g, label_ids, depth, camera)
        shadow = shadow_cue(g, occ, camera)
        pairs = pair_cue(g)
        mix = fit_mixture(shadow) if shadow is not None else None
        none, gm_none = pair_none(pairs) if pairs is not None else (None, 0.3)
        entropy = 0.05
        if mix is not None:
            q = float(np.clip(mix.share, 1e-3, 1 - 1e-3))
            entropy = max(-(q * math.log(q) + (1 - q) * math.log(1 - q)), 0.05)
        return cls(shadow, pairs, mix, none, gm_none, entropy)

    def evidence(self, az: float, el: float) -> tuple[float, dict]:
        """Shading gain (nats per pair) plus the geometric shadow agreement in units of what a
        perfect prediction would score (the entropy of the shadowed share), weakly."""
        sd = 0.0
        if self.shadow is not None:
            sd = shadow_score(self.shadow, self.mix, *self.shadow.shadowed(az, el)) / self.entropy
        sh, k, gm = 0.0, 1.0, self.gm_none
        if self.pairs is not None:
            sh, k, gm = pair_fit(self.pairs, self.none, az, el)
        return sh + SHADOW_AGREEMENT_WEIGHT * sd, {
            "shadow_agreement": sd, "shading_gain": sh, "shading_sky_share": k, "shading_ground_ratio": gm}

    def coarse(self) -> list[tuple[float, float, float]]:
        """(shading gain, azimuth, elevation) on a coarse grid of directions, best first."""
        coarse = []
        for az in np.arange(0.0, 360.0, 15.0):
            for el in (15.0, 25.0, 35.0, 45.0, 55.0, 65.0, 78.0):
                coarse.append((pair_fit(self.pairs, self.none, az, el)[0] if self.pairs is not None else 0.0,
                               float(az), el))
        coarse.sort(key=lambda t: -t[0])
        return coarse

    def best_direction(self, coarse: list) -> tuple[float, float, float, dict]:
        """(evidence, azimuth, elevation, its cues): the best few coarse directions, and a finer
        grid around the best of them, with the shadow agreement too."""
        best = (-np.inf, 0.0, 45.0, {})
        for _, az, el in coarse[:6]:
            e, info = self.evidence(az, el)
            if e > best[0]:
                best = (e, az, el, info)
        _, az0, el0, _ = best
        for az in az0 + np.arange(-10.0, 10.1, 5.0):
            for el in np.clip(el0 + np.arange(-8.0, 8.1, 4.0), 8.0, 85.0):
                e, info = self.evidence(float(az % 360.0), float(el))
                if e > best[0]:
                    best = (e, float(az % 360.0), float(el), info)
        return best


@dataclass(eq=False)
class _Sun:
    """The sun as the cues find it, step by step."""

    sunny: bool
    az: float
    el: float
    info: dict  # the cues of the direction chosen
    strength: float = 0.0  # how clearly the shadows show it, 0..1
    two_levels: bool = False  # the ground shows lit and shadowed levels
    lit_ground: tuple | None = None  # a shading sun leaving all the ground in view lit
    cast: tuple | None = None  # a sun the casters' shadows show
    shaded: tuple | None = None  # a shading sun leaving all the ground in view in shadow

    @property
    def one_level(self) -> bool:
        """The ground in view is all lit or all in shadow (one of the suns without two levels)."""
        return self.lit_ground is not None or self.cast is not None or self.shaded is not None


def _two_level_sun(g, camera: Camera, c: _Cues, coarse: list, cues: dict) -> _Sun:
    """Is there a sun? Cast shadows on the ground say so reliably; without them, only a clear
    shading sun that leaves the ground in view lit (module docstring)."""
    score, az, el, info = c.best_direction(coarse)
    cues.update(info)
    cues["direction_score"] = score
    sun = _Sun(False, az, el, info)
    mix = c.mix
    if mix is not None:
        sun.two_levels = bool(mix.gain >= MIN_TWO_LEVEL_GAIN and mix.delta <= MAX_SHADOW_LOG_RATIO
                              and 0.01 <= mix.share <= 0.95 and mix.share * len(mix.posterior) >= 25)
        sun.strength = float(np.clip(mix.gain / 0.25, 0, 1) * np.clip((-mix.delta - 0.2) / 0.5, 0, 1))
        if not 0.01 <= mix.share <= 0.95:
            sun.strength = 0.0
    line_sun = None
    if sun.two_levels and c.pairs is not None:
        # a straight shadow edge off the street's axes runs along the sun's azimuth: it decides
        # between directions the shading barely tells apart
        phi, length = find_shadow_line(g, camera, c.shadow, mix)
        cues["shadow_line"] = [phi, length]
        if length >= lines.LINE_MIN_LENGTH:
            line_sun = along_line(phi, coarse[0][0], c.pairs, c.none, c.evidence)
    if line_sun is not None:
        score, sun.az, sun.el, sun.info = line_sun
        cues.update(sun.info)
        cues["direction_score"] = score
    cues["shadow_line_sun"] = line_sun is not None
    # cast shadows on the ground say there is a sun; the shading pairs, where there are any, may
    # veto it (no direction explains them); without pairs (real stereo gives few normals good
    # enough beyond a few metres) clear shadows decide alone, and the direction is marked unsure
    sun.sunny = bool(sun.two_levels and (score > 0.0 if c.pairs is not None else sun.strength >= UNCONFIRMED_STRENGTH))
    cues["sun_direction_sure"] = bool(sun.sunny and score > 0.0)
    return sun


def _other_suns(g, camera: Camera, c: _Cues, coarse: list, cues: dict, sun: _Sun) -> None:
    """Without two levels, a sun may still show: tried in turn, a shading sun that leaves all the
    ground in view lit, the casters' shadows, a shading sun that leaves it all in shadow."""
    shadow, pairs = c.shadow, c.pairs
    if not sun.two_levels and shadow is not None and pairs is not None:
        sun.lit_ground = lit_ground_sun(shadow, pairs, c.none, coarse)
    if not sun.two_levels and sun.lit_ground is None and shadow is not None \
            and np.mean(shadow.rel > -MAX_SHADOW_LOG_RATIO) <= CASTER_MAX_BRIGHT:
        casters = caster_cue(g, camera)
        if casters is not None:
            sun.cast = sun_from_casters(casters, coarse)
    if not sun.two_levels and sun.lit_ground is None and sun.cast is None and shadow is not None and pairs is not None:
        sun.shaded = shaded_ground_sun(shadow, pairs, c.none, coarse)
    if sun.lit_ground is not None or sun.shaded is not None:
        # the shading shows a sun (and the ground in view all lit, or all in shadow)
        sun.sunny = True
        gain, sun.az, sun.el, k, gm = sun.lit_ground or sun.shaded
        sun.info = {"shadow_agreement": 0.0, "shading_gain": gain, "shading_sky_share": k, "shading_ground_ratio": gm}
        cues.update(sun.info)
        sun.strength = float(np.clip((gain - LIT_GROUND_MIN_GAIN) / LIT_GROUND_MIN_GAIN, 0, 1))
    if sun.cast is not None:
        # the casters in view throw their shadows where that sun puts them
        sun.sunny = True
        agreement, sun.az, sun.el, cast_step = sun.cast
        gain, k, gm = pair_fit(pairs, c.none, sun.az, sun.el) if pairs is not None else \
            (0.0, math.exp(cast_step), c.gm_none)
        sun.info = {"shadow_agreement": 0.0, "shading_gain": gain, "shading_sky_share": k, "shading_ground_ratio": gm}
        cues.update(sun.info)
        cues["caster_agreement"] = agreement
        sun.strength = float(np.clip(agreement / (2 * CASTER_MIN_AGREEMENT), 0, 1))
    cues["lit_ground_sun"] = sun.lit_ground is not None
    cues["caster_sun"] = sun.cast is not None
    cues["shaded_ground_sun"] = sun.shaded is not None


def _plan_sun(c: _Cues, cues: dict, sun: _Sun, ps, plan_dir, site: SunSite | None) -> None:
    """The plan's edges run along the sun's azimuth and along the street (roof lines, car
    sides): where the other cues already found a sun and its direction (two ground levels and
    the shading pairs, the lit or shaded ground, the casters), the plan's direction replaces
    theirs only if it explains the shading and the shadows as well, or if theirs is where the
    sun never stands at the photo's site."""
    found = (cues["sun_direction_sure"] or sun.one_level) and (site is None or len(site.elevations(sun.az)) > 0)
    shading_sun = bool(sun.sunny and found) and c.evidence(sun.az, sun.el)[0] >= c.evidence(*plan_dir[:2])[0]
    sun.sunny, sun.lit_ground, sun.cast, sun.shaded = True, None, None, None
    cues["plan_direction"] = not shading_sun
    if not shading_sun:
        sun.az, sun.el, sun.info = plan_dir
        cues.update(sun.info)
        told = sun.info.get("site", {}).get("side_told", False)
        cues["sun_direction_sure"] = bool(sun.info["caster_agreement"] > 0 or told)
    sun.strength = plansun.strength(ps)


def _shadow_step(c: _Cues, sun: _Sun, ps, plan_dir) -> float:
    """log(shadow / lit) of the ground: the sky's share of the light (0 without a sun)."""
    if not sun.sunny:
        return 0.0
    if plan_dir is not None:
        return plansun.log_ratio(ps)
    if sun.lit_ground is not None or sun.shaded is not None:  # a shadow's step: the sky's share of the light
        return math.log((sun.lit_ground or sun.shaded)[3])
    if sun.cast is not None:  # the casters' shadows against the lit ground around them
        return sun.cast[3]
    return _core_step(c.shadow, c.mix)


def _core_step(cue: ShadowCue, mix: Mixture) -> float:
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
