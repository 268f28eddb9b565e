"""How the lit pass shades its 4x multisampled targets (``Renderer(shading=...)``): per sample
(:class:`PerSample`: lit.glsl runs for every sample) or per pixel (:class:`PerPixel`: lit.glsl
once per pixel at its centre, then fill.glsl rasterises the same geometry at every sample with
those colours). Both leave Irpv's targets to resolve, and draw Ir's planes the same way Irpv's
were, so that the two agree where a plane covers part of a pixel."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import moderngl
import numpy as np

from synthcompose.models import Model

from .gl import GLContext
from .gpu_model import GpuModel
from .lit import SCENE_DEPTH_UNIT, LitDraw
from .transforms import gl_mat4
from .values import Lighting, RenderObject

SAMPLES = 4
SHADING = ("auto", "pixel", "sample")
_PLANE_COL_UNIT = 12  # texture unit of the per-pixel plane colour that fill.glsl (PLANE) reads


def device_shading(renderer_name: str) -> str:
    """What ``shading="auto"`` means on the GL device ``renderer_name``: "pixel" on a software
    renderer (llvmpipe), "sample" on a GPU."""
    return "pixel" if any(s in renderer_name.lower() for s in ("llvmpipe", "softpipe", "swrast")) else "sample"


#: what the lit pass's multisampled targets store: "half" (default) keeps the colours (Irpv, the
#: object's colour) and the coverage in half floats (11 significant bits: one step is at most
#: 1/1024 of a value, a fifth of an 8-bit step or less once in sRGB; coverage in quarters
#: exactly) and the depths (the object's, the plane's) in full floats; "full" everything in full
#: floats. At 208 bytes per pixel in full floats these targets were the largest part of a batch's
#: peak memory (a car close by: 2048 x 721 pixels, 300 MB); half takes 136
PRECISIONS = ("half", "full")


def framebuffer(gl: GLContext, colours: Sequence, depth=None,
                viewport: tuple[int, int, int, int] | None = None) -> moderngl.Framebuffer:
    """A framebuffer of ``colours`` and ``depth`` (owned by ``gl``); ``viewport``: where its
    draws map the region of interest (a band of it: :mod:`.bands`), None: onto the whole."""
    fbo = gl.own(gl.ctx.framebuffer(list(colours), depth))
    if viewport is not None:
        fbo.viewport = viewport
    return fbo


def multisampled(gl: GLContext, size: tuple[int, int], precision: str = "half",
                 viewport: tuple[int, int, int, int] | None = None):
    """The lit pass's 4x multisampled targets (irpv, alpha, odepth, plane, objc: lit.glsl's
    outputs 0-4), their depth, and a framebuffer of them (:data:`PRECISIONS`, :func:`framebuffer`)."""
    ctx = gl.ctx
    colour = "f2" if precision == "half" else "f4"
    ms = [gl.own(ctx.renderbuffer(size, c, samples=SAMPLES, dtype=dtype))
          for c, dtype in ((4, colour), (1, colour), (1, "f4"), (2, "f4"), (4, colour))]
    ms_depth = gl.own(ctx.depth_renderbuffer(size, samples=SAMPLES))
    return ms, ms_depth, framebuffer(gl, ms, ms_depth, viewport)


class PerSample:
    """``shading="sample"``: the lit programs draw straight into the multisampled targets."""

    def __init__(self, gl: GLContext, lit: LitDraw, precision: str = "half") -> None:
        self.gl, self.lit, self.precision = gl, lit, precision
        self.viewport: tuple[int, int, int, int] | None = None  # the band drawn (see framebuffer)

    def scene_depth(self, given: bool) -> None:
        """Nothing to set: lit.glsl's uniforms (lit.frame_uniforms) carry whether the real scene's
        depth is bound."""

    def lit_pass(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int],
                 view: np.ndarray, proj: np.ndarray):
        """Irpv's multisampled targets drawn (:func:`multisampled`), to resolve (``view`` and
        ``proj`` unused: the lit programs' uniforms carry them)."""
        ms, ms_depth, ms_fbo = multisampled(self.gl, size, self.precision, self.viewport)
        ms_fbo.use()
        ms_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.lit.draw(objects, lighting, objects_too=True)
        return ms, ms_depth, ms_fbo

    def ir_source(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int]) -> None:
        """Nothing to prepare: Ir's planes are shaded as they are drawn."""
        return None

    def draw_ir(self, objects: Sequence[RenderObject], lighting: Lighting, source: None) -> None:
        """The planes alone, unshadowed, into the bound multisampled framebuffer."""
        self.lit.draw(objects, lighting, objects_too=False, shadows=False)


