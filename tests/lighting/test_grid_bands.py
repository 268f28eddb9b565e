"""The light estimate's cell means, made band by band of rows (memory), equal the whole frame's."""
import cv2
import numpy as np
import pytest

from synthcompose.lighting.grid import LEVEL_LUT, _cell_mean, _linear_cell_mean


@pytest.mark.parametrize("h, w, f", [(1024, 2048, 3), (1023, 2047, 5), (97, 130, 2), (64, 64, 1), (600, 800, 8)])
def test_banded_linear_cell_mean_is_the_whole_frames(h, w, f):
    rgb = np.random.default_rng(h + w + f).integers(0, 256, (h, w, 3), dtype=np.uint8)
    whole = _cell_mean(cv2.LUT(rgb, LEVEL_LUT), f)
    banded = _linear_cell_mean(rgb, f, band_cells=7)
    assert banded.dtype == whole.dtype and banded.shape == whole.shape
    assert np.array_equal(banded, whole)
