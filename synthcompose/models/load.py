"""Model files: glTF/GLB/OBJ/STL/PLY through trimesh (with the glTF tangents and normal-map
scales trimesh drops), FBX through pyassimp; scaled to real size in the object frame O
(:mod:`.mesh`); :func:`load_model` (cached per process) and :func:`model_digest`."""
from __future__ import annotations

import functools
import io
import json
import struct
from dataclasses import replace
from pathlib import Path

import numpy as np

from synthcompose.colour import srgb_to_linear
from synthcompose.errors import ModelError

from .builtin import BUILTINS
from .mesh import AXES, BUILTIN_PREFIX, TANGENT_ALIAS, MeshPart, Model, finish_part, part_from_trimesh

# trimesh drops a glTF's TANGENT attribute and normalTexture.scale; a file with normal maps is
# handed to it with its JSON edited in memory: TANGENT also under this name (trimesh keeps
# attributes whose name starts with "_") and each normal-mapped material renamed to a key of
# the scales (the renderer does not use material names)
_MATERIAL_KEY = "synthcompose-normal-mapped-material-{}"
_GLB_MAGIC, _GLB_JSON = 0x46546C67, 0x4E4F534A


#: a model above this many triangles is refused rather than rendered slowly
MAX_TRIANGLES = 2_000_000


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
                attrs[TANGENT_ALIAS] = attrs["TANGENT"]
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
    try:
        for mesh in scene.dump():
            if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
                continue
            _check_indices(path, mesh.faces, len(mesh.vertices), mesh.metadata.get("name"))
            linear = None
            if scales and mesh.metadata.get("node") in scene.graph.nodes:
                linear = np.asarray(scene.graph[mesh.metadata["node"]][0], np.float64)[:3, :3]
            parts.append(part_from_trimesh(mesh, smooth, scales, linear))
    except ModelError:
        raise
    except OSError as exc:  # Pillow decodes a texture only when it is used
        raise ModelError(path, f"has a texture that cannot be decoded ({exc})") from None
    except Exception as exc:  # noqa: BLE001 - trimesh raises many types for bad files
        raise ModelError(path, f"cannot be read as a mesh ({type(exc).__name__}: {exc})") from None
    return parts


def _check_indices(path: Path, faces, vertices: int, mesh: str | None = None) -> None:
    """Every face index must name one of the mesh's ``vertices``."""
    faces = np.asarray(faces)
    if faces.size and (faces.min() < 0 or faces.max() >= vertices):
        where = f" (mesh {mesh!r})" if mesh else ""
        bad = int(faces.max()) if faces.max() >= vertices else int(faces.min())
        raise ModelError(path, f"has a face index {bad} out of range: its mesh has {vertices} vertices{where}")


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
                faces = np.asarray(mesh.faces, np.int64)
                if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
                    continue
                pos = np.asarray(mesh.vertices, np.float32)
                _check_indices(path, faces, len(pos))
                nrm = np.asarray(mesh.normals, np.float32) if len(mesh.normals) else np.zeros_like(pos)
                color = np.array([0.6, 0.6, 0.6, 1.0], np.float32)
                props = getattr(mesh.material, "properties", {}) or {}
                diffuse = props.get(("diffuse", 0)) if hasattr(props, "get") else None
                if diffuse is not None and len(diffuse) >= 3:
                    color[:3] = srgb_to_linear(np.asarray(diffuse[:3], np.float32))
                n = len(pos)
                parts.append(finish_part(pos, nrm, np.zeros((n, 2)), np.tile(color, (n, 1)),
                                          np.tile([0.0, 0.6], (n, 1)), faces, None))
            return parts
    except ModelError:
        raise
    except (Exception, AssimpError) as exc:  # AssimpError derives from BaseException
        raise ModelError(path, f"assimp cannot read it ({exc})") from None


def axis_matrix(up: str, forward: str, path) -> np.ndarray:
    """(3, 3) rotation taking the file's axes to O (forward -> +x, up -> +z)."""
    if up not in AXES or forward not in AXES:
        raise ModelError(path, f"axes must be one of {sorted(AXES)}, got up={up!r} forward={forward!r}")
    iu, su = AXES[up]
    iff, sf = AXES[forward]
    if iu == iff:
        raise ModelError(path, f"up {up!r} and forward {forward!r} must be different axes")
    r = np.zeros((3, 3))
    r[0, iff] = sf
    r[2, iu] = su
    r[1] = np.cross(r[2], r[0])  # y = z x x, right-handed
    return r


def normalise(parts: list[MeshPart], rot: np.ndarray, size: dict[str, float], key: str, path) -> Model:
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
    _check_solid(path, parts, pos, ext)
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
        out.append(replace(p, positions=((q - offset) * scale).astype(np.float32), normals=nrm.astype(np.float32),
                           tangents=tan))
    return Model(key, tuple(out), tuple(float(e * scale) for e in ext))


#: a model whose height is below this share of its largest extent is flat; one whose
#: triangles' area is below this share of its largest extent squared has no surface to draw
FLAT_SHARE = 1e-6


def _check_solid(path, parts: list[MeshPart], pos: list[np.ndarray], ext: np.ndarray) -> None:
    """Refuse a model nothing of which would be seen: flat, lying on the ground (no height:
    a street camera sees it edge-on or not at all; a standing plate, a sign's, may be thin),
    or all of whose triangles have zero area."""
    if ext[2] <= FLAT_SHARE * ext.max():
        raise ModelError(path, f"is flat: its height is {float(ext[2]):.3g} in its own units, against "
                               f"{float(ext.max()):.3g} for its largest side (check 'up': the model's up axis)")
    area = 0.0
    for p, q in zip(parts, pos):
        _check_indices(path, p.indices, len(q))
        a, b, c = (q[p.indices[:, k]].astype(np.float64) for k in range(3))
        area += 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
    if area <= FLAT_SHARE * float(ext.max()) ** 2:
        triangles = sum(len(p.indices) for p in parts)
        raise ModelError(path, f"has no surface: all its {triangles} triangles have zero area (nothing would be drawn)")


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
        return normalise(BUILTINS[name](), np.eye(3), size, key, path)
    p = Path(path)
    if p.is_dir():
        raise ModelError(p, "is a folder, not a model file")
    if not p.is_file():
        raise ModelError(p, "model file is missing")
    if p.stat().st_size == 0:
        raise ModelError(p, "model file is empty")
    parts = _load_assimp(p) if p.suffix.lower() == ".fbx" else _load_trimesh(p)
    return normalise(parts, axis_matrix(up, forward, p), size, key, p)

