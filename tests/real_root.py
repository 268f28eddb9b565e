"""The real Cityscapes root the real-frame tests read (SYNTHCOMPOSE_REAL_ROOT), and their skip
marker: CI has none, and real pixels never enter the repository."""
from __future__ import annotations

import os

import pytest

REAL = os.environ.get("SYNTHCOMPOSE_REAL_ROOT")
needs_real = pytest.mark.skipif(not REAL, reason="SYNTHCOMPOSE_REAL_ROOT (a labelled Cityscapes root) not set")

#: the street frames labelled sunny / overcast by eye (unlabelled frames: left photo, disparity,
#: camera) and their labels file: SYNTHCOMPOSE_STREETS_ROOT, SYNTHCOMPOSE_SUN_LABELS
STREETS = os.environ.get("SYNTHCOMPOSE_STREETS_ROOT")
SUN_LABELS = os.environ.get("SYNTHCOMPOSE_SUN_LABELS")
needs_streets = pytest.mark.skipif(not (STREETS and SUN_LABELS),
                                   reason="SYNTHCOMPOSE_STREETS_ROOT and SYNTHCOMPOSE_SUN_LABELS not set")
