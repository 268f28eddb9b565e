"""The light's colours, the ground's levels and the exposure, from the ground samples (grey world):
lit against shadowed samples of the same surfaces give the sun's and the sky's colours."""
from __future__ import annotations

import numpy as np

from .light import EXPOSURE_RANGE, LUM, ROAD_ALBEDO, ROAD_ID, SIDEWALK_ALBEDO, SIDEWALK_ID, unit_vector
from .shadows import ShadowCue


def ground_colours(shadow: ShadowCue, in_shadow: np.ndarray, lit_scale: float):
    """(sky, sun, ground) unit colours, the lit levels of each class ((class id, luminance), ...),
    the exposure and the surface it was read on, from the ground samples ``in_shadow`` marks as
    shadowed and the rest lit (each lit level times ``lit_scale``)."""
    lo, hi = np.quantile(shadow.rel, [0.03, 0.9])
    typical = (shadow.rel >= lo) & (shadow.rel <= hi)  # not markings, not deep holes
    lit = ~in_shadow & typical
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
    return sky_rgb, sun_rgb, ground_rgb, levels, exposure, reference


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
