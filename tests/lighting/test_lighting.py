"""Light estimation (lighting.py) and camera match (compose.py) on generated scenes with a known
light (synthetic.SceneLight: shading in linear light, cast shadows), the manifest's lighting modes,
the record and the compare-lighting command."""
from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcompose import lighting
from synthcompose.camera import Camera
from synthcompose.cli import main
from synthcompose.colour import srgb_to_linear
from synthcompose.compose import Composer, SceneLayers
from synthcompose.errors import ManifestError
from synthcompose.geometry.depth import disparity_to_depth
from synthcompose.lighting import GROUND_IDS, LUM, estimate_lighting
from synthcompose.lighting.camera_match import BOX_EDGE_SIGMA, RENDER_BLUR_SIGMA, CameraMatch, estimate_blur, estimate_noise
from synthcompose.manifest import parse_manifest
from synthcompose.render import RenderPasses, Roi
from synthcompose.synthetic import SceneLight, make_sample, random_scene, render_scene, render_scene_sunlit
from synthcompose.synthetic.photo import recorded_colour

from ..tolerances import (
    BLUR_ESTIMATE_REL,
    COMPOSE_NOISE_MEAN_8BIT,
    COMPOSE_NOISE_SIGMA_REL,
    CONFIDENCE_MIN,
    LIGHT_CHROMA_REL,
    LIGHTING_FLOAT_ABS,
    NOISE_ESTIMATE_REL,
    OBJECT_BLUR_REL,
    RECORDED_NOISE_REL,
    SHADOW_LINE_AZIMUTH_DEG,
    SHADOW_LINE_DEG,
    SHARP_OBJECT_BLUR_PX,
    SKY_SHARE_ABS,
    SUN_AZIMUTH_DEG,
    SUN_AZIMUTH_MEDIAN_DEG,
    SUN_AZIMUTH_WITHIN_SHARE,
    SUN_FOUND_MIN,
    SUN_FOUND_SUNLIT_SHARE,
    SUN_MASK_GROUND_MAX,
)

#: The sun's direction and share are still checked on exact geometry and the clean shading
#: (their cues - pairs of faces, shadow edges - need normals that real stereo gives only at
#: short range); the ambient light, what an overcast frame and every object in shadow get, is
#: checked on frames that measure like real ones (REAL_STEREO, REAL_PHOTO: the generator's
#: SGM-like disparity and camera look), as on the real development set.
LIGHT_STEREO, LIGHT_PHOTO = "exact", "clean"
REAL_STEREO, REAL_PHOTO = "realistic", "realistic"

W, H = 640, 320
SKY_TINT, SUN_TINT = (0.9, 0.97, 1.12), (1.08, 1.0, 0.9)  # bluish sky, warm sun
ASSETS = Path(__file__).resolve().parents[2] / "assets" / "models"


def chroma(rgb) -> np.ndarray:
    c = np.asarray(rgb, float)
    return c / (c @ LUM)


def chroma_error(estimated, true) -> float:
    """Largest relative error of a colour's chromaticity (both scaled to luminance 1)."""
    return float(np.abs(chroma(estimated) / chroma(true) - 1.0).max())


def azimuth_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def estimate(seed: int, light: SceneLight | None, stereo: str = LIGHT_STEREO, photo: str = LIGHT_PHOTO,
             size: tuple[int, int] = (W, H)):
    scene = random_scene(np.random.default_rng(seed), *size, light=light)
    arrays = render_scene(scene, stereo=stereo, photo=photo)
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    return estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera), arrays, scene


def recorded(tint, scene) -> np.ndarray:
    """The colour a light of ``tint`` has once this scene's camera records it."""
    return recorded_colour(tint, scene.noise_seed)


