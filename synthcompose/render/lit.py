"""lit.glsl, the lit pass's programs: the uniforms and textures of one render (the light, its
depth maps, the photo and its reflection), the program variant for a ground plane or for a run
of parts with the same maps, and the draw of the planes and the objects over them.

Texture units of lit.glsl's samplers: 0 base colour, 1 sun map, 2 sky map, 3 photo (ROI crop),
4 environment (reflections), 5 sun mask, 6 normal map, 13 undersides (contact shadows), 14 the
ground's sky (the planes' occlusion).
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import cv2
import moderngl
import numpy as np

from synthcompose.camera import Camera
from synthcompose.look.plates import plate_image
from synthcompose.models import Model

from .gl import GLContext
from .gpu_model import GpuMaps, GpuModel, GroundPlane, mipmapped
from .shadows import GROUND_SKY_SIZE, ground_sky_texels, light_range
from .transforms import TEXTURE_FROM_CLIP, gl_mat4
from .values import Lighting, RenderObject

GL_SRGB8 = 0x8C41  # internal format of the reflection texture: sampled as linear light
_UNDER_UNIT = 13  # texture unit of the objects' undersides seen from below (contact shadows)
_GROUND_SKY_UNIT = 14  # texture unit of the sky the ground planes see past the objects
SCENE_DEPTH_UNIT = 15  # texture unit of the real scene's nearest depth (plane_ground.glsl)
#: tangent of the sun's angular radius (0.267 degrees): a shadow's edge is this soft per metre
#: from its caster (shaders/lit.glsl, sun_visibility)
SUN_RADIUS = math.tan(math.radians(0.267))
#: a ground plane's darkening (the objects' shadows and occlusion) fades out over this many
#: metres to its edges, so that no outline of the plane shows (values.PLANE_MARGIN is wider)
PLANE_FADE = 0.3
#: ground planes one lit pass fades over together (lit.glsl's u_plane_inv; objects per render)
MAX_PLANES = 15
#: contact shadow: ground under a part of an object lower than about this (metres) loses most
#: of its ambient light (the tyre's or the foot's contact patch), averaged over this radius
CONTACT_HEIGHT, CONTACT_RADIUS = 0.15, 0.3
#: number plates kept on the GPU (a batch meets new ones with every image set)
PLATES_KEPT = 16


def environment(gl: GLContext, photo: np.ndarray) -> moderngl.Texture:
    """The photo at half size as a mipmapped sRGB texture (reads linear): what glossy paint
    and glass reflect (shaders/lit.glsl, environment())."""
    h, w = photo.shape[:2]
    small = cv2.resize(photo, (max(w // 2, 1), max(h // 2, 1)), interpolation=cv2.INTER_AREA)
    tex = gl.own(gl.ctx.texture((small.shape[1], small.shape[0]), 3, np.ascontiguousarray(small).tobytes(),
                                internal_format=GL_SRGB8))
    tex.build_mipmaps()
    tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    return tex


def frame_uniforms(camera: Camera, view: np.ndarray, proj: np.ndarray, lighting: Lighting, light: Sequence,
                   env: moderngl.Texture | None, has_sun_mask: bool,
                   has_scene_depth: bool = False) -> dict[str, object]:
    """What every lit variant takes in one render: ``camera`` the full frame's, ``view`` and
    ``proj`` the ROI's; ``light`` (half, sun, sky, under) from
    :func:`~synthcompose.render.shadows.light_matrices`; ``env`` the photo's reflection
    texture (:func:`environment`), None without a photo."""
    half, sun_mat, sky_mat, under_mat = light
    uniforms: dict[str, object] = {
        "u_view": gl_mat4(view), "u_proj": gl_mat4(proj), "u_camera_pos": tuple(camera.position),
        "u_sun_dir": tuple(lighting.sun_direction), "u_sun_rgb": tuple(lighting.sun_rgb),
        "u_sky_rgb": tuple(lighting.sky_rgb), "u_ground_rgb": tuple(lighting.ground_rgb),
        "u_sun_matrix": gl_mat4(TEXTURE_FROM_CLIP @ sun_mat), "u_sky_matrix": gl_mat4(TEXTURE_FROM_CLIP @ sky_mat),
        "u_map_metres": 2 * half, "u_sun_radius": SUN_RADIUS,
        "u_under_map": _UNDER_UNIT, "u_ground_sky": _GROUND_SKY_UNIT,
        "u_ground_sky_scale": ground_sky_texels(half) / GROUND_SKY_SIZE,  # the map's share used
        "u_under_matrix": gl_mat4(TEXTURE_FROM_CLIP @ under_mat),
        "u_under_range": light_range(half),  # metres the light maps' depth 0..1 spans
        "u_self_bias": 0.05 / light_range(half),
        "u_contact_height": CONTACT_HEIGHT, "u_contact_radius": CONTACT_RADIUS / (2 * half),
        "u_texture": 0, "u_normal_map": 6, "u_sun_map": 1, "u_sky_map": 2, "u_photo": 3,
        "u_plane_from_photo": env is not None,
        # reflections sample the full photo (see environment)
        "u_env": 4, "u_has_env": env is not None,
        "u_sun_mask": 5, "u_has_sun_mask": has_sun_mask,
        "u_scene_depth": SCENE_DEPTH_UNIT, "u_has_scene_depth": has_scene_depth,
    }
    if env is not None:
        uniforms.update({
            "u_env_view": gl_mat4(camera.optical_from_vehicle),
            "u_env_k": (camera.fx / camera.width, camera.fy / camera.height,
                        (camera.u0 + 0.5) / camera.width, (camera.v0 + 0.5) / camera.height),
            "u_env_lods": float(math.log2(max(env.width, env.height)))})
    return uniforms


def bind_inputs(blank: moderngl.Texture, shadow_textures: Sequence[moderngl.Texture],
                photo: moderngl.Texture | None, env: moderngl.Texture | None,
                sun_mask: moderngl.Texture | None, scene_depth: moderngl.Texture | None = None) -> None:
    """Bind one render's textures to lit.glsl's units (``blank`` where there is none: every
    active sampler must see a texture of its own kind); ``shadow_textures``: sun, sky, under,
    the ground's sky."""
    (env if env is not None else blank).use(4)
    (sun_mask if sun_mask is not None else blank).use(5)
    (scene_depth if scene_depth is not None else blank).use(SCENE_DEPTH_UNIT)
    shadow_textures[0].use(1)
    shadow_textures[1].use(2)
    shadow_textures[2].use(_UNDER_UNIT)
    shadow_textures[3].use(_GROUND_SKY_UNIT)
    (photo if photo is not None else blank).use(3)
    blank.use(0)
    blank.use(6)


