"""Glass (shaders/lit.glsl, GLASS; docs/vehicles.md "Glass"): a pane lets what is behind it show
through by its transmission and adds its reflection on top, in the colour the compose writes;
behind it may be the vehicle's interior, a far pane, or the photo itself, and the labels stay the
object's over the whole pane.

The generated scene: panes 9 m ahead facing the camera, above the ground plane's reach (nothing of
the plane behind them), composed over two different backgrounds: the difference of the two
results is what the pane lets through, the rest is its reflection."""
import numpy as np
import pytest

from synthcompose.colour import srgb_to_linear
from synthcompose.models import MeshPart, Model
from synthcompose.models.mesh import finish_part
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera
from ..tolerances import GLASS_INTERIOR_REL, GLASS_REFLECTION_REL, GLASS_TRANSMISSION_ABS

#: no sun: no highlight on the panes, the sky's light alone
LIGHT = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.0)
TAU = 0.7  # the panes' material lets this through (glTF alpha 0.3)
#: a pane's reflectance at normal incidence: two faces of n = 1.5 glass (lit.glsl): 2 f / (1 + f)
REFLECTED = 2 * 0.04 / 1.04


def _quad(x: float, y0: float, y1: float, z0: float, z1: float, rgba, roughness: float) -> MeshPart:
    """A quad in the plane x = const facing -x (the camera), wound to face it."""
    pos = np.array([[x, y0, z0], [x, y1, z0], [x, y1, z1], [x, y0, z1]], np.float32)
    n = len(pos)
    return finish_part(pos, np.tile([-1.0, 0.0, 0.0], (n, 1)), np.zeros((n, 2)), np.tile(rgba, (n, 1)),
                        np.tile([0.0, roughness], (n, 1)), np.array([[0, 1, 2], [0, 2, 3]]), None)


def _pane(x: float, rgb=(0.0, 0.0, 0.0)) -> MeshPart:
    """A clear pane (black: it scatters nothing of its own) or a tinted one of colour ``rgb``."""
    return _quad(x, 1.0, -1.0, 0.8, 1.8, (*rgb, 1.0 - TAU), 0.05)


BOARD = (0.3, 0.1, 0.05)  # linear albedo of a board behind the pane: the interior


def _render(gl, model: Model, shading: str, backgrounds) -> dict:
    """The object 9 m ahead, its passes and the composite over each background (linear)."""
    cam = make_camera()
    renderer = Renderer(gl, shading=shading)
    pose = np.eye(4)
    pose[:3, 3] = (9.0, 0.0, 0.0)
    passes = renderer.render(cam, [RenderObject(model, pose, (0.2, 0.2, 0.2))], LIGHT)
    out = {}
    for name in ("irpv", "ir", "alpha", "objc", "id"):  # full-frame arrays, zero outside the ROI
        roi = passes.read(name)
        out[name] = np.zeros((cam.height, cam.width) + roi.shape[2:], roi.dtype)
        out[name][passes.roi.slices] = roi
    renderer.release(passes)
    # the compose's rule (compose.glsl, reference_compose) in float: R' = Irpv + (1 - a)(R - Ir)
    a = out["alpha"][..., None]
    out["composed"] = [out["irpv"][..., :3] + (1.0 - a) * (srgb_to_linear(bg / 255.0) - out["ir"][..., :3])
                       for bg in backgrounds]
    return out


def _backgrounds(shape):
    return [np.full((*shape, 3), v, np.uint8) for v in (40, 200)]


def _inside(out, margin=3):
    """Pixels well inside the pane's silhouette (id pass), away from its edges."""
    from scipy import ndimage
    ids = out["id"] == 1
    return ndimage.binary_erosion(ids, np.ones((2 * margin + 1, 2 * margin + 1), bool))


def _through(out, backgrounds):
    """What the composite lets through of the background, per pixel: d(result) / d(background)."""
    lo, hi = (float(srgb_to_linear(bg[0, 0] / 255.0)[1]) for bg in backgrounds)
    return (out["composed"][1][..., 1] - out["composed"][0][..., 1]) / (hi - lo)