# ------------------------------------------------------------------ the light
@pytest.mark.parametrize("seed, azimuth, elevation", [(1, -150.0, 45.0), (2, 150.0, 40.0), (3, 60.0, 50.0)])
def test_sunny_scene_gives_the_sun_its_share_and_the_colours(seed, azimuth, elevation):
    light = SceneLight(sun_azimuth_deg=azimuth, sun_elevation_deg=elevation, sun_fraction=0.65,
                       sky_tint=SKY_TINT, sun_tint=SUN_TINT)
    est, _, _ = estimate(seed, light)
    assert est.sunny
    assert abs(est.sky_share - (1 - light.sun_fraction)) <= SKY_SHARE_ABS  # relative intensity of the ambient
    assert chroma_error(est.sky_rgb, SKY_TINT) <= LIGHT_CHROMA_REL  # the ambient's colour, from the shadows
    assert chroma_error(est.sun_rgb, SUN_TINT) <= LIGHT_CHROMA_REL  # the sun's, lit minus shadow
    # the renderer's light follows the Lighting convention: 1 on an up-facing unshadowed surface
    lt = est.to_lighting()
    up = np.asarray(lt.sky_rgb) + np.asarray(lt.sun_rgb) * lt.sun_direction[2]
    assert up @ LUM == pytest.approx(1.0, abs=LIGHTING_FLOAT_ABS)
    assert np.asarray(lt.sun_rgb) @ LUM * lt.sun_direction[2] == pytest.approx(est.sun_fraction, abs=LIGHTING_FLOAT_ABS)


@pytest.mark.slow
def test_sun_azimuth_over_random_sunny_scenes():
    """The sun's direction, over 48 generated scenes with a sun anywhere round the camera (as
    benchmarks/eval_lighting.py measures it): where the ground in view shows cast shadows, is
    all lit under a clear shading sun, or all in the shadow of walls the sun lights, the sun is
    found, and its azimuth is mostly within 20 degrees. Measured on these scenes: found in 39,
    33 of them within 20 degrees, median error 2.8 degrees (before the shaded-ground sun and
    the straight shadow edges: found in 30, 25 within 20 degrees, median 5; before the casters'
    shadows: 26, 21; before the lit-ground sun: 18, 15; with the earlier pair weights, kerbs at
    full weight: 6 of 17).

    An object placed on ground the sun does not reach is lit by the sky alone, whatever the
    sun's direction; so the scenes that matter most are those whose ground in view the sun
    reaches (more than 10 % of its pixels, from the generator's own visibility): 27 of the 48.
    Measured: the sun found in 26 of them, 24 within 20 degrees (before the straight shadow
    edges: 25, 22; before the casters' shadows: 22, 19). Of the other 21, the sun is found in
    13 (9 within 20 degrees), 8 of them with the ground marked in shadow."""
    rng = np.random.default_rng(77)
    errors, found, sunlit_ground = [], 0, []  # the last: (found, error) where the ground is sunlit
    for seed in range(300, 348):
        azimuth, elevation = float(rng.uniform(-180, 180)), float(rng.uniform(20, 65))
        light = SceneLight(sun_azimuth_deg=azimuth, sun_elevation_deg=elevation,
                           sun_fraction=float(rng.uniform(0.5, 0.75)))
        scene = random_scene(np.random.default_rng(seed), W, H, light=light)
        arrays, sunlit = render_scene_sunlit(scene, stereo=LIGHT_STEREO, photo=LIGHT_PHOTO)
        depth = disparity_to_depth(arrays["disparity"], scene.camera)
        est = estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera)
        error = azimuth_error(est.sun_azimuth_deg, azimuth)
        if est.sunny:
            found += 1
            errors.append(error)
        ground = np.isin(arrays["label_ids"], GROUND_IDS)
        if ground.any() and sunlit[ground].mean() > 0.10:
            sunlit_ground.append((est.sunny, error))
    errors = np.array(errors)
    assert found >= SUN_FOUND_MIN
    assert np.mean(errors <= SUN_AZIMUTH_DEG) >= SUN_AZIMUTH_WITHIN_SHARE, np.round(errors)
    assert np.median(errors) <= SUN_AZIMUTH_MEDIAN_DEG
    assert len(sunlit_ground) >= 20  # the generator gives scenes of both kinds
    lit_found = [e for f, e in sunlit_ground if f]
    assert len(lit_found) >= SUN_FOUND_SUNLIT_SHARE * len(sunlit_ground), sunlit_ground
    within = sum(e <= SUN_AZIMUTH_DEG for e in lit_found)
    assert within >= SUN_AZIMUTH_WITHIN_SHARE * len(sunlit_ground), sunlit_ground


