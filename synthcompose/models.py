"""3D models: load glTF/GLB/OBJ/STL/PLY (trimesh) and FBX (pyassimp) into one form.

Object frame O (like the vehicle frame): x forward, y left, z up, metres; the model's
footprint is centred on the origin in x/y and its lowest point sits at z = 0, so placing
an object means putting O's origin on the ground.
"""
from __future__ import annotations

import functools
import io
import json
import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .colour import srgb_to_linear
from .errors import ModelError

#: prefix of a model built in code rather than read from a file
BUILTIN_PREFIX = "builtin:"
#: opaque stand-in colour for transparent glass (linear RGB)
GLASS_RGB = np.array([0.015, 0.02, 0.025], np.float32)
#: a model above this many triangles is refused rather than rendered slowly
MAX_TRIANGLES = 2_000_000

#: textured materials with such names are drawn blank (:data:`NEUTRAL_PLATE`, linear RGBA)
_NEUTRAL = re.compile(r"licen[cs]e|plate|decal|logo|badge", re.IGNORECASE)
NEUTRAL_PLATE = (0.55, 0.55, 0.52, 1.0)
_AXES = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0), "+z": (2, 1.0), "-z": (2, -1.0)}


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
    tan = mesh.vertex_attributes.get(_TANGENT_ALIAS)
    if tan is None or linear is None:
        return None
    tan = np.asarray(tan, np.float64)
    if tan.ndim != 2 or tan.shape != (len(mesh.vertices), 4) or not np.isfinite(tan).all():
        return None
    w = np.where(tan[:, 3] < 0, -1.0, 1.0) * (1.0 if np.linalg.det(linear) >= 0 else -1.0)
    return np.concatenate([tan[:, :3] @ np.asarray(linear, np.float64).T, w[:, None]], axis=1)


def _part_from_trimesh(mesh, smooth: bool, normal_scales: dict[str, float] | None = None,
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
                # (a model learns it); drawn as a blank plate instead
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
        if (texture is not None or normal_texture is not None) and visual.uv is not None and len(visual.uv) == n:
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
    return _finish_part(mesh.vertices, normals, uvs, colors, metal_rough, mesh.faces, texture,
                        tangents=tangents, normal_texture=normal_texture, normal_scale=normal_scale)


def _finish_part(positions, normals, uvs, colors, material, faces, texture, *, tangents=None,
                 normal_texture=None, normal_scale=1.0) -> MeshPart:
    colors = np.asarray(colors, np.float32).copy()
    glass = colors[:, 3] < 0.5
    if glass.any():  # transparent glass: render as dark glossy opaque surface
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
    )


# trimesh drops a glTF's TANGENT attribute and normalTexture.scale; a file with normal maps is
# handed to it with its JSON edited in memory: TANGENT also under this name (trimesh keeps
# attributes whose name starts with "_") and each normal-mapped material renamed to a key of
# the scales (the renderer does not use material names)
_TANGENT_ALIAS = "_SYNTHCOMPOSE_TANGENT"
_MATERIAL_KEY = "synthcompose-normal-mapped-material-{}"
_GLB_MAGIC, _GLB_JSON = 0x46546C67, 0x4E4F534A


def _gltf_json(path: Path, data: bytes) -> dict | None:
    """The JSON of a .gltf/.glb file's bytes, or None when it cannot be read as such."""
    try:
        if path.suffix.lower() == ".glb":
            magic, _, _, length, kind = struct.unpack_from("<5I", data)
            if magic != _GLB_MAGIC or kind != _GLB_JSON:
                return None
            data = data[20:20 + length]
        header = json.loads(data)
    except (struct.error, ValueError, UnicodeDecodeError):
        return None
    return header if isinstance(header, dict) else None


def _with_json(path: Path, data: bytes, header: dict) -> bytes:
    """The file's bytes with its JSON replaced by ``header``."""
    text = json.dumps(header, separators=(",", ":")).encode("utf-8")
    if path.suffix.lower() != ".glb":
        return text
    text += b" " * (-len(text) % 4)  # chunks are 4-byte aligned, JSON padded with spaces
    (length,) = struct.unpack_from("<I", data, 12)
    rest = data[20 + length:]  # the BIN chunk (and any others), unchanged
    total = 12 + 8 + len(text) + len(rest)
    return struct.pack("<5I", _GLB_MAGIC, 2, total, len(text), _GLB_JSON) + text + rest


