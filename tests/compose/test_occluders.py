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


def test_level_ground_the_finder_left_unnamed_is_ground_to_the_compose():
    """A frame without labels: a flat street seen by a level camera, its road found but a
    footway beside it left unnamed (label 0, as a leafy one is), with a speck of the matcher's a
    metre nearer on it. On the labels the light is measured on (the found surfaces completed from
    the depth) the footway is ground: the compose's band over ground applies there and its
    speck takes the ground's depth; on the found labels alone it would hide the shadow there."""
    from synthcompose.camera import Camera
    from synthcompose.labels import label_id
    from synthcompose.lighting.plan import completed_labels
    from synthcompose.stages.shade import ground_occluders

    h, w = 128, 256
    cam = Camera(fx=283.0, fy=283.0, u0=128.0, v0=40.0, baseline=0.22, x=1.7, y=0.0, z=1.22, yaw=0.0,
                 pitch=0.0, roll=0.0, width=w, height=h)
    rows = np.arange(h, dtype=np.float32)[:, None]
    with np.errstate(divide="ignore"):
        depth = np.where(rows > cam.v0 + 2, cam.fy * cam.z / (rows - cam.v0), np.inf).repeat(w, axis=1)
    depth = depth.astype(np.float32)
    found = np.where(np.isfinite(depth), label_id("road"), 0).astype(np.uint8)
    footway = (slice(60, h), slice(190, 240))
    found[footway] = 0
    speck = (slice(80, 83), slice(200, 205))
    flat = depth.copy()
    depth[speck] -= 1.0
    completed = completed_labels(found, depth, cam)
    bands = [slice(0, h)]
    occluders, ground = ground_occluders(depth, bands, completed)
    assert ground[footway].all()
    assert np.allclose(occluders[speck], flat[speck], atol=1e-3)
    _, ground_found = ground_occluders(depth, bands, found)
    assert not ground_found[footway].any()


def test_rows_worked_out_a_few_at_a_time_give_the_same_values(monkeypatch):
    """occluders_in_rows works OCCLUDER_ROWS rows at a time (its temporaries): the holes are
    filled along rows and the closing reads GROUND_SPECK rows around, so any number of rows at
    once gives the same depth and ground, holes, specks and unlabelled pixels included."""
    import importlib

    shade_module = importlib.import_module("synthcompose.stages.shade")  # (the package names its function shade)
    rng = np.random.default_rng(3)
    depth, ground, _, _, _ = _road_with_specks()
    depth[rng.random((H, W)) < 0.15] = np.inf  # the matcher's holes
    unlabelled = rng.random((H, W)) < 0.2
    ground &= rng.random((H, W)) > 0.1
    bands = [slice(4, 23), slice(17, 37)]
    whole = occluders_in_rows(depth, bands, ground, unlabelled)
    for rows in (1, 5, 13):
        monkeypatch.setattr(shade_module, "OCCLUDER_ROWS", rows)
        parts = occluders_in_rows(depth, bands, ground, unlabelled)
        assert np.array_equal(parts[0], whole[0]) and np.array_equal(parts[1], whole[1]), rows
    assert np.isfinite(whole[0][4:37]).any() and (whole[1][4:37] != ground[4:37]).any()  # holes filled, ground grown