def test_straight_shadow_edge_decides_the_sun_azimuth(monkeypatch):
    """Walls facing across the street tell how far the sun stands to one side for its height,
    hardly its azimuth: here the shading alone picks a direction 50 degrees off. The shadow of a
    building's corner, out of view, has a straight edge on the road along the sun's azimuth."""
    light = SceneLight(sun_azimuth_deg=55.0, sun_elevation_deg=60.0, sun_fraction=0.74)
    scene = random_scene(np.random.default_rng(1006), 1024, 512, light=light)
    arrays = render_scene(scene, stereo=LIGHT_STEREO, photo=LIGHT_PHOTO)
    depth = disparity_to_depth(arrays["disparity"], scene.camera)

    def error(est) -> float:
        return abs((est.sun_azimuth_deg - 55.0 + 180.0) % 360.0 - 180.0)

    est = estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera)
    assert est.sunny and est.cues["shadow_line_sun"]
    assert abs((est.cues["shadow_line"][0] - 55.0 + 90.0) % 180.0 - 90.0) <= SHADOW_LINE_DEG
    assert error(est) <= SHADOW_LINE_AZIMUTH_DEG
    monkeypatch.setattr(lighting.lines, "LINE_MIN_LENGTH", math.inf)
    without = estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera)
    assert not without.cues["shadow_line_sun"] and error(without) > SUN_AZIMUTH_DEG


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_overcast_scene_is_overcast(seed):
    """On a frame that measures like a real one: the estimate rests on evidence (the ground),
    finds no sun, and the ambient colour is the light's as the camera records it (within 10 %)."""
    est, _, scene = estimate(seed, SceneLight(sun_fraction=0.0), REAL_STEREO, REAL_PHOTO, (1024, 512))
    assert "ground" in est.evidence and est.to_dict()["fallback"] is False
    assert not est.sunny and est.confidence >= CONFIDENCE_MIN
    assert est.sun_fraction == 0.0 and est.sky_share == 1.0
    assert chroma_error(est.sky_rgb, recorded((1.0, 1.0, 1.0), scene)) <= LIGHT_CHROMA_REL
    lt = est.to_lighting()
    assert max(lt.sun_rgb) == 0.0
    assert np.asarray(lt.sky_rgb) @ LUM == pytest.approx(1.0, abs=LIGHTING_FLOAT_ABS)


@pytest.mark.parametrize("seed, azimuth, elevation", [(1, -150.0, 45.0), (2, 150.0, 40.0), (3, 60.0, 50.0)])
def test_cast_shadows_on_frames_that_measure_like_real_ones(seed, azimuth, elevation):
    """Realistic stereo and photo: the ground's two levels show the sun and its share, with the
    evidence recorded; where nothing shows its direction the sun is put high (a short shadow)."""
    light = SceneLight(sun_azimuth_deg=azimuth, sun_elevation_deg=elevation, sun_fraction=0.65)
    est, _, _ = estimate(seed, light, REAL_STEREO, REAL_PHOTO, (1024, 512))
    assert est.sunny and "ground" in est.evidence and est.confidence >= CONFIDENCE_MIN
    assert abs(est.sky_share - (1 - light.sun_fraction)) <= SKY_SHARE_ABS
    if not est.cues["sun_direction_sure"]:
        assert est.sun_elevation_deg >= lighting.estimate.UNSURE_ELEVATION


@pytest.mark.parametrize("tint", [(0.8, 0.95, 1.3), (1.25, 1.0, 0.75)])
def test_tinted_ambient_colour(tint):
    est, _, scene = estimate(4, SceneLight(sun_fraction=0.0, sky_tint=tint), REAL_STEREO, REAL_PHOTO, (1024, 512))
    assert not est.sunny and est.evidence
    assert chroma_error(est.sky_rgb, recorded(tint, scene)) <= LIGHT_CHROMA_REL
    assert chroma_error(est.to_lighting().sky_rgb, recorded(tint, scene)) <= LIGHT_CHROMA_REL
    # on exact geometry and the clean shading, the light's own colour
    clean, _, _ = estimate(4, SceneLight(sun_fraction=0.0, sky_tint=tint))
    assert chroma_error(clean.sky_rgb, tint) <= LIGHT_CHROMA_REL


