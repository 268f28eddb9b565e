"""3D models: load glTF/GLB/OBJ/STL/PLY (trimesh) and FBX (pyassimp) into one form.

Object frame O (like the vehicle frame): x forward, y left, z up, metres; the model's
footprint is centred on the origin in x/y and its lowest point sits at z = 0, so placing
an object means putting O's origin on the ground.
"""
from __future__ import annotations

import functools
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
    """

    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    colors: np.ndarray
    material: np.ndarray
    indices: np.ndarray
    texture: np.ndarray | None


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


def _part_from_trimesh(mesh, smooth: bool) -> MeshPart:
    """Convert one trimesh.Trimesh (transform already applied) to a MeshPart."""
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
        else:  # SimpleMaterial (OBJ .mtl)
            diffuse = getattr(mat, "diffuse", None)
            if diffuse is not None:
                d = np.asarray(diffuse, np.float32) / 255.0
                colors[:] = np.concatenate([srgb_to_linear(d[:3]), d[3:]])
            if getattr(mat, "image", None) is not None:
                texture = _as_rgba_u8(mat.image)
                colors[:] = (1.0, 1.0, 1.0, 1.0)
        if texture is not None and visual.uv is not None and len(visual.uv) == n:
            uvs = np.asarray(visual.uv, np.float32)
            uvs = np.stack([uvs[:, 0], 1.0 - uvs[:, 1]], axis=1)  # image row 0 at v = 0
        else:
            texture = None
    elif isinstance(visual, trimesh.visual.color.ColorVisuals) and visual.kind == "vertex":
        vc = np.asarray(visual.vertex_colors, np.float32) / 255.0
        colors = np.concatenate([srgb_to_linear(vc[:, :3]), vc[:, 3:]], axis=1).astype(np.float32)
    return _finish_part(mesh.vertices, normals, uvs, colors, metal_rough, mesh.faces, texture)


def _finish_part(positions, normals, uvs, colors, material, faces, texture) -> MeshPart:
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
    )


def _load_trimesh(path: Path) -> list[MeshPart]:
    import trimesh

    try:
        scene = trimesh.load(str(path), force="scene", process=False)
    except Exception as exc:  # trimesh raises many types for bad files
        raise ModelError(path, f"cannot be read as a mesh ({type(exc).__name__}: {exc})") from None
    smooth = path.suffix.lower() not in (".stl",)
    parts = []
    for mesh in scene.dump():
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            continue
        parts.append(_part_from_trimesh(mesh, smooth))
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
        out.append(MeshPart(((q - offset) * scale).astype(np.float32), nrm.astype(np.float32), p.uvs,
                            p.colors, p.material, p.indices, p.texture))
    return Model(key, tuple(out), tuple(float(e * scale) for e in ext))


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
_ASSETS = Path(__file__).resolve().parent.parent / "assets" / "models"


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

    The plate comes from ``assets/models/stop_sign`` (MIT, see its LICENSE); the pole is a
    cylinder. ``plate_height`` is the height of the plate's centre above the ground.
    """
    import trimesh

    pole = trimesh.creation.cylinder(radius=pole_radius, height=plate_height + 0.1, sections=24)
    pole.apply_translation([0, 0, (plate_height + 0.1) / 2])
    parts = [_coloured(pole, (0.55, 0.56, 0.57), metallic=0.8, roughness=0.4)]
    # plate files: octagon in their x/y plane, front towards +z, text upright along +y
    to_o = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # file z -> O x, x -> y, y -> z
    red = trimesh.load(str(_ASSETS / "stop_sign" / "stop_sign_red.stl"), process=False)
    white = trimesh.load(str(_ASSETS / "stop_sign" / "stop_sign_white.stl"), process=False)
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
