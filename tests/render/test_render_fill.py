"""The lit pass, shaded per sample or once per pixel and filled into the multisampled targets
(shaders/fill.glsl): edges of the object and edges between its materials come out antialiased,
each resolved pixel mixes the colours of what covers it, and the two ways agree."""
import numpy as np
import pytest
from scipy import ndimage

from synthcompose.models import MeshPart, Model
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera
from ..tolerances import (
    AA_ROWS_MIXED_MIN,
    AA_SHARE_STEP_MAX,
    EDGE_GROUND_EXCESS_LINEAR,
    PLANE_SEAM_LINEAR,
    RESOLVE_FLOAT_EPS,
    RESOLVE_SUBTRACT_EPS,
    SHADING_MODES_EDGE_LINEAR,
    SHADING_MODES_EDGE_QUANTILE,
    SHADING_MODES_INSIDE_LINEAR,
    SHADING_MODES_PLANE,
)

LIGHT = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.5)
RED, BLUE = (0.6, 0.05, 0.05), (0.05, 0.1, 0.6)


def _panel() -> Model:
    """A 2 m x 1.5 m board facing the camera (O: -x), 0.3 m above the ground, split by a slanted
    line into a red and a blue part (one mesh part each)."""
    def part(corners, colour):
        n = len(corners)
        return MeshPart(
            positions=np.asarray(corners, np.float32), normals=np.tile([-1.0, 0.0, 0.0], (n, 1)).astype(np.float32),
            uvs=np.zeros((n, 2), np.float32), colors=np.tile([*colour, 1.0], (n, 1)).astype(np.float32),
            material=np.tile([0.0, 0.9], (n, 1)).astype(np.float32),
            indices=np.array([[0, 1, 2], [0, 2, 3]], np.uint32), texture=None)
    # y from 1 (left in the image) to -1, z from 0.3 to 1.8; the split runs from (y=0.35, top)
    # to (y=-0.2, bottom)
    left = part([[0, 1.0, 0.3], [0, -0.2, 0.3], [0, 0.35, 1.8], [0, 1.0, 1.8]], RED)
    right = part([[0, -0.2, 0.3], [0, -1.0, 0.3], [0, -1.0, 1.8], [0, 0.35, 1.8]], BLUE)
    return Model("test-panel", (left, right), (0.05, 2.0, 1.8))


