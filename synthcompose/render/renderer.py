"""The :class:`Renderer`: one render's order of work. The ROI's inputs (photo crop, its
reflection, the sun mask), the light's depth maps (:mod:`.shadows`), the lit pass Irpv and the
planes alone Ir, shaded per sample or per pixel (:mod:`.shading`) and resolved into textures,
then the integer ids at pixel centres; the passes are listed in :mod:`synthcompose.render`."""
from __future__ import annotations

from collections import OrderedDict
from typing import Sequence

import cv2
import moderngl
import numpy as np

from synthcompose.camera import Camera
from synthcompose.models import Model

from .bands import copy_rows, row_bands, viewport, with_apron
from .gl import GLContext
from .gpu_model import GpuModel, GroundPlane
from .lit import LitDraw, bind_inputs, environment, frame_uniforms
from .shading import PRECISIONS, SHADING, FillPrograms, PerPixel, PerSample, device_shading, framebuffer
from .shadows import ShadowMaps, light_matrices
from .transforms import gl_mat4
from .values import FAR, NEAR, Lighting, RenderObject, RenderPasses, Roi, crop_camera, roi_for

#: the lit passes' resolved textures: (name, components); Ir last
PASSES = (("irpv", 4), ("alpha", 1), ("odepth", 1), ("plane", 2), ("objc", 4), ("ir", 4))
#: the resolved passes of colour: with the multisampled colours in half floats (``precision``
#: "half", :data:`~.shading.PRECISIONS`) they are resolved into half floats too (the mean of a
#: pixel's samples rounded to 11 significant bits: at most a fifth of an 8-bit step once in
#: sRGB), the others (coverage, depths) into full floats: a region's resolved passes take 40
#: bytes a pixel instead of 64 (a car close by: a region of 2048 x 800 pixels, 39 MB less)
COLOUR_PASSES = ("irpv", "objc", "ir")


#: the real scene's depth a plane is held against: the nearest within this many pixels across
#: (plane_ground.glsl), so that the stereo's far specks and holes leave no hole in a plane
NEAREST_PX = 5


def nearest_depth(depth: np.ndarray, rows: tuple[int, int] | None = None) -> np.ndarray:
    """(H, W) float32: the nearest finite depth of ``depth`` within :data:`NEAREST_PX` pixels,
    0 where there is none (plane_ground.glsl's "unknown"); ``rows`` [r0, r1): those rows alone,
    the same values (read from the rows around them)."""
    r0, r1 = rows or (0, depth.shape[0])
    reach = NEAREST_PX // 2
    p0, p1 = max(r0 - reach, 0), min(r1 + reach, depth.shape[0])
    part = depth[p0:p1]
    d = np.where(np.isfinite(part) & (part > 0), part, np.float32(1e9)).astype(np.float32, copy=False)
    d = cv2.erode(d, np.ones((NEAREST_PX, NEAREST_PX), np.uint8))[r0 - p0:r1 - p0]
    return np.ascontiguousarray(np.where(d < 1e9, d, 0.0), np.float32)


def _resolve(gl: GLContext, source: moderngl.Framebuffer, targets: list[moderngl.Texture], *done) -> None:
    """Average the samples of the multisampled framebuffer ``source`` into ``targets``
    (textures), then free ``source`` and ``done`` (its renderbuffers no longer needed)."""
    resolve = gl.own(gl.ctx.framebuffer(targets))
    gl.wait()
    gl.ctx.copy_framebuffer(resolve, source)
    for obj in (resolve, source, *done):
        gl.free(obj)


#: models kept on the GPU between renders: beyond it the least recently drawn are freed (a
#: person posed for each object is a new mesh every time, :mod:`..models.skinning`)
MODELS_KEPT = 24