def _normal_mapped(header: dict) -> dict[str, float]:
    """Edit ``header`` as described above; the renamed materials' normal scales."""
    scales = {}
    for i, mat in enumerate(header.get("materials") or []):
        info = mat.get("normalTexture") if isinstance(mat, dict) else None
        if not isinstance(info, dict):
            continue
        if info.get("texCoord", 0) != 0:  # trimesh reads TEXCOORD_0 only
            del mat["normalTexture"]
            continue
        mat["name"] = _MATERIAL_KEY.format(i)
        scale = info.get("scale", 1.0)
        scales[mat["name"]] = float(scale) if isinstance(scale, (int, float)) else 1.0
    for mesh in header.get("meshes") or []:
        for prim in (mesh.get("primitives") or []) if isinstance(mesh, dict) else []:
            attrs = prim.get("attributes") if isinstance(prim, dict) else None
            if isinstance(attrs, dict) and "TANGENT" in attrs:
                attrs[_TANGENT_ALIAS] = attrs["TANGENT"]
    return scales


def _trimesh_source(path: Path):
    """What to hand trimesh.load for ``path`` (its name, or the edited glTF when it has normal
    maps), the keyword arguments that go with it, and the normal scales."""
    import trimesh

    if path.suffix.lower() not in (".gltf", ".glb"):
        return str(path), {}, {}
    data = path.read_bytes()
    header = _gltf_json(path, data)
    materials = header.get("materials") if header is not None else None
    if not isinstance(materials, list) or not any(isinstance(m, dict) and "normalTexture" in m for m in materials):
        return str(path), {}, {}
    scales = _normal_mapped(header)
    kwargs = {"file_type": path.suffix.lower()[1:], "resolver": trimesh.resolvers.FilePathResolver(str(path))}
    return io.BytesIO(_with_json(path, data, header)), kwargs, scales


def _load_trimesh(path: Path) -> list[MeshPart]:
    import trimesh

    try:
        source, kwargs, scales = _trimesh_source(path)
        scene = trimesh.load(source, force="scene", process=False, **kwargs)
    except Exception as exc:  # trimesh raises many types for bad files
        raise ModelError(path, f"cannot be read as a mesh ({type(exc).__name__}: {exc})") from None
    smooth = path.suffix.lower() not in (".stl",)
    parts = []
    for mesh in scene.dump():
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        linear = None
        if scales and mesh.metadata.get("node") in scene.graph.nodes:
            linear = np.asarray(scene.graph[mesh.metadata["node"]][0], np.float64)[:3, :3]
        parts.append(_part_from_trimesh(mesh, smooth, scales, linear))
    return parts


def _load_assimp(path: Path) -> list[MeshPart]:
    try:
        import pyassimp
        import pyassimp.postprocess as pp
        from pyassimp.errors import AssimpError
    except (Exception, BaseException) as exc:  # pyassimp raises AssimpError(BaseException) without libassimp
        raise ModelError(path, f"FBX needs pyassimp and the assimp library ({exc})") from None
    flags = pp.aiProcess_Triangulate | pp.aiProcess_PreTransformVertices | pp.aiProcess_GenSmoothNormals
    try:
        with pyassimp.load(str(path), processing=flags) as scene:
            parts = []
            for mesh in scene.meshes:
                faces = np.asarray(mesh.faces, np.uint32)
                if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
                    continue
                pos = np.asarray(mesh.vertices, np.float32)
                nrm = np.asarray(mesh.normals, np.float32) if len(mesh.normals) else np.zeros_like(pos)
                color = np.array([0.6, 0.6, 0.6, 1.0], np.float32)
                props = getattr(mesh.material, "properties", {}) or {}
                diffuse = props.get(("diffuse", 0)) if hasattr(props, "get") else None
                if diffuse is not None and len(diffuse) >= 3:
                    color[:3] = srgb_to_linear(np.asarray(diffuse[:3], np.float32))
                n = len(pos)
                parts.append(_finish_part(pos, nrm, np.zeros((n, 2)), np.tile(color, (n, 1)),
                                          np.tile([0.0, 0.6], (n, 1)), faces, None))
            return parts
    except ModelError:
        raise
    except (Exception, AssimpError) as exc:  # AssimpError derives from BaseException
        raise ModelError(path, f"assimp cannot read it ({exc})") from None


