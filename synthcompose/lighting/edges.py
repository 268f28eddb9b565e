"""Cue: the sun's shadow edges on the ground plan (:mod:`.plan`).

A cast shadow in sunshine ends in a step: the ground is lit by sun and sky on one side and by
the sky alone on the other, 1.6 to 5 times darker, and the step is sharp - its penumbra is the
sun's angular size (0.53 degrees) times the distance to the caster's edge, a few centimetres
for a pole's or a car's shadow, 10-30 cm for a house's - and the shadow's side is bluer (the
sky is bluer than the sun). Under an overcast sky the shade of a car or a wall fades over about
its height (and the ground right in front of what stands is left out of the plan); what steps
remain are paint (bright and narrow: left out), kerbs (two kinds of ground: steps are measured
within one kind) and wet or mended patches.

On the ground plan (metres), within :data:`~.plan.FAR` of the camera, per ground kind:

1. log luminance against the kind's median; bright structures narrower than
   :data:`MARKING_WIDTH` (lane paint) are left out;
2. step edges between two regions: along the gradient of the smoothed log luminance, the step
   between the sides :data:`NEAR_SIDE` away and the step between the sides :data:`FAR_SIDE`
   away, both at least :data:`MIN_STEP`, about equal (a step, not a line) and each side flat;
   their mean at least :data:`EDGE_STEP` (1.8 times: a sun's shadow, not a patch);
3. narrow dark lines (a pole's or a trunk's shadow): a black top-hat of :data:`LINE_WIDTH`, at
   least :data:`EDGE_STEP` deep;
4. their chains (8-connected cells) and straight segments (probabilistic Hough on the plan, at
   least :data:`MIN_SEGMENT` long).

What is returned are measures; the estimate weighs them (:mod:`.estimate`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .light import LUM
from .plan import CELL, GroundPlan

#: metres either side of an edge where its two sides are read, near and far
NEAR_SIDE, FAR_SIDE = 0.15, 0.4
#: the bright side of a step still bright this far out (metres): a lit region, not a bright strip
BRIGHT_REACH = 0.8
#: each side's step at least this (log luminance), their mean at least EDGE_STEP (1.8 times)
MIN_STEP, EDGE_STEP = 0.4, 0.6
#: bright structures narrower than this (metres) are paint: left out
MARKING_WIDTH = 0.8
#: dark lines narrower than this (metres) are measured as lines (a pole's shadow)
LINE_WIDTH = 0.6
#: an edge counts in a chain at least this long (metres): not a speck
MIN_CHAIN = 0.75
#: a straight segment at least this long (metres) on the plan
MIN_SEGMENT = 1.5
#: the ground kinds measured need at least this many plan cells (1.5 m^2)
MIN_CELLS = 600


@dataclass(frozen=True, eq=False)
class ShadowEdges:
    """Edge points of steps and dark lines on the ground plan.

    xy      : (N, 2) vehicle-frame plan position (metres)
    along   : (N,) azimuth (degrees, mod 180) of the edge's own direction on the plan
    step    : (N,) log luminance, bright side over dark
    chroma  : (N,) log(R_bright / R_dark) - log(B_bright / B_dark): > 0 where the dark side is
              bluer (nan where clipped, and for lines)
    line    : (N,) bool, a narrow dark line's centre rather than a step's edge
    chain   : (N,) metres, the extent of the chain it belongs to
    anchored: (N,) bool, its chain reaches a caster's foot (a vertical caster's shadow starts there)
    segments: ((azimuth mod 180, length m, x0, y0, x1, y1), ...) straight segments
    area    : square metres of ground measured
    """

    xy: np.ndarray
    along: np.ndarray
    step: np.ndarray
    chroma: np.ndarray
    line: np.ndarray
    chain: np.ndarray
    anchored: np.ndarray
    segments: tuple
    area: float

    def length(self, mask: np.ndarray | None = None) -> float:
        """Metres of edge (one cell per point) in chains at least :data:`MIN_CHAIN` long."""
        sel = self.chain >= MIN_CHAIN
        if mask is not None:
            sel &= mask
        return float(sel.sum() * CELL)


def _relative(plan: GroundPlan) -> tuple[np.ndarray, np.ndarray]:
    """(log luminance against each ground kind's median, cells used): kinds with enough cells,
    bright paint left out."""
    y = plan.lin @ LUM.astype(np.float32)
    ll = np.log(np.maximum(y, 1e-5)).astype(np.float32)
    rel = np.zeros_like(ll)
    used = np.zeros(ll.shape, bool)
    k = int(round(MARKING_WIDTH / CELL)) | 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    for c in np.unique(plan.cls[plan.valid]):
        sel = plan.valid & (plan.cls == c)
        if sel.sum() < MIN_CELLS:
            continue
        r = np.where(sel, ll - np.median(ll[sel]), 0.0).astype(np.float32)
        rs = _smooth(r, sel, 2.0)  # the top-hat of the texture's noise would be paint everywhere
        opened = cv2.dilate(np.where(sel, cv2.erode(np.where(sel, rs, 9.0).astype(np.float32), kernel), -9.0)
                            .astype(np.float32), kernel)
        paint = sel & (rs - opened > 0.35) & (opened > -8.0)
        paint = cv2.dilate(paint.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
        rel[sel] = r[sel]
        used |= sel & ~paint
    return rel, used


def _smooth(rel: np.ndarray, used: np.ndarray, sigma: float) -> np.ndarray:
    w = used.astype(np.float32)
    num = cv2.GaussianBlur(np.where(used, rel, 0.0).astype(np.float32), (0, 0), sigma)
    return num / np.maximum(cv2.GaussianBlur(w, (0, 0), sigma), 1e-3)


def shadow_edges(plan: GroundPlan) -> ShadowEdges:
    """The step edges and dark lines of the ground plan (module doc)."""
    rel, used = _relative(plan)
    nr, nc = rel.shape
    sm = _smooth(rel, used, 1.5)
    kind = np.where(used, plan.cls, 0).astype(np.int32)
    gc = cv2.Sobel(sm, cv2.CV_32F, 1, 0) / 8.0  # per cell along a row (columns change)
    gr = cv2.Sobel(sm, cv2.CV_32F, 0, 1) / 8.0  # per cell along a column (rows change)
    mag = np.hypot(gc, gr)
    core = cv2.erode(used.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    rr, cc = np.nonzero(core & (mag > 0.08))
    ur, uc = gr[rr, cc] / mag[rr, cc], gc[rr, cc] / mag[rr, cc]

    def at(k: float) -> tuple[np.ndarray, np.ndarray]:
        return (np.clip(np.rint(rr + ur * k).astype(np.int64), 0, nr - 1),
                np.clip(np.rint(cc + uc * k).astype(np.int64), 0, nc - 1))

    # non-maximum suppression along the gradient
    r1, c1 = at(1.0)
    r2, c2 = at(-1.0)
    keep = (mag[rr, cc] >= mag[r1, c1]) & (mag[rr, cc] > mag[r2, c2])
    rr, cc, ur, uc = rr[keep], cc[keep], ur[keep], uc[keep]
    # the step between two regions: at NEAR_SIDE and FAR_SIDE either side, both on ground of
    # the edge's kind, nearly the same step (the regions are wider than the far reach: not a
    # line of paint or a pole's shadow, measured below) and each side flat
    k1, k2 = int(round(NEAR_SIDE / CELL)), int(round(FAR_SIDE / CELL))
    (rb, cb), (rd, cd), (rb2, cb2), (rd2, cd2) = at(k1), at(-k1), at(k2), at(-k2)
    same = kind[rr, cc]
    good = np.ones(len(rr), bool)
    for r, c in ((rb, cb), (rd, cd), (rb2, cb2), (rd2, cd2)):
        good &= used[r, c] & (kind[r, c] == same)
    s1, s2 = sm[rb, cb] - sm[rd, cd], sm[rb2, cb2] - sm[rd2, cd2]
    good &= (s1 > MIN_STEP) & (s2 > 0.8 * s1) & (np.abs(sm[rb2, cb2] - sm[rb, cb]) < 0.3) & \
        (np.abs(sm[rd2, cd2] - sm[rd, cd]) < 0.3)
    step = (s1 + s2) / 2
    good &= step >= EDGE_STEP
    # the bright side is a region, not a strip of paint or kerbstone a little wider than the
    # paint's top-hat: still bright BRIGHT_REACH out (where that is ground of the kind)
    r3, c3 = at(int(round(BRIGHT_REACH / CELL)))
    seen = used[r3, c3] & (kind[r3, c3] == same)
    good &= seen & (sm[r3, c3] - sm[rd2, cd2] > 0.5 * step)
    rr, cc, ur, uc, step = rr[good], cc[good], ur[good], uc[good], step[good]
    chroma = _chroma(plan, rr, cc, ur, uc, k1, k2)
    # narrow dark lines: a black top-hat
    lr, lc, ldepth, lalong = _dark_lines(sm, used)
    line = np.concatenate([np.zeros(len(rr), bool), np.ones(len(lr), bool)])
    rows, cols = np.concatenate([rr, lr]), np.concatenate([cc, lc])
    along = np.concatenate([GroundPlan.direction(-uc, ur) % 180.0, lalong])
    step = np.concatenate([step, ldepth])
    chroma = np.concatenate([chroma, np.full(len(lr), np.nan)])
    chains, anchored = _chains(rows, cols, (nr, nc), plan.feet)
    long = chains >= MIN_CHAIN
    segments = _segments(plan, rows[long], cols[long], (nr, nc))
    return ShadowEdges(plan.xy(rows, cols), along, step, chroma, line, chains, anchored, segments,
                       float(used.sum() * CELL * CELL))


def _chroma(plan: GroundPlan, rr, cc, ur, uc, k1: int, k2: int) -> np.ndarray:
    """(N,) log(R_b / R_d) - log(B_b / B_d) across each edge, from the mean colours of its two
    sides (``k1`` to ``k2`` cells out); nan where either side is clipped."""
    nr, nc = plan.valid.shape
    acc = {}
    for side, ks in (("b", range(k1, k2 + 1)), ("d", range(-k2, -k1 + 1))):
        tot = np.zeros((len(rr), 3))
        clip = np.zeros(len(rr), bool)
        for k in ks:
            r = np.clip(np.rint(rr + ur * k).astype(np.int64), 0, nr - 1)
            c = np.clip(np.rint(cc + uc * k).astype(np.int64), 0, nc - 1)
            tot += plan.lin[r, c]
            clip |= plan.clipped[r, c]
        acc[side] = (np.log(np.maximum(tot, 1e-6)), clip)
    d = acc["b"][0] - acc["d"][0]
    return np.where(acc["b"][1] | acc["d"][1], np.nan, d[:, 0] - d[:, 2])


def _dark_lines(sm: np.ndarray, used: np.ndarray):
    """Centres of narrow dark lines (black top-hat of :data:`LINE_WIDTH`, at least
    :data:`MIN_STEP` deep, thinned along their cross direction): rows, cols, depth, azimuth of
    the line (degrees mod 180)."""
    k = int(round(LINE_WIDTH / CELL)) | 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    filled = np.where(used, sm, -9.0).astype(np.float32)
    closed = cv2.erode(cv2.dilate(filled, kernel), kernel)
    depth = np.where(used, closed - sm, 0.0)
    # the closing must not reach over what is not ground: both sides of the line measured
    inside = cv2.erode(used.astype(np.uint8), kernel) > 0
    cand = inside & (depth >= EDGE_STEP)
    if cand.sum() == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    d = cv2.GaussianBlur(np.asarray(depth, np.float32), (0, 0), 1.0)
    # the line's direction: the Hessian's eigenvector of the larger eigenvalue (a ridge's)
    drr = cv2.Sobel(d, cv2.CV_32F, 0, 2)  # (dx, dy): along rows twice
    dcc = cv2.Sobel(d, cv2.CV_32F, 2, 0)
    drc = cv2.Sobel(d, cv2.CV_32F, 1, 1)
    theta = 0.5 * np.arctan2(2 * drc, drr - dcc)  # (row, col) = (cos, sin): along the ridge
    r, c = np.nonzero(cand)
    ar, ac = -np.sin(theta[r, c]), np.cos(theta[r, c])  # across it
    h, w = d.shape
    ra = np.clip(np.rint(r + ar).astype(np.int64), 0, h - 1)
    ca = np.clip(np.rint(c + ac).astype(np.int64), 0, w - 1)
    rb = np.clip(np.rint(r - ar).astype(np.int64), 0, h - 1)
    cb = np.clip(np.rint(c - ac).astype(np.int64), 0, w - 1)
    top = (d[r, c] >= d[ra, ca]) & (d[r, c] > d[rb, cb])
    r, c = r[top], c[top]
    along = GroundPlan.direction(np.cos(theta[r, c]), np.sin(theta[r, c])) % 180.0
    return r, c, depth[r, c].astype(np.float64), along


def _chains(rows: np.ndarray, cols: np.ndarray, shape, feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N,) metres: the diagonal of the box of the 8-connected chain (edge cells dilated by
    one) each point belongs to; (N,) bool: its chain reaches a caster's foot (``feet``)."""
    if not len(rows):
        return np.zeros(0), np.zeros(0, bool)
    m = np.zeros(shape, np.uint8)
    m[rows, cols] = 1
    n, comp, stats, _ = cv2.connectedComponentsWithStats(cv2.dilate(m, np.ones((3, 3), np.uint8)), connectivity=8)
    ext = np.hypot(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT]) * CELL
    at_foot = np.zeros(n, bool)
    at_foot[np.unique(comp[(comp > 0) & feet])] = True
    return ext[comp[rows, cols]], at_foot[comp[rows, cols]]


