"""The sun as the ground plan shows it: whether its shadow edges are there (:mod:`.edges`), the
directions they run along, how deep they are, and the lit and shadowed levels and colours of
the ground (what the estimate takes from it: :mod:`.estimate`).

A sun is seen when at least :data:`MIN_EDGE_LENGTH` metres of shadow edge (steps between two
regions, and narrow dark lines: a pole's shadow) lie on the ground within the plan's reach, in
chains, each at least 1.8 times darker on one side. Paint, kerbs, the shade at the foot of what
stands and the ground's texture do not make such edges (:mod:`.edges`); an overcast sky leaves
none, a sun's shadows many metres of them (per-frame figures: docs/realism.md).

The shadow edges of vertical casters (poles, trunks, the corners of cars and houses) run along
the sun's azimuth on the ground; roof lines and car sides throw edges along the street. The
directions of the edges are histogrammed (weighed by length) and their strongest few peaks are
the azimuths (mod 180) the estimate chooses from, with the shadows the casters in view would
throw (:mod:`.casters`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .edges import MIN_CHAIN, ShadowEdges, shadow_edges
from .light import LUM
from .plan import CELL, GroundPlan, ground_plan

#: metres of shadow edge on the ground plan that mean a sun
MIN_EDGE_LENGTH = 2.0
#: peaks of the edges' directions kept (degrees apart at least PEAK_SEPARATION)
PEAKS, PEAK_SEPARATION = 3, 20


@dataclass(frozen=True)
class PlanSun:
    """What the ground plan says of the sun.

    edge_length : metres of shadow edge (steps and dark lines, in chains)
    sunny       : edge_length >= :data:`MIN_EDGE_LENGTH`
    step        : median log luminance of the edges' steps (bright over dark), 0 without edges
    chroma      : median chromatic step of the edges (> 0: the dark side bluer), nan unknown
    azimuths    : ((azimuth mod 180 in degrees, metres of edge within 7.5 degrees of it, side),
                  ...) the strongest first; ``side`` +1 where the straight segments along it
                  start at a caster's foot at their end towards the azimuth (the sun is that
                  way: a shadow runs from its caster away from the sun), -1 towards azimuth +
                  180, 0 where they do not tell
    levels      : ((label, lit linear luminance), ...) of the plan's ground kinds that have both
                  levels, by their own split
    shadow_log_ratio : log(shadow / lit) of those kinds (their cores), 0 without
    lit_rgb, shadow_rgb : mean linear colour (luminance 1) of the lit and the shadowed ground
    lit_share   : share of the ground measured that is lit
    area        : square metres of ground measured
    """

    edge_length: float
    sunny: bool
    step: float
    chroma: float
    azimuths: tuple
    levels: tuple
    shadow_log_ratio: float
    lit_rgb: tuple
    shadow_rgb: tuple
    lit_share: float
    area: float

    def to_dict(self) -> dict:
        return {"edge_length_m": round(self.edge_length, 2), "sunny": self.sunny, "step": round(self.step, 3),
                "chroma": None if not np.isfinite(self.chroma) else round(self.chroma, 3),
                "azimuths": [[round(a, 1), round(m, 2), side] for a, m, side in self.azimuths],
                "shadow_log_ratio": round(self.shadow_log_ratio, 3), "lit_share": round(self.lit_share, 3),
                "area_m2": round(self.area, 1)}


def measure(rgb: np.ndarray, label_ids: np.ndarray, depth: np.ndarray, camera, labelled: bool = True,
            plan: GroundPlan | None = None) -> tuple[PlanSun, GroundPlan, ShadowEdges]:
    """(:class:`PlanSun`, the plan, its edges) of a photo (the arguments of
    :func:`~.plan.ground_plan`)."""
    plan = plan if plan is not None else ground_plan(rgb, label_ids, depth, camera, labelled)
    edges = shadow_edges(plan)
    counted = edges.chain >= MIN_CHAIN
    length = float(counted.sum() * CELL)
    step = float(np.median(edges.step[counted])) if counted.any() else 0.0
    ch = edges.chroma[counted & np.isfinite(edges.chroma)]
    chroma = float(np.median(ch)) if len(ch) >= 5 else float("nan")
    levels, ratio, lit_rgb, shadow_rgb, lit_share = _levels(plan, step if length >= MIN_EDGE_LENGTH else 0.0)
    peaks = tuple((az, m, _side(plan, edges, az)) for az, m in _peaks(edges, counted))
    return PlanSun(length, length >= MIN_EDGE_LENGTH, step, chroma, peaks, levels, ratio,
                   lit_rgb, shadow_rgb, lit_share, edges.area), plan, edges


#: metres of edge whose chains reach a caster's foot that make those the ones the directions are
#: read from: a vertical caster's shadow starts at its foot and runs along the sun's azimuth; a
#: roof line's or a car side's runs along the street, away from any foot
MIN_ANCHORED = 0.5


def _peaks(edges: ShadowEdges, counted: np.ndarray) -> tuple:
    """The strongest directions of the counted edges (of those reaching a caster's foot, where
    there are :data:`MIN_ANCHORED` metres of them): ((azimuth mod 180, metres), ...)."""
    if (counted & edges.anchored).sum() * CELL >= MIN_ANCHORED:
        counted = counted & edges.anchored
    if not counted.any():
        return ()
    h = np.bincount(np.round(edges.along[counted]).astype(np.int64) % 180, minlength=180).astype(np.float64)
    smooth = np.convolve(np.concatenate([h[-7:], h, h[:7]]), np.ones(15), "valid")
    out = []
    for _ in range(PEAKS):
        i = int(np.argmax(smooth))
        if smooth[i] <= 0:
            break
        w = np.arange(i - 7, i + 8)
        centre = float((w @ h[w % 180]) / max(h[w % 180].sum(), 1e-9)) % 180.0
        out.append((centre, float(smooth[i] * CELL)))
        smooth[np.arange(i - PEAK_SEPARATION, i + PEAK_SEPARATION + 1) % 180] = 0.0
    return tuple(out)


def _side(plan: GroundPlan, edges: ShadowEdges, azimuth: float) -> int:
    """Which way along ``azimuth`` (mod 180) the sun lies, from the straight segments along it
    (within 10 degrees) that start at a caster's foot (:attr:`GroundPlan.feet`) at one end and
    not at the other: +1 towards ``azimuth``, -1 towards its half turn, 0 undecided (votes
    weighed by length, a clear majority needed)."""
    x0, y0 = plan.origin
    nr, nc = plan.feet.shape
    vote = 0.0
    total = 0.0
    for az, length, xa, ya, xb, yb in edges.segments:
        if min(abs(az - azimuth) % 180.0, 180.0 - abs(az - azimuth) % 180.0) > 10.0:
            continue
        ends = []
        for x, y in ((xa, ya), (xb, yb)):
            r, c = int((x - x0) / CELL), int((y0 - y) / CELL)
            ends.append(0 <= r < nr and 0 <= c < nc and bool(plan.feet[r, c]))
        if ends[0] == ends[1]:
            continue
        foot = (xa, ya) if ends[0] else (xb, yb)
        tail = (xb, yb) if ends[0] else (xa, ya)
        towards = np.degrees(np.arctan2(foot[1] - tail[1], foot[0] - tail[0]))  # tail -> foot: to the sun
        d = (towards - azimuth) % 360.0
        vote += length if (d < 90.0 or d > 270.0) else -length
        total += length
    if total <= 0 or abs(vote) < 0.5 * total:
        return 0
    return 1 if vote > 0 else -1


def _levels(plan: GroundPlan, step: float):
    """Per ground kind of the plan, its lit and shadowed cells split at half the edges' step
    below its brightest usual level: (levels, log(shadow / lit) of the cores, lit colour, shadow
    colour, lit share). Without a step: all lit."""
    y = plan.lin @ LUM.astype(np.float32)
    ll = np.log(np.maximum(y, 1e-5))
    levels, steps, weights = [], [], []
    lit_acc, sh_acc = np.zeros(3), np.zeros(3)
    n_lit = n_all = 0
    for k in np.unique(plan.cls[plan.valid]):
        sel = plan.valid & (plan.cls == k) & ~plan.clipped
        if sel.sum() < 600:
            continue
        v = ll[sel]
        top = float(np.quantile(v, 0.9))
        lit = v > top - step / 2 if step > 0 else np.ones(len(v), bool)
        n_all += len(v)
        n_lit += int(lit.sum())
        c = plan.lin[sel]
        if lit.sum() >= 100:
            levels.append((int(k), float(np.exp(np.median(v[lit])))))
            lit_acc += unit_vector(c[lit].mean(axis=0)) * lit.sum()
        if step > 0 and (~lit).sum() >= 100 and lit.sum() >= 100:
            steps.append(float(np.median(v[~lit]) - np.median(v[lit])))
            weights.append(min(int(lit.sum()), int((~lit).sum())))
            sh_acc += unit_vector(c[~lit].mean(axis=0)) * (~lit).sum()
    ratio = float(np.average(steps, weights=weights)) if steps else 0.0
    lit_rgb = tuple(float(t) for t in unit_vector(lit_acc)) if lit_acc.any() else (1.0, 1.0, 1.0)
    shadow_rgb = tuple(float(t) for t in unit_vector(sh_acc)) if sh_acc.any() else lit_rgb
    return tuple(levels), ratio, lit_rgb, shadow_rgb, (n_lit / n_all if n_all else 1.0)


def unit_vector(c) -> np.ndarray:
    c = np.maximum(np.asarray(c, np.float64), 1e-6)
    return c / float(c @ LUM)


#: elevations (degrees) tried along the edges' azimuths
ELEVATIONS = (10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0)
#: without casters to tell, the sun's elevation (degrees): a shadow as long as the caster is high
DEFAULT_ELEVATION = 45.0
#: the casters tell the sun's side of the edges' axis where they agree this much more with it
#: than with the other side
SIDE_MARGIN = 1.5


def direction(ps: PlanSun, casters, evidence, site=None) -> tuple[float, float, dict]:
    """The sun's (azimuth, elevation, info) along the strongest direction of the edges (the
    first of ``ps.azimuths``): on each side of that axis, within 6 degrees of it, at
    :data:`ELEVATIONS`, where the casters in view throw their shadows onto dark ground
    (``casters``: :class:`~.casters._CasterCue` or None); the side the casters agree with
    :data:`SIDE_MARGIN` times better than with the other, else the side ``evidence(az, el) ->
    (score, info)`` (the shading pairs and the predicted shadows) prefers, at the casters'
    elevation there or :data:`DEFAULT_ELEVATION`. ``info`` is evidence's at the chosen
    direction, with the casters' agreement.

    ``site`` (:class:`~.solar.SunSite`, from the photo's vehicle file, or None): where the sun
    can stand. A side the sun never reaches at that latitude (the north, seen from Germany) is
    not taken; the elevations tried on a side are those the sun has there on some day of the
    year, and without a caster to tell, the elevation is their median (``info["site"]``).

    The casters tell the side and the height along that direction, never another one: their
    agreement is a mean over points landing on darker or brighter ground than its kind's median,
    and where most of a street lies in shadow (a canyon, the sun across it) the shadows of
    either row of houses land on dark road in any direction that reaches it. Let to choose
    among the edges' peaks they took a weak one (a car's side, 0.25 m of edge against 1.15 m)
    on real frames; along the strongest, 11 (seed 3) and 9 (seed 5) of 12 generated sunny
    scenes had the sun's axis within 15 degrees, against 10 and 8 when they chose. The side the
    edges' own segments tell (``ps.azimuths``' third field: which end of a shadow meets a
    caster's foot) is not used: on those scenes it was told twice and wrong both times, where the
    casters were right; with the margin the side was right on 9 and 7 of 12 (6 and 6 when the
    segments decided; 8 and 7 with the casters alone, whichever side they agreed with more)."""
    if not ps.azimuths:
        return 0.0, DEFAULT_ELEVATION, dict(evidence(0.0, DEFAULT_ELEVATION)[1], caster_agreement=0.0)
    phi = ps.azimuths[0][0]
    sides = [_Side.of(base, site) for base in (phi, phi + 180.0)]
    if not any(s.possible for s in sides):  # the site rules out both: it is not believed
        site, sides = None, [_Side.of(base, None) for base in (phi, phi + 180.0)]
    sides = [s for s in sides if s.possible]
    best = [s.casters_pick(casters) for s in sides]
    agree = [b[0] for b in best]
    if len(best) == 1:
        chosen = best[0]
    elif max(agree) > 0 and max(agree) >= SIDE_MARGIN * max(min(agree), 0.0):
        chosen = best[int(np.argmax(agree))]
    else:  # the casters do not tell the side: the shading pairs and the predicted shadows do
        chosen = max(best, key=lambda b: evidence(b[1], DEFAULT_ELEVATION)[0])
    agreement, found = chosen[0], (chosen[1], chosen[2])
    info = dict(evidence(*found)[1])
    info["caster_agreement"] = agreement
    if site is not None:
        side = sides[best.index(chosen)]
        info["site"] = {"compass_azimuth": round(site.compass(found[0]), 1),
                        "elevations": [round(side.low, 1), round(side.high, 1)],
                        "side_told": len(sides) == 1}
    return found[0], found[1], info


@dataclass(frozen=True)
class _Side:
    """One side of the edges' axis: its azimuth (vehicle frame), and the elevations the sun has
    there (all of :data:`ELEVATIONS` without a site; the casters turn it only where the sun
    stands too)."""

    base: float
    possible: bool
    low: float
    high: float
    typical: float
    site: object = None

    @classmethod
    def of(cls, base: float, site) -> "_Side":
        if site is None:
            return cls(base % 360.0, True, ELEVATIONS[0], ELEVATIONS[-1], DEFAULT_ELEVATION)
        e = site.elevations(base)
        if not len(e):
            return cls(base % 360.0, False, 0.0, 0.0, DEFAULT_ELEVATION, site)
        return cls(base % 360.0, True, float(e.min()), float(e.max()), float(np.median(e)), site)

    def casters_pick(self, casters) -> tuple[float, float, float]:
        """(agreement, azimuth, elevation): the casters' best direction within 6 degrees of the
        side, at the elevations the sun has there; (0, the side, its typical elevation) where
        they agree with none."""
        pick = (0.0, self.base, self.typical)
        els = [e for e in ELEVATIONS if self.low - 2.5 <= e <= self.high + 2.5]
        if casters is None or not els:
            return pick
        turns = [d for d in (-6.0, -3.0, 0.0, 3.0, 6.0)
                 if self.site is None or d == 0.0 or len(self.site.elevations(self.base + d))]
        az = np.array([(self.base + d) % 360.0 for d in turns for _ in els])
        el = np.array([min(max(e, self.low), self.high) for _ in turns for e in els])
        agree, dark, _ = casters.score(az, el)
        i = int(np.argmax(agree))
        if agree[i] > 0 and dark[i] >= 10:
            pick = (float(agree[i]), float(az[i]), float(el[i]))
        return pick


def strength(ps: PlanSun) -> float:
    """0..1: how clearly the edges show a sun (their length against twice the threshold)."""
    return float(np.clip(ps.edge_length / (2 * MIN_EDGE_LENGTH), 0.0, 1.0))


def log_ratio(ps: PlanSun) -> float:
    """log(shadow / lit) of the ground: its kinds' cores, or the edges' step."""
    return ps.shadow_log_ratio if ps.shadow_log_ratio < -0.2 else -ps.step


def colours(ps: PlanSun, delta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sky, sun, ground) colours (luminance 1): the shadowed ground's is the sky's, lit minus
    shadowed the sun's, the lit ground's the ground's."""
    lit, shade = np.asarray(ps.lit_rgb), np.asarray(ps.shadow_rgb)
    sun = np.maximum(lit - shade * np.exp(delta), 1e-3)
    return unit_vector(shade), unit_vector(sun), unit_vector(lit)
