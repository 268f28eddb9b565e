"""The compose shader against a NumPy reference of the same formula, on small float buffers."""
import cv2
import numpy as np
import pytest

from synthcompose.camera import Camera
from synthcompose.colour import LUM, SRGB8_TO_LINEAR
from synthcompose.compose import Composer, SceneLayers, reference_compose
from synthcompose.render import RenderPasses, Roi

from ..tolerances import COMPOSE_MAX_ERR_8BIT

W, H = 37, 23  # odd sizes catch row-alignment mistakes
OBJ_DEPTH = 5.0


def _passes(gl, irpv, ir, alpha, obj_id, plane_cov=1.0):
    size = (W, H)
    rgba = lambda a: np.concatenate([a, np.ones(a.shape[:2] + (1,), np.float32)], -1)  # noqa: E731
    tex = {
        "irpv": gl.texture(size, 4, rgba(irpv).astype(np.float32), dtype="f4"),
        "ir": gl.texture(size, 4, rgba(ir).astype(np.float32), dtype="f4"),
        "alpha": gl.texture(size, 1, alpha.astype(np.float32), dtype="f4"),
        "odepth": gl.texture(size, 1, (alpha * OBJ_DEPTH).astype(np.float32), dtype="f4"),
        "plane": gl.texture(size, 2, np.dstack([np.full((H, W), 8.0 * plane_cov), np.full((H, W), plane_cov)])
                            .astype(np.float32), dtype="f4"),
        "id": gl.texture(size, 1, obj_id.astype(np.uint32), dtype="u4"),
        "id_depth": gl.texture(size, 1, np.full((H, W), OBJ_DEPTH, np.float32), dtype="f4"),
    }
    cam = Camera(500, 500, W / 2, H / 2, 0.2, 0, 0, 1.2, 0, 0, 0, W, H)
    return RenderPasses(Roi(0, 0, W, H), cam, tex, gl)


def _scene(rng, depth):
    labels = rng.choice([7, 8, 11, 21, 23], (H, W)).astype(np.uint8)
    return SceneLayers(
        rgb=rng.integers(0, 256, (H, W, 3), dtype=np.uint8), label_ids=labels,
        instance_ids=np.where(labels == 11, 11, 26004).astype(np.int32),
        disparity=rng.integers(0, 5000, (H, W)).astype(np.uint16),
        depth=np.full((H, W), depth, np.float32), disparity_scale=0.2 * 500 * 256.0)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_rgb_matches_numpy_reference_on_random_inputs(gl_clean, seed):
    rng = np.random.default_rng(seed)
    irpv = rng.random((H, W, 3), np.float32)
    ir = rng.random((H, W, 3), np.float32)
    alpha = rng.random((H, W)).astype(np.float32)
    alpha[rng.random((H, W)) < 0.2] = 0.0
    alpha[rng.random((H, W)) < 0.2] = 1.0
    obj_id = (alpha > 0.5).astype(np.uint32)
    scene = _scene(rng, np.inf)
    passes = _passes(gl_clean, irpv, ir, alpha, obj_id)
    out = Composer(gl_clean).compose_roi(passes, scene, [26], [26007])
    ref = reference_compose(scene.rgb, irpv, ir, alpha)
    err = np.abs(out["rgb"].astype(int) - ref.astype(int))
    assert err.max() <= COMPOSE_MAX_ERR_8BIT, f"max error {err.max()} at {np.unravel_index(err.argmax(), err.shape)}"
    # labels: object class exactly on its ID mask, unchanged elsewhere
    mask = obj_id > 0
    assert (out["label_ids"][mask] == 26).all()
    assert (out["label_ids"][~mask] == scene.label_ids[~mask]).all()
    assert (out["instance_ids"][mask] == 26007).all()
    assert (out["instance_ids"][~mask] == scene.instance_ids[~mask]).all()
    # disparity: the object's depth in the Cityscapes encoding; inside its silhouette (the pixel
    # and its 4 neighbours the object's) where 10 % or more of the photo shows through, the photo's
    expected = np.rint(scene.disparity_scale / OBJ_DEPTH) + 1
    padded = np.pad(mask, 1, mode="edge")
    inside = mask & padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
    through = inside & (alpha < 0.9)
    assert (out["disparity"][mask & ~through] == expected).all()
    assert (out["disparity"][through] == scene.disparity[through]).all()
    assert (out["disparity"][~mask] == scene.disparity[~mask]).all()
    assert ((out["visible"] > 0) == mask).all()


