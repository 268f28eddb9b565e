"""Stage 4 - render: the passes differential rendering needs, for a region of interest.

For the objects placed in one frame, :class:`Renderer` draws (all in linear light, in the
frame's own camera, only inside the screen rectangle the objects and their planes cover):

* ``irpv``  : objects + their local ground planes, lit, with shadows (4x MSAA, resolved)
* ``ir``    : the planes alone, lit, no shadows
* ``alpha`` : object coverage in [0, 1] (antialiased)
* ``odepth``: coverage-weighted object depth (divide by alpha for the mean depth)
* ``plane`` : (coverage-weighted plane depth, plane coverage)
* ``id``    : uint object index 1..K at each pixel centre (0 = none), and ``id_depth``
"""
from __future__ import annotations

import math
from typing import Sequence

import cv2
import moderngl
import numpy as np

from .camera import Camera
from .gl import GLContext
from .gpu_model import _BIAS, VERTEX_LAYOUT, _gl, _GpuModel, _layout, _look_at, _ortho, _set_recolour
from .models import Model
from .renderables import FAR, NEAR, Lighting, RenderObject, RenderPasses, Roi, crop_camera, roi_for

__all__ = ["FAR", "NEAR", "Lighting", "RenderObject", "RenderPasses", "Renderer", "Roi", "crop_camera", "roi_for"]

GL_SRGB8 = 0x8C41  # internal format of the reflection texture: sampled as linear light
SAMPLES = 4
_PLANE_COL_UNIT = 12  # texture unit of the per-pixel plane colour that fill.glsl (PLANE) reads
_UNDER_UNIT = 13  # texture unit of the objects' undersides seen from below (contact shadows)
#: the sky's occlusion on the ground is averaged over discs of this radius and 2.5 times it
#: (metres): under an overcast sky an object shades the ground around it over about its height
SKY_RADIUS = 0.5
#: contact shadow: ground under a part of an object lower than about this (metres) loses most
#: of its ambient light (the tyre's or the foot's contact patch), averaged over this radius
CONTACT_HEIGHT, CONTACT_RADIUS = 0.15, 0.3
SHADING = ("auto", "pixel", "sample")


