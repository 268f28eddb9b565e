"""A skinned glTF read and posed with NumPy: the glTF's joints, inverse bind matrices and
JOINTS_0 / WEIGHTS_0 read with NumPy (trimesh does not pose skins), posed by linear blend
skinning from a pose of :mod:`.poses`, and returned as a :class:`~.mesh.Model` in the object
frame O (x the person's facing direction, y left, z up, feet on z = 0, footprint centred).

The pose convention (as BVH's): each joint ``j`` gets a rotation ``Q_j`` about its head, in
O's axes, applied after its parent's: its posed world rotation is ``W_j = W_parent Q_j`` and its
head goes to ``p_j = p_parent + W_parent (h_j - h_parent)``, ``h`` the bind pose's heads (from
the inverse bind matrices). The skinning matrix of ``j`` is then ``[W_j | p_j - W_j h_j]``, so the
bind pose's own joint orientations do not matter. A vertex goes to ``sum_k w_k S_{j_k} v``.
"""
from __future__ import annotations

import functools
import json
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synthcompose.errors import ModelError

from .load import axis_matrix
from .mesh import MeshPart, Model, finish_part

_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
_NORMALISED_MAX = {np.uint8: 255.0, np.uint16: 65535.0, np.int8: 127.0, np.int16: 32767.0}


@dataclass(frozen=True, eq=False)
class SkinPart:
    """One primitive: positions (N, 3) and normals (N, 3) in O's axes (unscaled), joints (N, 4)
    int64, weights (N, 4) float32 (sum 1), indices (M, 3), material name and its colour
    (linear RGBA), metallic, roughness."""

    name: str
    positions: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    indices: np.ndarray
    color: tuple[float, float, float, float]
    metallic: float
    roughness: float


@dataclass(frozen=True, eq=False)
class Skin:
    """A skinned model in its bind pose, in O's axes (the file's units): ``names`` (J,), ``parents``
    (J,) (-1: a root), ``heads`` (J, 3) the bind pose's joint heads, ``parts``; ``height``: the bind
    mesh's extent along z; ``order``: joints with every parent before its children."""

    path: str
    names: tuple[str, ...]
    parents: np.ndarray
    heads: np.ndarray
    parts: tuple[SkinPart, ...]
    order: tuple[int, ...]
    extents: np.ndarray

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise ModelError(self.path, f"the skeleton has no joint {name!r}") from None


# ---------------------------------------------------------------------- reading
def _glb_chunks(path: Path, data: bytes) -> tuple[dict, bytes]:
    try:
        magic, version, _ = struct.unpack_from("<3I", data)
        if magic != 0x46546C67 or version != 2:
            raise ValueError("not a glTF 2.0 binary")
        length, kind = struct.unpack_from("<2I", data, 12)
        if kind != 0x4E4F534A:
            raise ValueError("first chunk is not JSON")
        doc = json.loads(data[20:20 + length])
        offset = 20 + length
        binary = b""
        if offset + 8 <= len(data):
            blen, bkind = struct.unpack_from("<2I", data, offset)
            if bkind == 0x004E4942:
                binary = data[offset + 8:offset + 8 + blen]
        return doc, binary
    except (struct.error, ValueError, UnicodeDecodeError) as exc:
        raise ModelError(path, f"cannot be read as a GLB ({exc})") from None


