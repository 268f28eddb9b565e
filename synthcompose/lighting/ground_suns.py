"""Suns the ground shows without two levels of light: a clear shading sun that leaves all the
ground in view lit (:func:`lit_ground_sun`), or all of it in shadow (:func:`shaded_ground_sun`)."""
from __future__ import annotations

import math

import numpy as np

from .light import LIT_GROUND_KNOWN, LIT_GROUND_MARGIN, LIT_GROUND_MIN_GAIN, LIT_PAIRS_LOW
from .pairs import GAMMAS, KS, PairCue, pair_fit, pair_sun, rho
from .shadows import ShadowCue


def lit_ground_sun(shadow: ShadowCue, pairs: PairCue, none: np.ndarray, coarse: list):
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


def shaded_ground_sun(shadow: ShadowCue, pairs: PairCue, none: np.ndarray, coarse: list):
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