def _segments(plan: GroundPlan, rows: np.ndarray, cols: np.ndarray, shape) -> tuple:
    """Straight segments through the edge cells (probabilistic Hough, at least
    :data:`MIN_SEGMENT` long, gaps up to 0.3 m): (azimuth mod 180, length, x0, y0, x1, y1)."""
    if len(rows) < int(MIN_SEGMENT / CELL):
        return ()
    m = np.zeros(shape, np.uint8)
    m[rows, cols] = 255
    m = cv2.dilate(m, np.ones((3, 3), np.uint8))
    found = cv2.HoughLinesP(m, 1, math.pi / 180, threshold=int(MIN_SEGMENT / CELL),
                            minLineLength=int(MIN_SEGMENT / CELL), maxLineGap=int(0.3 / CELL))
    out = []
    for seg in ([] if found is None else found):
        c0, r0, c1, r1 = (int(t) for t in np.ravel(seg))
        (x0, y0), (x1, y1) = plan.xy(np.array([r0, r1]), np.array([c0, c1]))
        az = float(GroundPlan.direction(r1 - r0, c1 - c0) % 180.0)
        out.append((az, float(math.hypot(x1 - x0, y1 - y0)), float(x0), float(y0), float(x1), float(y1)))
    # Hough returns overlapping segments of one thick line: keep the longest of each
    out.sort(key=lambda s: -s[1])
    kept: list = []
    for s in out:
        mid = np.array([(s[2] + s[4]) / 2, (s[3] + s[5]) / 2])
        if any(min(abs(s[0] - k[0]), 180 - abs(s[0] - k[0])) < 8 and
               _dist_to_segment(mid, k) < 0.3 for k in kept):
            continue
        kept.append(s)
    return tuple(kept)


def _dist_to_segment(p: np.ndarray, s) -> float:
    a, b = np.array(s[2:4]), np.array(s[4:6])
    t = float(np.clip((p - a) @ (b - a) / max((b - a) @ (b - a), 1e-9), 0, 1))
    return float(np.linalg.norm(p - a - t * (b - a)))
