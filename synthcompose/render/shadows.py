"""The light's views of the objects: three depth maps drawn before the lit pass (the sun's
shadow map, the sky-occlusion map seen from straight above, and the objects' undersides seen
from straight below, for contact shadows), the sky the ground planes see past the objects
(worked out once per texel of the top-down map's square: shaders/ground_sky.glsl), and the
matrices that make them (vehicle frame -> light clip space, orthographic, around the objects and
their planes)."""
from __future__ import annotations

import math
from typing import Callable, Sequence

import moderngl
import numpy as np

from synthcompose.models import Model

from .gl import GLContext
from .gpu_model import GpuModel, GroundPlane
from .transforms import TEXTURE_FROM_CLIP, gl_mat4, look_at, ortho
from .values import Lighting, RenderObject

#: the ground planes' sky map: about this many metres a texel, whatever the light views' square
#: (2 * half metres: a car alone, or objects 20 m apart), so that a far car's occlusion is worked
#: out as finely as a near one's (read through a 25 cm disc: lit.glsl); the texture's side, of
#: which a square of :func:`ground_sky_texels` is used; beyond 41 m across the texels grow
GROUND_SKY_TEXEL, GROUND_SKY_SIZE = 0.04, 1024


def ground_sky_texels(half: float) -> int:
    """Texels across the part of the ground's sky map used for light views ``half`` metres
    either side of their centre (:func:`light_matrices`): :data:`GROUND_SKY_TEXEL` metres each,
    at least 256, at most :data:`GROUND_SKY_SIZE`."""
    return int(min(max(math.ceil(2 * half / GROUND_SKY_TEXEL), 256), GROUND_SKY_SIZE))


def light_matrices(objects: Sequence[RenderObject], lighting: Lighting) -> list:
    """[half, sun, sky, under]: the half size (metres) of the square every light view covers,
    then the (4, 4) vehicle -> clip matrices of the sun's view, the view from above and the
    view from below."""
    pts = np.concatenate([o.corners(lighting) for o in objects])
    centre = (pts.min(0) + pts.max(0)) / 2
    half = float(np.linalg.norm(pts - centre, axis=1).max()) + 0.1
    mats = [half]
    for direction in (np.asarray(lighting.sun_direction, float), np.array([0.0, 0.0, 1.0]),
                      np.array([0.0, 0.0, -1.0])):
        direction = direction / np.linalg.norm(direction)
        up = np.array([1.0, 0, 0]) if abs(direction[2]) > 0.99 else np.array([0, 0, 1.0])
        view = look_at(centre + direction * (half + 5.0), centre, up)
        mats.append(ortho(half, 0.1, 2 * half + 10.0) @ view)
    return mats


def light_range(half: float) -> float:
    """Metres the light views' depth 0..1 spans (:func:`light_matrices`' near and far)."""
    return 2 * half + 10.0 - 0.1