class Renderer:
    """Draws render passes with one :class:`GLContext`; models are uploaded once and kept."""

    def __init__(self, gl: GLContext, shadow_size: int = 1024, shading: str = "auto") -> None:
        """``shading``: "sample" runs the lighting for every sample of the 4x multisampled lit
        pass; "pixel" once per pixel, at its centre, then fills the samples (fill.glsl) - on
        llvmpipe, which shades every sample, the lit pass takes about a third of the time, at
        the cost of parts thinner than a pixel (a window seal) showing in pieces; "auto": per
        pixel on a software renderer (llvmpipe), per sample on a GPU."""
        if shading not in SHADING:
            raise ValueError(f"shading must be one of {', '.join(SHADING)}, not {shading!r}")
        self.gl = gl.activate()
        if shading == "auto":
            shading = "pixel" if any(s in gl.renderer_name.lower() for s in ("llvmpipe", "softpipe", "swrast")) \
                else "sample"
        self.shading = shading
        ctx = gl.ctx
        self.programs = {"id": gl.program("id"), "depth": gl.program("depth")}
        self._lit_uniforms: dict[str, object] = {}  # what every lit variant takes in this render
        if shading == "pixel":  # fill.glsl's programs: object samples, plane samples, neighbours
            self.programs["fill"] = gl.program("fill")
            self._fill_plane = gl.program("fill", PLANE=1)
            self._neighbours = gl.program("fill", NEIGHBOURS=1)
            self._frame_vao = gl.own(ctx.vertex_array(self._neighbours, []))  # one full-frame triangle
        self._models: dict[str, _GpuModel] = {}
        # bound to sampler units that have nothing to show: every active sampler of a draw
        # must see a texture of its own kind (another pass may have left an integer one)
        self._blank = gl.texture((1, 1), 4, np.full((1, 1, 4), 255, np.uint8))
        self.shadow_maps = []
        for k in range(3):  # sun map, top-down sky-occlusion map, the objects' undersides from below
            tex = gl.own(ctx.depth_texture((shadow_size, shadow_size)))
            # the first two are shadow tests; the third is read as depth: how high the lowest
            # part of an object stands over each ground point (contact shadows, lit.glsl)
            tex.compare_func = "<=" if k < 2 else ""
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = False
            fbo = gl.own(ctx.framebuffer(depth_attachment=tex))
            self.shadow_maps.append((tex, fbo))
        plane = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
        pdata = np.concatenate([plane, np.tile([0, 0, 1], (4, 1)), np.zeros((4, 2)), np.ones((4, 4)),
                                np.zeros((4, 2))], axis=1).astype(np.float32)
        self._plane_vbo = gl.own(ctx.buffer(pdata.tobytes()))
        self._plane_ibo = gl.own(ctx.buffer(np.array([0, 1, 2, 0, 2, 3], np.uint32).tobytes()))
        self._plane_vaos: dict[moderngl.Program, moderngl.VertexArray] = {}

    def _gpu_model(self, model: Model) -> _GpuModel:
        if model.key not in self._models:
            self._models[model.key] = _GpuModel(self.gl, model, self.programs)
        return self._models[model.key]

    def _lit(self, plane: bool, shadows: bool = True, maps: "_GpuMaps | None" = None) -> moderngl.Program:
        """The lit.glsl variant for a ground plane (``shadows`` False: Ir) or for object parts
        with ``maps``, with this render's uniforms (:attr:`_lit_uniforms`) set."""
        defines = {"PLANE": 1} if plane else {}
        if plane and not shadows:
            defines["NO_SHADOWS"] = 1
        if maps is not None and maps.base is not None:
            defines["TEXTURE"] = 1
        if maps is not None and maps.normal is not None:
            defines["NORMAL_MAP"] = 1
        prog = self.gl.program("lit", **defines)
        for name, value in self._lit_uniforms.items():
            uniform = prog.get(name, None)  # a variant may not use it
            if uniform is None:
                continue
            if isinstance(value, bytes):
                uniform.write(value)
            else:
                uniform.value = value
        return prog

    def _plane_vao(self, prog: moderngl.Program) -> moderngl.VertexArray:
        if prog not in self._plane_vaos:
            self._plane_vaos[prog] = self.gl.own(self.gl.ctx.vertex_array(
                prog, [_layout(prog, self._plane_vbo, VERTEX_LAYOUT)], index_buffer=self._plane_ibo,
                index_element_size=4))
        return self._plane_vaos[prog]

    # ---------------------------------------------------------------- shadows
    def _light_matrices(self, objects: Sequence[RenderObject], lighting: Lighting):
        pts = np.concatenate([o.corners(lighting) for o in objects])
        centre = (pts.min(0) + pts.max(0)) / 2
        half = float(np.linalg.norm(pts - centre, axis=1).max()) + 0.1
        mats = [half]
        for direction in (np.asarray(lighting.sun_direction, float), np.array([0.0, 0.0, 1.0]),
                          np.array([0.0, 0.0, -1.0])):
            direction = direction / np.linalg.norm(direction)
            up = np.array([1.0, 0, 0]) if abs(direction[2]) > 0.99 else np.array([0, 0, 1.0])
            view = _look_at(centre + direction * (half + 5.0), centre, up)
            mats.append(_ortho(half, 0.1, 2 * half + 10.0) @ view)
        return mats

    def _draw_shadow_maps(self, objects, mats) -> None:
        ctx = self.gl.ctx
        prog = self.programs["depth"]
        for (tex, fbo), light in zip(self.shadow_maps, mats):
            fbo.use()
            fbo.clear(depth=1.0)
            ctx.enable(moderngl.DEPTH_TEST)
            prog["u_light"].write(_gl(light))
            for obj in objects:
                prog["u_model"].write(_gl(obj.vehicle_from_object))
                self._gpu_model(obj.model).draw("depth")

    # ----------------------------------------------------------------- passes
    def render(self, camera: Camera, objects: Sequence[RenderObject], lighting: Lighting,
               photo: np.ndarray | None = None, roi: Roi | None = None,
               sun_mask: np.ndarray | None = None) -> RenderPasses | None:
        """Render every pass for ``objects`` inside ``roi`` (default: their screen rectangle).

        ``photo`` (H, W, 3) uint8 sRGB, the full frame: when given, the ground planes take
        their albedo from it per pixel (see lit.glsl) and the ROI crop is kept in the
        passes as ``photo`` for the compose stage. ``sun_mask`` (H, W) float, full frame: the sun
        reaching the real ground at each pixel (0 in its real shadows, lighting.py); the planes
        use it instead of their object's ``sun_visibility``.
        """
        roi = roi or roi_for(camera, objects, lighting)
        if roi is None:
            return None
        gl, ctx = self.gl.activate(), self.gl.ctx
        cam = crop_camera(camera, roi)
        size = (roi.width, roi.height)
        tex: dict[str, moderngl.Texture] = {}
        if photo is not None:
            rows, cols = roi.slices
            tex["photo"] = gl.texture(size, 3, np.ascontiguousarray(photo[rows, cols]), dtype="f1")
            tex["env"] = self._environment(photo)  # reflections (lit.glsl: environment)
        if sun_mask is not None:
            rows, cols = roi.slices
            tex["sun_mask"] = gl.texture(size, 1, np.ascontiguousarray(sun_mask[rows, cols], np.float32), dtype="f4")
        view = cam.optical_from_vehicle
        proj = cam.gl_projection(NEAR, FAR)
        half, sun_mat, sky_mat, under_mat = self._light_matrices(objects, lighting)
        self._draw_shadow_maps(objects, (sun_mat, sky_mat, under_mat))

        uniforms: dict[str, object] = {
            "u_view": _gl(view), "u_proj": _gl(proj), "u_camera_pos": tuple(camera.position),
            "u_sun_dir": tuple(lighting.sun_direction), "u_sun_rgb": tuple(lighting.sun_rgb),
            "u_sky_rgb": tuple(lighting.sky_rgb), "u_ground_rgb": tuple(lighting.ground_rgb),
            "u_sun_matrix": _gl(_BIAS @ sun_mat), "u_sky_matrix": _gl(_BIAS @ sky_mat),
            "u_sky_radius": SKY_RADIUS / (2 * half),  # in map units
            "u_under_map": _UNDER_UNIT, "u_under_matrix": _gl(_BIAS @ under_mat),
            "u_under_range": 2 * half + 10.0 - 0.1,  # metres the under map's depth 0..1 spans
            "u_self_bias": 0.05 / (2 * half + 10.0 - 0.1),
            "u_contact_height": CONTACT_HEIGHT, "u_contact_radius": CONTACT_RADIUS / (2 * half),
            "u_texture": 0, "u_normal_map": 6, "u_sun_map": 1, "u_sky_map": 2, "u_photo": 3,
            "u_plane_from_photo": photo is not None,
            # reflections sample the full photo (see _environment)
            "u_env": 4, "u_has_env": photo is not None,
            "u_sun_mask": 5, "u_has_sun_mask": sun_mask is not None,
        }
        if photo is not None:
            uniforms.update({
                "u_env_view": _gl(camera.optical_from_vehicle),
                "u_env_k": (camera.fx / camera.width, camera.fy / camera.height,
                            (camera.u0 + 0.5) / camera.width, (camera.v0 + 0.5) / camera.height),
                "u_env_lods": float(math.log2(max(tex["env"].width, tex["env"].height)))})
        self._lit_uniforms = uniforms
        (tex["env"] if photo is not None else self._blank).use(4)
        (tex["sun_mask"] if sun_mask is not None else self._blank).use(5)
        self.shadow_maps[0][0].use(1)
        self.shadow_maps[1][0].use(2)
        self.shadow_maps[2][0].use(_UNDER_UNIT)
        (tex["photo"] if photo is not None else self._blank).use(3)
        self._blank.use(0)
        self._blank.use(6)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)

        # multisampled lit pass -> irpv, alpha, odepth, plane, objc; then ir. The large targets
        # (about 300 bytes per ROI pixel in all) are made where needed and freed as soon as
        # they are done with, so that a large ROI (a car close by: 2048 x 721) peaks lower
        if self.shading == "pixel":
            ms, ms_depth, ms_fbo = self._lit_per_pixel(objects, lighting, size, view, proj)
        else:
            ms, ms_depth, ms_fbo = self._multisampled(size)
            ms_fbo.use()
            ms_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            self._draw_lit(objects, lighting, objects_too=True)
        tex.update({name: gl.texture(size, c, dtype="f4") for name, c in
                    (("irpv", 4), ("alpha", 1), ("odepth", 1), ("plane", 2), ("objc", 4))})
        resolve = gl.own(ctx.framebuffer([tex["irpv"], tex["alpha"], tex["odepth"], tex["plane"], tex["objc"]]))
        gl.wait()
        ctx.copy_framebuffer(resolve, ms_fbo)
        for obj in (resolve, ms_fbo, *ms[1:]):  # the colour target and the depth serve Ir
            gl.free(obj)
        # Ir: the planes alone, unshadowed, made as Irpv's planes were (shaded per sample, or
        # once per pixel and filled), so that the two agree where a plane covers part of a pixel
        plane_ir = self._planes_per_pixel(objects, lighting, size) if self.shading == "pixel" else None
        ms_fbo_ir = gl.own(ctx.framebuffer(ms[:1], ms_depth))
        ms_fbo_ir.use()
        ms_fbo_ir.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        if plane_ir is None:
            self._draw_lit(objects, lighting, objects_too=False, shadows=False)
        else:
            self._fill_planes(objects, lighting, plane_ir)
            gl.free(plane_ir)
        tex["ir"] = gl.texture(size, 4, dtype="f4")
        resolve_ir = gl.own(ctx.framebuffer([tex["ir"]]))
        gl.wait()
        ctx.copy_framebuffer(resolve_ir, ms_fbo_ir)
        for obj in (resolve_ir, ms_fbo_ir, ms_depth, ms[0]):
            gl.free(obj)

        # integer id + depth at pixel centres
        tex["id"] = gl.texture(size, 1, dtype="u4")
        tex["id_depth"] = gl.texture(size, 1, dtype="f4")
        id_depth_rb = gl.own(ctx.depth_renderbuffer(size))
        id_fbo = gl.own(ctx.framebuffer([tex["id"], tex["id_depth"]], id_depth_rb))
        id_fbo.use()
        id_fbo.clear(depth=1.0)
        tex["id"].write(np.zeros(size[::-1], np.uint32))  # clear() cannot clear integer targets
        idp = self.programs["id"]
        idp["u_view"].write(_gl(view))
        idp["u_proj"].write(_gl(proj))
        for k, obj in enumerate(objects, start=1):
            idp["u_model"].write(_gl(obj.vehicle_from_object))
            idp["u_id"].value = k
            self._gpu_model(obj.model).draw("id")
        for obj in (id_fbo, id_depth_rb):
            gl.free(obj)
        return RenderPasses(roi, cam, tex, gl)

    def _multisampled(self, size: tuple[int, int]):
        """The lit pass's 4x multisampled targets (irpv, alpha, odepth, plane, objc: lit.glsl's
        outputs 0-4), their depth, and a framebuffer of them."""
        gl, ctx = self.gl, self.gl.ctx
        ms = [gl.own(ctx.renderbuffer(size, c, samples=SAMPLES, dtype="f4")) for c in (4, 1, 1, 2, 4)]
        ms_depth = gl.own(ctx.depth_renderbuffer(size, samples=SAMPLES))
        return ms, ms_depth, gl.own(ctx.framebuffer(ms, ms_depth))

    def _lit_per_pixel(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int],
                       view: np.ndarray, proj: np.ndarray):
        """The lit pass with the light shaded once per pixel (``shading="pixel"``); returns the
        multisampled targets drawn (:meth:`_multisampled`), to resolve."""
        gl, ctx = self.gl, self.gl.ctx
        # the light, shaded once per pixel at its centre (1x): the objects over their planes
        # (object colour and coverage: lit.glsl's out_object), and the planes alone with the
        # objects' shadows; then fill.glsl rasterises the same geometry at SAMPLES per pixel
        # with those colours, and the resolve averages the samples (MSAA's colour, without
        # llvmpipe shading every sample: a third of the time)
        centre = [gl.own(ctx.renderbuffer(size, c, dtype="f4")) for c in (4, 1, 1, 2)]
        centre_depth = gl.own(ctx.depth_renderbuffer(size))
        object_col, object_key, plane_col = (gl.texture(size, 4, dtype="f4") for _ in range(3))
        objects_fbo = gl.own(ctx.framebuffer(centre + [object_col, object_key], centre_depth))
        planes_fbo = gl.own(ctx.framebuffer([plane_col], centre_depth))
        for fbo, with_objects in ((objects_fbo, True), (planes_fbo, False)):
            fbo.use()
            fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            self._draw_lit(objects, lighting, objects_too=with_objects)
        for obj in (objects_fbo, planes_fbo, centre_depth, *centre):  # only their textures are read on
            gl.free(obj)
        # the other material near each pixel (fill.glsl, NEIGHBOURS), once per pixel
        other_col, other_key = gl.texture(size, 4, dtype="f4"), gl.texture(size, 4, dtype="f4")
        others_fbo = gl.own(ctx.framebuffer([other_col, other_key]))
        textures = {"u_object_col": object_col, "u_object_key": object_key, "u_plane_col": plane_col,
                    "u_other_col": other_col, "u_other_key": other_key}
        units = {name: unit for unit, name in enumerate(textures, start=7)}
        object_col.use(units["u_object_col"])
        object_key.use(units["u_object_key"])
        for name in ("u_object_col", "u_object_key"):
            self._neighbours[name].value = units[name]
        others_fbo.use()
        ctx.disable(moderngl.DEPTH_TEST)
        self._frame_vao.render(moderngl.TRIANGLES, vertices=3)
        ctx.enable(moderngl.DEPTH_TEST)
        gl.free(others_fbo)
        gl.wait()  # the freed targets are released once drawn: before the multisampled ones exist
        ms, ms_depth, ms_fbo = self._multisampled(size)
        fill, fill_plane = self.programs["fill"], self._fill_plane
        for prog in (fill, fill_plane):  # (the plane variant's texture: _fill_planes)
            prog["u_view"].write(_gl(view))
            prog["u_proj"].write(_gl(proj))
        for name, texture in textures.items():
            fill[name].value = units[name]
            texture.use(units[name])
        ms_fbo.use()
        ms_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._fill_planes(objects, lighting, plane_col)
        for obj in objects:
            fill["u_model"].write(_gl(obj.vehicle_from_object))
            self._gpu_model(obj.model).draw("fill")
        for obj in textures.values():
            gl.free(obj)
        gl.wait()
        return ms, ms_depth, ms_fbo

    def _planes_per_pixel(self, objects: Sequence[RenderObject], lighting: Lighting, size: tuple[int, int]):
        """The objects' ground planes alone, unshadowed, shaded once per pixel at its centre: a
        texture, for Ir to be filled from as Irpv's planes were (:meth:`_fill_planes`). Made after
        Irpv's resolve, when most of the multisampled targets are freed."""
        gl, ctx = self.gl, self.gl.ctx
        gl.wait()  # the freed targets are released once Irpv's resolve is done: before these exist
        plane_ir = gl.texture(size, 4, dtype="f4")
        depth = gl.own(ctx.depth_renderbuffer(size))
        fbo = gl.own(ctx.framebuffer([plane_ir], depth))
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self._draw_lit(objects, lighting, objects_too=False, shadows=False)
        for obj in (fbo, depth):
            gl.free(obj)
        return plane_ir

    def _fill_planes(self, objects: Sequence[RenderObject], lighting: Lighting, plane_col: moderngl.Texture) -> None:
        """Rasterise the objects' ground planes into the bound multisampled framebuffer, every
        sample its pixel's colour from ``plane_col`` (the planes shaded once per pixel:
        fill.glsl, PLANE); view and projection as set by :meth:`_lit_per_pixel`."""
        prog = self._fill_plane
        plane_col.use(_PLANE_COL_UNIT)
        prog["u_plane_col"].value = _PLANE_COL_UNIT
        vao = self._plane_vao(prog)
        for obj in objects:
            prog["u_model"].write(_gl(obj.plane_matrix(lighting)))
            vao.render(moderngl.TRIANGLES)

    def _draw_lit(self, objects: Sequence[RenderObject], lighting: Lighting, objects_too: bool,
                  shadows: bool = True) -> None:
        """Draw the objects' ground planes (``shadows`` False: unshadowed, for Ir) and
        (``objects_too``) the objects over them with the lit programs, into the bound framebuffer.
        Each run of parts with the same maps is drawn with the variant for those maps (_lit)."""
        prog = self._lit(plane=True, shadows=shadows)
        vao = self._plane_vao(prog)
        for obj in objects:
            prog["u_model"].write(_gl(obj.plane_matrix(lighting)))
            prog["u_plane_albedo"].value = tuple(obj.plane_albedo)
            prog["u_sun_scale"].value = float(obj.sun_visibility)
            vao.render(moderngl.TRIANGLES)
        if not objects_too:
            return
        # objects drawn over their planes
        variants: dict[tuple[bool, bool], moderngl.Program] = {}
        for obj in objects:
            gpu = self._gpu_model(obj.model)
            for first, count, maps in gpu.ranges:
                key = (maps.base is not None, maps.normal is not None)
                if key not in variants:
                    variants[key] = self._lit(plane=False, maps=maps)
                prog = variants[key]
                prog["u_model"].write(_gl(obj.vehicle_from_object))
                prog["u_sun_scale"].value = float(obj.sun_visibility)
                _set_recolour(prog, obj.recolour)
                if maps.base is not None:
                    maps.base.use(0)
                if maps.normal is not None:
                    maps.normal.use(6)
                    prog["u_normal_scale"].value = maps.normal_scale
                gpu.vao(prog).render(moderngl.TRIANGLES, vertices=count, first=first)

    def _environment(self, photo: np.ndarray) -> moderngl.Texture:
        """The photo at half size as a mipmapped sRGB texture (reads linear): what glossy paint
        and glass reflect (shaders/lit.glsl, environment())."""
        h, w = photo.shape[:2]
        small = cv2.resize(photo, (max(w // 2, 1), max(h // 2, 1)), interpolation=cv2.INTER_AREA)
        tex = self.gl.own(self.gl.ctx.texture((small.shape[1], small.shape[0]), 3, np.ascontiguousarray(small).tobytes(),
                                              internal_format=GL_SRGB8))
        tex.build_mipmaps()
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def release(self, passes: RenderPasses) -> None:
        self.gl.activate()
        for t in passes.textures.values():
            self.gl.free(t)
