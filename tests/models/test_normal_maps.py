"""glTF normal maps: tangents from the file or computed, and the shading they give."""
import json
import struct

import numpy as np
import pytest
import trimesh
from PIL import Image
from scipy import ndimage

from synthcompose.colour import linear_to_srgb
from synthcompose.models import load_model, vertex_tangents
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera
from ..tolerances import (
    FILE_TANGENT_MIN_COS,
    FLAT_NORMAL_MAP_8BIT,
    NORMAL_MAP_MIN_RATIO,
    NORMAL_MAP_SHADING_REL,
    NORMAL_MAP_SHOWS_8BIT,
    NORMAL_SCALE_EFFECT_LINEAR,
    TANGENT_FLOAT,
    TANGENT_MIN_COS,
)

# a 1 m quad standing in the file's y-z plane (glTF: y up) and facing -x; loaded with up +y and
# forward +x it faces the camera (O: -x); u grows along the file's +z (O: -y, right in the image),
# v up the quad, so the tangent is O's -y, the bitangent O's +z and the handedness +1
QUAD = np.array([[0.0, 0.0, -0.5], [0.0, 0.0, 0.5], [0.0, 1.0, 0.5], [0.0, 1.0, -0.5]])
QUAD_UV = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # trimesh's: v grows up
QUAD_FACES = np.array([[0, 1, 2], [0, 2, 3]])
ALBEDO = 0.5


def _map(rgb, size=8) -> Image.Image:
    return Image.fromarray(np.full((size, size, 3), rgb, np.uint8))