def test_directional_shading_without_cast_shadows_gives_the_ground_no_sun():
    """The default generator shades with a sun but draws no cast shadows: nothing the inserted
    objects stand on shows a shadow, so they get ambient light only (and no shadow of their own
    that the real objects lack): either no sun, or one that does not reach the ground in view."""
    est, arrays, _ = estimate(0, None)
    ground = np.isin(arrays["label_ids"], GROUND_IDS)
    mask = est.sun_mask(arrays["rgb"], arrays["label_ids"])
    assert not est.sunny or mask[ground].mean() <= SUN_MASK_GROUND_MAX


def test_sun_that_leaves_the_ground_in_shadow():
    """A low sun from the side, behind the buildings: the ground in view is all in their shadow,
    the walls facing the sun are lit. The sun is found from the walls' shading; the ground is
    marked in shadow, so an object standing on it gets no sun and casts no sun shadow."""
    light = SceneLight(sun_azimuth_deg=120.0, sun_elevation_deg=30.0, sun_fraction=0.65)
    scene = random_scene(np.random.default_rng(1), W, H, light=light)
    arrays, sunlit = render_scene_sunlit(scene, stereo=LIGHT_STEREO, photo=LIGHT_PHOTO)
    ground = np.isin(arrays["label_ids"], GROUND_IDS)
    assert sunlit[ground].mean() < 0.02  # the scene is what the test is about
    depth = disparity_to_depth(arrays["disparity"], scene.camera)
    est = estimate_lighting(arrays["rgb"], arrays["label_ids"], depth, scene.camera)
    assert est.sunny and est.cues["shaded_ground_sun"]
    assert abs((est.sun_azimuth_deg - 120.0 + 180.0) % 360.0 - 180.0) <= SUN_AZIMUTH_DEG
    mask = est.sun_mask(arrays["rgb"], arrays["label_ids"])
    assert mask[ground].mean() <= SUN_MASK_GROUND_MAX
    road = srgb_to_linear(np.median(arrays["rgb"][arrays["label_ids"] == 7], axis=0) / 255.0)
    assert est.sun_visibility(7, road) == 0.0
    assert 0.0 < est.sun_fraction < 1.0


def test_objects_in_a_real_shadow_get_no_sun():
    light = SceneLight(sun_azimuth_deg=-150.0, sun_elevation_deg=45.0, sun_fraction=0.65)
    est, arrays, _ = estimate(1, light)
    assert est.sunny
    levels = dict(est.ground_levels)
    lit = levels[7]  # road, lit
    grey = np.ones(3) / (np.ones(3) @ LUM)
    assert est.sun_visibility(7, grey * lit) == 1.0
    assert est.sun_visibility(7, grey * lit * math.exp(est.shadow_log_ratio)) == 0.0
    assert 0.0 < est.sun_visibility(7, grey * lit * math.exp(est.shadow_log_ratio / 2)) < 1.0
    overcast, _, _ = estimate(1, SceneLight(sun_fraction=0.0))
    assert overcast.sun_visibility(7, grey * 0.01) == 1.0