@dataclass(frozen=True)
class FillPrograms:
    """fill.glsl's programs: object samples, plane samples (PLANE), the other material near
    each pixel (NEIGHBOURS), and the vertex array of one full-frame triangle for the latter."""

    objects: moderngl.Program
    planes: moderngl.Program
    neighbours: moderngl.Program
    frame_vao: moderngl.VertexArray

    @classmethod
    def compile(cls, gl: GLContext) -> "FillPrograms":
        objects, planes, neighbours = gl.program("fill"), gl.program("fill", PLANE=1), gl.program("fill", NEIGHBOURS=1)
        return cls(objects, planes, neighbours, gl.own(gl.ctx.vertex_array(neighbours, [])))


class PerPixel:
    """``shading="pixel"``: lit.glsl once per pixel into 1x targets, then fill.glsl fills the
    samples (the cost and the gain: :class:`~synthcompose.render.Renderer`). The models draw
    their samples with the renderer's program "fill"
    (:attr:`FillPrograms.objects`), the planes theirs with :attr:`FillPrograms.planes`."""

    def __init__(self, gl: GLContext, fill: FillPrograms, lit: LitDraw,
                 gpu_model: Callable[[Model], GpuModel], precision: str = "half") -> None:
        self.gl, self.fill, self.lit, self.precision = gl, fill, lit, precision
        self._gpu_model = gpu_model
        self.viewport: tuple[int, int, int, int] | None = None  # the band drawn (see framebuffer)

    def scene_depth(self, given: bool) -> None:
        """Whether the real scene's depth is bound (lit.SCENE_DEPTH_UNIT): fill.glsl's planes are
        left out where lit.glsl's are (plane_ground.glsl)."""
        self.fill.planes["u_scene_depth"].value = SCENE_DEPTH_UNIT
        self.fill.planes["u_has_scene_depth"].value = given

    def lit_pass(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int],
                 view: np.ndarray, proj: np.ndarray):
        """The lit pass with the light shaded once per pixel; returns the multisampled targets
        drawn (:func:`multisampled`), to resolve."""
        gl, ctx = self.gl, self.gl.ctx
        # the light, shaded once per pixel at its centre (1x): the objects over their planes
        # (object colour and coverage: lit.glsl's out_object), and the planes alone with the
        # objects' shadows; then fill.glsl rasterises the same geometry at SAMPLES per pixel
        # with those colours, and the resolve averages the samples (MSAA's colour, without
        # llvmpipe shading every sample: a third of the time)
        centre = [gl.own(ctx.renderbuffer(size, c, dtype="f4")) for c in (4, 1, 1, 2)]
        centre_depth = gl.own(ctx.depth_renderbuffer(size))
        object_col, object_key, plane_col = (gl.texture(size, 4, dtype="f4") for _ in range(3))
        objects_fbo = framebuffer(gl, centre + [object_col, object_key], centre_depth, self.viewport)
        planes_fbo = framebuffer(gl, [plane_col], centre_depth, self.viewport)
        # the nearest surface's depth first, so that lit.glsl shades each pixel once: the
        # objects' triangles overlap two to three deep, and llvmpipe shades every fragment that
        # passes the depth test when it comes (lit.glsl's objects are most of the pass)
        self._depth_prepass(objects, lighting, centre_depth, view, proj)
        objects_fbo.use()
        objects_fbo.depth_mask = False
        objects_fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.depth_func = "<="
        self.lit.draw(objects, lighting, objects_too=True, reverse=True)  # what "<" forwards leaves
        ctx.depth_func = "<"
        planes_fbo.use()
        planes_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.lit.draw(objects, lighting, objects_too=False)
        for obj in (objects_fbo, planes_fbo, centre_depth, *centre):  # only their textures are read on
            gl.free(obj)
        # the other material near each pixel (fill.glsl, NEIGHBOURS), once per pixel
        other_col, other_key = gl.texture(size, 4, dtype="f4"), gl.texture(size, 4, dtype="f4")
        others_fbo = framebuffer(gl, [other_col, other_key])  # one triangle over the framebuffer
        textures = {"u_object_col": object_col, "u_object_key": object_key, "u_plane_col": plane_col,
                    "u_other_col": other_col, "u_other_key": other_key}
        units = {name: unit for unit, name in enumerate(textures, start=7)}
        object_col.use(units["u_object_col"])
        object_key.use(units["u_object_key"])
        for name in ("u_object_col", "u_object_key"):
            self.fill.neighbours[name].value = units[name]
        others_fbo.use()
        ctx.disable(moderngl.DEPTH_TEST)
        self.fill.frame_vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.enable(moderngl.DEPTH_TEST)
        gl.free(others_fbo)
        gl.wait()  # the freed targets are released once drawn: before the multisampled ones exist
        ms, ms_depth, ms_fbo = multisampled(gl, size, self.precision, self.viewport)
        fill, fill_plane = self.fill.objects, self.fill.planes
        for prog in (fill, fill_plane):  # (the plane variant's texture: _fill_planes)
            prog["u_view"].write(gl_mat4(view))
            prog["u_proj"].write(gl_mat4(proj))
        for name, texture in textures.items():
            fill[name].value = units[name]
            texture.use(units[name])
        ms_fbo.use()
        ms_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._fill_planes(objects, lighting, plane_col)
        for obj in objects:
            fill["u_model"].write(gl_mat4(obj.vehicle_from_object))
            self._gpu_model(obj.model).draw("fill")
        for obj in textures.values():
            gl.free(obj)
        gl.wait()
        return ms, ms_depth, ms_fbo

    def _depth_prepass(self, objects: Sequence[RenderObject], lighting: Lighting, depth: moderngl.Renderbuffer,
                       view: np.ndarray, proj: np.ndarray) -> None:
        """The depth of the nearest plane or opaque part at each pixel centre into ``depth``, drawn
        with fill.glsl, whose vertex stage computes the position as lit.glsl's does (the same
        products in the same order: the same depths, which the lit draw then tests with "<=")."""
        gl = self.gl
        fbo = framebuffer(gl, [], depth, self.viewport)
        fbo.use()
        fbo.clear(depth=1.0)
        fill, fill_plane = self.fill.objects, self.fill.planes
        for prog in (fill, fill_plane):
            prog["u_view"].write(gl_mat4(view))
            prog["u_proj"].write(gl_mat4(proj))
        vao = self.lit.plane.vao(fill_plane)
        for obj in objects:
            fill_plane["u_model"].write(gl_mat4(obj.plane_matrix(lighting)))
            vao.render(moderngl.TRIANGLES)
        for obj in objects:  # not the glass, which the lit draw blends over this depth
            fill["u_model"].write(gl_mat4(obj.vehicle_from_object))
            self._gpu_model(obj.model).draw_opaque("fill")
        gl.free(fbo)

    def ir_source(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int]):
        """The objects' ground planes alone, unshadowed, shaded once per pixel at its centre: a
        texture, for Ir to be filled from as Irpv's planes were (:meth:`draw_ir`). Made after
        Irpv's resolve, when most of the multisampled targets are freed."""
        gl, ctx = self.gl, self.gl.ctx
        gl.wait()  # the freed targets are released once Irpv's resolve is done: before these exist
        plane_ir = gl.texture(size, 4, dtype="f4")
        depth = gl.own(ctx.depth_renderbuffer(size))
        fbo = framebuffer(gl, [plane_ir], depth, self.viewport)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.lit.draw(objects, lighting, objects_too=False, shadows=False)
        for obj in (fbo, depth):
            gl.free(obj)
        return plane_ir

    def draw_ir(self, objects: Sequence[RenderObject], lighting: Lighting, source: moderngl.Texture) -> None:
        """Ir's planes filled into the bound multisampled framebuffer from ``source``
        (:meth:`ir_source`), which is then freed."""
        self._fill_planes(objects, lighting, source)
        self.gl.free(source)

    def _fill_planes(self, objects: Sequence[RenderObject], lighting: Lighting, plane_col: moderngl.Texture) -> None:
        """Rasterise the objects' ground planes into the bound multisampled framebuffer, every
        sample its pixel's colour from ``plane_col`` (the planes shaded once per pixel:
        fill.glsl, PLANE); view and projection as set by :meth:`lit_pass`."""
        prog = self.fill.planes
        plane_col.use(_PLANE_COL_UNIT)
        prog["u_plane_col"].value = _PLANE_COL_UNIT
        vao = self.lit.plane.vao(prog)
        for obj in objects:
            prog["u_model"].write(gl_mat4(obj.plane_matrix(lighting)))
            vao.render(moderngl.TRIANGLES)
