"""The one form every model takes: :class:`Model` of :class:`MeshPart` (positions, normals, UVs,
linear colours, metallic/roughness, textures, tangents), and its conversion from trimesh.

Object frame O (like the vehicle frame): x forward, y left, z up, metres; the model's
footprint is centred on the origin in x/y and its lowest point sits at z = 0, so placing
an object means putting O's origin on the ground.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from synthcompose.colour import srgb_to_linear

#: prefix of a model built in code rather than read from a file
BUILTIN_PREFIX = "builtin:"
#: opaque stand-in colour for transparent vertices of a part that is not all glass (linear RGB)
GLASS_RGB = np.array([0.015, 0.02, 0.025], np.float32)
#: a material whose alpha (glTF baseColorFactor's, or a vertex colour's) is below this is glass
GLASS_ALPHA = 0.5

#: textured materials with such names are drawn blank (:data:`NEUTRAL_PLATE`, linear RGBA)
_NEUTRAL = re.compile(r"licen[cs]e|plate|decal|logo|badge", re.IGNORECASE)
#: ... and those of them that are number plates carry each object's own plate (:mod:`..plates`)
_PLATE = re.compile(r"licen[cs]e|plate", re.IGNORECASE)
NEUTRAL_PLATE = (0.55, 0.55, 0.52, 1.0)
#: the name a glTF's TANGENT attribute is handed to trimesh under (:mod:`.load`; trimesh keeps
#: attributes whose name starts with "_")
TANGENT_ALIAS = "_SYNTHCOMPOSE_TANGENT"
AXES = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0), "+z": (2, 1.0), "-z": (2, -1.0)}


@dataclass(frozen=True, eq=False)
class MeshPart:
    """One drawable piece: triangles sharing a texture.

    positions : (N, 3) float32, object frame O, metres
    normals   : (N, 3) float32, unit
    uvs       : (N, 2) float32, texture coordinates (zeros without a texture)
    colors    : (N, 4) float32, linear base colour factor (rgb) and alpha
    material  : (N, 2) float32, (metallic, roughness)
    indices   : (M, 3) uint32
    texture   : (H, W, 4) uint8 sRGB base-colour texture or None; row 0 = v = 0
    tangents  : (N, 4) float32 or None (None without a normal map): xyz the unit tangent along
                +u, orthogonal to the normal; w = +-1 the handedness, bitangent = w * (normal x
                tangent), pointing to -v (up in the texture image), as glTF's TANGENT
    normal_texture : (H, W, 4) uint8 tangent-space normal map (linear, glTF: +x along the
                tangent, +y along the bitangent) or None; row 0 = v = 0
    normal_scale   : glTF normalTexture.scale, multiplies the map's x and y
    plate     : (W, H) px of the model's own plate texture when this part is a number plate
                (its texture is dropped, its UVs kept): each object's plate is drawn on it
    label     : the Cityscapes class of this part when it is not the object's (a sign's pole:
                "pole"; a class without instances); None: the object's class
    name      : the material's name ("" when the file gives none); vehicles name theirs by
                role (docs/vehicles.md): ``paint`` is the recolourable one (:mod:`..appearance`)
    transmission : 0 for an opaque part; for glass (every vertex's alpha under
                :data:`GLASS_ALPHA`) the share of light its material lets through, 1 - alpha: the
                lit pass draws it over what is behind it (shaders/lit.glsl, GLASS)
    """

    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    colors: np.ndarray
    material: np.ndarray
    indices: np.ndarray
    texture: np.ndarray | None
    tangents: np.ndarray | None = None
    normal_texture: np.ndarray | None = None
    normal_scale: float = 1.0
    plate: tuple[int, int] | None = None
    label: str | None = None
    name: str = ""
    transmission: float = 0.0


@dataclass(frozen=True, eq=False)
class Model:
    """A model in the object frame O at real-world scale."""

    key: str
    parts: tuple[MeshPart, ...]
    extents: tuple[float, float, float]  # (length x, width y, height z), metres

    @property
    def triangles(self) -> int:
        return sum(len(p.indices) for p in self.parts)


# ------------------------------------------------------------------ conversions
def _as_rgba_u8(img) -> np.ndarray:
    arr = np.asarray(img.convert("RGBA"), np.uint8)
    return np.ascontiguousarray(arr)


def vertex_tangents(positions, normals, uvs, faces) -> np.ndarray:
    """(N, 4) float32 per-vertex tangents in :class:`MeshPart`'s convention, from the geometry.

    ``uvs`` as in MeshPart (glTF's: v grows down the image). Each triangle adds its dP/du and
    dP/dv weighted by its UV area (so triangles with degenerate UVs add nothing); the sum is
    made orthogonal to the vertex normal (Gram-Schmidt) and w = -1 where the UV mapping is
    mirrored. A vertex with no usable tangent gets any unit vector orthogonal to its normal.
    """
    pos = np.asarray(positions, np.float64)
    uv = np.asarray(uvs, np.float64)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    e1, e2 = pos[f[:, 1]] - pos[f[:, 0]], pos[f[:, 2]] - pos[f[:, 0]]
    d1, d2 = uv[f[:, 1]] - uv[f[:, 0]], uv[f[:, 2]] - uv[f[:, 0]]
    sign = np.sign(d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1])[:, None]
    # (dP/du, dP/dv) * det: the inverse of the UV edge matrix times the position edges
    face_t = (d2[:, 1:2] * e1 - d1[:, 1:2] * e2) * sign
    face_b = (d1[:, 0:1] * e2 - d2[:, 0:1] * e1) * sign
    tan = np.zeros_like(pos)
    bit = np.zeros_like(pos)
    corners = f.reshape(-1)
    np.add.at(tan, corners, np.repeat(face_t, 3, axis=0))
    np.add.at(bit, corners, np.repeat(face_b, 3, axis=0))
    # glTF's bitangent points to -v (image up): mirrored where dP/dv agrees with n x t
    w = np.where(np.einsum("ij,ij->i", np.cross(np.asarray(normals, np.float64), tan), bit) > 0, -1.0, 1.0)
    return _orthonormal_tangents(tan, w, normals)


def _orthonormal_tangents(tan, w, normals) -> np.ndarray:
    """(N, 4) float32: ``tan`` made unit and orthogonal to ``normals``, ``w`` appended."""
    nrm = np.asarray(normals, np.float64)
    nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)
    tan = np.asarray(tan, np.float64)
    before = np.linalg.norm(tan, axis=1, keepdims=True)
    tan = tan - nrm * np.einsum("ij,ij->i", nrm, tan)[:, None]
    length = np.linalg.norm(tan, axis=1, keepdims=True)
    # none, or (almost) along the normal: any direction orthogonal to the normal
    other = np.where(np.abs(nrm[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    spare = np.cross(nrm, other)
    spare /= np.maximum(np.linalg.norm(spare, axis=1, keepdims=True), 1e-12)
    ok = (length > 1e-6 * before) & (length > 0)
    tan = np.where(ok, tan / np.where(ok, length, 1.0), spare)
    return np.concatenate([tan, np.asarray(w, np.float64).reshape(-1, 1)], axis=1).astype(np.float32)


def _file_tangents(mesh, linear: np.ndarray | None) -> np.ndarray | None:
    """The file's own TANGENT attribute (see :func:`_load_trimesh`) taken through the node
    transform ``linear`` (3, 3) that trimesh applied to the positions, or None."""
    tan = mesh.vertex_attributes.get(TANGENT_ALIAS)
    if tan is None or linear is None:
        return None
    tan = np.asarray(tan, np.float64)
    if tan.ndim != 2 or tan.shape != (len(mesh.vertices), 4) or not np.isfinite(tan).all():
        return None
    w = np.where(tan[:, 3] < 0, -1.0, 1.0) * (1.0 if np.linalg.det(linear) >= 0 else -1.0)
    return np.concatenate([tan[:, :3] @ np.asarray(linear, np.float64).T, w[:, None]], axis=1)


def part_from_trimesh(mesh, smooth: bool, normal_scales: dict[str, float] | None = None,
                       linear: np.ndarray | None = None) -> MeshPart:
    """Convert one trimesh.Trimesh (transform already applied) to a MeshPart.

    ``normal_scales``: the glTF materials that keep their normal map (name -> scale, see
    :func:`_load_trimesh`); ``linear``: the (3, 3) node transform applied, for file tangents.
    """
    import trimesh

    if not smooth:
        mesh = mesh.copy()
        mesh.unmerge_vertices()
        normals = np.zeros((len(mesh.vertices), 3))
        normals[mesh.faces.reshape(-1)] = np.repeat(mesh.face_normals, 3, axis=0)
    else:
        normals = mesh.vertex_normals
    n = len(mesh.vertices)
    uvs = np.zeros((n, 2), np.float32)
    colors = np.ones((n, 4), np.float32) * np.float32(0.6)
    colors[:, 3] = 1.0
    metal_rough = np.tile(np.array([0.0, 0.6], np.float32), (n, 1))
    texture = None
    normal_texture, normal_scale = None, 1.0
    plate = None
    visual = mesh.visual
    if isinstance(visual, trimesh.visual.texture.TextureVisuals):
        mat = visual.material
        if isinstance(mat, trimesh.visual.material.PBRMaterial):
            factor = mat.baseColorFactor
            if factor is not None:
                # glTF's factor is linear; trimesh keeps it as uint8 = round(255 * value)
                colors[:] = np.asarray(factor, np.float32) / (255.0 if np.asarray(factor).dtype == np.uint8 else 1.0)
            else:
                colors[:] = (1.0, 1.0, 1.0, 1.0)
            if mat.metallicFactor is not None:
                metal_rough[:, 0] = mat.metallicFactor
            if mat.roughnessFactor is not None:
                metal_rough[:, 1] = mat.roughnessFactor
            if mat.baseColorTexture is not None:
                texture = _as_rgba_u8(mat.baseColorTexture)
            if texture is not None and _NEUTRAL.search(mat.name or ""):
                # a plate, a decal, a logo: its text or brand would be the same on every object
                # (a model learns it); drawn blank instead, a number plate with each object's own
                if _PLATE.search(mat.name or "") and visual.uv is not None and len(visual.uv) == n:
                    plate = (int(texture.shape[1]), int(texture.shape[0]))
                texture, colors[:] = None, NEUTRAL_PLATE
            if mat.normalTexture is not None and normal_scales and mat.name in normal_scales:
                normal_texture = _as_rgba_u8(mat.normalTexture)
                normal_scale = normal_scales[mat.name]
        else:  # SimpleMaterial (OBJ .mtl)
            diffuse = getattr(mat, "diffuse", None)
            if diffuse is not None:
                d = np.asarray(diffuse, np.float32) / 255.0
                colors[:] = np.concatenate([srgb_to_linear(d[:3]), d[3:]])
            if getattr(mat, "image", None) is not None:
                texture = _as_rgba_u8(mat.image)
                colors[:] = (1.0, 1.0, 1.0, 1.0)
        if (texture is not None or normal_texture is not None or plate) and visual.uv is not None and len(visual.uv) == n:
            uvs = np.asarray(visual.uv, np.float32)
            uvs = np.stack([uvs[:, 0], 1.0 - uvs[:, 1]], axis=1)  # image row 0 at v = 0
        else:
            texture = normal_texture = None
    elif isinstance(visual, trimesh.visual.color.ColorVisuals) and visual.kind == "vertex":
        vc = np.asarray(visual.vertex_colors, np.float32) / 255.0
        colors = np.concatenate([srgb_to_linear(vc[:, :3]), vc[:, 3:]], axis=1).astype(np.float32)
    tangents = None
    if normal_texture is not None:
        tangents = _file_tangents(mesh, linear)
        if tangents is None:
            tangents = vertex_tangents(mesh.vertices, normals, uvs, mesh.faces)
        else:
            tangents = _orthonormal_tangents(tangents[:, :3], tangents[:, 3], normals)
    name = ""
    if isinstance(visual, trimesh.visual.texture.TextureVisuals) and visual.material is not None:
        name = str(getattr(visual.material, "name", "") or "")
    return finish_part(mesh.vertices, normals, uvs, colors, metal_rough, mesh.faces, texture,
                        tangents=tangents, normal_texture=normal_texture, normal_scale=normal_scale, plate=plate,
                        name=name)


def finish_part(positions, normals, uvs, colors, material, faces, texture, *, tangents=None,
                 normal_texture=None, normal_scale=1.0, plate=None, label=None, name="") -> MeshPart:
    colors = np.asarray(colors, np.float32).copy()
    glass = colors[:, 3] < GLASS_ALPHA
    transmission = 0.0
    if len(glass) and glass.all():
        # a glass material: drawn over what is behind it, letting 1 - alpha through (lit.glsl)
        transmission = float(np.clip(1.0 - np.median(colors[:, 3]), 0.0, 1.0))
        material = np.asarray(material, np.float32).copy()
        material[:, 1] = np.minimum(material[:, 1], 0.1)
    elif glass.any():  # transparent vertices of a part that is not all glass: dark glossy opaque
        colors[glass, :3] = GLASS_RGB + colors[glass, :3] * colors[glass, 3:4] * 0.2
        material = np.asarray(material, np.float32).copy()
        material[glass, 1] = 0.05
    colors[:, 3] = 1.0
    return MeshPart(
        positions=np.asarray(positions, np.float32),
        normals=np.asarray(normals, np.float32),
        uvs=np.asarray(uvs, np.float32),
        colors=colors,
        material=np.asarray(material, np.float32),
        indices=np.asarray(faces, np.uint32).reshape(-1, 3),
        texture=texture,
        tangents=None if tangents is None else np.asarray(tangents, np.float32),
        normal_texture=normal_texture,
        normal_scale=float(normal_scale),
        plate=plate,
        label=label,
        name=str(name),
        transmission=transmission,
    )
