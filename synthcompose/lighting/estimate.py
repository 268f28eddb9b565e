"""The estimate: the cues weighed into one :class:`LightEstimate` (see the package's doc)."""
from __future__ import annotations

import math

import numpy as np

from synthcompose.camera import Camera

from . import lines, plansun
from .casters import CASTER_MAX_BRIGHT, CASTER_MIN_AGREEMENT, caster_cue, sun_from_casters
from .grid import make_grid, smoothing_for
from .light import (
    EXPOSURE_RANGE,
    LIT_GROUND_KNOWN,
    LIT_GROUND_MARGIN,
    LIT_GROUND_MIN_GAIN,
    LIT_PAIRS_LOW,
    LUM,
    MAX_SHADOW_LOG_RATIO,
    MIN_TWO_LEVEL_GAIN,
    ROAD_ALBEDO,
    ROAD_ID,
    SHADOW_AGREEMENT_WEIGHT,
    SIDEWALK_ALBEDO,
    SIDEWALK_ID,
    SKY_ID,
    LightEstimate,
    unit_vector,
)
from .lines import along_line, find_shadow_line
from .pairs import GAMMAS, KS, PairCue, pair_cue, pair_fit, pair_none, pair_sun, rho
from .plan import completed_labels
from .shadows import Mixture, Occluders, ShadowCue, fit_mixture, shadow_cue, shadow_score

#: the sun's elevation (degrees, at least) when the ground's shadows show a sun but no cue its
#: direction
UNSURE_ELEVATION = 70.0
#: without shading pairs to confirm them, two ground levels mean a sun only this clearly (the
#: strength: gain and depth of the shadow step, 0..1); weaker ones are dark paving, wet patches
UNCONFIRMED_STRENGTH = 0.3


