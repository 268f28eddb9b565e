"""The lit pass's light equation (shaders/lit.glsl) against a NumPy reference, pixel by pixel.

The scene is one a ray caster follows exactly: four upright boards (one model, four mesh parts)
standing 9 m ahead of a 192 x 96 camera on their ground plane, one sun and the sky / ground
ambient of :class:`Lighting`, no textures, no normal maps. Upright boards have no area seen
from straight above or below, so the renderer's top-down sky-occlusion map and its map of the
objects' undersides stay empty: the planes' sky visibility is exactly 1, their contact
occlusion 0, and the objects' own sky occlusion is the height term alone. What the sun map
gives (its shadows) is decided geometrically here, leaving out a band round every shadow edge
(the map's texels, the penumbra and the filter's widening by the pixel's own footprint on the
ground blur them: a pixel counts as lit or shadowed when its centre and its corners all are).

What each board checks (colours in linear light, ``objc`` = lit.glsl's ``out_object``):

* ``matte``: rough dielectric (no glossy term) whose vertex normals turn from up-left (towards
  the sun) to down-right (away from it, past n.l = 0): the hemisphere ambient over n.z from
  +0.45 to -0.46, Lambert's n.l and its clamp; it stands on the ground, so its lowest 40 cm
  show the object-occlusion height term;
* ``glossy``: a dark paint turned so that the sun's highlight lies on it, its normals turning
  to nearly edge-on: Schlick's Fresnel, the sky / ground reflection (no photo: its fallback
  colours) and the Blinn-Phong highlight;
* ``metal``: metallic, base colour as F0, no diffuse; its reflections (r.z from -0.08 to 0.03)
  fall where the fallback environment blends the ground's colour into the sky's (the smoothstep
  over r.z);
* ``back``: its normals point away from the camera: the two-sided flip.

The planes: Ir (no shadows) everywhere the ground plane covers a pixel, Irpv where the plane
is seen, lit and in the boards' shadows; with a reduced ``sun_visibility``; with a per-pixel
sun mask; and with a photo, from which the planes take their albedo (Ir then reproduces the
photo and a shadow scales it by shadowed / unshadowed light).

Not covered here (they need a geometry whose maps are not empty, or the photo): the soft
values of the shadow filters, the sky occlusion and contact shadows of the ground, the sky
map's part of the objects' occlusion, base colour textures, and reflections of the photo;
normal maps are checked against the same equation in test_normal_maps.py.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from synthcompose.camera import Camera
from synthcompose.models import MeshPart, Model
from synthcompose.render import Lighting, Renderer, RenderObject

from ..tolerances import HALF_RESOLVED_REL, HALF_STORAGE_ABS, LIT_REFERENCE_LINEAR, SHADOW_EDGE_MARGIN_M

CAMERA = Camera(fx=200.0, fy=200.0, u0=96.0, v0=48.0, baseline=0.2, x=0.0, y=0.0, z=1.22, yaw=0.0, pitch=0.05,
                roll=0.0, width=192, height=96)
POSE = np.eye(4)
POSE[:3, 3] = (9.0, 0.0, 0.0)  # the object frame's origin on the ground (the object's ground_z = 0)
_EL, _AZ = np.radians(15.0), np.radians(150.0)  # a low sun, ahead on the left
SUN = (float(np.cos(_EL) * np.cos(_AZ)), float(np.cos(_EL) * np.sin(_AZ)), float(np.sin(_EL)))
LIGHT = Lighting(sun_direction=SUN, sun_rgb=(2.2, 2.0, 1.7), sky_rgb=(0.45, 0.5, 0.6), ground_rgb=(0.12, 0.11, 0.09))
PLANE_ALBEDO = (0.3, 0.25, 0.2)


def unit_vector(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True)
class Board:
    """An upright rectangle: corners left-bottom, right-bottom, right-top, left-top (object
    frame), the normal of its left and of its right edge (interpolated across), material."""

    name: str
    corners: np.ndarray  # (4, 3)
    normal_left: np.ndarray
    normal_right: np.ndarray
    albedo: tuple[float, float, float]
    metallic: float
    roughness: float


def _upright(left_y: float, right_y: float, z: tuple[float, float]) -> np.ndarray:
    """Corners of a board in the plane x = 0 (facing the camera, O: -x)."""
    return np.array([[0.0, left_y, z[0]], [0.0, right_y, z[0]], [0.0, right_y, z[1]], [0.0, left_y, z[1]]])


def _glossy_board() -> Board:
    """1 m wide, centred on y = 0 and turned so that its normal is the horizontal part of the
    sun's half vector seen from the camera (the highlight on it); its vertex normals turn from
    there to nearly edge-on to the camera at its right edge (n.v about 0.25: Fresnel's rise)."""
    centre = np.array([0.0, 0.0, 1.0]) + POSE[:3, 3]
    v = unit_vector(CAMERA.position - centre)
    h = unit_vector(np.asarray(SUN) + v)
    n = unit_vector([h[0], h[1], 0.0])
    along = np.array([-n[1], n[0], 0.0])  # towards -y: right in the image
    corners = np.array([-0.5 * along, 0.5 * along, 0.5 * along, -0.5 * along])
    corners[:, 2] = [0.4, 0.4, 1.6, 1.6]
    return Board("glossy", corners, n, unit_vector([-0.26, -0.97, 0.0]), (0.2, 0.03, 0.03), 0.0, 0.6)


BOARDS = (
    Board("matte", _upright(3.2, 2.2, (0.0, 1.6)), unit_vector([-1.0, 0.6, 0.6]), unit_vector([-0.5, -1.0, -0.6]),
          (0.55, 0.45, 0.35), 0.0, 1.0),
    _glossy_board(),
    Board("metal", _upright(-1.6, -2.6, (0.4, 1.6)), unit_vector([-1.0, 0.0, 0.0]), unit_vector([-1.0, 0.0, 0.0]),
          (0.9, 0.85, 0.75), 1.0, 0.3),
    Board("back", _upright(-3.4, -4.2, (0.3, 1.3)), unit_vector([1.0, 0.0, 0.0]), unit_vector([1.0, 0.0, 0.0]),
          (0.4, 0.5, 0.3), 0.0, 1.0),
)


def boards_model() -> Model:
    parts = []
    for b in BOARDS:
        normals = np.array([b.normal_left, b.normal_right, b.normal_right, b.normal_left])
        parts.append(MeshPart(
            positions=b.corners.astype(np.float32), normals=normals.astype(np.float32),
            uvs=np.zeros((4, 2), np.float32), colors=np.tile([*b.albedo, 1.0], (4, 1)).astype(np.float32),
            material=np.tile([b.metallic, b.roughness], (4, 1)).astype(np.float32),
            indices=np.array([[0, 1, 2], [0, 2, 3]], np.uint32), texture=None))
    pts = np.concatenate([b.corners for b in BOARDS])
    extents = tuple(float(e) for e in np.maximum(np.ptp(pts, axis=0), 0.05))
    return Model("test-lit-reference-boards", tuple(parts), extents)


# ------------------------------------------------------------------ the NumPy reference
def mix(a, b, t):
    """GLSL mix."""
    return a * (1.0 - t) + b * t


def smoothstep(e0: float, e1: float, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def srgb_to_linear(c):
    """IEC 61966-2-1, as shaders/common.glsl."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c < 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _dot(a, b):
    return np.sum(a * b, axis=-1, keepdims=True)


def object_colour(p, n, v, board: Board, light: Lighting, sun_vis, sun_scale: float = 1.0, ground_z: float = 0.0):
    """lit.glsl's colour of an object point ``p`` (N, 3) with interpolated normal ``n`` and unit
    direction to the camera ``v``, the sky map open above it (object_occlusion's second factor
    1), no texture, no normal map, no photo (environment(): the fallback colours)."""
    sky, ground, sun_dir = (np.asarray(x, float) for x in (light.sky_rgb, light.ground_rgb, light.sun_direction))
    n = unit_vector(n)
    n = np.where(_dot(n, v) < 0.0, -n, n)  # two-sided
    ndl = np.maximum(_dot(n, sun_dir), 0.0)
    occlusion = mix(0.35, 1.0, smoothstep(0.0, 0.4, p[:, 2:3] - ground_z)) * mix(0.4, 1.0, 1.0)
    albedo, metallic = np.asarray(board.albedo, float), board.metallic
    roughness = float(np.clip(board.roughness, 0.05, 1.0))
    ambient = mix(ground, sky, 0.5 + 0.5 * n[:, 2:3]) * occlusion
    sun = np.asarray(light.sun_rgb, float) * sun_scale
    diffuse = albedo * (1.0 - metallic) * (ambient + sun * ndl * sun_vis)
    f0 = mix(np.full(3, 0.04), albedo, metallic)
    ndv = np.clip(_dot(n, v), 0.0, 1.0)
    fresnel = f0 + (1.0 - f0) * (1.0 - ndv) ** 5
    r = -v + 2.0 * _dot(n, v) * n  # reflect(-v, n)
    env = mix(ground, sky, smoothstep(-0.2, 0.2, r[:, 2:3])) * occlusion
    gloss = 1.0 - roughness
    h = unit_vector(sun_dir + v)
    shininess = mix(4.0, 512.0, gloss * gloss)
    spec = sun * sun_vis * np.maximum(_dot(n, h), 0.0) ** shininess * (shininess + 8.0) / 25.0 * ndl
    return diffuse + fresnel * (env * gloss + spec * gloss)


def plane_colour(light: Lighting, sun_scale, sun_vis, albedo=PLANE_ALBEDO, photo_linear=None):
    """lit.glsl's PLANE colour of the flat ground (n = +z): sky visibility 1 (Irpv: the sky map
    is empty; Ir: NO_SHADOWS); the albedo from the photo where one is given."""
    sky, sun = np.asarray(light.sky_rgb, float), np.asarray(light.sun_rgb, float)
    ndl = max(light.sun_direction[2], 0.0)
    ambient = mix(np.asarray(light.ground_rgb, float), sky, 1.0)
    sun_scale = np.asarray(sun_scale, float).reshape(-1, 1)
    if photo_linear is None:
        albedo = np.asarray(albedo, float)
    else:
        albedo = photo_linear / np.maximum(ambient + sun * sun_scale * ndl, 1e-4)
    return albedo * (ambient + sun * sun_scale * ndl * np.asarray(sun_vis, float).reshape(-1, 1))


# ------------------------------------------------------------------ ray casting
@dataclass(frozen=True)
class Rect:
    """A rectangle in the vehicle frame: corner p0, edges e1 (p0 -> p1) and e2 (p0 -> p3)."""

    p0: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    @classmethod
    def of(cls, corners: np.ndarray) -> "Rect":
        return cls(corners[0], corners[1] - corners[0], corners[3] - corners[0])

    def hit(self, origin, direction, grow: float = 0.0):
        """Ray parameter t of each ray's hit (inf where it misses the rectangle grown by
        ``grow`` metres, or where t <= 1e-6) and the hit's coordinate along e1 (0..1)."""
        g = np.cross(self.e1, self.e2)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((self.p0 - origin) @ g) / (direction @ g)
        q = origin + t[..., None] * direction
        a = (q - self.p0) @ self.e1 / (self.e1 @ self.e1)
        b = (q - self.p0) @ self.e2 / (self.e2 @ self.e2)
        ga, gb = grow / np.linalg.norm(self.e1), grow / np.linalg.norm(self.e2)
        inside = (a >= -ga) & (a <= 1 + ga) & (b >= -gb) & (b <= 1 + gb) & (t > 1e-6)
        return np.where(inside, t, np.inf), a


