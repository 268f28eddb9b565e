"""No two inserted objects of the default street cast interpenetrate: many seeded draws on
generated streets, placed by the batch's own stages; each pair checked on the ground (their
footprints at least the placement's object gap apart) and in 3D (no vertex of one mesh, as
posed, inside the convex hull of the other)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from synthcompose.manifest import parse_manifest
from synthcompose.placement.boxes import footprint_corners
from synthcompose.placement.frequency import object_weights
from synthcompose.stages.options import StageOptions
from synthcompose.stages.place import place
from synthcompose.stages.prepare import prepare
from synthcompose.stages.timing import Timings
from synthcompose.synthetic import make_sample

W, H = 1024, 512
SEEDS = (1, 2, 3, 4)
#: a vertex counts as inside another mesh's hull when deeper than this, metres (float rounding)
INSIDE_M = 1e-3


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = np.clip(np.dot(p - a, b - a) / max(np.dot(b - a, b - a), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def _inside(p: np.ndarray, poly: np.ndarray) -> bool:
    """``p`` inside the convex (4, 2) polygon ``poly`` (either winding)."""
    edges, rel = np.roll(poly, -1, axis=0) - poly, p - poly
    cross = edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0]
    return all(c >= 0 for c in cross) or all(c <= 0 for c in cross)


def footprint_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Least ground distance between two convex (4, 2) footprints (0 when they overlap)."""
    if any(_inside(p, b) for p in a) or any(_inside(p, a) for p in b):
        return 0.0
    return min(min(_segment_distance(p, q[i], q[(i + 1) % 4]) for i in range(4))
               for p, q in [(p, b) for p in a] + [(p, a) for p in b])


def posed_vertices(obj) -> np.ndarray:
    m = obj.placement.matrix
    pts = np.concatenate([p.positions for p in obj.model.parts]).astype(np.float64)
    return pts @ m[:3, :3].T + m[:3, 3]


@pytest.fixture(scope="module")
def placed_sets(tmp_path_factory):
    work = tmp_path_factory.mktemp("collisions")
    ids = make_sample(work / "cs", count=4, width=W, height=H, seed=11)
    out = []
    for seed in SEEDS:
        m = parse_manifest({"dataset": str(work / "cs"), "output": str(work / "out"), "seed": seed,
                            "objects_per_image": 4, "cast": "street", "render": {"right_view": False}},
                           work / "m.json")
        weights = object_weights([o.weight for o in m.objects], [], "weights")
        for ident in ids:
            o = StageOptions.of(m)
            placed = place(o.place, weights, prepare(o.read, ident, Timings()), Timings())
            out.append((m, placed))
    return out


def deepest_inside(points: np.ndarray, other: np.ndarray) -> float:
    """How deep the deepest of ``points`` lies inside the convex hull of ``other``, metres (< 0:
    none inside)."""
    eq = ConvexHull(other).equations  # inside: every plane's n . x + d < 0
    return -float((points @ eq[:, :3].T + eq[:, 3]).max(axis=1).min())


@pytest.mark.slow
def test_no_two_objects_of_the_street_cast_interpenetrate(placed_sets):
    pairs = 0
    classes = set()
    for m, placed in placed_sets:
        objs = placed.objects
        classes |= {o.spec.class_name for o in objs}
        for i, a in enumerate(objs):
            pa = posed_vertices(a)
            for b in objs[i + 1:]:
                pairs += 1
                gap = footprint_distance(footprint_corners(a.placement.matrix, a.placement.extents),
                                         footprint_corners(b.placement.matrix, b.placement.extents))
                assert gap >= m.rules.object_gap - 1e-6, (a.cast.entry.id, b.cast.entry.id, gap)
                pb = posed_vertices(b)
                names = (a.cast.entry.id, b.cast.entry.id)
                assert deepest_inside(pa, pb) < INSIDE_M and deepest_inside(pb, pa) < INSIDE_M, names
                if pairs == 1:  # the check sees an overlap: b moved onto a's place
                    moved = pb + a.placement.position - b.placement.position
                    assert max(deepest_inside(pa, moved), deepest_inside(moved, pa)) > 0.02
    assert pairs >= 30, pairs  # many pairs were checked
    assert {"person", "traffic sign"} <= classes