def estimate_lighting(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera: Camera,
                      work_width: int = 700, labelled: bool = True,
                      completed: np.ndarray | None = None) -> LightEstimate:
    """Estimate the light of one photo.

    rgb (H, W, 3) uint8 sRGB; label_ids (H, W) uint8 Cityscapes ids (or, ``labelled`` False,
    the surfaces found from the geometry: completed here with the level ground and what stands
    on it, :func:`~.plan.completed_labels`); depth (H, W) float metres, inf where unknown;
    ``camera`` the frame's camera; ``completed``: those completed labels where the caller has
    them already. The completed labels serve the ground plan (:mod:`.plansun`) only: the other
    cues keep the found surfaces (on the completed ones their two-level and shading cues called
    3 of 7 overcast street frames sunny, on the found ones 1).
    Deterministic: the same inputs give the same estimate.
    """
    if completed is None:
        completed = label_ids if labelled else completed_labels(label_ids, depth, camera)
    smooth, sigma_d = smoothing_for(depth, label_ids, camera)
    g = make_grid(rgb, label_ids, depth, camera, work_width, smooth)
    occ = Occluders.build(g, label_ids, depth, camera)
    shadow = shadow_cue(g, occ, camera)
    pairs = pair_cue(g)
    mix = fit_mixture(shadow) if shadow is not None else None
    none, gm_none = pair_none(pairs) if pairs is not None else (None, 0.3)
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
            sd = shadow_score(shadow, mix, *shadow.shadowed(az, el)) / entropy
        sh, k, gm = 0.0, 1.0, gm_none
        if pairs is not None:
            sh, k, gm = pair_fit(pairs, none, az, el)
        return sh + SHADOW_AGREEMENT_WEIGHT * sd, {
            "shadow_agreement": sd, "shading_gain": sh, "shading_sky_share": k, "shading_ground_ratio": gm}

    # coarse grid on the shading alone; the best few directions, and a finer grid around the
    # best of them, with the shadow agreement too
    coarse = []
    for az in np.arange(0.0, 360.0, 15.0):
        for el in (15.0, 25.0, 35.0, 45.0, 55.0, 65.0, 78.0):
            coarse.append((pair_fit(pairs, none, az, el)[0] if pairs is not None else 0.0, float(az), el))
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
        phi, length = find_shadow_line(g, camera, shadow, mix)
        cues["shadow_line"] = [phi, length]
        if length >= lines.LINE_MIN_LENGTH:
            line_sun = along_line(phi, coarse[0][0], pairs, none, evidence)
    if line_sun is not None:
        score, az, el, info = line_sun
        cues.update(info)
        cues["direction_score"] = score
    cues["shadow_line_sun"] = line_sun is not None
    # cast shadows on the ground say there is a sun; the shading pairs, where there are any, may
    # veto it (no direction explains them); without pairs (real stereo gives few normals good
    # enough beyond a few metres) clear shadows decide alone, and the direction is marked unsure
    sunny = bool(two_levels and (score > 0.0 if pairs is not None else strength >= UNCONFIRMED_STRENGTH))
    cues["sun_direction_sure"] = bool(sunny and score > 0.0)
    # without two levels, a sun may still show: tried in turn, a shading sun that leaves all the
    # ground in view lit, the casters' shadows, a shading sun that leaves it all in shadow
    lit_ground = cast = shaded = None
    if not two_levels and shadow is not None and pairs is not None:
        lit_ground = _lit_ground_sun(shadow, pairs, none, coarse)
    if not two_levels and lit_ground is None and shadow is not None \
            and np.mean(shadow.rel > -MAX_SHADOW_LOG_RATIO) <= CASTER_MAX_BRIGHT:
        casters = caster_cue(g, camera)
        if casters is not None:
            cast = sun_from_casters(casters, coarse)
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
        gain, k, gm = pair_fit(pairs, none, az, el) if pairs is not None else (0.0, math.exp(cast_step), gm_none)
        info = {"shadow_agreement": 0.0, "shading_gain": gain, "shading_sky_share": k, "shading_ground_ratio": gm}
        cues.update(info)
        cues["caster_agreement"] = agreement
        strength = float(np.clip(agreement / (2 * CASTER_MIN_AGREEMENT), 0, 1))
    cues["lit_ground_sun"] = lit_ground is not None
    cues["caster_sun"] = cast is not None
    cues["shaded_ground_sun"] = shaded is not None
    # the shadow edges on the ground plan: where they show a sun, they decide, and the sun lies
    # along their directions (plansun)
    ps, _, _ = plansun.measure(rgb, completed, depth, camera, labelled)
    cues["plan"] = ps.to_dict()
    plan_dir = None
    if ps.sunny:  # its casters: what stands, labelled or found from the depth
        cg = g if labelled else make_grid(rgb, completed, depth, camera, work_width, smooth)
        plan_dir = plansun.direction(ps, caster_cue(cg, camera), evidence)
    if plan_dir is not None:
        # the plan's edges run along the sun's azimuth and along the street (roof lines, car
        # sides): where the other cues already found a sun and its direction (two ground levels
        # and the shading pairs, the lit or shaded ground, the casters), the plan's direction
        # replaces theirs only if it explains the shading and the shadows as well
        found = cues["sun_direction_sure"] or any(c is not None for c in (lit_ground, cast, shaded))
        shading_sun = bool(sunny and found) and evidence(az, el)[0] >= evidence(*plan_dir[:2])[0]
        sunny, lit_ground, cast, shaded = True, None, None, None
        cues["plan_direction"] = not shading_sun
        if not shading_sun:
            az, el, info = plan_dir
            cues.update(info)
            cues["sun_direction_sure"] = info["caster_agreement"] > 0
        strength = plansun.strength(ps)
    if not sunny:
        delta = 0.0
    elif plan_dir is not None:
        delta = plansun.log_ratio(ps)
    elif lit_ground is not None or shaded is not None:  # a shadow's step: the sky's share of the light
        delta = math.log((lit_ground or shaded)[3])
    elif cast is not None:  # the casters' shadows against the lit ground around them
        delta = cast[3]
    else:
        delta = _core_step(shadow, mix)
    cues["ground_shadow_core_log_ratio"] = delta
    if sunny and not cues["sun_direction_sure"] and lit_ground is None and cast is None and shaded is None:
        # the shadows show a sun but nothing shows where (the plan's edges give an axis, but no
        # caster its side and height): a high sun, whose shadow falls short and under the
        # object, is the least wrong guess (a shadow thrown the wrong way is seen)
        el = max(el, UNSURE_ELEVATION)
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
        ground_rgb = unit_vector(lit_col)
        if in_shadow.sum() >= 10:
            shade_col = _class_mean(shadow, in_shadow & typical)
            sky_rgb = unit_vector(shade_col)
            # lit / shadow of the same surfaces, per channel, = 1 + sun / sky
            ratio = _class_ratio(shadow, lit, in_shadow & typical)
            sun_rgb = unit_vector(np.maximum(sky_rgb * (ratio - 1.0), 1e-3))
        else:
            sky_rgb = sun_rgb = ground_rgb
        levels = tuple((int(k), lit_scale * float(np.median(shadow.lin[lit & (shadow.cls == k)] @ LUM)))
                       for k in np.unique(shadow.cls) if (lit & (shadow.cls == k)).sum() >= 20)
        exposure, reference = _exposure(shadow, lit, lit_scale)
        cues["exposure_reference"] = reference
    if plan_dir is not None:  # the plan's own lit and shadowed ground
        sky_rgb, sun_rgb, ground_rgb = plansun.colours(ps, delta)
        levels = ps.levels
        road = dict(levels).get(ROAD_ID)
        if road is not None:
            exposure = float(np.clip(road / ROAD_ALBEDO, *EXPOSURE_RANGE))
    sky = g.pure & (g.label == SKY_ID)
    evidence = tuple(name for name, cue in (("ground", shadow), ("shading", pairs)) if cue is not None)
    if ps.edge_length > 0 and "ground" not in evidence:
        evidence += ("ground",)
    if sky.sum() >= 50:
        evidence += ("sky",)
        cues["sky_pixels_linear_rgb"] = [float(v) for v in g.lin[sky].mean(axis=0)]
        if shadow is None:  # no ground in view: the sky's colour
            sky_rgb = sun_rgb = ground_rgb = unit_vector(g.lin[sky].mean(axis=0))
    return LightEstimate(
        sunny=sunny, sun_azimuth_deg=float(az % 360.0), sun_elevation_deg=float(el), sun_fraction=sun_fraction,
        sky_rgb=tuple(float(v) for v in sky_rgb), sun_rgb=tuple(float(v) for v in sun_rgb),
        ground_rgb=tuple(float(v) for v in ground_rgb), ground_ratio=float(info["shading_ground_ratio"]),
        exposure=float(exposure), confidence=float(confidence), ground_levels=levels,
        shadow_log_ratio=float(delta) if sunny else 0.0, ground_shadowed=shaded is not None, evidence=evidence,
        cues=cues)