def _axis_matrix(up: str, forward: str, path) -> np.ndarray:
    """(3, 3) rotation taking the file's axes to O (forward -> +x, up -> +z)."""
    if up not in _AXES or forward not in _AXES:
        raise ModelError(path, f"axes must be one of {sorted(_AXES)}, got up={up!r} forward={forward!r}")
    iu, su = _AXES[up]
    iff, sf = _AXES[forward]
    if iu == iff:
        raise ModelError(path, f"up {up!r} and forward {forward!r} must be different axes")
    r = np.zeros((3, 3))
    r[0, iff] = sf
    r[2, iu] = su
    r[1] = np.cross(r[2], r[0])  # y = z x x, right-handed
    return r


def _normalise(parts: list[MeshPart], rot: np.ndarray, size: dict[str, float], key: str, path) -> Model:
    if not parts:
        raise ModelError(path, "contains no triangles")
    tri = sum(len(p.indices) for p in parts)
    if tri > MAX_TRIANGLES:
        raise ModelError(path, f"has {tri} triangles, more than the limit of {MAX_TRIANGLES}")
    rot = rot.astype(np.float32)
    pos = [p.positions @ rot.T for p in parts]
    allpos = np.concatenate(pos)
    if not np.isfinite(allpos).all():
        raise ModelError(path, "has non-finite vertex coordinates")
    lo, hi = allpos.min(0), allpos.max(0)
    ext = hi - lo
    dims = {"length": 0, "width": 1, "height": 2}
    if len(size) != 1 or next(iter(size)) not in dims:
        raise ModelError(path, f"size must give exactly one of length/width/height, got {size}")
    dim, target = next(iter(size.items()))
    if ext[dims[dim]] <= 1e-9:
        raise ModelError(path, f"has zero {dim} (degenerate model)")
    scale = float(target) / float(ext[dims[dim]])
    offset = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]], np.float32)
    out = []
    for p, q in zip(parts, pos):
        nrm = p.normals @ rot.T
        length = np.linalg.norm(nrm, axis=1, keepdims=True)
        nrm = np.where(length > 1e-12, nrm / np.maximum(length, 1e-12), np.array([0, 0, 1], np.float32))
        tan = None
        if p.tangents is not None:  # a rotation: still unit and orthogonal to the normals
            tan = np.concatenate([p.tangents[:, :3] @ rot.T, p.tangents[:, 3:]], axis=1).astype(np.float32)
        out.append(MeshPart(((q - offset) * scale).astype(np.float32), nrm.astype(np.float32), p.uvs,
                            p.colors, p.material, p.indices, p.texture, tan, p.normal_texture, p.normal_scale))
    return Model(key, tuple(out), tuple(float(e * scale) for e in ext))


def model_digest(path: str) -> str:
    """sha256 of a model file and, for a .gltf, of the buffers and images it names by relative
    URI: what decides how it renders (a batch that resumes redoes the image sets when it
    changes). Built-in models: their name."""
    import hashlib

    if path.startswith(BUILTIN_PREFIX):
        return path
    h = hashlib.sha256()
    p = Path(path)
    files = [p]
    if p.suffix.lower() == ".gltf":
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
            for entry in (doc.get("buffers") or []) + (doc.get("images") or []):
                uri = entry.get("uri") if isinstance(entry, dict) else None
                if isinstance(uri, str) and uri and not uri.startswith("data:"):
                    files.append(p.parent / uri)
        except (OSError, ValueError, AttributeError):
            pass  # load_model names what is wrong with the file
    for f in files:
        try:
            h.update(f.read_bytes())
        except OSError:
            h.update(b"missing:" + str(f).encode())
    return h.hexdigest()