def test_a_footway_darker_than_the_roads_shadow_lies_in_shadow():
    """No paving is darker than asphalt in the shade: a footway measured below the road's shadow
    level was measured in shadow (leverkusen_000038: the houses' shade all along the footway,
    the sun on the road), and what stands there gets no sun; a kind above it is read as before."""
    from dataclasses import replace

    from synthcompose.lighting.estimate import kinds_in_shade

    step = math.log(0.4)
    levels = dict(kinds_in_shade(((7, 0.1), (8, 0.015), (22, 0.06)), step))
    assert levels[7] == 0.1 and levels[22] == 0.06
    assert levels[8] == pytest.approx(0.015 / 0.4)
    assert kinds_in_shade(((8, 0.015),), step) == ((8, 0.015),)  # no road to read against
    assert kinds_in_shade(((7, 0.1), (8, 0.015)), 0.0) == ((7, 0.1), (8, 0.015))
    light = SceneLight(sun_azimuth_deg=-150.0, sun_elevation_deg=45.0, sun_fraction=0.65)
    est, _, _ = estimate(1, light)
    est = replace(est, shadow_log_ratio=step, ground_levels=tuple(levels.items()), ground_shadowed=False)
    grey = np.ones(3) / (np.ones(3) @ LUM)
    assert est.sun_visibility(8, grey * 0.015) == 0.0  # the footway as it was measured: in shadow
    assert est.sun_visibility(8, grey * 0.015 / 0.4) == 1.0  # a sunlit patch of it
    assert est.sun_visibility(22, grey * 0.06) == 1.0


def test_the_sun_mask_reads_unlabelled_pixels_against_the_roads_level():
    """Pixels no label names (no disparity at the left border, ground the surfaces left out):
    in a real shadow they get no sun, as the road beside them does, so an inserted shadow is not
    drawn there in full (a dark patch cut along the disparity's border, specks in the road's
    holes); lit ones get it."""
    light = SceneLight(sun_azimuth_deg=-150.0, sun_elevation_deg=45.0, sun_fraction=0.65)
    est, _, _ = estimate(1, light)
    assert est.sunny and not est.ground_shadowed
    lit = dict(est.ground_levels)[7]
    shade = lit * math.exp(est.shadow_log_ratio)
    level = np.array([[shade, shade, lit, lit]], np.float32).repeat(8, axis=0).repeat(8, axis=1)
    lut = np.asarray(lighting.light.LEVEL_LUT, np.float32)  # a grey byte's linear luminance
    rgb = np.searchsorted(lut, level).clip(0, 255).astype(np.uint8)[..., None].repeat(3, axis=2)
    labels = np.array([[7, 0, 7, 0]], np.uint8).repeat(8, axis=0).repeat(8, axis=1)
    mask = est.sun_mask(rgb, labels)
    middle = mask[4, 4::8]  # the middle row, one pixel of each block away from the blocks' borders
    assert middle[0] == pytest.approx(0.0) and middle[1] == pytest.approx(0.0), middle
    assert middle[2] == pytest.approx(1.0) and middle[3] == pytest.approx(1.0), middle


def test_estimate_is_deterministic_and_recordable():
    light = SceneLight(sun_azimuth_deg=150.0, sun_elevation_deg=40.0, sun_fraction=0.65)
    a, _, _ = estimate(2, light)
    b, _, _ = estimate(2, light)
    assert a == b and a.cues == b.cues
    record = json.loads(json.dumps(a.to_dict()))
    assert record["mode"] == "estimate" and record["sunny"] is True
    assert set(record) >= {"sun_azimuth_deg", "sun_elevation_deg", "sun_fraction", "sky_rgb", "sun_rgb",
                           "ground_rgb", "confidence", "exposure", "cues"}


# ------------------------------------------------------------------ camera: noise and blur
def _smooth_image(seed: int = 0) -> np.ndarray:
    """Flat patches, gentle gradients and a few sharp anti-aliased edges (box-filtered 4x)."""
    rng = np.random.default_rng(seed)
    big = np.zeros((H * 4, W * 4, 3), np.uint8)
    yy, xx = np.mgrid[0:H * 4, 0:W * 4]
    for c in range(3):
        big[..., c] = (60 + 80 * xx / (W * 4) + 40 * yy / (H * 4) + 10 * c).astype(np.uint8)
    for _ in range(25):
        pts = (rng.random((4, 2)) * [W * 4, H * 4]).astype(np.int32)
        cv2.fillPoly(big, [cv2.convexHull(pts)], tuple(int(v) for v in rng.integers(30, 220, 3)))
    return cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA)


