"""The sun on real street frames labelled sunny / overcast by eye (SYNTHCOMPOSE_STREETS_ROOT and
SYNTHCOMPOSE_SUN_LABELS; skipped without them): the estimate finds the sunny ones from the
shadow edges on their ground, and not the overcast ones (benchmarks/eval_sun.py gives the
figures per frame)."""
from __future__ import annotations

from pathlib import Path

from evaluation.shadowlook import read_sun_labels
from synthcompose.geometry.depth import disparity_to_depth
from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.lighting import estimate_lighting
from synthcompose.lighting.solar import SunSite
from synthcompose.placement.surfaces import frame_for

from ..real_root import STREETS, SUN_LABELS, needs_streets
from ..tolerances import OVERCAST_SUNNY_MAX, SUNNY_FOUND_MIN

pytestmark = needs_streets


def test_sunny_street_frames_are_called_sunny_and_overcast_ones_not():
    labels = read_sun_labels(SUN_LABELS)
    root = Path(STREETS)
    called = {"sunny": [], "overcast": []}
    for ident in find_image_sets(root):
        kind = labels.get("_".join(ident.name.split("_")[:2]))
        if kind is None:
            continue
        s = read_image_set(root, ident)
        depth = disparity_to_depth(s.disparity, s.camera)
        frame, _ = frame_for(s, depth)
        est = estimate_lighting(s.rgb, frame.label_ids, depth, s.camera, labelled=frame.labelled,
                               site=SunSite.of(s.vehicle))
        called[kind].append(est.sunny)
    assert called["sunny"] and called["overcast"]
    assert sum(called["sunny"]) >= SUNNY_FOUND_MIN * len(called["sunny"]), called
    assert sum(called["overcast"]) <= OVERCAST_SUNNY_MAX * len(called["overcast"]), called