class Renderer:
    """Draws render passes with one :class:`GLContext`; models are uploaded once and kept (the
    :data:`MODELS_KEPT` most recently drawn)."""

    def __init__(self, gl: GLContext, shadow_size: int = 1024, shading: str = "auto", precision: str = "half") -> None:
        """``shading``: "sample" runs the lighting for every sample of the 4x multisampled lit
        pass; "pixel" once per pixel, at its centre, then fills the samples (fill.glsl) - on
        llvmpipe, which shades every sample, the lit pass takes about a third of the time, at
        the cost of parts thinner than a pixel (a window seal) showing in pieces; "auto": per
        pixel on a software renderer (llvmpipe), per sample on a GPU. ``precision``: what the
        multisampled lit targets store (:data:`~synthcompose.render.shading.PRECISIONS`)."""
        if shading not in SHADING:
            raise ValueError(f"shading must be one of {', '.join(SHADING)}, not {shading!r}")
        if precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, not {precision!r}")
        self.gl = gl.activate()
        #: the texture format of each resolved pass (:data:`COLOUR_PASSES`)
        self.pass_dtypes = {name: "f2" if precision == "half" and name in COLOUR_PASSES else "f4" for name, _ in PASSES}
        if shading == "auto":
            shading = device_shading(gl.renderer_name)
        self.shading = shading
        self.programs = {"id": gl.program("id"), "depth": gl.program("depth")}
        fill = FillPrograms.compile(gl) if shading == "pixel" else None
        if fill is not None:
            self.programs["fill"] = fill.objects  # the models draw their samples with it
        self._models: OrderedDict[str, GpuModel] = OrderedDict()  # the most recently drawn last
        # bound to sampler units that have nothing to show: every active sampler of a draw
        # must see a texture of its own kind (another pass may have left an integer one)
        self._blank = gl.texture((1, 1), 4, np.full((1, 1, 4), 255, np.uint8))
        self.shadows = ShadowMaps(gl, shadow_size)
        self._lit = LitDraw(gl, GroundPlane(gl), self._gpu_model)
        self._env: tuple[np.ndarray, moderngl.Texture] | None = None  # (photo, its reflection texture)
        self._shading = PerSample(gl, self._lit, precision) if fill is None else \
            PerPixel(gl, fill, self._lit, self._gpu_model, precision)

    def _gpu_model(self, model: Model) -> GpuModel:
        gpu = self._models.pop(model.key, None)
        if gpu is None:
            gpu = GpuModel(self.gl, model, self.programs)
        self._models[model.key] = gpu
        return gpu

    def _trim(self, objects: Sequence[RenderObject]) -> None:
        """Free the least recently drawn models beyond :data:`MODELS_KEPT`, none of ``objects``'."""
        wanted = {obj.model.key for obj in objects}
        for key in [k for k in self._models if k not in wanted][:max(len(self._models) - MODELS_KEPT, 0)]:
            self._models.pop(key).release()

    @property
    def models_kept(self) -> int:
        """How many models are on the GPU now."""
        return len(self._models)

    def render(self, camera: Camera, objects: Sequence[RenderObject], lighting: Lighting,
               photo: np.ndarray | None = None, roi: Roi | None = None,
               sun_mask: np.ndarray | None = None, eye: tuple[Camera, np.ndarray] | None = None,
               scene_depth: np.ndarray | None = None) -> RenderPasses | None:
        """Render every pass for ``objects`` inside ``roi`` (default: their screen rectangle).

        ``photo`` (H, W, 3) uint8 sRGB, the full frame: when given, the ground planes take
        their albedo from it per pixel (see lit.glsl). ``sun_mask`` (H, W) float, full frame: the sun
        reaching the real ground at each pixel (0 in its real shadows, lighting.py); the planes
        use it instead of their object's ``sun_visibility``. ``eye`` (camera, its full photo):
        the view the view-dependent light (highlights, reflections of the photo) is worked out
        for, when not ``camera``'s: the right view of a stereo pair shows the left view's
        shading, so that a matcher finds the surface's depth in both (stages.right).
        ``scene_depth`` (H, W) float, full frame: the real scene's depth (metres, inf where
        unknown); a plane nearer than it by plane_ground.glsl's share is left out there (it
        floats over lower ground: :func:`nearest_depth`).
        """
        roi = roi or roi_for(camera, objects, lighting)
        if roi is None:
            return None
        gl, ctx = self.gl.activate(), self.gl.ctx
        self._trim(objects)
        cam = crop_camera(camera, roi)
        size = (roi.width, roi.height)
        rows, cols = roi.slices
        # the lit pass's inputs in the region (views: made for each band of a large one)
        photo_roi = None if photo is None else photo[rows, cols]
        sun_roi = None if sun_mask is None else sun_mask[rows, cols]
        depth_roi = None if scene_depth is None else scene_depth[rows, cols]
        tex: dict[str, moderngl.Texture] = {}
        env = None
        if photo is not None:
            env = self._environment(photo if eye is None else eye[1])  # reflections (lit.glsl: environment)
        view = cam.optical_from_vehicle
        proj = cam.gl_projection(NEAR, FAR)
        light = light_matrices(objects, lighting)  # half, sun, sky, under
        self.shadows.draw(objects, light, self._gpu_model, lighting, self._lit.plane)
        self._lit.uniforms = frame_uniforms(camera if eye is None else eye[0], view, proj, lighting, light,
                                            env, sun_mask is not None, scene_depth is not None)
        self._shading.scene_depth(scene_depth is not None)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        bands = row_bands(*size)
        if len(bands) == 1:  # the whole region at once; its inputs freed once drawn
            inputs = self._inputs(size, (0, size[1]), photo_roi, sun_roi, depth_roi)
            bind_inputs(self._blank, self.shadows.textures, inputs[0], env, inputs[1], inputs[2])
            tex.update(self._lit_passes(objects, lighting, size, view, proj))
            for t in inputs:
                if t is not None:
                    gl.free(t)
        else:  # band by band into the whole region's passes (render.bands)
            whole = {name: gl.texture(size, c, dtype=self.pass_dtypes[name]) for name, c in PASSES}
            for band in bands:
                self._band(objects, lighting, size, view, proj, band, whole, env, photo_roi, sun_roi, depth_roi)
            tex.update(whole)
        tex["id"], tex["id_depth"] = self._ids(objects, size, view, proj)
        return RenderPasses(roi, cam, tex, gl)

    def _lit_passes(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int],
                    view: np.ndarray, proj: np.ndarray) -> dict[str, moderngl.Texture]:
        """The multisampled lit pass resolved into irpv, alpha, odepth, plane, objc, then ir, for
        the framebuffer size ``size`` (the shading's viewport: the region or a band of it). The
        large targets (about 300 bytes per ROI pixel in all) are made where needed and freed as
        soon as they are done with."""
        gl = self.gl
        ms, ms_depth, ms_fbo = self._shading.lit_pass(objects, lighting, size, view, proj)
        out = {name: gl.texture(size, c, dtype=self.pass_dtypes[name]) for name, c in PASSES[:-1]}
        # freed once resolved, but for the colour target ms[0] and the depth: they serve Ir
        _resolve(gl, ms_fbo, list(out.values()), *ms[1:])
        # Ir: the planes alone, unshadowed, made as Irpv's planes were (shaded per sample, or
        # once per pixel and filled), so that the two agree where a plane covers part of a pixel
        source = self._shading.ir_source(objects, lighting, size)
        ms_fbo_ir = framebuffer(gl, ms[:1], ms_depth, self._shading.viewport)
        ms_fbo_ir.use()
        ms_fbo_ir.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._shading.draw_ir(objects, lighting, source)
        out["ir"] = gl.texture(size, 4, dtype=self.pass_dtypes["ir"])
        _resolve(gl, ms_fbo_ir, [out["ir"]], ms_depth, ms[0])
        return out

    def _band(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int], view: np.ndarray,
              proj: np.ndarray, band: tuple[int, int], whole: dict[str, moderngl.Texture], env,
              photo_roi: np.ndarray | None, sun_roi: np.ndarray | None, depth_roi: np.ndarray | None) -> None:
        """One band of rows of the region's lit passes, into ``whole`` (:mod:`.bands`)."""
        gl = self.gl
        drawn = with_apron(band, size[1])
        band_size = (size[0], drawn[1] - drawn[0])
        inputs = self._inputs(band_size, drawn, photo_roi, sun_roi, depth_roi)
        bind_inputs(self._blank, self.shadows.textures, inputs[0], env, inputs[1], inputs[2])
        self._shading.viewport = viewport(drawn, *size)
        try:
            out = self._lit_passes(objects, lighting, band_size, view, proj)
        finally:
            self._shading.viewport = None
        names = [name for name, _ in PASSES]
        copy_rows(gl, [out[n] for n in names], [whole[n] for n in names], band[0] - drawn[0], band[0],
                  band[1] - band[0])
        for t in list(out.values()) + [t for t in inputs if t is not None]:
            gl.free(t)

    def _inputs(self, size: tuple[int, int], drawn: tuple[int, int], photo_roi: np.ndarray | None,
                sun_roi: np.ndarray | None, depth_roi: np.ndarray | None) -> list[moderngl.Texture | None]:
        """The lit pass's input textures (photo, sun mask, nearest scene depth) of the region's
        rows ``drawn`` [r0, r1) (``size``: their width and height), from the region's views
        (None: no such input)."""
        gl, (r0, r1) = self.gl, drawn
        return [None if photo_roi is None else gl.texture(size, 3, np.ascontiguousarray(photo_roi[r0:r1]), dtype="f1"),
                None if sun_roi is None else gl.texture(size, 1, np.ascontiguousarray(sun_roi[r0:r1], np.float32),
                                                        dtype="f4"),
                None if depth_roi is None else gl.texture(size, 1, nearest_depth(depth_roi, drawn), dtype="f4")]

    def _environment(self, photo: np.ndarray) -> moderngl.Texture:
        """The reflection texture of ``photo`` (:func:`~.lit.environment`), made once for the
        render of both views of a stereo pair (the right view reflects the left photo) and kept
        until a render asks for another photo."""
        if self._env is not None and self._env[0] is photo:
            return self._env[1]
        if self._env is not None:
            self.gl.free(self._env[1])
        self._env = (photo, environment(self.gl, photo))
        return self._env[1]

    def _ids(self, objects: Sequence[RenderObject], size: tuple[int, int], view: np.ndarray, proj: np.ndarray):
        """The id pass: (uint object index 1..K at each pixel centre, 0 = none, with a part's
        own label above gpu_model.PART_SHIFT: 16 bits; its depth)."""
        gl, ctx = self.gl, self.gl.ctx
        ids = gl.texture(size, 1, dtype="u2")
        id_depth = gl.texture(size, 1, dtype="f4")
        id_depth_rb = gl.own(ctx.depth_renderbuffer(size))
        id_fbo = gl.own(ctx.framebuffer([ids, id_depth], id_depth_rb))
        id_fbo.use()
        id_fbo.clear(depth=1.0)
        ids.write(np.zeros(size[::-1], np.uint16))  # clear() cannot clear integer targets
        idp = self.programs["id"]
        idp["u_view"].write(gl_mat4(view))
        idp["u_proj"].write(gl_mat4(proj))
        for k, obj in enumerate(objects, start=1):
            idp["u_model"].write(gl_mat4(obj.vehicle_from_object))
            self._gpu_model(obj.model).draw_ids(k)
        for obj in (id_fbo, id_depth_rb):
            gl.free(obj)
        return ids, id_depth

    def release(self, passes: RenderPasses) -> None:
        self.gl.activate()
        for t in passes.textures.values():
            self.gl.free(t)
