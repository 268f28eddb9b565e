"""The real scene's depth the compose tests the inserted objects and their shadows against
(stages.shade.occluders_in_rows): the matcher's specks on the ground are lifted to the road."""
import numpy as np

from synthcompose.stages.shade import GROUND_SPECK, occluders_in_rows

H, W = 40, 60


def _road_with_specks():
    """A road whose depth grows with the distance up the image, a real car on it (nearer, not
    ground), and specks of a few pixels a metre nearer than the road around them."""
    depth = np.repeat(np.linspace(30.0, 8.0, H, dtype=np.float32)[:, None], W, axis=1)
    ground = np.ones((H, W), bool)
    car = (slice(5, 20), slice(40, 55))
    depth[car] = 6.0
    ground[car] = False
    specks = np.zeros((H, W), bool)
    for y, x, n in ((25, 10, 2), (30, 20, GROUND_SPECK - 2), (12, 15, 3)):
        specks[y:y + 2, x:x + n] = True
    road = depth.copy()
    depth[specks] -= 1.0
    return depth, ground, car, specks, road


def test_the_grounds_specks_take_the_roads_depth_and_nothing_comes_nearer():
    """A speck a metre nearer than the road hid the inserted shadow on it (bright dots in the
    shadow under a car, hamburg_000000 of the labelled frames): the compose now sees the road's
    depth there. The road keeps its slope, the real car its depth, and no ground pixel comes
    nearer (the real ground hides no more of an object than before)."""
    depth, ground, car, specks, road = _road_with_specks()
    out, out_ground = occluders_in_rows(depth, [slice(0, H)], ground, np.zeros((H, W), bool))
    assert np.allclose(out[specks], road[specks], atol=1e-4)
    inner = np.zeros((H, W), bool)  # away from the image's border, past which the closing reads nothing
    inner[GROUND_SPECK:-GROUND_SPECK, GROUND_SPECK:-GROUND_SPECK] = True  # (Cityscapes: the ego vehicle's bonnet)
    far_from_car = ground & inner
    far_from_car[0:20 + GROUND_SPECK, 40 - GROUND_SPECK:] = False
    assert np.allclose(out[far_from_car & ~specks], road[far_from_car & ~specks], atol=1e-4)
    assert (out[car] == 6.0).all()
    assert (out[ground] >= depth[ground] - 1e-6).all()
    assert (out_ground == ground).all()


def test_rows_outside_the_bands_are_left_unread():
    """Only the rows the compose reads are filled and cleaned; the others stay unknown."""
    depth, ground, _, _, _ = _road_with_specks()
    out, _ = occluders_in_rows(depth, [slice(10, 20)], ground, np.zeros((H, W), bool))
    assert np.isinf(out[:10]).all() and np.isinf(out[20:]).all() and np.isfinite(out[10:20]).all()
