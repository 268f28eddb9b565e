"""The real Cityscapes root the real-frame tests read (SYNTHCOMPOSE_REAL_ROOT), and their skip
marker: CI has none, and real pixels never enter the repository."""
from __future__ import annotations

import os

import pytest

REAL = os.environ.get("SYNTHCOMPOSE_REAL_ROOT")
needs_real = pytest.mark.skipif(not REAL, reason="SYNTHCOMPOSE_REAL_ROOT (a labelled Cityscapes root) not set")