def _pixel_rays(cam: Camera, dx: float, dy: float) -> np.ndarray:
    """(H, W, 3) unit ray directions (vehicle frame) through pixel centre + (dx, dy)."""
    rows, cols = np.mgrid[0:cam.height, 0:cam.width].astype(float)
    d = np.stack([(cols + dx - cam.u0) / cam.fx, (rows + dy - cam.v0) / cam.fy, np.ones_like(rows)], -1)
    return unit_vector(d @ cam.vehicle_from_optical[:3, :3].T)


#: the pixel centre, then its corners: a pixel counts as seeing one surface when all five do
#: (the lit pass's samples lie inside the pixel)
_OFFSETS = ((0.0, 0.0), (-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5))


@dataclass
class Scene:
    """Per pixel of the ROI, what the reference says: which surface it sees whole (-1 none /
    mixed, k board k, len(BOARDS) the ground plane), the centre's point, and the sun there."""

    surface: np.ndarray  # (H, W) int
    ground_whole: np.ndarray  # (H, W) bool: the ground plane alone covers the whole pixel (Ir)
    point: np.ndarray  # (H, W, 3) point seen at the pixel centre (nearest)
    along: np.ndarray  # (H, W) coordinate along the board seen (0 left .. 1 right)
    view: np.ndarray  # (H, W, 3) unit direction to the camera
    lit: np.ndarray  # (H, W) bool: the sun's ray misses every board by the margin
    shadow: np.ndarray  # (H, W) bool: it hits one well inside