def _lit_ground_sun(shadow: ShadowCue, pairs: PairCue, none: np.ndarray, coarse: list):
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


def _shaded_ground_sun(shadow: ShadowCue, pairs: PairCue, none: np.ndarray, coarse: list):
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


def _shading_sun(pairs: PairCue, none: np.ndarray, coarse: list, tests):
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
            gain = pair_fit(pairs, none, float(az % 360.0), float(el))[0]
            if gain > best[0] and test(float(az % 360.0), float(el)):
                best = (gain, float(az % 360.0), float(el))
    gain, k, gm = pair_fit(pairs, none, best[1], best[2])
    return gain, best[1], best[2], k, gm


def _lit_pairs_low(pairs: PairCue, none: np.ndarray, az: float, el: float) -> float:
    """Height (m) of the lowest tenth of the pairs that the sun from (az, el) lights (its model
    explains them clearly better than ambient light, and it makes their two ends differ): near 0
    when the sun reaches the feet of the walls and cars, so the ground around them; higher when
    the ground in view lies in the shadow of what stands beyond it (inf without such pairs)."""
    _, k, gm = pair_fit(pairs, none, az, el)
    t = pairs.terms
    i, j = int(np.argmin(np.abs(KS - k))), int(np.argmin(np.abs(GAMMAS - gm)))
    s1, s2 = pair_sun(t, az, el)
    ambient = np.log(t["kh1"][i, j] / t["kh2"][i, j])
    sun = np.log((t["kh1"][i, j] + (1 - k) * s1) / (t["kh2"][i, j] + (1 - k) * s2))
    lit = (np.abs(sun - ambient) > 0.4) & (rho(t["y"] - sun) + 0.5 < none)
    return float(np.quantile(pairs.z[lit], 0.1)) if lit.sum() >= 20 else math.inf


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


def _class_mean(cue: ShadowCue, mask: np.ndarray) -> np.ndarray:
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


def _class_ratio(cue: ShadowCue, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3,) per-channel ratio of the mean colours of samples ``a`` over samples ``b``, within
    each class (same albedo), averaged over the classes in log."""
    logs, weights = [], []
    for k in np.unique(cue.cls):
        sa, sb = a & (cue.cls == k), b & (cue.cls == k)
        if sa.sum() >= 10 and sb.sum() >= 10:
            logs.append(np.log(np.maximum(cue.lin[sa].mean(axis=0), 1e-6) / np.maximum(cue.lin[sb].mean(axis=0), 1e-6)))
            weights.append(min(int(sa.sum()), int(sb.sum())))
    return np.exp(np.average(logs, axis=0, weights=weights)) if logs else np.ones(3)


def _exposure(cue: ShadowCue, mask: np.ndarray, scale: float = 1.0) -> tuple[float, str]:
    """Irradiance of lit ground from the samples in ``mask`` (their luminance times ``scale``)
    against the typical albedo of road, else sidewalk; and which of them."""
    for cls, albedo, name in ((ROAD_ID, ROAD_ALBEDO, "road"), (SIDEWALK_ID, SIDEWALK_ALBEDO, "sidewalk")):
        sel = mask & (cue.cls == cls)
        if sel.sum() >= 100:
            y = scale * float(np.median(cue.lin[sel] @ LUM))
            return float(np.clip(y / albedo, *EXPOSURE_RANGE)), name
    return 1.0, "none"