def test_a_glass_material_is_a_transparent_part():
    part = _pane(0.0)
    assert part.transmission == pytest.approx(TAU, abs=1e-6)
    assert part.colors[:, 3].min() == 1.0  # its key stays a plain base colour factor
    opaque = _quad(0.0, 1, -1, 0, 1, (0.5, 0.5, 0.5, 1.0), 0.5)
    assert opaque.transmission == 0.0


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_the_background_shows_through_a_pane_by_its_transmission(gl_clean, shading):
    cam = make_camera()
    bgs = _backgrounds((cam.height, cam.width))
    out = _render(gl_clean, Model("glass-one", (_pane(0.0),), (0.01, 2.0, 1.8)), shading, bgs)
    inside = _inside(out)
    assert inside.sum() > 3000
    through = _through(out, bgs)[inside]
    expected = (1.0 - REFLECTED) * TAU  # near normal incidence: the Fresnel term barely grows
    assert np.abs(through - expected).max() < GLASS_TRANSMISSION_ABS, (through.min(), through.max(), expected)
    # the colour coverage is what does not show through; the labels are the object's all over it
    assert np.abs(out["alpha"][inside] - (1.0 - through)).max() < GLASS_TRANSMISSION_ABS
    assert (out["id"][inside] == 1).all()
    # the reflection adds on top: what is left once the background's share is taken away
    reflection = out["composed"][0][..., 1][inside] - through * srgb_to_linear(40 / 255.0)
    sky = np.asarray(LIGHT.sky_rgb)[1]
    assert reflection.min() > 0.0
    # what it reflects (the renderer's sky and ground, a horizontal ray) by the pane's reflectance
    assert np.abs(reflection - out["objc"][..., 1][inside]).max() < GLASS_TRANSMISSION_ABS
    assert reflection.max() < REFLECTED * sky * (1.0 + GLASS_REFLECTION_REL)


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_two_panes_multiply_their_transmission(gl_clean, shading):
    cam = make_camera()
    bgs = _backgrounds((cam.height, cam.width))
    one = _render(gl_clean, Model("glass-one", (_pane(0.0),), (0.01, 2.0, 1.8)), shading, bgs)
    two = _render(gl_clean, Model("glass-two", (_pane(-0.75), _pane(0.75)), (1.5, 2.0, 1.8)), shading, bgs)
    far = _render(gl_clean, Model("glass-far", (_pane(0.75),), (1.5, 2.0, 1.8)), shading, bgs)
    # where both panes are in the line of sight (the far one is smaller on screen)
    inside = _inside(far) & _inside(two)
    assert inside.sum() > 1000
    t1, t2 = _through(one, bgs)[inside], _through(two, bgs)[inside]
    assert np.abs(t2 - t1 * t1).max() < GLASS_TRANSMISSION_ABS, (t2.mean(), (t1 * t1).mean())


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_the_interior_shows_behind_the_pane_and_hides_the_photo(gl_clean, shading):
    cam = make_camera()
    bgs = _backgrounds((cam.height, cam.width))
    board = _quad(0.5, 1.5, -1.5, 0.5, 2.0, (*BOARD, 1.0), 0.9)
    alone = _render(gl_clean, Model("board", (board,), (1.0, 3.0, 2.0)), shading, bgs)
    behind = _render(gl_clean, Model("glass-board", (_pane(-0.5), board), (1.0, 3.0, 2.0)), shading, bgs)
    glass = _render(gl_clean, Model("glass-one-near", (_pane(-0.5),), (1.0, 3.0, 2.0)), shading, bgs)
    inside = _inside(glass)
    # nothing of the photo comes through: the board is opaque
    assert np.abs(_through(behind, bgs)[inside]).max() < GLASS_TRANSMISSION_ABS
    assert (behind["alpha"][inside] > 0.999).all()
    # the board seen through the pane: its colour by the pane's transmission, plus the reflection
    t = _through(glass, bgs)[inside]
    expected = glass["objc"][..., 1][inside] + t * alone["composed"][0][..., 1][inside]
    got = behind["composed"][0][..., 1][inside]
    assert np.abs(got - expected).max() < GLASS_INTERIOR_REL * float(expected.max())


def test_a_tinted_pane_adds_its_colour_by_what_it_does_not_let_through(gl_clean):
    """A lens of red plastic (alpha 0.3) over the photo: alpha blending's share of its lit colour
    on top of the reflection, red over the background's grey."""
    cam = make_camera()
    bgs = _backgrounds((cam.height, cam.width))
    clear = _render(gl_clean, Model("glass-one", (_pane(0.0),), (0.01, 2.0, 1.8)), "pixel", bgs)
    red = _render(gl_clean, Model("glass-red", (_pane(0.0, (0.5, 0.02, 0.02)),), (0.01, 2.0, 1.8)), "pixel", bgs)
    inside = _inside(clear)
    added = red["composed"][0][inside] - clear["composed"][0][inside]
    # the red channel gains about (1 - reflectance) (1 - tau) 0.5 x the light, green barely
    assert added[:, 0].min() > 0.05
    assert np.abs(added[:, 1]).max() < 0.01
    # what shows through is the same: transmission does not depend on the colour
    assert np.abs(_through(red, bgs)[inside] - _through(clear, bgs)[inside]).max() < GLASS_TRANSMISSION_ABS
