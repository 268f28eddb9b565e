"""The camera-match noise (compose.frame_noise) is fixed by each pixel's place in the frame."""
from __future__ import annotations

import numpy as np

from synthcompose.compose import NOISE_TILE, frame_noise


def test_a_region_a_pixel_larger_keeps_every_other_pixels_noise():
    """A pose a hair different (another CPU's arithmetic) may grow an object's region by a
    pixel: the noise of the pixels both regions hold is the same, so the photo moves by the
    pixels that changed and no others."""
    a = frame_noise(7, slice(40, 140), slice(100, 300))
    b = frame_noise(7, slice(39, 140), slice(100, 301))
    assert np.array_equal(a, b[1:, :-1])


def test_the_noise_is_seeded_standard_normal_and_joins_across_tiles():
    n = frame_noise(3, slice(0, 4 * NOISE_TILE), slice(0, 4 * NOISE_TILE))
    assert np.array_equal(n, frame_noise(3, slice(0, 4 * NOISE_TILE), slice(0, 4 * NOISE_TILE)))
    assert not np.array_equal(n, frame_noise(4, slice(0, 4 * NOISE_TILE), slice(0, 4 * NOISE_TILE)))
    assert abs(float(n.mean())) < 0.02 and abs(float(n.std()) - 1.0) < 0.02
    # bands of one region (a large region is rendered in bands) give the region's noise
    top, bottom = frame_noise(3, slice(10, 90), slice(5, 200)), frame_noise(3, slice(90, 170), slice(5, 200))
    assert np.array_equal(np.vstack([top, bottom]), frame_noise(3, slice(10, 170), slice(5, 200)))


def test_the_compose_bands_noise_is_the_regions_each_tile_drawn_once(monkeypatch):
    """The compose makes the noise band by band (compose._BandNoise): the bands' rows stacked are
    the region's noise, a tile the bands' edge cuts is drawn once, and the tiles above the band
    being composed are let go."""
    from synthcompose import compose

    rows, cols = slice(37, 37 + 300), slice(100, 230)
    whole = frame_noise(9, rows, cols)
    drawn = []
    real_rng = np.random.default_rng
    monkeypatch.setattr(compose.np.random, "default_rng", lambda key: drawn.append(tuple(key)) or real_rng(key))
    noise = compose._BandNoise(9, rows, cols)
    bands = [(0, 50), (50, 170), (170, 171), (171, 300)]
    got = []
    for y0, y1 in bands:
        got.append(noise.rows(y0, y1))
        assert all(ty >= (rows.start + y1) // NOISE_TILE for ty, _ in noise.tiles)
    assert np.array_equal(np.vstack(got), whole)
    assert len(drawn) == len(set(drawn))  # no tile twice
    tile_rows = range(rows.start // NOISE_TILE, (rows.stop - 1) // NOISE_TILE + 1)
    tile_cols = range(cols.start // NOISE_TILE, (cols.stop - 1) // NOISE_TILE + 1)
    assert len(drawn) == len(tile_rows) * len(tile_cols)
