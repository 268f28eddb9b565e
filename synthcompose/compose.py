"""Stage 5 - compose: differential rendering into the photo, and the new ground truth.

Runs ``shaders/compose.glsl`` over the render's region of interest, band by band of its rows,
into that region of copies of the full-frame arrays. Outputs per pixel (see the shader for the rule):
RGB R' = a*Irpv + (1-a)*(R + Irpv - Ir) in linear light; labels, instance ids and
disparity take the object's values where its pixel centre is in front of the real scene.

Camera match (optional, :class:`synthcompose.lighting.camera_match.CameraMatch`, measured there): the
photo's blur and noise are given to the inserted object only - its layer blurred by a Gaussian,
seeded noise of the photo's level where it covers the pixel.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import cv2
import moderngl
import numpy as np

from synthcompose.lighting.camera_match import CameraMatch
from synthcompose.render.bands import COMPOSE_BAND_PIXELS, row_bands
from synthcompose.render.gl import GLContext

from .colour import linear_to_srgb, srgb_to_linear
from .labels import label_ids
from .render import RenderPasses, Roi

#: labels that are always in front of inserted objects (they belong to our own car or the
#: image border): ego vehicle, rectification border, out of roi
FRONT_LABELS = label_ids("ego vehicle", "rectification border", "out of roi")
#: an object pixel is in front of the real scene when  d_obj < d_scene + TOL_ABS + TOL_REL*d_obj
TOL_ABS = 0.05  # metres
TOL_REL = 0.005
MAX_OBJECTS = 15
#: over real ground (SceneLayers.ground) the band is K sigma_z of its stereo, and at least this
#: share of the depth: the ground cannot hide what stands on it (a crest that would is rare
#: within the few metres an object and its shadow cover)
GROUND_TOL_REL = 0.05


#: the compose's integer outputs after the colour: name, dtype (the texture's: 8 or 16 bits)
OUTPUTS = (("label_ids", np.uint8), ("instance_ids", np.uint16), ("disparity", np.uint16), ("visible", np.uint8))
#: the real scene's layers the compose shader reads, the photo first, made for each band's rows
#: (the colour-only variant reads the first four)
SCENE_LAYERS = ("u_photo", "u_scene_depth", "u_labels", "u_ground", "u_instances", "u_disparity")


def _uint_texture(gl: GLContext, size: tuple[int, int], values: np.ndarray) -> moderngl.Texture:
    """An unsigned integer texture of ``values`` (>= 0) in 8, 16 or 32 bits, the fewest that hold
    them (a usampler2D reads the same numbers from each)."""
    top = int(values.max()) if values.size else 0
    dtype = next((d for d, limit in (("u1", 0xFF), ("u2", 0xFFFF)) if top <= limit), "u4")
    return gl.texture(size, 1, np.ascontiguousarray(values, {"u1": np.uint8, "u2": np.uint16}.get(dtype, np.uint32)),
                      dtype=dtype)


@dataclass(frozen=True, eq=False)
class Composed:
    """Full-frame outputs. rgb (H, W, 3) uint8; label_ids (H, W) uint8; instance_ids (H, W)
    the scene's type (uint16, as a Cityscapes file holds them); disparity (H, W) uint16."""

    rgb: np.ndarray
    label_ids: np.ndarray
    instance_ids: np.ndarray
    disparity: np.ndarray
    visible: np.ndarray  # (H, W) uint8: index k (1..K) of the object seen at the pixel, else 0


@dataclass(frozen=True, eq=False)
class SceneLayers:
    """The real frame as the compose pass sees it (full-frame arrays)."""

    rgb: np.ndarray  # (H, W, 3) uint8 sRGB
    label_ids: np.ndarray  # (H, W) uint8
    instance_ids: np.ndarray  # (H, W) uint16 (Cityscapes' instanceIds)
    disparity: np.ndarray  # (H, W) uint16
    depth: np.ndarray  # (H, W) float32 metres, inf where unknown
    disparity_scale: float  # baseline * fx * 256
    ground: np.ndarray | None = None  # (H, W) bool: real ground (objects stand, shadows fall on it)
    ground_band: float = 0.0  # K sigma_d / (f B): over ground, the in-front band is this * z^2