class ShadowMaps:
    """The three depth maps (``shadow_size`` square) and their framebuffers: :attr:`maps`,
    (texture, framebuffer) of the sun, the sky and the undersides; and the ground planes' sky
    (:data:`GROUND_SKY_SIZE` square, one float a texel, of which :func:`ground_sky_texels` are
    used: the share of the sky the ground there sees past the objects)."""

    def __init__(self, gl: GLContext, shadow_size: int) -> None:
        ctx = gl.ctx
        self.gl = gl
        self.maps: list[tuple[moderngl.Texture, moderngl.Framebuffer]] = []
        for k in range(3):  # sun map, top-down sky-occlusion map, the objects' undersides from below
            tex = gl.own(ctx.depth_texture((shadow_size, shadow_size)))
            # read as depths (lit.glsl compares them itself): how far the objects stand from the
            # sun (the penumbra's size), how high they rise over a ground point (its horizon),
            # how high their lowest part stands over it (contact shadows)
            tex.compare_func = ""
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = False
            fbo = gl.own(ctx.framebuffer(depth_attachment=tex))
            self.maps.append((tex, fbo))
        self.ground_sky = gl.own(ctx.texture((GROUND_SKY_SIZE, GROUND_SKY_SIZE), 1, dtype="f2"))
        self.ground_sky.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.ground_sky.repeat_x = self.ground_sky.repeat_y = False
        self._ground_fbo = gl.own(ctx.framebuffer([self.ground_sky]))
        self._drawn: bytes | None = None  # what the maps hold (see draw)

    @property
    def textures(self) -> tuple[moderngl.Texture, ...]:
        """The sun's, the sky's and the undersides' depth textures, and the ground's sky."""
        return tuple(tex for tex, _ in self.maps) + (self.ground_sky,)

    def draw(self, objects: Sequence[RenderObject], light, gpu_model: Callable[[Model], GpuModel],
             lighting: Lighting, plane: GroundPlane) -> None:
        """Draw ``objects`` (their models uploaded by ``gpu_model``) into each map with the depth
        program, seen through ``light`` (half, sun, sky, under: :func:`light_matrices`); then
        each object's ground plane (``plane``, posed for ``lighting``) into the ground's sky map.
        The maps do not depend on the camera: drawn again only when the objects or the light
        changed (the right view of a stereo pair uses the left view's)."""
        half, mats = light[0], light[1:]
        drawn = b"".join([obj.model.key.encode() + np.asarray(obj.vehicle_from_object, np.float64).tobytes()
                          + np.asarray(obj.plane_matrix(lighting), np.float64).tobytes() for obj in objects]
                         + [np.asarray(m, np.float64).tobytes() for m in mats])
        if drawn == self._drawn:
            return
        self._drawn = drawn
        ctx = self.gl.ctx
        prog = self.gl.program("depth")
        for (tex, fbo), light in zip(self.maps, mats):
            fbo.use()
            fbo.clear(depth=1.0)
            ctx.enable(moderngl.DEPTH_TEST)
            prog["u_light"].write(gl_mat4(light))
            for obj in objects:
                prog["u_model"].write(gl_mat4(obj.vehicle_from_object))
                gpu_model(obj.model).draw("depth")
        self._draw_ground_sky(objects, half, mats[1], mats[2], lighting, plane)

    def _draw_ground_sky(self, objects, half: float, sky_mat, under_mat, lighting: Lighting,
                         plane: GroundPlane) -> None:
        """The sky each object's ground plane sees, drawn into the sky map's square (later
        planes over earlier ones where they overlap: the same objects darken them alike)."""
        ctx = self.gl.ctx
        prog = self.gl.program("ground_sky")
        n = ground_sky_texels(half)
        self._ground_fbo.use()
        self._ground_fbo.clear(1.0, 1.0, 1.0, 1.0, viewport=(0, 0, GROUND_SKY_SIZE, GROUND_SKY_SIZE))
        self._ground_fbo.viewport = (0, 0, n, n)  # the square's texels (lit.glsl: u_ground_sky_scale)
        ctx.disable(moderngl.DEPTH_TEST)
        self.maps[1][0].use(2)
        prog["u_sky_map"].value = 2
        self.maps[2][0].use(3)
        prog["u_under_map"].value = 3
        prog["u_under_matrix"].write(gl_mat4(TEXTURE_FROM_CLIP @ under_mat))
        prog["u_sky_clip"].write(gl_mat4(sky_mat))
        prog["u_sky_matrix"].write(gl_mat4(TEXTURE_FROM_CLIP @ sky_mat))
        prog["u_under_range"].value = light_range(half)
        vao = plane.vao(prog)
        for obj in objects:
            prog["u_model"].write(gl_mat4(obj.plane_matrix(lighting)))
            vao.render(moderngl.TRIANGLES)
        ctx.enable(moderngl.DEPTH_TEST)