def _encode(n) -> tuple[int, int, int]:
    """A tangent-space normal as the 8-bit RGB of a normal map."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    return tuple(int(c) for c in np.round((n + 1) / 2 * 255))


def _quad(normal_map=None, offset=(0.0, 0.0, 0.0), tangents=None) -> trimesh.Trimesh:
    mat = trimesh.visual.material.PBRMaterial(baseColorFactor=[ALBEDO, ALBEDO, ALBEDO, 1.0], metallicFactor=0.0,
                                              roughnessFactor=1.0, normalTexture=normal_map)
    mesh = trimesh.Trimesh(QUAD + offset, QUAD_FACES, vertex_normals=np.tile([-1.0, 0.0, 0.0], (4, 1)),
                           visual=trimesh.visual.TextureVisuals(uv=QUAD_UV, material=mat), process=False)
    if tangents is not None:  # trimesh writes it as "_TANGENT"; _edit_glb renames it
        mesh.vertex_attributes["TANGENT"] = np.asarray(tangents, np.float32)
    return mesh


def _edit_glb(path, edit) -> None:
    """Apply ``edit`` to the JSON of the GLB file at ``path``."""
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    header = json.loads(data[20:20 + length])
    edit(header)
    text = json.dumps(header).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + length:]
    path.write_bytes(struct.pack("<5I", 0x46546C67, 2, 20 + len(text) + len(rest), len(text), 0x4E4F534A)
                     + text + rest)


def _save(path, *meshes, transform=None):
    scene = trimesh.Scene()
    for mesh in meshes:
        scene.add_geometry(mesh, transform=transform)
    scene.export(path)
    return str(path)


def _load(path, height=1.0):
    return load_model(str(path), (("height", height),), "+y", "+x")


def _face_derivatives(part):
    """Per triangle: unit dP/du and dP/dv of the loaded part (its uvs: v grows down)."""
    f = part.indices.astype(int)
    p, uv = part.positions.astype(float), part.uvs.astype(float)
    e = np.stack([p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]]], axis=1)  # (M, 2, 3)
    d = np.stack([uv[f[:, 1]] - uv[f[:, 0]], uv[f[:, 2]] - uv[f[:, 0]]], axis=1)  # (M, 2, 2)
    dp = np.linalg.solve(d, e)  # rows: dP/du, dP/dv
    return dp / np.linalg.norm(dp, axis=2, keepdims=True)


def _check_tangent_frame(part):
    """Unit tangents, orthogonal to the normals, along +u; bitangent w (n x t) along -v."""
    t, w, n = part.tangents[:, :3], part.tangents[:, 3], part.normals
    assert np.allclose(np.linalg.norm(t, axis=1), 1.0, atol=TANGENT_FLOAT)
    assert np.abs(np.einsum("ij,ij->i", t, n)).max() < TANGENT_FLOAT
    assert set(np.unique(w)) <= {-1.0, 1.0}
    dp = _face_derivatives(part)
    f = part.indices.astype(int)
    for corner in range(3):
        vi = f[:, corner]
        assert np.einsum("ij,ij->i", t[vi], dp[:, 0]).min() > TANGENT_MIN_COS
        b = w[vi, None] * np.cross(n[vi], t[vi])
        assert np.einsum("ij,ij->i", b, dp[:, 1]).max() < -TANGENT_MIN_COS


# ---------------------------------------------------------------------------- loading
def test_tangents_are_computed_from_the_uvs(tmp_path):
    model = _load(_save(tmp_path / "quad.glb", _quad(_map(_encode([0.0, 0.5, 1.0])))))
    (part,) = model.parts
    assert part.normal_texture is not None and part.normal_texture.shape == (8, 8, 4)
    assert part.normal_scale == 1.0
    _check_tangent_frame(part)
    assert np.allclose(part.tangents, [0.0, -1.0, 0.0, 1.0], atol=TANGENT_FLOAT)  # see QUAD


def test_gltf_with_external_files_keeps_both_textures(tmp_path):
    quad = _quad(_map(_encode([0.0, 0.5, 1.0])))
    quad.visual.material.baseColorTexture = _map((200, 30, 40))
    for name, data in trimesh.Scene(quad).export(file_type="gltf").items():  # .gltf + .bin files
        (tmp_path / name).write_bytes(data)
    (part,) = _load(tmp_path / "model.gltf").parts
    assert part.texture is not None and tuple(part.texture[0, 0]) == (200, 30, 40, 255)
    assert part.normal_texture is not None and tuple(part.normal_texture[0, 0]) == (*_encode([0.0, 0.5, 1.0]), 255)
    _check_tangent_frame(part)


def test_computed_tangents_follow_a_curved_skewed_and_mirrored_mapping():
    # a wavy height field z = h(x, y) with uv a linear map of (x, y), once mirrored
    xs, ys = np.meshgrid(np.linspace(0.0, 2.0, 41), np.linspace(0.0, 1.0, 21))
    x, y = xs.ravel(), ys.ravel()
    pos = np.column_stack([x, y, 0.2 * np.sin(3 * x) * np.cos(2 * y)])
    hx, hy = 0.6 * np.cos(3 * x) * np.cos(2 * y), -0.4 * np.sin(3 * x) * np.sin(2 * y)
    normals = np.column_stack([-hx, -hy, np.ones_like(x)])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    i = np.arange(41 * 21).reshape(21, 41)[:-1, :-1].ravel()
    faces = np.concatenate([np.column_stack([i, i + 1, i + 42]), np.column_stack([i, i + 42, i + 41])])
    for a in (np.array([[0.8, 0.3], [-0.2, 0.9]]), np.array([[-0.7, 0.2], [0.1, 0.6]])):  # det > 0, < 0
        uvs = np.column_stack([x, y]) @ a.T
        tangents = vertex_tangents(pos, normals, uvs, faces)
        # exact dP/du, dP/dv of the surface: dP/d(x, y) times the inverse of the uv map
        jac = np.stack([np.column_stack([np.ones_like(x), np.zeros_like(x), hx]),
                        np.column_stack([np.zeros_like(x), np.ones_like(x), hy])], axis=1)  # (N, 2, 3)
        dp = np.einsum("ij,njk->nik", np.linalg.inv(a).T, jac)
        dpdu = dp[:, 0] - normals * np.einsum("ij,ij->i", normals, dp[:, 0])[:, None]
        dpdu /= np.linalg.norm(dpdu, axis=1, keepdims=True)
        t, w = tangents[:, :3], tangents[:, 3]
        assert np.abs(np.einsum("ij,ij->i", t, normals)).max() < TANGENT_FLOAT
        assert np.einsum("ij,ij->i", t, dpdu).min() > TANGENT_MIN_COS
        expected_w = np.sign(np.einsum("ij,ij->i", np.cross(normals, t), -dp[:, 1]))
        assert (w == expected_w).all()
        # seen from the normal's side, (x, y) turn like (right, up): with v growing down the
        # image, a map that keeps that turn (det > 0) shows the texture mirrored
        assert (w == (-1.0 if np.linalg.det(a) > 0 else 1.0)).all()


def test_tangents_and_normal_scale_come_from_the_file(tmp_path):
    # the file's TANGENT is dP/du with handedness -1 (the computed one would say +1), and the
    # node turns the quad 90 degrees about the file's y: the tangents must turn with it
    file_tangents = np.tile([0.0, 0.0, 1.0, -1.0], (4, 1))
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])
    path = tmp_path / "quad.glb"
    _save(path, _quad(_map(_encode([0.0, 0.5, 1.0])), tangents=file_tangents), transform=turn)

    def edit(header):
        prim = header["meshes"][0]["primitives"][0]
        prim["attributes"]["TANGENT"] = prim["attributes"].pop("_TANGENT")
        header["materials"][0]["normalTexture"]["scale"] = 0.5

    _edit_glb(path, edit)
    (part,) = _load(path).parts
    assert part.normal_scale == 0.5
    assert (part.tangents[:, 3] == -1.0).all()
    assert np.einsum("ij,ij->i", part.tangents[:, :3], part.normals).max() < TANGENT_FLOAT
    dp = _face_derivatives(part)
    first = part.tangents[part.indices[:, 0].astype(int), :3]
    assert np.einsum("ij,ij->i", first, dp[:, 0]).min() > FILE_TANGENT_MIN_COS


def test_models_without_a_normal_map_or_uvs_load_as_before(tmp_path):
    plain = _load(_save(tmp_path / "plain.glb", _quad()))
    no_uv = _quad(_map(_encode([0.0, 0.5, 1.0])))
    no_uv.visual = trimesh.visual.TextureVisuals(material=no_uv.visual.material)
    second_uv = tmp_path / "second_uv.glb"  # a map on TEXCOORD_1, which is not read
    _save(second_uv, _quad(_map(_encode([0.0, 0.5, 1.0]))))
    _edit_glb(second_uv, lambda h: h["materials"][0]["normalTexture"].update(texCoord=1))
    for model in (plain, _load(_save(tmp_path / "no_uv.glb", no_uv)), _load(second_uv),
                  load_model("builtin:box", (("length", 1.0),))):
        for part in model.parts:
            assert part.tangents is None and part.normal_texture is None


# ---------------------------------------------------------------------------- rendering
LIGHT = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.5)  # front left, high
POSE = np.eye(4)
POSE[:3, 3] = (9.0, 0.0, 0.0)


def _render(renderer, model):
    """sRGB 8-bit object colour and the pixels well inside the object."""
    passes = renderer.render(make_camera(), [RenderObject(model, POSE, (0.2, 0.2, 0.2))], LIGHT)
    objc = passes.read("objc")
    renderer.release(passes)
    inside = ndimage.binary_erosion(objc[..., 3] > 0.999, iterations=2)
    # the upper half of the 1 m quad: lower down, lit.glsl darkens what stands near the ground
    # (object_occlusion), which these shading checks leave out
    rows = np.nonzero(inside.any(axis=1))[0]
    inside[(rows.min() + rows.max()) // 2:] = False
    assert inside.sum() > 1000
    return np.round(linear_to_srgb(objc[..., :3]) * 255).astype(np.int32), inside, objc[..., :3]


def _expected(model, m_rgb, scale=1.0):
    """Linear colour lit.glsl gives the rough, non-metallic quad ``model`` with tangent-space
    normal map texel m_rgb (see QUAD: T = -y, B = +z, N = -x), sun unshadowed."""
    m = np.asarray(m_rgb, float) / 255 * 2 - 1
    m[:2] *= scale
    n = m[0] * np.array([0, -1.0, 0]) + m[1] * np.array([0, 0, 1.0]) + m[2] * np.array([-1.0, 0, 0])
    n /= np.linalg.norm(n)
    ambient = np.interp(0.5 + 0.5 * n[2], [0, 1], [LIGHT.ground_rgb[0], LIGHT.sky_rgb[0]])
    albedo = model.parts[0].colors[0, 0]  # ALBEDO as the file keeps it (8 bits in trimesh)
    return albedo * (ambient + LIGHT.sun_rgb[0] * max(n @ np.asarray(LIGHT.sun_direction), 0.0))


def test_a_flat_normal_map_renders_like_none(gl_clean, tmp_path):
    renderer = Renderer(gl_clean)
    plain, inside, _ = _render(renderer, _load(_save(tmp_path / "plain.glb", _quad())))
    flat, inside_flat, _ = _render(renderer, _load(_save(tmp_path / "flat.glb", _quad(_map((128, 128, 255))))))
    assert (inside == inside_flat).all()
    assert np.abs(plain - flat)[inside].max() <= FLAT_NORMAL_MAP_8BIT


@pytest.mark.parametrize("name, tilt, brighter", [
    ("up, towards the sun", [0.0, 0.5, 0.87], True),
    ("left, towards the sun", [-0.5, 0.0, 0.87], True),
    ("right, away from the sun", [0.5, 0.0, 0.87], False),
    ("down, away from the sun", [0.0, -0.5, 0.87], False),
])
def test_a_tilted_normal_map_shades_as_its_normal(gl_clean, tmp_path, name, tilt, brighter):
    renderer = Renderer(gl_clean)
    rgb = _encode(tilt)
    plain_model = _load(_save(tmp_path / "plain.glb", _quad()))
    tilted_model = _load(_save(tmp_path / "tilted.glb", _quad(_map(rgb))))
    _, inside, plain = _render(renderer, plain_model)
    _, inside_t, tilted = _render(renderer, tilted_model)
    assert (inside == inside_t).all()
    plain, tilted = plain[inside].mean(0), tilted[inside].mean(0)
    changed = (tilted > plain * NORMAL_MAP_MIN_RATIO) if brighter else (tilted < plain / NORMAL_MAP_MIN_RATIO)
    assert changed.all(), (name, plain, tilted)
    # the shading of that normal, and of no map for the plain quad
    assert tilted == pytest.approx(np.full(3, _expected(tilted_model, rgb)), rel=NORMAL_MAP_SHADING_REL)
    assert plain == pytest.approx(np.full(3, _expected(plain_model, (127.5, 127.5, 255))), rel=NORMAL_MAP_SHADING_REL)


def test_normal_scale_weakens_the_tilt(gl_clean, tmp_path):
    renderer = Renderer(gl_clean)
    rgb = _encode([0.0, 0.5, 0.87])
    path = tmp_path / "scaled.glb"
    _save(path, _quad(_map(rgb)))
    _edit_glb(path, lambda h: h["materials"][0]["normalTexture"].update(scale=0.3))
    model = _load(path)
    _, inside, lit = _render(renderer, model)
    assert lit[inside].mean(0) == pytest.approx(np.full(3, _expected(model, rgb, 0.3)), rel=NORMAL_MAP_SHADING_REL)
    _, _, full = _render(renderer, _load(_save(tmp_path / "full.glb", _quad(_map(rgb)))))
    assert lit[inside].mean() < full[inside].mean() - NORMAL_SCALE_EFFECT_LINEAR


def test_a_part_without_a_map_is_untouched_by_its_neighbours_map(gl_clean, tmp_path):
    # two quads side by side, the left one drawn first; with a strong map on the left one (down
    # and right, away from the sun), the right one's pixels stay byte-identical (nothing of the
    # map leaks to the next part)
    left, right = (0.0, 0.0, -0.65), (0.0, 0.0, 0.65)
    renderer = Renderer(gl_clean)
    both = _load(_save(tmp_path / "both.glb", _quad(None, right), _quad(_map(_encode([0.6, -0.6, 0.5])), left)))
    neither = _load(_save(tmp_path / "neither.glb", _quad(None, right), _quad(None, left)))
    assert [p.normal_texture is not None for p in both.parts] == [True, False]  # drawn in this order
    with_map, _, _ = _render(renderer, both)
    without, inside, _ = _render(renderer, neither)
    cols = np.nonzero(inside.any(axis=0))[0]
    k = np.argmax(np.diff(cols))
    gap = (cols[k] + cols[k + 1]) // 2  # the middle of the gap between the quads
    assert np.abs(with_map - without)[:, :gap].max() > NORMAL_MAP_SHOWS_8BIT  # the map shows on the left quad
    assert (with_map[:, gap:] == without[:, gap:]).all()