def set_recolour(prog: moderngl.Program, recolour) -> None:
    """lit.glsl's recolour uniforms for one object (its paint or clothes)."""
    keys, rgbs = np.zeros((3, 4), np.float32), np.zeros((3, 3), np.float32)
    for i, (key, rgb) in enumerate(recolour[:3]):
        keys[i], rgbs[i] = key, rgb
    prog["u_recolour_n"].value = min(len(recolour), 3)
    prog["u_recolour_key"].write(keys.tobytes())
    prog["u_recolour_rgb"].write(rgbs.tobytes())


class LitDraw:
    """Draws with lit.glsl: the ground planes (``plane``) and the objects (their models from
    ``gpu_model``), with the uniforms of the render under way (:attr:`uniforms`)."""

    def __init__(self, gl: GLContext, plane: GroundPlane, gpu_model: Callable[[Model], GpuModel]) -> None:
        self.gl = gl
        self.plane = plane
        self._gpu_model = gpu_model
        self.uniforms: dict[str, object] = {}  # what every lit variant takes in this render
        self._plates: dict[tuple[str, tuple[int, int]], moderngl.Texture] = {}  # the newest last

    def _base_texture(self, obj: RenderObject, maps: GpuMaps) -> moderngl.Texture | None:
        """The base colour texture a run of ``obj``'s parts is drawn with: the part's own, or
        for a number plate the object's plate (made on first use, :data:`PLATES_KEPT` kept)."""
        if maps.plate is None or obj.plate is None:
            return maps.base
        key = (obj.plate, maps.plate)
        tex = self._plates.pop(key, None)
        if tex is None:
            tex = mipmapped(self.gl, plate_image(*key))
            if len(self._plates) >= PLATES_KEPT:
                self.gl.free(self._plates.pop(next(iter(self._plates))))
        self._plates[key] = tex
        return tex

    def program(self, plane: bool, shadows: bool = True, textured: bool = False,
                normal_map: bool = False, glass: bool = False) -> moderngl.Program:
        """The lit.glsl variant for a ground plane (``shadows`` False: Ir) or for object parts
        (with a base colour texture, a normal map; ``glass``: a pane drawn over what is behind
        it), with this render's uniforms (:attr:`uniforms`) set."""
        defines = {"PLANE": 1} if plane else {}
        if plane and not shadows:
            defines["NO_SHADOWS"] = 1
        if textured:
            defines["TEXTURE"] = 1
        if normal_map:
            defines["NORMAL_MAP"] = 1
        if glass:
            defines["GLASS"] = 1
        prog = self.gl.program("lit", **defines)
        for name, value in self.uniforms.items():
            uniform = prog.get(name, None)  # a variant may not use it
            if uniform is None:
                continue
            if isinstance(value, bytes):
                uniform.write(value)
            else:
                uniform.value = value
        return prog

    def draw(self, objects: Sequence[RenderObject], lighting: Lighting, objects_too: bool,
             shadows: bool = True, reverse: bool = False) -> None:
        """Draw the objects' ground planes (``shadows`` False: unshadowed, for Ir) and
        (``objects_too``) the objects over them with the lit programs, into the bound framebuffer.
        Each run of parts with the same maps is drawn with the variant for those maps (:meth:`program`);
        the opaque parts of every object first, then their glass (:meth:`_draw_glass`).
        ``reverse``: every opaque triangle of that sequence in the opposite order (the objects
        last to first, then the planes), the glass after them as forwards: with a depth test that
        passes equal depths, the fragment that is left at a pixel is the one the forward order
        leaves with a strict test (the first drawn of the nearest),
        :class:`~synthcompose.render.shading.PerPixel`'s depth pre-pass (of the opaque parts)."""
        if not reverse:
            self._draw_planes(objects, lighting, shadows, reverse)
        glass, variants = self._draw_objects(objects, reverse) if objects_too else ([], {})
        if reverse:
            self._draw_planes(objects, lighting, shadows, reverse)
        if glass:
            if reverse:
                self.gl.ctx.depth_func = "<"  # the forward draw's test against the opaque parts' depth
            self._draw_glass(glass, variants)

    def _draw_planes(self, objects: Sequence[RenderObject], lighting: Lighting, shadows: bool, reverse: bool) -> None:
        prog = self.program(plane=True, shadows=shadows)
        vao = self.plane.vao(prog, reverse)
        if shadows:  # every plane's square: the darkening fades out at the edges of their union
            if len(objects) > MAX_PLANES:
                raise ValueError(f"lit.glsl: {len(objects)} ground planes, at most {MAX_PLANES}")
            prog["u_planes_n"].value = len(objects)
            inv = np.zeros((MAX_PLANES, 4, 4))
            halves = np.zeros((MAX_PLANES, 2), "f4")
            for k, obj in enumerate(objects):
                inv[k] = np.linalg.inv(obj.plane_matrix(lighting))
                halves[k] = obj.plane_half(lighting)
            prog["u_plane_inv"].write(b"".join(gl_mat4(m) for m in inv))
            prog["u_plane_halves"].write(halves.tobytes())
            prog["u_plane_fade"].value = PLANE_FADE
        for obj in (reversed(objects) if reverse else objects):
            prog["u_model"].write(gl_mat4(obj.plane_matrix(lighting)))
            prog["u_plane_albedo"].value = tuple(obj.plane_albedo)
            prog["u_sun_scale"].value = float(obj.sun_visibility)
            vao.render(moderngl.TRIANGLES)

    def _draw_objects(self, objects: Sequence[RenderObject], reverse: bool) -> tuple[list, dict]:
        """The objects' opaque runs over their planes (``reverse``: :meth:`draw`), each with the
        variant for its maps; their glass runs (object, run) and the variants, for :meth:`_draw_glass`."""
        variants: dict[tuple[bool, bool, bool], moderngl.Program] = {}
        glass = []
        for obj in (reversed(objects) if reverse else objects):
            ranges = self._gpu_model(obj.model).ranges
            for run in (reversed(ranges) if reverse else ranges):
                if run[2].transmission > 0.0:
                    glass.append((obj, run))
                else:
                    self._draw_run(obj, run, variants, reverse)
        if reverse:  # the glass in the forward order
            glass.reverse()
        return glass, variants

    def _draw_run(self, obj: RenderObject, run, variants: dict, reverse: bool = False) -> None:
        """One run of ``obj``'s parts (first index, count, maps) with its lit variant
        (``reverse``: its triangles last to first)."""
        first, count, maps = run
        base = self._base_texture(obj, maps)
        key = (base is not None, maps.normal is not None, maps.transmission > 0.0)
        if key not in variants:
            variants[key] = self.program(plane=False, textured=key[0], normal_map=key[1], glass=key[2])
        prog = variants[key]
        prog["u_model"].write(gl_mat4(obj.vehicle_from_object))
        prog["u_sun_scale"].value = float(obj.sun_visibility)
        if key[2]:  # a pane: no base colour of its own to change
            prog["u_transmission"].value = float(maps.transmission)
        else:
            set_recolour(prog, obj.recolour)
        if base is not None:
            base.use(0)
        if maps.normal is not None:
            maps.normal.use(6)
            prog["u_normal_scale"].value = maps.normal_scale
        gpu = self._gpu_model(obj.model)
        gpu.vao(prog, reverse).render(moderngl.TRIANGLES, vertices=count,
                                      first=gpu.reversed_range(first, count) if reverse else first)

    def _draw_glass(self, glass: list, variants: dict) -> None:
        """The glass runs over everything drawn, blended (premultiplied: what a pane reflects is
        added, what it lets through of what is behind is kept, lit.glsl GLASS), without writing
        depth: first the panes facing away from the camera (a car's far windows, seen through
        its near ones), then those facing it, each object's from the farthest object to the
        nearest. The vehicles' glass is wound to face out of the vehicle (docs/vehicles.md)."""
        ctx = self.gl.ctx
        eye = np.asarray(self.uniforms["u_camera_pos"], np.float64)
        glass = sorted(glass, key=lambda item: -float(np.linalg.norm(item[0].vehicle_from_object[:3, 3] - eye)))
        fbo = ctx.fbo
        depth_mask = fbo.depth_mask
        fbo.depth_mask = False
        ctx.enable(moderngl.BLEND | moderngl.CULL_FACE)
        ctx.blend_func = moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA
        try:
            for side in ("front", "back"):  # the faces culled: back faces drawn first
                ctx.cull_face = side
                for obj, run in glass:
                    self._draw_run(obj, run, variants)
        finally:
            ctx.disable(moderngl.BLEND | moderngl.CULL_FACE)
            ctx.cull_face = "back"
            fbo.depth_mask = depth_mask
