"""The footways found without labels on the real labelled frames (SYNTHCOMPOSE_REAL_ROOT; skipped
without): issue 30 asks a precision of at least 0.8 against the frames' own labels, so that a
person put on a found footway stands where people walk."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.labels import label_id
from synthcompose.placement.surfaces import SIDEWALK, find_surfaces

from ..real_root import REAL, needs_real

#: footway in Cityscapes' labels: sidewalk, and the paved parking strips and squares beyond a kerb
FOOTWAY = [label_id(n) for n in ("sidewalk", "parking", "ground")]
#: the least footway precision on each frame (issue 30)
FOOTWAY_PRECISION_MIN = 0.8


def _labelled() -> list:
    return find_image_sets(Path(REAL)) if REAL else []


@needs_real
@pytest.mark.parametrize("ident", _labelled(), ids=str)
def test_the_footway_found_without_labels_is_footway(ident):
    s = read_image_set(Path(REAL), ident)
    side = find_surfaces(s.disparity, s.rgb, s.camera).labels == SIDEWALK
    assert side.sum() > 1000
    precision = np.isin(s.label_ids[side], FOOTWAY).mean()
    assert precision >= FOOTWAY_PRECISION_MIN, (str(ident), round(float(precision), 3))