@pytest.mark.parametrize("sigma", [2.0, 5.0])
def test_noise_estimate_within_20_percent(sigma):
    base = _smooth_image().astype(np.float32)
    noisy = np.clip(np.rint(base + np.random.default_rng(1).normal(0, sigma, base.shape)), 0, 255).astype(np.uint8)
    est = estimate_noise(noisy)
    expected = math.sqrt(sigma ** 2 + 1 / 12)  # plus the 8-bit rounding
    assert np.all(np.abs(est / expected - 1) <= NOISE_ESTIMATE_REL), est


def test_noise_estimate_of_a_generated_photo():
    # the generator adds N(0, 1.6) per channel and N(0, 1.4) to all channels, then rounds
    _, arrays, _ = estimate(3, SceneLight(sun_fraction=0.0))
    expected = math.sqrt(1.6 ** 2 + 1.4 ** 2 + 1 / 12)
    assert np.all(np.abs(estimate_noise(arrays["rgb"]) / expected - 1) <= NOISE_ESTIMATE_REL)


def test_blur_estimate_grows_with_blur():
    img = _smooth_image(2).astype(np.float32)
    found = []
    for sigma in (0.0, 0.7, 1.4, 2.1):
        blurred = img if sigma == 0 else cv2.GaussianBlur(img, (0, 0), sigma)
        found.append(estimate_blur(np.clip(np.rint(blurred), 0, 255).astype(np.uint8)))
        # a Gaussian adds in quadrature to the sharp edges' own measure
        assert found[-1] == pytest.approx(math.hypot(BOX_EDGE_SIGMA, sigma), rel=BLUR_ESTIMATE_REL)
    assert all(b > a for a, b in zip(found, found[1:])), found
    match = CameraMatch.measure(np.clip(np.rint(cv2.GaussianBlur(img, (0, 0), 1.4)), 0, 255).astype(np.uint8))
    # the object layer gets what the photo has beyond the renderer's own edges
    expected = math.sqrt(math.hypot(BOX_EDGE_SIGMA, 1.4) ** 2 - RENDER_BLUR_SIGMA ** 2)
    assert match.object_blur_sigma == pytest.approx(expected, rel=OBJECT_BLUR_REL)
    # an ideal photo (box-filtered edges): just what lifts the renderer's edges to a box edge's
    sharp = math.sqrt(BOX_EDGE_SIGMA ** 2 - RENDER_BLUR_SIGMA ** 2)
    assert CameraMatch.measure(_smooth_image(2)).object_blur_sigma == pytest.approx(sharp, abs=SHARP_OBJECT_BLUR_PX)


# ------------------------------------------------------------------ camera: the compose pass
RW, RH = 41, 29


def _object_passes(gl):
    """A flat grey object (colour 0.3) in the middle of the ROI, with a half-covered rim; the
    plane has no shadow (Irpv = Ir outside the object)."""
    alpha = np.zeros((RH, RW), np.float32)
    alpha[9:20, 12:29] = 1.0
    rim = np.zeros_like(alpha, bool)
    rim[8:21, 11:30] = True
    alpha[rim & (alpha == 0)] = 0.5
    obj = np.full((RH, RW, 3), 0.3, np.float32)
    ir = np.full((RH, RW, 3), 0.2, np.float32)
    irpv = alpha[..., None] * obj + (1 - alpha[..., None]) * ir
    one = np.ones((RH, RW, 1), np.float32)
    size = (RW, RH)
    tex = {
        "irpv": gl.texture(size, 4, np.concatenate([irpv, one], -1), dtype="f4"),
        "ir": gl.texture(size, 4, np.concatenate([ir, one], -1), dtype="f4"),
        "alpha": gl.texture(size, 1, alpha, dtype="f4"),
        "odepth": gl.texture(size, 1, alpha * 5.0, dtype="f4"),
        "plane": gl.texture(size, 2, np.dstack([np.full((RH, RW), 8.0), np.ones((RH, RW))]).astype(np.float32),
                            dtype="f4"),
        "objc": gl.texture(size, 4, np.concatenate([alpha[..., None] * obj, alpha[..., None]], -1), dtype="f4"),
        "id": gl.texture(size, 1, (alpha >= 0.5).astype(np.uint32), dtype="u4"),
        "id_depth": gl.texture(size, 1, np.full((RH, RW), 5.0, np.float32), dtype="f4"),
    }
    cam = Camera(500, 500, RW / 2, RH / 2, 0.2, 0, 0, 1.2, 0, 0, 0, RW, RH)
    return RenderPasses(Roi(0, 0, RW, RH), cam, tex, gl), alpha


