"""Stage 5 - compose: differential rendering into the photo, and the new ground truth.

Runs ``shaders/compose.glsl`` over the render's region of interest, then pastes that region
into copies of the full-frame arrays. Outputs per pixel (see the shader for the rule):
RGB R' = a*Irpv + (1-a)*(R + Irpv - Ir) in linear light; labels, instance ids and
disparity take the object's values where its pixel centre is in front of the real scene.

Camera match (optional, :class:`CameraMatch`): the photo's noise level and blur are measured
(:func:`estimate_noise`, :func:`estimate_blur`) and given to the inserted object only - its
layer blurred by a Gaussian, seeded noise of the photo's level where it covers the pixel.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import cv2

import moderngl
import numpy as np

from .colour import linear_to_srgb, srgb_to_linear
from .gl import GLContext
from .render import RenderPasses

#: labels that are always in front of inserted objects (they belong to our own car or the
#: image border): ego vehicle, rectification border, out of roi
FRONT_LABELS = (1, 2, 3)
#: an object pixel is in front of the real scene when  d_obj < d_scene + TOL_ABS + TOL_REL*d_obj
TOL_ABS = 0.05  # metres
TOL_REL = 0.005
MAX_OBJECTS = 15
#: over real ground (SceneLayers.ground) the band is K sigma_z of its stereo, and at least this
#: share of the depth: the ground cannot hide what stands on it (a crest that would is rare
#: within the few metres an object and its shadow cover)
GROUND_TOL_REL = 0.05


@dataclass(frozen=True, eq=False)
class Composed:
    """Full-frame outputs. rgb (H, W, 3) uint8; label_ids (H, W) uint8; instance_ids (H, W)
    int32; disparity (H, W) uint16."""

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
    instance_ids: np.ndarray  # (H, W) int32
    disparity: np.ndarray  # (H, W) uint16
    depth: np.ndarray  # (H, W) float32 metres, inf where unknown
    disparity_scale: float  # baseline * fx * 256
    ground: np.ndarray | None = None  # (H, W) bool: real ground (objects stand, shadows fall on it)
    ground_band: float = 0.0  # K sigma_d / (f B): over ground, the in-front band is this * z^2


# ---------------------------------------------------------------- camera match
#: what :func:`estimate_blur` measures on edges as sharp as the renderer's (4x MSAA resolved,
#: i.e. box-filtered over the pixel): the object layer is blurred by the rest of the photo's
RENDER_BLUR_SIGMA = 0.82
#: the object blur is kept below this (pixels): beyond, the photo is out of focus or smeared
#: and a Gaussian is no longer a good model
MAX_OBJECT_BLUR = 1.6

_IMMERKAER = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)  # L2 norm 6


def _grouped_median(values: np.ndarray) -> float:
    """Median of non-negative integer-valued data, interpolated within its integer bin (a plain
    median of integers moves in steps of 1)."""
    counts = np.bincount(values.astype(np.int64))
    cum = np.cumsum(counts)
    half = cum[-1] / 2.0
    k = int(np.searchsorted(cum, half))
    below = cum[k - 1] if k > 0 else 0
    return float(k - 0.5 + (half - below) / max(counts[k], 1))


def estimate_noise(rgb: np.ndarray) -> np.ndarray:
    """(3,) noise standard deviation of each channel, in 8-bit code values: robust MAD of a
    Laplacian-like high-pass (Immerkaer's mask, blind to planes) over the flat half of the
    image, away from edges and clipped values."""
    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY).astype(np.float32)
    smooth = cv2.GaussianBlur(grey, (0, 0), 1.0)
    grad = cv2.magnitude(cv2.Sobel(smooth, cv2.CV_32F, 1, 0), cv2.Sobel(smooth, cv2.CV_32F, 0, 1))
    lo, hi = np.quantile(grad[::4, ::4], [0.5, 0.8])
    flat = grad <= lo
    flat &= cv2.dilate((grad > hi).astype(np.uint8), np.ones((5, 5), np.uint8)) == 0
    channels = cv2.split(np.ascontiguousarray(rgb))
    flat &= (cv2.min(cv2.min(channels[0], channels[1]), channels[2]) > 4) & \
        (cv2.max(cv2.max(channels[0], channels[1]), channels[2]) < 251)
    flat[:2], flat[-2:], flat[:, :2], flat[:, -2:] = False, False, False, False
    if flat.sum() < 500:
        flat[2:-2, 2:-2] = True
    out = np.empty(3)
    for c in range(3):
        # integer mask on 8-bit data: exact in 16 bits (|r| <= 16 * 255)
        r = cv2.filter2D(channels[c], cv2.CV_16S, _IMMERKAER, borderType=cv2.BORDER_REFLECT)
        out[c] = 1.4826 * _grouped_median(np.abs(r[flat])) / 6.0
    return out


def estimate_blur(rgb: np.ndarray, reblur: float = 1.0) -> float:
    """Blur of the photo as the sigma (pixels) of an equivalent Gaussian, from its strong edges:
    re-blurring a step edge of blur s by ``reblur`` lowers its peak gradient by the factor
    sqrt(s^2 + reblur^2) / s (Zhuo & Sim's defocus estimate); median over edge pixels. An ideal
    edge box-filtered over the pixel measures :data:`RENDER_BLUR_SIGMA`."""
    grey8 = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    grey = grey8.astype(np.float32)
    re = cv2.GaussianBlur(grey, (0, 0), reblur)

    edges = cv2.Canny(grey8, 40, 100) > 0
    edges[:3], edges[-3:], edges[:, :3], edges[:, -3:] = False, False, False, False
    if edges.sum() < 50:
        return float("nan")

    def grad(a: np.ndarray) -> np.ndarray:  # gradient magnitude at the edge pixels
        gx, gy = cv2.Sobel(a, cv2.CV_32F, 1, 0)[edges], cv2.Sobel(a, cv2.CV_32F, 0, 1)[edges]
        return np.sqrt(gx * gx + gy * gy) / np.float32(8.0)

    g, gr = grad(grey), grad(re)
    strong = g >= max(8.0, float(np.quantile(g, 0.6)))
    ratio = g[strong] / np.maximum(gr[strong], 1e-6)
    ratio = ratio[ratio > 1.01]
    if len(ratio) < 20:
        return float("nan")
    return float(np.median(reblur / np.sqrt(ratio ** 2 - 1.0)))


@dataclass(frozen=True)
class CameraMatch:
    """What the inserted object gets so that it looks taken by the same camera.

    noise_sigma       : the photo's noise per channel, 8-bit code values (sRGB)
    blur_sigma        : the photo's blur, Gaussian sigma in pixels (:func:`estimate_blur`)
    object_blur_sigma : blur applied to the object layer: sqrt(blur^2 - RENDER_BLUR_SIGMA^2)
    seed              : of the noise (same seed, same noise)
    """

    noise_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)
    blur_sigma: float = 0.0
    object_blur_sigma: float = 0.0
    seed: int = 0

    @classmethod
    def measure(cls, rgb: np.ndarray, seed: int = 0) -> "CameraMatch":
        noise = estimate_noise(rgb)
        blur = estimate_blur(rgb)
        extra = 0.0 if not math.isfinite(blur) else math.sqrt(max(blur ** 2 - RENDER_BLUR_SIGMA ** 2, 0.0))
        return cls(tuple(float(v) for v in noise), float(blur) if math.isfinite(blur) else 0.0,
                   float(min(extra, MAX_OBJECT_BLUR)), int(seed))

    @property
    def blur_radius(self) -> int:
        """Half width of the blur kernel in pixels (0: no blur)."""
        return 0 if self.object_blur_sigma < 0.1 else int(math.ceil(2.5 * self.object_blur_sigma))

    def to_dict(self) -> dict:
        return {"noise_sigma_8bit": [round(v, 3) for v in self.noise_sigma],
                "blur_sigma_px": round(self.blur_sigma, 3), "object_blur_sigma_px": round(self.object_blur_sigma, 3),
                "noise_seed": self.seed}


class Composer:
    """Runs the compose shader with the shared :class:`GLContext`."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl.activate()
        self.prog = gl.program("compose")
        self.vao = gl.own(gl.ctx.vertex_array(self.prog, []))
        # the blur's first pass (compose.glsl, LAYERS): each pixel's object and background layers
        self.layers_prog = gl.program("compose", LAYERS=1)
        self.layers_vao = gl.own(gl.ctx.vertex_array(self.layers_prog, []))
        mask = np.zeros(8, np.uint32)
        for label in FRONT_LABELS:
            mask[label >> 5] |= np.uint32(1 << (label & 31))
        for prog in (self.prog, self.layers_prog):
            prog["u_front_labels"].write(mask.tobytes())
            prog["u_tol_abs"].value = TOL_ABS
            prog["u_tol_rel"].value = TOL_REL
        self._zero = gl.texture((1, 1), 4, np.zeros((1, 1, 4), np.float32), dtype="f4")  # unused samplers

    def compose_roi(self, passes: RenderPasses, scene: SceneLayers, classes: Sequence[int],
                    instances: Sequence[int], match: CameraMatch | None = None) -> dict[str, np.ndarray]:
        """Compose inside ``passes.roi``; returns ROI-sized arrays rgb/label_ids/instance_ids/disparity.
        ``match``: blur and noise for the object layer (None: none)."""
        if len(classes) > MAX_OBJECTS:
            raise ValueError(f"at most {MAX_OBJECTS} objects per image set")
        gl, ctx = self.gl.activate(), self.gl.ctx
        roi = passes.roi
        rows, cols = roi.slices
        size = (roi.width, roi.height)
        made = {
            "u_scene_depth": gl.texture(size, 1, np.ascontiguousarray(scene.depth[rows, cols]), dtype="f4"),
            "u_labels": gl.texture(size, 1, scene.label_ids[rows, cols].astype(np.uint32), dtype="u4"),
            "u_instances": gl.texture(size, 1, scene.instance_ids[rows, cols].astype(np.uint32), dtype="u4"),
            "u_disparity": gl.texture(size, 1, scene.disparity[rows, cols].astype(np.uint32), dtype="u4"),
            "u_ground": gl.texture(size, 1, np.zeros((roi.height, roi.width), np.uint32) if scene.ground is None
                                   else scene.ground[rows, cols].astype(np.uint32), dtype="u4"),
        }
        if "photo" not in passes.textures:
            made["u_photo"] = gl.texture(size, 3, np.ascontiguousarray(scene.rgb[rows, cols]), dtype="f1")
        match = match or CameraMatch()
        noise_on = any(v > 0 for v in match.noise_sigma)
        if noise_on:  # seeded in NumPy: the same seed gives the same bytes on any machine
            noise = np.random.default_rng(match.seed).standard_normal((roi.height, roi.width, 3), np.float32)
            made["u_noise"] = gl.texture(size, 3, noise, dtype="f4")
        if match.blur_radius and "objc" not in passes.textures:
            raise ValueError("blurring the object layer needs the render's 'objc' pass")
        inputs = dict(made)
        for name in ("photo", "irpv", "ir", "alpha", "odepth", "plane", "id", "id_depth", "objc"):
            if name in passes.textures:
                inputs[f"u_{name}"] = passes.textures[name]
        inputs.setdefault("u_objc", self._zero)
        inputs.setdefault("u_noise", self._zero)
        inputs["u_layer_obj"] = inputs["u_layer_bg"] = self._zero
        for unit, (name, tex) in enumerate(inputs.items()):
            tex.use(unit)
            for prog in (self.prog, self.layers_prog):
                if name in prog:
                    prog[name].value = unit
        for prog in (self.prog, self.layers_prog):
            prog["u_ground_band"].value = float(scene.ground_band)
            prog["u_ground_rel"].value = GROUND_TOL_REL if scene.ground is not None else 0.0
        layers = []
        if match.blur_radius:  # each pixel's layers once, for the blur's taps to read
            layers = [gl.texture(size, 4, dtype="f4"), gl.texture(size, 4, dtype="f4")]
            layers_fbo = gl.own(ctx.framebuffer(layers))
            layers_fbo.use()
            ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
            self.layers_vao.render(moderngl.TRIANGLES, vertices=3)
            gl.free(layers_fbo)
            for name, tex in zip(("u_layer_obj", "u_layer_bg"), layers):
                tex.use(self.prog[name].value)
        cls = np.zeros(16, np.uint32)
        cls[1:len(classes) + 1] = classes
        inst = np.zeros(16, np.uint32)
        inst[1:len(instances) + 1] = instances
        self.prog["u_class"].write(cls.tobytes())
        self.prog["u_instance"].write(inst.tobytes())
        self.prog["u_disp_scale"].value = scene.disparity_scale
        self.prog["u_noise_sigma"].value = tuple(float(v) / 255.0 for v in match.noise_sigma) if noise_on else (0.0,) * 3
        self.prog["u_blur_radius"].value = match.blur_radius
        self.prog["u_blur_sigma"].value = max(match.object_blur_sigma, 1e-3)

        outs = [gl.texture(size, 4, dtype="f1"), gl.texture(size, 1, dtype="u4"),
                gl.texture(size, 1, dtype="u4"), gl.texture(size, 1, dtype="u4"), gl.texture(size, 1, dtype="u4")]
        fbo = gl.own(ctx.framebuffer(outs))
        fbo.use()
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        gl.wait()
        h, w = roi.height, roi.width
        rgb = np.frombuffer(outs[0].read(), np.uint8).reshape(h, w, 4)[..., :3]
        label = np.frombuffer(outs[1].read(), np.uint32).reshape(h, w)
        instance = np.frombuffer(outs[2].read(), np.uint32).reshape(h, w)
        disparity = np.frombuffer(outs[3].read(), np.uint32).reshape(h, w)
        visible = np.frombuffer(outs[4].read(), np.uint32).reshape(h, w)
        gl.free(fbo)
        for tex in outs + layers + list(made.values()):
            gl.free(tex)
        return {"rgb": rgb, "label_ids": label.astype(np.uint8), "instance_ids": instance.astype(np.int32),
                "disparity": disparity.astype(np.uint16), "visible": visible.astype(np.uint8)}

    def compose(self, passes: RenderPasses | None, scene: SceneLayers, classes: Sequence[int],
                instances: Sequence[int], match: CameraMatch | None = None) -> Composed:
        """Full-frame result: the scene's arrays with the ROI replaced by the composition."""
        out = Composed(scene.rgb.copy(), scene.label_ids.copy(), scene.instance_ids.copy(), scene.disparity.copy(),
                       np.zeros(scene.label_ids.shape, np.uint8))
        if passes is None:
            return out
        roi_out = self.compose_roi(passes, scene, classes, instances, match)
        rows, cols = passes.roi.slices
        for name, arr in roi_out.items():
            getattr(out, name)[rows, cols] = arr
        return out


def reference_compose(R: np.ndarray, irpv: np.ndarray, ir: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """NumPy reference of the shader's RGB rule with nothing real in front (for tests).

    R (H, W, 3) uint8 sRGB; irpv, ir (H, W, 3) float linear; alpha (H, W) -> (H, W, 3) uint8.
    """
    a = alpha[..., None]
    lin = a * irpv + (1 - a) * (srgb_to_linear(R / 255.0) + irpv - ir)
    return np.rint(linear_to_srgb(lin) * 255).astype(np.uint8)