def cast(cam: Camera, obj: RenderObject, light: Lighting) -> Scene:
    """Ray-cast the boards and their ground plane for the ROI camera ``cam``."""
    m = obj.vehicle_from_object
    rects = [Rect.of(b.corners @ m[:3, :3].T + m[:3, 3]) for b in BOARDS]
    unit = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], float)
    plane = Rect.of((unit @ obj.plane_matrix(light).T)[:, :3])
    origin = np.asarray(cam.position, float)
    labels, ground_hits, points = [], [], []
    for k, (dx, dy) in enumerate(_OFFSETS):
        d = _pixel_rays(cam, dx, dy)
        hits = [r.hit(origin, d) for r in rects + [plane]]
        t = np.stack([h[0] for h in hits])
        near = np.argmin(t, axis=0)
        labels.append(np.where(np.isfinite(t.min(axis=0)), near, -1))
        ground_hits.append(np.isfinite(t[-1]))
        points.append(origin + np.where(np.isfinite(t.min(axis=0)), t.min(axis=0), 0.0)[..., None] * d)
        if k == 0:
            t_near = t.min(axis=0)
            point = origin + np.where(np.isfinite(t_near), t_near, 0.0)[..., None] * d
            along = np.choose(np.clip(near, 0, len(BOARDS) - 1), [h[1] for h in hits[:-1]])
            view = -d
    labels = np.stack(labels)
    surface = np.where((labels == labels[0]).all(axis=0), labels[0], -1)
    # the sun: the ray from the points seen (the centre's and the corners': the sun map's filter
    # is widened by the pixel's footprint) towards the sun, against every board but its own
    sun = np.asarray(light.sun_direction, float)
    loose, strict = np.zeros(surface.shape, bool), np.ones(surface.shape, bool)
    for q in points:
        hit_loose, hit_strict = np.zeros(surface.shape, bool), np.zeros(surface.shape, bool)
        for k, r in enumerate(rects):
            own = labels[0] == k
            hit_loose |= np.isfinite(r.hit(q, sun, grow=SHADOW_EDGE_MARGIN_M)[0]) & ~own
            hit_strict |= np.isfinite(r.hit(q, sun, grow=-SHADOW_EDGE_MARGIN_M)[0]) & ~own
        loose |= hit_loose
        strict &= hit_strict
    return Scene(surface, np.stack(ground_hits).all(axis=0), point, along, view, ~loose, strict)