def test_compose_noise_and_blur_are_reproducible_and_touch_only_the_object(gl_clean):
    rng = np.random.default_rng(11)
    scene = SceneLayers(rgb=np.full((RH, RW, 3), 118, np.uint8) + rng.integers(0, 3, (RH, RW, 3), dtype=np.uint8),
                        label_ids=np.full((RH, RW), 7, np.uint8), instance_ids=np.full((RH, RW), 7, np.int32),
                        disparity=np.full((RH, RW), 900, np.uint16), depth=np.full((RH, RW), np.inf, np.float32),
                        disparity_scale=0.2 * 500 * 256.0)
    passes, alpha = _object_passes(gl_clean)
    comp = Composer(gl_clean)
    plain = comp.compose_roi(passes, scene, [26], [26000])
    match = CameraMatch(noise_sigma=(4.0, 4.0, 4.0), blur_sigma=1.0, object_blur_sigma=0.8, seed=3)
    a = comp.compose_roi(passes, scene, [26], [26000], match)
    b = comp.compose_roi(passes, scene, [26], [26000], match)
    c = comp.compose_roi(passes, scene, [26], [26000], CameraMatch((4.0, 4.0, 4.0), 1.0, 0.8, seed=4))
    assert all(np.array_equal(a[k], b[k]) for k in a)  # same seed, same bytes
    assert not np.array_equal(a["rgb"], c["rgb"])  # another seed, other noise
    # nothing but the object: beyond the blur's reach of any covered pixel, the plain result
    reach = cv2.dilate((alpha > 0).astype(np.uint8), np.ones((2 * match.blur_radius + 1,) * 2, np.uint8)) > 0
    assert np.array_equal(a["rgb"][~reach], plain["rgb"][~reach])
    assert np.array_equal(plain["rgb"][alpha == 0], scene.rgb[alpha == 0])
    for k in ("label_ids", "instance_ids", "disparity", "visible"):
        assert np.array_equal(a[k], plain[k])
    # the blur spreads the object just beyond its rim; the noise has the photo's level inside
    outside = reach & (alpha == 0)
    assert np.any(a["rgb"][outside] != plain["rgb"][outside])
    inner = np.zeros_like(alpha, bool)
    inner[12:17, 15:26] = True
    noise = a["rgb"][inner].astype(float) - plain["rgb"][inner].astype(float)
    assert noise.std() == pytest.approx(4.0, rel=COMPOSE_NOISE_SIGMA_REL)
    assert abs(noise.mean()) < COMPOSE_NOISE_MEAN_8BIT
    # no noise, no blur: exactly the plain composition
    off = comp.compose_roi(passes, scene, [26], [26000], CameraMatch())
    assert all(np.array_equal(off[k], plain[k]) for k in off)


# ------------------------------------------------------------------ manifest, record, command
def _manifest(dataset: Path, output: Path, **lighting) -> dict:
    data = {"dataset": str(dataset), "output": str(output), "seed": 3, "objects_per_image": 1,
            "objects": [{"name": "car", "model": str(ASSETS / "openmaterial_car" / "vehicle_example.gltf"),
                         "class": "car", "size": {"length": 4.4}}]}
    if lighting:
        data["lighting"] = lighting
    return data