#: the camera-match noise is drawn in tiles of this many pixels, each from (seed, tile row, tile column)
NOISE_TILE = 64


def frame_noise(seed: int, rows: slice, cols: slice, tiles: dict | None = None,
                needed: frozenset | None = None) -> np.ndarray:
    """(h, w, 3) float32 standard normal noise of a region of the frame, each pixel's value fixed
    by its place in the frame and the seed, not by the region: a region a pixel larger (a pose
    a hair different on another CPU's arithmetic) keeps every other pixel's noise, and the
    bands of a large region join without a seam. Drawn per :data:`NOISE_TILE` square tile;
    ``tiles``: the tiles drawn so far, (tile row, tile column) -> tile, taken from and added to
    (the compose's bands share the tiles their edges cut); ``needed``: the tiles (tile row, tile
    column) the caller reads (:func:`noise_tiles_read`), the others left 0 (None: every tile)."""
    t = NOISE_TILE
    out = np.empty((rows.stop - rows.start, cols.stop - cols.start, 3), np.float32)
    if needed is not None:
        out[:] = 0.0
    for ty in range(rows.start // t, (rows.stop - 1) // t + 1):
        for tx in range(cols.start // t, (cols.stop - 1) // t + 1):
            if needed is not None and (ty, tx) not in needed:
                continue
            tile = None if tiles is None else tiles.get((ty, tx))
            if tile is None:
                tile = np.random.default_rng([int(seed), ty, tx]).standard_normal((t, t, 3), np.float32)
                if tiles is not None:
                    tiles[ty, tx] = tile
            y0, y1 = max(rows.start, ty * t), min(rows.stop, (ty + 1) * t)
            x0, x1 = max(cols.start, tx * t), min(cols.stop, (tx + 1) * t)
            out[y0 - rows.start:y1 - rows.start, x0 - cols.start:x1 - cols.start] = \
                tile[y0 - ty * t:y1 - ty * t, x0 - tx * t:x1 - tx * t]
    return out


def noise_tiles_read(alpha: np.ndarray, roi: Roi, radius: int) -> frozenset:
    """The noise tiles (tile row, tile column of the frame) that compose.glsl can read in the
    region ``roi``: it adds the noise where the object covers the pixel (cover > 0), which,
    blurred, is within ``radius`` pixels (the region's own, its edges clamped) of a pixel of
    non-zero ``alpha`` (the region's coverage pass), and nowhere else."""
    covered = (alpha != 0).astype(np.uint8)
    if radius:  # (outside the region counts as uncovered)
        covered = cv2.dilate(covered, np.ones((2 * radius + 1,) * 2, np.uint8), borderType=cv2.BORDER_CONSTANT,
                             borderValue=0)
    t = NOISE_TILE
    oy, ox = roi.y0 % t, roi.x0 % t
    th, tw = -(-(oy + roi.height) // t), -(-(ox + roi.width) // t)
    grid = np.zeros((th * t, tw * t), np.uint8)
    grid[oy:oy + roi.height, ox:ox + roi.width] = covered
    rows, cols = np.nonzero(grid.reshape(th, t, tw, t).max(axis=(1, 3)))
    return frozenset(zip((rows + roi.y0 // t).tolist(), (cols + roi.x0 // t).tolist()))


class _BandNoise:
    """The camera-match noise of a region (:func:`frame_noise`), made for one band of its rows at
    a time; the tiles a band's last rows cut are kept for the next band's first."""

    def __init__(self, seed: int, rows: slice, cols: slice, needed: frozenset | None = None) -> None:
        self.seed, self.top, self.cols, self.needed = seed, rows.start, cols, needed
        self.tiles: dict[tuple[int, int], np.ndarray] = {}

    def rows(self, y0: int, y1: int) -> np.ndarray:
        """(y1 - y0, w, 3) float32: the noise of the region's rows [y0, y1), in order (each band
        below the last one)."""
        out = frame_noise(self.seed, slice(self.top + y0, self.top + y1), self.cols, self.tiles, self.needed)
        below = (self.top + y1) // NOISE_TILE  # the first tile row the next band can reach
        for key in [k for k in self.tiles if k[0] < below]:
            del self.tiles[key]
        return out


class Composer:
    """Runs the compose shader with the shared :class:`GLContext`."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl.activate()
        # the blur's first pass (compose.glsl, LAYERS): each pixel's object and background layers
        self.layers_prog = gl.program("compose", LAYERS=1)
        self.layers_vao = gl.own(gl.ctx.vertex_array(self.layers_prog, []))
        self._variants: dict[tuple[bool, bool], tuple[moderngl.Program, moderngl.VertexArray]] = {}
        self._variant(blur=False, rgb_only=False)  # compiled now: a shader error shows at start-up
        self._zero = gl.texture((1, 1), 4, np.zeros((1, 1, 4), np.float32), dtype="f4")  # unused samplers

    def _variant(self, blur: bool, rgb_only: bool) -> tuple[moderngl.Program, moderngl.VertexArray]:
        """The compose program (compose.glsl's BLUR, RGB_ONLY variants) and its vertex array,
        compiled on first use with the constant uniforms set."""
        key = (blur, rgb_only)
        if key not in self._variants:
            defines = ({"BLUR": 1} if blur else {}) | ({"RGB_ONLY": 1} if rgb_only else {})
            prog = self.gl.program("compose", **defines)
            mask = np.zeros(8, np.uint32)
            for label in FRONT_LABELS:
                mask[label >> 5] |= np.uint32(1 << (label & 31))
            for p in (prog, self.layers_prog):
                if "u_front_labels" in p:  # (not in the BLUR, RGB_ONLY variant's main pass)
                    p["u_front_labels"].write(mask.tobytes())
                    p["u_tol_abs"].value = TOL_ABS
                    p["u_tol_rel"].value = TOL_REL
            self._variants[key] = (prog, self.gl.own(self.gl.ctx.vertex_array(prog, [])))
        return self._variants[key]

    def compose_roi(self, passes: RenderPasses, scene: SceneLayers, classes: Sequence[int],
                    instances: Sequence[int], match: CameraMatch | None = None,
                    tones: Sequence[tuple[float, float]] | None = None,
                    rgb_only: bool = False, into: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Compose inside ``passes.roi``; returns ROI-sized arrays rgb/label_ids/instance_ids/disparity/visible
        (``rgb_only``: rgb alone, for a view whose labels are not written: the right view).
        ``match``: blur and noise for the object layer (None: none); ``tones``: (gain, saturation)
        of each object's linear colour, the camera's look (lighting.camera.object_tones; None:
        as rendered). ``into``: the arrays to write them into (the ROI's views of the full-frame
        outputs; rgb uint8, the others any integer type that holds them), returned."""
        if len(classes) > MAX_OBJECTS:
            raise ValueError(f"at most {MAX_OBJECTS} objects per image set")
        self.gl.activate()
        roi = passes.roi
        rows, cols = roi.slices
        match = match or CameraMatch()
        prog, vao = self._variant(blur=match.blur_radius > 0, rgb_only=rgb_only)
        noise_on = any(v > 0 for v in match.noise_sigma)
        if match.blur_radius and "objc" not in passes.textures:
            raise ValueError("blurring the object layer needs the render's 'objc' pass")
        inputs = {}
        for name in ("irpv", "ir", "alpha", "odepth", "plane", "id", "id_depth", "objc"):
            if name in passes.textures:
                inputs[f"u_{name}"] = passes.textures[name]
        # the band's own textures: the real scene's layers and the camera's noise (_band)
        for name in SCENE_LAYERS[:4 if rgb_only else 6] + ("u_noise", "u_layer_obj", "u_layer_bg"):
            inputs[name] = self._zero
        inputs.setdefault("u_objc", self._zero)
        for unit, (name, tex) in enumerate(inputs.items()):
            tex.use(unit)
            for p in (prog, self.layers_prog):
                if name in p:
                    p[name].value = unit
        tone = np.ones((16, 2), np.float32)
        for k, (gain, sat) in enumerate(tones or (), start=1):
            tone[k] = gain, sat
        for p in (prog, self.layers_prog):  # (the BLUR variant's main pass reads the layers instead)
            if "u_tone" in p:
                p["u_tone"].write(tone.tobytes())
            if "u_ground_band" in p:
                p["u_ground_band"].value = float(scene.ground_band)
                p["u_ground_rel"].value = GROUND_TOL_REL if scene.ground is not None else 0.0
        cls = np.zeros(16, np.uint32)
        cls[1:len(classes) + 1] = classes
        inst = np.zeros(16, np.uint32)
        inst[1:len(instances) + 1] = instances
        values = {"u_disp_scale": scene.disparity_scale, "u_blur_radius": match.blur_radius,
                  "u_noise_sigma": tuple(float(v) / 255.0 for v in match.noise_sigma) if noise_on else (0.0,) * 3,
                  "u_blur_sigma": max(match.object_blur_sigma, 1e-3)}
        for name, value in values.items():  # a variant may not use each
            if name in prog:
                prog[name].value = value
        if not rgb_only:
            prog["u_class"].write(cls.tobytes())
            prog["u_instance"].write(inst.tobytes())
        h, w = roi.height, roi.width
        out = into if into is not None else {"rgb": np.empty((h, w, 3), np.uint8)} | (
            {} if rgb_only else {name: np.empty((h, w), dtype) for name, dtype in OUTPUTS})
        # band by band (one band below COMPOSE_BAND_PIXELS): the scene's layers, the blur's layers,
        # the noise and the outputs exist for one band at a time (with the rows around it the
        # blur reads); the noise is seeded in NumPy (the same seed gives the same bytes on any
        # machine), each of its tiles drawn once
        noise = None
        if noise_on:  # only the tiles the shader reads are drawn (noise_tiles_read)
            needed = noise_tiles_read(passes.read("alpha", widen=False), roi, match.blur_radius)
            noise = _BandNoise(match.seed, rows, cols, needed)
        for y0, y1 in row_bands(w, h, COMPOSE_BAND_PIXELS):
            self._band(prog, vao, scene, roi, (y0, y1), match.blur_radius, rgb_only, out, noise)
        return out

    def _scene_layers(self, scene: SceneLayers, roi: Roi, rows: tuple[int, int], rgb_only: bool) -> list[moderngl.Texture]:
        """Textures of the real scene's :data:`SCENE_LAYERS` in the region's ``rows`` [r0, r1)
        (the colour-only variant's first four); integer layers in as few bytes as hold them."""
        gl = self.gl
        ys = slice(roi.y0 + rows[0], roi.y0 + rows[1])
        xs = roi.slices[1]
        size = (roi.width, rows[1] - rows[0])
        ground = scene.ground[ys, xs] if scene.ground is not None else np.zeros(size[::-1], np.uint8)
        made = [gl.texture(size, 3, np.ascontiguousarray(scene.rgb[ys, xs]), dtype="f1"),
                gl.texture(size, 1, np.ascontiguousarray(scene.depth[ys, xs]), dtype="f4"),
                _uint_texture(gl, size, scene.label_ids[ys, xs]), _uint_texture(gl, size, ground)]
        if not rgb_only:
            made += [_uint_texture(gl, size, scene.instance_ids[ys, xs]), _uint_texture(gl, size, scene.disparity[ys, xs])]
        return made

    def _band(self, prog: moderngl.Program, vao: moderngl.VertexArray, scene: SceneLayers, roi: Roi, band: tuple[int, int],
              radius: int, rgb_only: bool, out: dict[str, np.ndarray], noise: "_BandNoise | None" = None) -> None:
        """Compose rows ``band`` of the region ``roi`` of ``scene`` into ``out``'s rows, with the
        camera match's ``noise`` of those rows (None: no noise)."""
        gl, ctx = self.gl, self.gl.ctx
        w, (y0, y1) = roi.width, band
        # the rows the band reads: its own, and the blur's reach around them (the LAYERS pass)
        l0, l1 = (max(y0 - radius, 0), min(y1 + radius, roi.height)) if radius else (y0, y1)
        layers = self._scene_layers(scene, roi, (l0, l1), rgb_only)
        for p in (prog, self.layers_prog):
            if "u_scene_origin" in p:
                p["u_scene_origin"].value = (0, l0)
            for name, tex in zip(SCENE_LAYERS, layers):
                if name in p:
                    tex.use(p[name].value)
        if noise is not None:  # compose.glsl reads u_noise at the band's own rows
            layers.append(gl.texture((w, y1 - y0), 3, noise.rows(y0, y1), dtype="f4"))
            layers[-1].use(prog["u_noise"].value)
        if radius:  # each pixel's layers once, for the blur's taps to read
            blur = [gl.texture((w, l1 - l0), 4, dtype="f4"), gl.texture((w, l1 - l0), 4, dtype="f4")]
            layers += blur
            layers_fbo = gl.own(ctx.framebuffer(blur))
            layers_fbo.use()
            ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
            self.layers_prog["u_origin"].value = (0, l0)
            self.layers_vao.render(moderngl.TRIANGLES, vertices=3)
            gl.free(layers_fbo)
            for name, tex in zip(("u_layer_obj", "u_layer_bg"), blur):
                tex.use(prog[name].value)
            prog["u_layer_origin"].value = (0, l0)
        if "u_origin" in prog:
            prog["u_origin"].value = (0, y0)
        # the outputs: rgb, then (not rgb_only) label, instance, disparity, visible index
        bsize = (w, y1 - y0)
        outs = [gl.texture(bsize, 4, dtype="f1")]
        if not rgb_only:
            outs += [gl.texture(bsize, 1, dtype="u1" if dtype == np.uint8 else "u2") for _, dtype in OUTPUTS]
        fbo = gl.own(ctx.framebuffer(outs))
        fbo.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)
        gl.wait()
        out["rgb"][y0:y1] = np.frombuffer(outs[0].read(), np.uint8).reshape(y1 - y0, w, 4)[..., :3]
        if not rgb_only:
            for (name, dtype), tex in zip(OUTPUTS, outs[1:]):
                out[name][y0:y1] = np.frombuffer(tex.read(alignment=1), dtype).reshape(y1 - y0, w)
        gl.free(fbo)
        for tex in outs + layers:
            gl.free(tex)

    def compose(self, passes: RenderPasses | None, scene: SceneLayers, classes: Sequence[int],
                instances: Sequence[int], match: CameraMatch | None = None,
                tones: Sequence[tuple[float, float]] | None = None) -> Composed:
        """Full-frame result: the scene's arrays with the ROI replaced by the composition."""
        out = Composed(scene.rgb.copy(), scene.label_ids.copy(), scene.instance_ids.copy(), scene.disparity.copy(),
                       np.zeros(scene.label_ids.shape, np.uint8))
        if passes is None:
            return out
        rows, cols = passes.roi.slices  # composed into the copies' region (no region-sized arrays)
        self.compose_roi(passes, scene, classes, instances, match, tones,
                         into={name: getattr(out, name)[rows, cols] for name in ("rgb",) + tuple(n for n, _ in OUTPUTS)})
        return out


def reference_compose(R: np.ndarray, irpv: np.ndarray, ir: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """NumPy reference of the shader's RGB rule with nothing real in front (for tests).

    R (H, W, 3) uint8 sRGB; irpv, ir (H, W, 3) float linear; alpha (H, W) -> (H, W, 3) uint8.
    """
    a = alpha[..., None]
    lin = a * irpv + (1 - a) * (srgb_to_linear(R / 255.0) + irpv - ir)
    return np.rint(linear_to_srgb(lin) * 255).astype(np.uint8)