def _accessor(path: Path, doc: dict, binary: bytes, index: int) -> np.ndarray:
    """Accessor ``index`` as an array (normalised integers as floats 0..1); sparse accessors and
    external buffers are refused."""
    try:
        acc = doc["accessors"][index]
        view = doc["bufferViews"][acc["bufferView"]]
        if view.get("buffer", 0) != 0 or "sparse" in acc:
            raise ModelError(path, "skinned people must keep their data in the GLB's own buffer")
        dtype = np.dtype(_COMPONENTS[acc["componentType"]])
        width = _WIDTH[acc["type"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        stride = view.get("byteStride", 0) or dtype.itemsize * width
        count = acc["count"]
        raw = np.frombuffer(binary, np.uint8, count=(count - 1) * stride + dtype.itemsize * width if count else 0,
                            offset=start)
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        raise ModelError(path, f"accessor {index} is broken ({exc})") from None
    rows = np.lib.stride_tricks.as_strided(raw, (count, dtype.itemsize * width), (stride, 1))
    arr = np.ascontiguousarray(rows).view(dtype).reshape(count, width)
    if acc.get("normalized"):
        arr = arr.astype(np.float32) / _NORMALISED_MAX[dtype.type]
    return arr


def _node_parents(doc: dict) -> dict[int, int]:
    parents = {}
    for i, node in enumerate(doc.get("nodes", [])):
        for c in node.get("children", []):
            parents[c] = i
    return parents


@functools.lru_cache(maxsize=16)
def read_skin(path: str, up: str, forward: str) -> Skin:
    """The skinned model of a GLB (one skin; every skinned primitive of its meshes), turned to
    O's axes by the file's ``up`` / ``forward``; cached per process (a few files)."""
    p = Path(path)
    if not p.is_file():
        raise ModelError(p, "model file is missing")
    doc, binary = _glb_chunks(p, p.read_bytes())
    skins = doc.get("skins") or []
    if len(skins) != 1:
        raise ModelError(p, f"a posed person needs exactly one skin, the file has {len(skins)}")
    skin = skins[0]
    joints = list(skin["joints"])
    nodes = doc["nodes"]
    names = tuple(str(nodes[j].get("name", f"joint{k}")) for k, j in enumerate(joints))
    node_parent = _node_parents(doc)
    parents = np.array([joints.index(node_parent[j]) if node_parent.get(j) in joints else -1 for j in joints])
    if "inverseBindMatrices" not in skin:
        raise ModelError(p, "the skin has no inverse bind matrices")
    ibm = _accessor(p, doc, binary, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    if len(ibm) != len(joints):
        raise ModelError(p, f"{len(ibm)} inverse bind matrices for {len(joints)} joints")
    axes = axis_matrix(up, forward, p)
    heads = np.linalg.inv(ibm.astype(np.float64))[:, :3, 3] @ axes.T
    mats = doc.get("materials", [])
    parts = []
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            attrs = prim.get("attributes", {})
            if prim.get("mode", 4) != 4 or "JOINTS_0" not in attrs or "WEIGHTS_0" not in attrs:
                continue
            pos = _accessor(p, doc, binary, attrs["POSITION"]).astype(np.float64) @ axes.T
            nrm = _accessor(p, doc, binary, attrs["NORMAL"]).astype(np.float64) @ axes.T if "NORMAL" in attrs \
                else np.zeros_like(pos)
            jnt = _accessor(p, doc, binary, attrs["JOINTS_0"]).astype(np.int64)
            wts = _accessor(p, doc, binary, attrs["WEIGHTS_0"]).astype(np.float32)
            if jnt.max(initial=0) >= len(joints):
                raise ModelError(p, f"JOINTS_0 names joint {jnt.max()}, the skin has {len(joints)}")
            total = wts.sum(1, keepdims=True)
            if (total <= 0).any():
                raise ModelError(p, "a vertex has no skin weight")
            idx = _accessor(p, doc, binary, prim["indices"]).reshape(-1, 3).astype(np.uint32) \
                if "indices" in prim else np.arange(len(pos), dtype=np.uint32).reshape(-1, 3)
            mat = mats[prim["material"]] if "material" in prim else {}
            pbr = mat.get("pbrMetallicRoughness", {})
            parts.append(SkinPart(str(mat.get("name", "")), pos, nrm, jnt, wts / total, idx,
                                  tuple(float(c) for c in pbr.get("baseColorFactor", (1, 1, 1, 1))),
                                  float(pbr.get("metallicFactor", 1.0)), float(pbr.get("roughnessFactor", 1.0))))
    if not parts:
        raise ModelError(p, "has no skinned triangles (JOINTS_0 / WEIGHTS_0)")
    order, seen = [], set()

    def visit(j):
        if j in seen:
            return
        if parents[j] >= 0:
            visit(int(parents[j]))
        seen.add(j)
        order.append(j)

    for j in range(len(joints)):
        visit(j)
    allpos = np.concatenate([q.positions for q in parts])
    return Skin(str(p), names, parents, heads, tuple(parts), tuple(order), allpos.max(0) - allpos.min(0))


# ---------------------------------------------------------------------- posing
def skinning_matrices(skin: Skin, rotations: np.ndarray, root_offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(J, 3, 4) skinning matrices for joint rotations ``rotations`` (J, 3, 3) (module docstring);
    ``root_offset`` moves the roots (O's axes, the file's units)."""
    world = np.empty_like(rotations)
    pos = np.empty((len(skin.names), 3))
    for j in skin.order:
        parent = skin.parents[j]
        if parent < 0:
            world[j] = rotations[j]
            pos[j] = skin.heads[j] + np.asarray(root_offset)
        else:
            world[j] = world[parent] @ rotations[j]
            pos[j] = pos[parent] + world[parent] @ (skin.heads[j] - skin.heads[parent])
    out = np.empty((len(skin.names), 3, 4))
    out[:, :, :3] = world
    out[:, :, 3] = pos - np.einsum("jab,jb->ja", world, skin.heads)
    return out


def blend(part: SkinPart, mats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(positions, normals) of ``part`` under the skinning matrices ``mats`` (J, 3, 4): linear
    blend skinning (normals by the blended linear part, made unit)."""
    m = np.einsum("nk,nkab->nab", part.weights, mats[part.joints])
    pos = np.einsum("nab,nb->na", m[:, :, :3], part.positions) + m[:, :, 3]
    nrm = np.einsum("nab,nb->na", m[:, :, :3], part.normals)
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.where(length > 1e-12, nrm / np.maximum(length, 1e-12), [0.0, 0.0, 1.0])
    return pos, nrm


def pose_skin(skin: Skin, rotations: np.ndarray, root_offset=(0.0, 0.0, 0.0)) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every part's posed (positions, normals), O's axes, the file's units."""
    mats = skinning_matrices(skin, rotations, root_offset)
    return [blend(part, mats) for part in skin.parts]


def to_model(skin: Skin, posed, key: str, height: float, extra: tuple[MeshPart, ...] = ()) -> Model:
    """The posed parts as a :class:`Model` scaled so that the bind pose is ``height`` metres tall,
    the lowest point on z = 0 and the footprint centred; ``extra`` parts (props, in O at the
    same scale as ``posed``) are added."""
    scale = height / float(skin.extents[2])
    parts = []
    for part, (pos, nrm) in zip(skin.parts, posed):
        n = len(pos)
        col = np.tile(np.asarray(part.color, np.float32), (n, 1))
        mat = np.tile(np.array([part.metallic, part.roughness], np.float32), (n, 1))
        parts.append(finish_part(pos, nrm, np.zeros((n, 2)), col, mat, part.indices, None, name=part.name))
    parts.extend(extra)
    allpos = np.concatenate([q.positions for q in parts])
    lo, hi = allpos.min(0), allpos.max(0)
    offset = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]], np.float32)
    out = [MeshPart(((q.positions - offset) * scale).astype(np.float32), q.normals, q.uvs, q.colors, q.material,
                    q.indices, None, name=q.name) for q in parts]
    return Model(key, tuple(out), tuple(float(e * scale) for e in (hi - lo)))
