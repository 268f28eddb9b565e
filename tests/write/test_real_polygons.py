"""Polygons of real Cityscapes frames (root from SYNTHCOMPOSE_REAL_ROOT, a labelled root; skipped
without it, as in CI): the frame's own labelIds and instanceIds, described by
:func:`frame_polygons`, draw back to themselves with cityscapesScripts (whose own polygons
made them). Outputs are never written into the repository."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.write.polygons import frame_polygons

from ..helpers import drawn_back
from ..real_root import REAL, needs_real
from ..tolerances import INSTANCES_DRAWN_BACK, LABELS_DRAWN_BACK

pytestmark = needs_real


def test_real_frames_labels_draw_back_from_their_polygons():
    root = Path(REAL)
    for ident in find_image_sets(root)[:8]:
        src = read_image_set(root, ident)
        if not src.labelled:
            continue
        labels, instances = drawn_back(frame_polygons(src.label_ids, src.instance_ids), src.label_ids.shape)
        assert (labels == src.label_ids).mean() >= LABELS_DRAWN_BACK, ident
        assert (instances == src.instance_ids.astype(np.int64)).mean() >= INSTANCES_DRAWN_BACK, ident
        # the real frames were drawn from polygons: a description of them misses almost nothing
        assert (labels != src.label_ids).sum() <= 1e-4 * labels.size, ident