def _render(gl, shading="pixel"):
    renderer = Renderer(gl, shading=shading)
    assert renderer.shading == shading
    pose = np.eye(4)
    pose[:3, 3] = (9.0, 0.0, 0.0)
    passes = renderer.render(make_camera(), [RenderObject(_panel(), pose, (0.2, 0.2, 0.2))], LIGHT)
    out = {name: passes.read(name) for name in ("irpv", "alpha", "objc", "plane")}
    renderer.release(passes)
    return out


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_object_edges_are_antialiased_and_mix_object_and_ground(gl_clean, shading):
    p = _render(gl_clean, shading)
    alpha, irpv, objc = p["alpha"], p["irpv"][..., :3], p["objc"]
    inside = alpha >= 0.999
    assert inside.sum() > 5000
    edge = (alpha > 0.01) & (alpha < 0.99)
    # the silhouette: a ring of partly covered pixels, every one of them next to the object
    assert edge.sum() > 200
    assert (edge & ~ndimage.binary_dilation(inside, np.ones((3, 3), bool))).sum() == 0
    assert len(np.unique(np.round(alpha[edge] * 4))) >= 3  # several coverage levels (4 samples)
    # objc carries the object's share: its coverage is alpha, and irpv = objc + (1 - alpha) * ground
    assert np.allclose(objc[..., 3], alpha, atol=RESOLVE_FLOAT_EPS)
    ground = irpv - objc[..., :3]
    e = edge & (p["plane"][..., 1] > 0.999 - alpha)  # the rest of the pixel is ground plane
    near_ground = ndimage.grey_dilation(np.where(alpha < 0.01, irpv[..., 0], -1.0), size=5)
    assert np.all(ground[e][:, 0] >= -RESOLVE_SUBTRACT_EPS)
    assert np.all(ground[e][:, 0] <= near_ground[e] * (1 - alpha[e]) + EDGE_GROUND_EXCESS_LINEAR)


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_the_edge_between_two_materials_is_antialiased(gl_clean, shading):
    p = _render(gl_clean, shading)
    inside = ndimage.binary_erosion(p["alpha"] >= 0.999, iterations=2)
    col = p["objc"][..., :3]
    red = inside & (col[..., 0] > 4 * col[..., 2])
    blue = inside & (col[..., 2] > 4 * col[..., 0])
    assert red.sum() > 2000 and blue.sum() > 2000
    # on each row the boundary pixels lie between the pure colours: some are mixtures, and the
    # share of red falls from the red side to the blue side without a gap
    share = col[..., 0] / np.maximum(col[..., 0] + col[..., 2], 1e-6)
    pure_red, pure_blue = np.median(share[red]), np.median(share[blue])
    mixed = inside & (share < pure_red - 0.05) & (share > pure_blue + 0.05)
    rows = np.flatnonzero(red.any(axis=1) & blue.any(axis=1))
    assert len(rows) > 50
    with_mix = [r for r in rows if mixed[r].any()]
    assert len(with_mix) >= AA_ROWS_MIXED_MIN * len(rows)  # a slanted edge: most rows have a partly red pixel
    for r in with_mix:
        cols = np.flatnonzero(inside[r])
        s = share[r, cols]
        assert np.all(np.diff(s) <= AA_SHARE_STEP_MAX)  # red on the left, blue on the right, monotone


def test_per_pixel_and_per_sample_shading_agree(gl_clean):
    a, b = _render(gl_clean, "pixel"), _render(gl_clean, "sample")
    assert np.array_equal(a["alpha"], b["alpha"])  # the same coverage
    assert np.allclose(a["plane"], b["plane"], atol=SHADING_MODES_PLANE)
    diff = np.abs(a["irpv"][..., :3] - b["irpv"][..., :3]).max(axis=-1)
    inside = ndimage.binary_erosion(a["alpha"] >= 0.999, np.ones((3, 3), bool))
    assert diff[inside].max() < SHADING_MODES_INSIDE_LINEAR  # away from edges: the same light at the same point
    assert np.quantile(diff, SHADING_MODES_EDGE_QUANTILE) < SHADING_MODES_EDGE_LINEAR  # at the edges, close
    with pytest.raises(ValueError, match="shading"):
        Renderer(gl_clean, shading="fast")


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_the_ground_planes_border_leaves_no_seam(gl_clean, shading):
    """Irpv - Ir carries the object's shadows into the photo: at the border of its ground plane,
    where the plane covers part of a pixel, the two must agree (no line drawn round the plane),
    in either way of shading."""
    renderer = Renderer(gl_clean, shading=shading)
    pose = np.eye(4)
    pose[:3, 3] = (9.0, 0.0, 0.0)
    ambient = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.0)
    passes = renderer.render(make_camera(), [RenderObject(_panel(), pose, (0.2, 0.2, 0.2))], ambient)
    p = {name: passes.read(name) for name in ("irpv", "ir", "alpha", "plane")}
    renderer.release(passes)
    cover = p["plane"][..., 1]
    far = ~ndimage.binary_dilation(p["alpha"] > 0.0, iterations=40)  # away from the contact shadow
    border = far & (cover > 0.01) & (cover < 0.99)
    assert border.sum() > 100
    diff = np.abs(p["irpv"][..., :3] - p["ir"][..., :3]).max(axis=-1)
    assert diff[border].max() <= PLANE_SEAM_LINEAR, \
        (diff[border].max(), np.median(p["ir"][..., 0][far & (cover > 0.99)]))
    assert diff[far & (cover > 0.99)].max() <= PLANE_SEAM_LINEAR