# ------------------------------------------------------------------ rendering
def _render(gl, shading: str = "pixel", sun_visibility: float = 1.0, photo=None, sun_mask=None,
            precision: str = "full"):
    renderer = Renderer(gl, shading=shading, precision=precision)  # full: the equation, not the storage
    obj = RenderObject(boards_model(), POSE, PLANE_ALBEDO, sun_visibility=sun_visibility)
    passes = renderer.render(CAMERA, [obj], LIGHT, photo=photo, sun_mask=sun_mask)
    out = {name: passes.read(name) for name in ("objc", "irpv", "ir", "alpha", "plane")}
    out["camera"], out["roi"] = passes.camera, passes.roi
    renderer.release(passes)
    return out, cast(passes.camera, obj, LIGHT)


def _errors(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    return np.abs(got[..., :3] - want).max(axis=-1)


def _report(what: str, err: np.ndarray) -> str:
    return f"{what}: max error {err.max():.3g} over {err.size} pixels (tolerance {LIT_REFERENCE_LINEAR})"


@pytest.fixture(scope="module", params=["pixel", "sample"])
def rendered(request, gl):
    gl.activate()
    return _render(gl, request.param)


def test_the_reference_scene_is_what_the_renderer_drew(rendered):
    """The ray caster's surfaces agree with the rasterised coverage, and every case this module
    checks has pixels to check."""
    out, scene = rendered
    for k in range(len(BOARDS)):
        whole = scene.surface == k
        assert whole.sum() >= 150, (BOARDS[k].name, whole.sum())
        assert (out["alpha"][whole] == 1.0).all()
    ground = scene.surface == len(BOARDS)
    assert (out["alpha"][ground] == 0.0).all() and (out["plane"][..., 1][ground] == 1.0).all()
    assert (ground & scene.lit).sum() >= 500 and (ground & scene.shadow).sum() >= 100
    assert (out["plane"][..., 1][scene.ground_whole & (out["alpha"] == 0.0)] == 1.0).all()


@pytest.mark.parametrize("k", range(len(BOARDS)), ids=[b.name for b in BOARDS])
def test_object_colour_matches_the_reference(rendered, k):
    out, scene = rendered
    board = BOARDS[k]
    seen = (scene.surface == k) & scene.lit
    a = scene.along[seen][:, None]
    n = mix(board.normal_left, board.normal_right, a)  # the vertex normals, interpolated
    want = object_colour(scene.point[seen], n, scene.view[seen], board, LIGHT, sun_vis=1.0)
    err = _errors(out["objc"][seen], want)
    assert err.max() <= LIT_REFERENCE_LINEAR, _report(board.name, err)


def test_ground_plane_lit_and_in_shadow_matches_the_reference(rendered):
    out, scene = rendered
    ground = scene.surface == len(BOARDS)
    for name, where, vis in (("lit", ground & scene.lit, 1.0), ("shadow", ground & scene.shadow, 0.0)):
        err = _errors(out["irpv"][where], plane_colour(LIGHT, 1.0, vis))
        assert err.max() <= LIT_REFERENCE_LINEAR, _report(f"Irpv, {name}", err)
    err = _errors(out["ir"][scene.ground_whole], plane_colour(LIGHT, 1.0, 1.0))
    assert err.max() <= LIT_REFERENCE_LINEAR, _report("Ir", err)


def test_sun_visibility_and_sun_mask_scale_the_sun(gl_clean):
    """RenderObject.sun_visibility scales the sun on the object and its plane; a sun mask
    replaces it on the plane, per pixel."""
    out, scene = _render(gl_clean, sun_visibility=0.4)
    board = BOARDS[0]
    seen = (scene.surface == 0) & scene.lit
    n = mix(board.normal_left, board.normal_right, scene.along[seen][:, None])
    want = object_colour(scene.point[seen], n, scene.view[seen], board, LIGHT, 1.0, sun_scale=0.4)
    err = _errors(out["objc"][seen], want)
    assert err.max() <= LIT_REFERENCE_LINEAR, _report("matte, sun visibility 0.4", err)
    ground = (scene.surface == len(BOARDS)) & scene.lit
    err = _errors(out["irpv"][ground], plane_colour(LIGHT, 0.4, 1.0))
    assert err.max() <= LIT_REFERENCE_LINEAR, _report("Irpv, sun visibility 0.4", err)

    mask = np.tile(np.linspace(0.0, 1.0, CAMERA.width, dtype=np.float32), (CAMERA.height, 1))
    out, scene = _render(gl_clean, sun_mask=mask)
    rows, cols = out["roi"].slices
    scale = mask[rows, cols]
    err = _errors(out["ir"][scene.ground_whole], plane_colour(LIGHT, scale[scene.ground_whole], 1.0))
    assert err.max() <= LIT_REFERENCE_LINEAR, _report("Ir, sun mask", err)
    for name, where, vis in (("lit", scene.lit, 1.0), ("shadow", scene.shadow, 0.0)):
        where = where & (scene.surface == len(BOARDS))
        err = _errors(out["irpv"][where], plane_colour(LIGHT, scale[where], vis))
        assert err.max() <= LIT_REFERENCE_LINEAR, _report(f"Irpv, sun mask, {name}", err)


def test_planes_take_their_albedo_from_the_photo(gl_clean):
    """With the photo: Ir reproduces it (linear light), Irpv is it where lit and it times
    shadowed / unshadowed light in the boards' shadows; with a sun mask too."""
    rng = np.random.default_rng(0)
    photo = rng.integers(0, 256, (CAMERA.height, CAMERA.width, 3), dtype=np.uint8)
    mask = np.tile(np.linspace(0.2, 1.0, CAMERA.width, dtype=np.float32), (CAMERA.height, 1))
    for sun_mask in (None, mask):
        out, scene = _render(gl_clean, photo=photo, sun_mask=sun_mask)
        rows, cols = out["roi"].slices
        linear = srgb_to_linear(photo[rows, cols] / 255.0)
        scale = np.ones(linear.shape[:2]) if sun_mask is None else sun_mask[rows, cols]
        whole = scene.ground_whole
        err = _errors(out["ir"][whole], plane_colour(LIGHT, scale[whole], 1.0, photo_linear=linear[whole]))
        assert err.max() <= LIT_REFERENCE_LINEAR, _report("Ir from the photo", err)
        assert np.abs(out["ir"][whole][:, :3] - linear[whole]).max() <= LIT_REFERENCE_LINEAR
        for name, where, vis in (("lit", scene.lit, 1.0), ("shadow", scene.shadow, 0.0)):
            where = where & (scene.surface == len(BOARDS))
            want = plane_colour(LIGHT, scale[where], vis, photo_linear=linear[where])
            err = _errors(out["irpv"][where], want)
            assert err.max() <= LIT_REFERENCE_LINEAR, _report(f"Irpv from the photo, {name}", err)


@pytest.mark.parametrize("shading", ["pixel", "sample"])
def test_half_float_storage_only_rounds(gl_clean, shading):
    """The batch's renderer stores the lit pass's colours in half floats, and resolves them into
    half floats: the passes differ from full floats' by their rounding alone (relative, per
    sample, averaged by the resolve, then the mean's); the coverage and the plane's depth not at all."""
    full, _ = _render(gl_clean, shading)
    half, _ = _render(gl_clean, shading, precision="half")
    for name in ("objc", "irpv", "ir"):
        bound = HALF_RESOLVED_REL * np.abs(full[name]) + HALF_STORAGE_ABS
        assert (np.abs(half[name] - full[name]) <= bound).all(), name
    for name in ("alpha", "plane"):
        assert np.array_equal(half[name], full[name]), name
