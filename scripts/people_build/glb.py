"""A skinned glTF 2.0 binary (GLB) written with NumPy: one mesh of one primitive per material
(POSITION, NORMAL, JOINTS_0 as unsigned short, WEIGHTS_0 as normalised unsigned byte, indices),
one skin whose joints are nodes in a hierarchy with the rest pose's translations (no rotation:
every joint's frame is parallel to the model's), inverse bind matrices, flat PBR materials."""
from __future__ import annotations

import json
import struct

import numpy as np

from .body import Body

_ARRAY, _ELEMENTS = 34962, 34963
_FLOAT, _UBYTE, _USHORT, _UINT = 5126, 5121, 5123, 5125


class _Buffer:
    def __init__(self) -> None:
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, kind: str, component: int, target: int | None = None,
            normalized: bool = False, minmax: bool = False) -> int:
        while len(self.data) % 4:
            self.data.append(0)
        raw = np.ascontiguousarray(array).tobytes()
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        self.views.append(view)
        self.data += raw
        acc = {"bufferView": len(self.views) - 1, "componentType": component, "count": int(len(array)), "type": kind}
        if normalized:
            acc["normalized"] = True
        if minmax:
            acc["min"] = [float(v) for v in np.min(array, 0)]
            acc["max"] = [float(v) for v in np.max(array, 0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _u8_weights(w: np.ndarray) -> np.ndarray:
    """(N, 4) uint8 weights summing to exactly 255 per vertex (glTF: normalised sums of 1)."""
    q = np.floor(w * 255.0).astype(np.int64)
    rest = 255 - q.sum(1)
    frac = w * 255.0 - q
    order = np.argsort(-frac, axis=1)
    for k in range(4):
        add = rest > k
        q[np.arange(len(q))[add], order[add, k]] += 1
    return q.astype(np.uint8)


def write_glb(body: Body, materials: dict[str, dict], name: str, extras: dict) -> bytes:
    """The GLB bytes. ``materials``: name -> {"rgb": linear base colour, "roughness", "metallic"}
    for every part's material (:class:`~.body.Part`)."""
    buf = _Buffer()
    sk = body.skeleton
    prims = []
    for part in body.parts:
        attrs = {
            "POSITION": buf.add(part.positions.astype(np.float32), "VEC3", _FLOAT, _ARRAY, minmax=True),
            "NORMAL": buf.add(part.normals.astype(np.float32), "VEC3", _FLOAT, _ARRAY),
            "JOINTS_0": buf.add(part.joints.astype(np.uint16), "VEC4", _USHORT, _ARRAY),
            "WEIGHTS_0": buf.add(_u8_weights(part.weights), "VEC4", _UBYTE, _ARRAY, normalized=True),
        }
        small = len(part.positions) < 65536
        idx = part.indices.reshape(-1).astype(np.uint16 if small else np.uint32)
        prims.append({"attributes": attrs, "indices": buf.add(idx, "SCALAR", _USHORT if small else _UINT, _ELEMENTS),
                      "material": list(materials).index(part.material), "mode": 4})
    ibm = np.zeros((len(sk.names), 4, 4), np.float32)
    ibm[:] = np.eye(4, dtype=np.float32)
    ibm[:, :3, 3] = -sk.heads
    ibm_acc = buf.add(ibm.transpose(0, 2, 1).reshape(-1, 16), "MAT4", _FLOAT)  # column-major
    nodes = [{"name": name, "mesh": 0, "skin": 0}]
    joint_nodes = []
    for j, jname in enumerate(sk.names):
        parent = sk.parents[j]
        t = sk.heads[j] - (sk.heads[parent] if parent >= 0 else 0.0)
        joint_nodes.append(len(nodes))
        nodes.append({"name": jname, "translation": [float(v) for v in t]})
    for j, parent in enumerate(sk.parents):
        if parent >= 0:
            nodes[joint_nodes[parent]].setdefault("children", []).append(joint_nodes[j])
    roots = [joint_nodes[j] for j, p in enumerate(sk.parents) if p < 0]
    doc = {
        "asset": {"version": "2.0", "generator": "synthcompose scripts/build_people.py"},
        "scene": 0,
        "scenes": [{"nodes": [0] + roots}],
        "nodes": nodes,
        "meshes": [{"name": name, "primitives": prims}],
        "skins": [{"joints": joint_nodes, "inverseBindMatrices": ibm_acc, "skeleton": roots[0]}],
        "materials": [{"name": m, "doubleSided": m in ("hair", "eyebrows"),
                       "pbrMetallicRoughness": {"baseColorFactor": [*[round(float(c), 4) for c in spec["rgb"]], 1.0],
                                                "metallicFactor": float(spec.get("metallic", 0.0)),
                                                "roughnessFactor": float(spec.get("roughness", 0.8))}}
                      for m, spec in materials.items()],
        "accessors": buf.accessors,
        "bufferViews": buf.views,
        "buffers": [{"byteLength": len(buf.data)}],
        "extras": extras,
    }
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    data = bytes(buf.data) + b"\0" * (-len(buf.data) % 4)
    total = 12 + 8 + len(text) + 8 + len(data)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
            + struct.pack("<II", len(data), 0x004E4942) + data)
