"""The compose draws the camera-match noise only in the tiles its shader can read
(compose.noise_tiles_read): the same bytes as with every tile drawn."""
from __future__ import annotations

import numpy as np

from synthcompose.camera import Camera
from synthcompose.compose import NOISE_TILE, Composer, SceneLayers, noise_tiles_read
from synthcompose.render import RenderPasses, Roi


def _brute(alpha: np.ndarray, roi: Roi, radius: int) -> frozenset:
    h, w = alpha.shape
    out = set()
    for y, x in zip(*np.nonzero(alpha != 0)):
        for yy in range(max(y - radius, 0), min(y + radius, h - 1) + 1):
            for xx in range(max(x - radius, 0), min(x + radius, w - 1) + 1):
                out.add(((yy + roi.y0) // NOISE_TILE, (xx + roi.x0) // NOISE_TILE))
    return frozenset(out)


def test_the_tiles_are_those_within_reach_of_coverage():
    rng = np.random.default_rng(2)
    for roi, radius in [(Roi(0, 0, 150, 90), 0), (Roi(37, 61, 150, 90), 3), (Roi(63, 127, 70, 40), 1)]:
        alpha = np.zeros((roi.height, roi.width), np.float16)
        for _ in range(5):
            y, x = int(rng.integers(0, roi.height)), int(rng.integers(0, roi.width))
            alpha[y:y + 3, x:x + 2] = rng.random()
        alpha[0, 0] = -0.0  # no coverage
        assert noise_tiles_read(alpha, roi, radius) == _brute(alpha, roi, radius)
    assert noise_tiles_read(np.zeros((5, 5), np.float32), Roi(0, 0, 5, 5), 2) == frozenset()


def test_the_compose_gives_the_bytes_of_every_tile_drawn(gl_clean, monkeypatch):
    import synthcompose.compose as compose_module
    from synthcompose.lighting import CameraMatch

    rng = np.random.default_rng(5)
    roi = Roi(40, 30, 230, 150)  # cuts 5 x 4 tiles, from inside the first
    w, h = roi.width, roi.height
    alpha = np.zeros((h, w), np.float32)
    alpha[20:60, 30:70] = rng.random((40, 40))
    alpha[120:140, 200:225] = 1.0
    size = (w, h)

    def rgba(a):
        return np.concatenate([a, np.ones(a.shape[:2] + (1,), np.float32)], -1).astype(np.float32)

    gl = gl_clean
    tex = {"irpv": gl.texture(size, 4, rgba(rng.random((h, w, 3))), dtype="f4"),
           "ir": gl.texture(size, 4, rgba(rng.random((h, w, 3))), dtype="f4"),
           "alpha": gl.texture(size, 1, alpha, dtype="f4"),
           "odepth": gl.texture(size, 1, alpha * 5.0, dtype="f4"),
           "plane": gl.texture(size, 2, np.dstack([np.full((h, w), 8.0), np.ones((h, w))]).astype(np.float32), dtype="f4"),
           "id": gl.texture(size, 1, (alpha > 0).astype(np.uint32), dtype="u4"),
           "id_depth": gl.texture(size, 1, np.full((h, w), 5.0, np.float32), dtype="f4"),
           "objc": gl.texture(size, 4, np.dstack([rng.random((h, w, 3)), alpha]).astype(np.float32), dtype="f4")}
    cam = Camera(500, 500, w / 2, h / 2, 0.2, 0, 0, 1.2, 0, 0, 0, w, h)
    passes = RenderPasses(roi, cam, tex, gl)
    H, W = roi.y0 + h + 10, roi.x0 + w + 10
    labels = rng.choice([7, 8, 11, 21], (H, W)).astype(np.uint8)
    scene = SceneLayers(rng.integers(0, 256, (H, W, 3), dtype=np.uint8), labels,
                        np.where(labels == 11, 11, 26004).astype(np.uint16), rng.integers(0, 5000, (H, W)).astype(np.uint16),
                        np.full((H, W), np.inf, np.float32), 0.2 * 500 * 256.0)
    every = frozenset((ty, tx) for ty in range(roi.y0 // NOISE_TILE, (roi.y0 + h - 1) // NOISE_TILE + 1)
                      for tx in range(roi.x0 // NOISE_TILE, (roi.x0 + w - 1) // NOISE_TILE + 1))
    comp = Composer(gl)
    for match in (CameraMatch((3.0, 3.0, 3.0), 0.0, 0.0, seed=4), CameraMatch((3.0, 3.0, 3.0), 1.5, 1.2, seed=4)):
        for rgb_only in (False, True):
            some = comp.compose_roi(passes, scene, [26], [26000], match, rgb_only=rgb_only)
            drawn = noise_tiles_read(alpha, roi, match.blur_radius)
            assert 0 < len(drawn) < len(every)
            monkeypatch.setattr(compose_module, "noise_tiles_read", lambda *_: every)
            full = comp.compose_roi(passes, scene, [26], [26000], match, rgb_only=rgb_only)
            monkeypatch.undo()
            for name in full:
                assert np.array_equal(some[name], full[name]), (name, match.blur_radius, rgb_only)
    for t in tex.values():
        gl.free(t)