@functools.lru_cache(maxsize=32)
def load_model(path: str, size_key: tuple[tuple[str, float], ...], up: str = "+y", forward: str = "+x") -> Model:
    """Load a model file or a builtin, at real size; cached per process.

    ``size_key`` is ``(("length", 4.5),)`` style: exactly one dimension in metres; the model is
    scaled uniformly to it. ``up``/``forward`` name the file's axes (glTF is Y-up).
    """
    size = dict(size_key)
    key = f"{path}|{size_key}|{up}|{forward}"
    if path.startswith(BUILTIN_PREFIX):
        name = path[len(BUILTIN_PREFIX):]
        if name not in BUILTINS:
            raise ModelError(path, f"unknown builtin model; known: {', '.join(sorted(BUILTINS))}")
        return _normalise(BUILTINS[name](), np.eye(3), size, key, path)
    p = Path(path)
    if not p.is_file():
        raise ModelError(p, "model file is missing")
    if p.stat().st_size == 0:
        raise ModelError(p, "model file is empty")
    parts = _load_assimp(p) if p.suffix.lower() == ".fbx" else _load_trimesh(p)
    return _normalise(parts, _axis_matrix(up, forward, p), size, key, p)


# --------------------------------------------------------------------- builtins
#: the built-in models' files, shipped in the package (a wheel alone can draw them)
_BUILTIN_FILES = Path(__file__).resolve().parent / "builtin"


def _coloured(mesh, rgb_srgb, metallic=0.0, roughness=0.6, smooth=True) -> MeshPart:
    import trimesh

    m = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    part = _part_from_trimesh(m, smooth)
    n = len(part.positions)
    col = np.tile(np.append(srgb_to_linear(np.asarray(rgb_srgb, np.float32)), 1.0), (n, 1)).astype(np.float32)
    return MeshPart(part.positions, part.normals, part.uvs, col,
                    np.tile(np.array([metallic, roughness], np.float32), (n, 1)), part.indices, None)


def traffic_sign_parts(plate_height: float = 2.0, pole_radius: float = 0.035) -> list[MeshPart]:
    """A stop sign on a pole, built in code; the sign's face looks along +x.

    The plate comes from ``synthcompose/builtin/stop_sign_*.stl`` (MIT, see LICENSE-stop_sign
    there; the source and full model stay in ``assets/models/stop_sign``); the pole is a
    cylinder. ``plate_height`` is the height of the plate's centre above the ground.
    """
    import trimesh

    pole = trimesh.creation.cylinder(radius=pole_radius, height=plate_height + 0.1, sections=24)
    pole.apply_translation([0, 0, (plate_height + 0.1) / 2])
    parts = [_coloured(pole, (0.55, 0.56, 0.57), metallic=0.8, roughness=0.4)]
    # plate files: octagon in their x/y plane, front towards +z, text upright along +y
    to_o = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # file z -> O x, x -> y, y -> z
    red = trimesh.load(str(_BUILTIN_FILES / "stop_sign_red.stl"), process=False)
    white = trimesh.load(str(_BUILTIN_FILES / "stop_sign_white.stl"), process=False)
    centre = red.bounds.mean(axis=0)
    for mesh, rgb in ((red, (0.70, 0.05, 0.06)), (white, (0.92, 0.92, 0.92))):
        m = mesh.copy()
        m.apply_translation(-centre)
        transform = np.eye(4)
        transform[:3, :3] = to_o
        transform[:3, 3] = [pole_radius + 0.004, 0, plate_height]
        m.apply_transform(transform)
        parts.append(_coloured(m, rgb, roughness=0.5, smooth=False))
    return parts


def box_parts() -> list[MeshPart]:
    """A 1 m cube standing on z = 0 (for tests and placement debugging)."""
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    box.apply_translation([0, 0, 0.5])
    return [_coloured(box, (0.8, 0.8, 0.8), smooth=False)]


BUILTINS = {"traffic-sign": traffic_sign_parts, "box": box_parts}