def test_manifest_lighting_modes(tmp_path):
    path = tmp_path / "m.json"
    m = parse_manifest(_manifest(tmp_path, tmp_path / "out"), path)
    assert m.lighting_mode == "estimate" and m.camera_match and not m.match_exposure
    old = parse_manifest(_manifest(tmp_path, tmp_path / "out", sun_elevation_deg=30, sun_azimuth_deg=10,
                                   sun_fraction=0.5), path)  # the keys of before: a fixed light
    assert old.lighting_mode == "fixed"
    assert old.lighting.sun_direction[2] == pytest.approx(0.5)
    fixed = parse_manifest(_manifest(tmp_path, tmp_path / "out", mode="fixed", camera_match=False), path)
    assert fixed.lighting_mode == "fixed" and not fixed.camera_match
    with pytest.raises(ManifestError, match="lighting/sun_fraction"):
        parse_manifest(_manifest(tmp_path, tmp_path / "out", mode="estimate", sun_fraction=0.2), path)
    with pytest.raises(ManifestError, match="lighting/mode"):
        parse_manifest(_manifest(tmp_path, tmp_path / "out", mode="sunny"), path)


@pytest.fixture(scope="module")
def sunny_dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("sunny")
    from synthcompose.io.dataset import ImageSetId
    from synthcompose.synthetic import write_image_set

    light = SceneLight(sun_azimuth_deg=-150.0, sun_elevation_deg=45.0, sun_fraction=0.65)
    scene = random_scene(np.random.default_rng(1), W, H, light=light)
    ident = ImageSetId("train", "sunnytown", "000000", "000000")
    write_image_set(root, ident, scene, render_scene(scene, stereo=LIGHT_STEREO, photo=LIGHT_PHOTO))
    return root, ident


def test_batch_records_the_estimate_and_the_camera(sunny_dataset, tmp_path):
    root, ident = sunny_dataset
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_manifest(root, tmp_path / "out")))
    assert main(["batch", str(path), "--no-progress"]) == 0
    record = json.loads(ident.path(tmp_path / "out", "record").read_text())
    assert record["status"] == "done"
    lt = record["lighting"]
    assert lt["mode"] == "estimate" and lt["sunny"] is True
    assert azimuth_error(lt["sun_azimuth_deg"], -150.0) <= SUN_AZIMUTH_DEG
    assert lt["renderer"]["sun_rgb"][1] > 0
    cam = record["camera_match"]
    assert cam["noise_sigma_8bit"][0] == pytest.approx(math.sqrt(1.6 ** 2 + 1.4 ** 2), rel=RECORDED_NOISE_REL)
    assert "sun_visibility" in record["objects"][0]["ground"]
    # the same manifest with the old keys: a fixed light, recorded as such
    path.write_text(json.dumps(_manifest(root, tmp_path / "fixed", sun_elevation_deg=50, sun_azimuth_deg=135,
                                         sun_fraction=0.35)))
    assert main(["batch", str(path), "--no-progress"]) == 0
    fixed = json.loads(ident.path(tmp_path / "fixed", "record").read_text())["lighting"]
    assert fixed["mode"] == "fixed" and fixed["sun_azimuth_deg"] == 135


def test_compare_lighting_command(tmp_path, capsys):
    root = tmp_path / "cs"
    ids = make_sample(root, count=2, width=W, height=H, seed=1, stereo=LIGHT_STEREO, photo=LIGHT_PHOTO)
    path = tmp_path / "m.json"
    path.write_text(json.dumps(_manifest(root, tmp_path / "unused")))
    out = tmp_path / "compare"
    assert main(["compare-lighting", str(path), str(out), "--limit", "1"]) == 0
    key = ids[0].key.replace("/", "_")
    for kind in ("fixed_vs_estimated", "before_after", "zoom"):
        img = cv2.imread(str(out / f"{key}_{kind}.png"))
        assert img is not None and img.shape[1] > W
    side = cv2.imread(str(out / f"{key}_fixed_vs_estimated.png"))
    assert side.shape[1] == 2 * W + 6
    assert not (out / f"{ids[1].key.replace('/', '_')}_zoom.png").exists()  # --limit 1
    # per object: input | output | the nearest real object of its class
    objects = sorted(out.glob(f"{key}_object*_side_by_side.png"))
    assert objects and all(cv2.imread(str(p)).shape[0] == 256 + 22 for p in objects)
    assert "fixed_vs_estimated.png" in capsys.readouterr().out