def test_real_scene_in_front_keeps_its_pixels(gl_clean):
    rng = np.random.default_rng(5)
    irpv = rng.random((H, W, 3), np.float32)
    ir = rng.random((H, W, 3), np.float32)
    alpha = np.ones((H, W), np.float32)
    scene = _scene(rng, OBJ_DEPTH - 1.0)  # everything real is 1 m in front of the object
    out = Composer(gl_clean).compose_roi(_passes(gl_clean, irpv, ir, alpha, np.ones((H, W))), scene, [26], [26000])
    assert (out["rgb"] == scene.rgb).all()
    assert (out["label_ids"] == scene.label_ids).all()
    assert (out["instance_ids"] == scene.instance_ids).all()
    assert (out["disparity"] == scene.disparity).all()
    assert (out["visible"] == 0).all()


def test_ego_vehicle_is_always_in_front(gl_clean):
    rng = np.random.default_rng(6)
    scene = _scene(rng, np.inf)
    labels = scene.label_ids.copy()
    labels[:, : W // 2] = 1  # ego vehicle, invalid disparity
    scene = SceneLayers(scene.rgb, labels, scene.instance_ids, scene.disparity, scene.depth, scene.disparity_scale)
    irpv = rng.random((H, W, 3), np.float32)
    out = Composer(gl_clean).compose_roi(
        _passes(gl_clean, irpv, irpv * 0.5, np.ones((H, W), np.float32), np.ones((H, W))), scene, [26], [26000])
    assert (out["rgb"][:, : W // 2] == scene.rgb[:, : W // 2]).all()
    assert (out["label_ids"][:, : W // 2] == 1).all()
    assert (out["label_ids"][:, W // 2:] == 26).all()


def test_shadow_only_where_the_plane_is_seen(gl_clean):
    """No object: R' = R + Irpv - Ir on the plane, R where there is no plane."""
    rng = np.random.default_rng(7)
    scene = _scene(rng, np.inf)
    ir = np.full((H, W, 3), 0.2, np.float32)
    irpv = ir * 0.5  # a shadow
    zero = np.zeros((H, W), np.float32)
    comp = Composer(gl_clean)
    with_plane = comp.compose_roi(_passes(gl_clean, irpv, ir, zero, zero), scene, [26], [26000])
    ref = reference_compose(scene.rgb, irpv, ir, zero)
    assert np.abs(with_plane["rgb"].astype(int) - ref).max() <= COMPOSE_MAX_ERR_8BIT
    without = comp.compose_roi(_passes(gl_clean, irpv, ir, zero, zero, plane_cov=0.0), scene, [26], [26000])
    assert (without["rgb"] == scene.rgb).all()


def test_through_an_objects_panes_the_photos_disparity_is_kept_and_the_label_is_the_objects(gl_clean):
    """Inside an object's silhouette where the photo shows through its panes (colour coverage
    under 0.9: docs/vehicles.md "Glass"), a camera sees through to the photo: its disparity is
    kept; the labels are the object's there too. Where the object covers all (a body, a pane in
    front of the interior) and at its silhouette's edge, the disparity is the object's."""
    rng = np.random.default_rng(5)
    scene = _scene(rng, np.inf)
    alpha = np.ones((H, W), np.float32)
    alpha[5:15, 5:25] = 0.5  # two panes: half of the photo shows through
    obj = np.ones((H, W))
    out = Composer(gl_clean).compose_roi(_passes(gl_clean, rng.random((H, W, 3), np.float32),
                                                 np.zeros((H, W, 3), np.float32), alpha, obj), scene, [26], [26000])
    written = np.uint16(np.floor(scene.disparity_scale / OBJ_DEPTH + 0.5) + 1)
    assert (out["label_ids"] == 26).all() and (out["instance_ids"] == 26000).all()
    assert (out["disparity"][6:14, 6:24] == scene.disparity[6:14, 6:24]).all()  # through the panes
    assert (out["disparity"][18:, :] == written).all()  # the body


def _random_passes(gl, rng, alpha):
    """The compose tests' passes of random colours over coverage ``alpha`` (test_compose's
    frame size), with the object's colour and coverage layer."""
    passes = _passes(gl, rng.random((H, W, 3), np.float32), rng.random((H, W, 3), np.float32), alpha,
                     (alpha > 0.5).astype(np.uint32))
    passes.textures["objc"] = gl.texture((W, H), 4, np.dstack([rng.random((H, W, 3)), alpha]).astype(np.float32),
                                         dtype="f4")
    return passes


def test_right_view_compose_gives_the_colour_of_the_full_one(gl_clean):
    from synthcompose.compose import Composer
    from synthcompose.lighting import CameraMatch

    rng = np.random.default_rng(9)
    alpha = rng.random((H, W)).astype(np.float32)
    alpha[:, : W // 2] = 0.0
    passes = _random_passes(gl_clean, rng, alpha)
    scene = _scene(rng, np.inf)
    comp = Composer(gl_clean)
    for match in (None, CameraMatch((2.0, 2.0, 2.0), 1.2, 1.0, seed=3)):
        full = comp.compose_roi(passes, scene, [26], [26000], match)
        right = comp.compose_roi(passes, scene, [26], [26000], match, rgb_only=True)
        assert set(right) == {"rgb"} and np.array_equal(full["rgb"], right["rgb"])


def test_banded_compose_gives_the_same_bytes(gl_clean, monkeypatch):
    import synthcompose.compose as compose_module
    from synthcompose.compose import Composer
    from synthcompose.lighting import CameraMatch
    from synthcompose.render import bands

    rng = np.random.default_rng(4)
    alpha = rng.random((H, W)).astype(np.float32)
    alpha[rng.random((H, W)) < 0.5] = 0.0
    passes = _random_passes(gl_clean, rng, alpha)
    # the real scene's layers, made for each band's rows, in front of the object and behind it
    # from pixel to pixel, over ground here and there
    plain = _scene(rng, np.inf)
    scene = SceneLayers(plain.rgb, plain.label_ids, plain.instance_ids, plain.disparity,
                        rng.uniform(OBJ_DEPTH - 2, OBJ_DEPTH + 2, (H, W)).astype(np.float32), plain.disparity_scale,
                        ground=rng.random((H, W)) < 0.3, ground_band=0.05)
    comp = Composer(gl_clean)
    for match in (None, CameraMatch((2.0, 2.0, 2.0), 1.2, 1.0, seed=3)):
        for rgb_only in (False, True):
            whole = comp.compose_roi(passes, scene, [26], [26000], match, rgb_only=rgb_only)
            monkeypatch.setattr(compose_module, "row_bands", lambda w, h, _n: bands.row_bands(w, h, 3 * W))
            banded = comp.compose_roi(passes, scene, [26], [26000], match, rgb_only=rgb_only)
            monkeypatch.undo()
            assert whole.keys() == banded.keys()
            for name in whole:
                assert np.array_equal(whole[name], banded[name]), (name, rgb_only)
            if not rgb_only:  # the object hidden in places, and the real scene's values kept there
                assert 0 < (whole["visible"] > 0).sum() < (alpha > 0).sum()
                kept = whole["visible"] == 0
                assert np.array_equal(whole["disparity"][kept], scene.disparity[kept])


def test_compose_writes_into_the_full_frame_arrays(gl_clean):
    """Composer.compose fills the region of copies of the frame's arrays in place: the same
    values as compose_roi's own arrays, the frame around the region as it was."""
    from synthcompose.compose import Composer

    rng = np.random.default_rng(6)
    alpha = rng.random((H, W)).astype(np.float32)
    alpha[rng.random((H, W)) < 0.4] = 0.0
    frame = _scene(rng, np.inf)
    big = SceneLayers(*(np.pad(a, ((3, 5), (4, 2)) + ((0, 0),) * (a.ndim - 2), mode="edge")
                        for a in (frame.rgb, frame.label_ids, frame.instance_ids, frame.disparity, frame.depth)),
                      disparity_scale=frame.disparity_scale)
    passes = _random_passes(gl_clean, rng, alpha)
    passes = RenderPasses(Roi(4, 3, W, H), passes.camera, passes.textures, gl_clean)
    comp = Composer(gl_clean)
    roi = comp.compose_roi(passes, big, [26], [26000])
    full = comp.compose(passes, big, [26], [26000])
    for name, arr in roi.items():
        out = getattr(full, name)
        before = np.zeros_like(out) if name == "visible" else getattr(big, name)
        assert out.dtype == before.dtype and np.array_equal(out[3:3 + H, 4:4 + W], arr), name
        outside = np.ones(out.shape[:2], bool)
        outside[3:3 + H, 4:4 + W] = False
        assert np.array_equal(out[outside], before[outside]), name


def test_a_fading_shadow_leaves_no_step_of_a_whole_level(gl_clean):
    """A darkening that fades out to nothing across the region, on a dark road (8-bit 60: one
    level is 3.6 % of its light): each column's mean luminance follows the darkening (no bias),
    the light changes from column to column by under half a level (rounded at random, not at
    one threshold: no straight step where the fade crosses half a level), every channel stays
    within one level of the exact composite, the luminance grain is under 0.3 of a level (the channels are rounded
    each on its own, the luminance kept), and the photo is kept where the darkening is nil."""
    rng = np.random.default_rng(11)
    scene = _scene(rng, np.inf)
    photo = np.full((H, W, 3), 60, np.uint8)
    scene = SceneLayers(photo, scene.label_ids, scene.instance_ids, scene.disparity, scene.depth, scene.disparity_scale)
    fade = np.clip(np.linspace(0.05, -0.01, W), 0.0, None).astype(np.float32)  # nil in the last columns
    lin = ((60 / 255.0 + 0.055) / 1.055) ** 2.4
    ir = np.full((H, W, 3), lin, np.float32)  # the plane reproduces the photo: R' = R * Irpv / Ir
    irpv = ir * (1.0 - fade)[None, :, None]
    zero = np.zeros((H, W), np.float32)
    out = Composer(gl_clean).compose_roi(_passes(gl_clean, irpv, ir, zero, zero), scene, [26], [26000])["rgb"]
    exact = reference_compose(photo, irpv, ir, zero).astype(np.float64)  # rounded to the nearest level
    want = np.array([((lin * (1 - f)) ** (1 / 2.4) * 1.055 - 0.055) * 255 for f in fade])  # levels, exact
    assert (np.abs(out.astype(np.float64) - want[None, :, None]) < 1.0 + 1e-6).all()
    y = cv2.LUT(out, SRGB8_TO_LINEAR).astype(np.float64) @ LUM  # linear luminance per pixel
    level = lin - ((59 / 255.0 + 0.055) / 1.055) ** 2.4  # one level down, in light
    got = y.mean(axis=0)
    assert np.abs(got - lin * (1 - fade)).max() < 0.1 * level, np.round((got - lin * (1 - fade)) / level, 3)
    between = [c for c, w in enumerate(want) if 0.2 < (60 - w) % 1.0 < 0.8]
    assert len(between) >= 8
    for c in between:  # fine grain: the colours a column mixes are less than a level apart in light
        assert y[:, c].std() < 0.3 * level, (c, y[:, c].std() / level)
    # no step: from column to column the mean light changes by under half a level
    assert np.abs(np.diff(got)).max() < 0.5 * level, np.round(np.diff(got) / level, 2)
    nil = fade == 0.0
    assert (out[:, nil] == photo[:, nil]).all() and (exact[:, nil] == 60).all()
