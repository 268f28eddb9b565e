"""A reader of jMonkeyEngine's binary model format (``.j3o``), enough for the meshes of a model:
its geometries' positions, normals, UVs and triangles with their material's name and base colour
map. Written from the format's description (a class table of aliased field names and types,
a table of object locations, then each object's fields, ints stored as a length byte and their
significant big-endian bytes, buffers little-endian); only what the build needs.

``read_j3o(data) -> list[J3OGeometry]`` walks the scene graph from its root, applying each node's
transform (translation, rotation quaternion, scale).
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

# field types of the format (the ones a model's meshes, materials and nodes use)
_BYTE, _BYTE_1D, _INT, _INT_1D, _INT_2D = 0, 1, 10, 11, 12
_FLOAT, _FLOAT_1D, _FLOAT_2D, _DOUBLE, _LONG = 20, 21, 22, 30, 40
_SHORT, _SHORT_1D, _BOOL, _BOOL_1D = 50, 51, 60, 61
_STRING, _STRING_1D, _BITSET = 70, 71, 80
_SAVABLE, _SAVABLE_1D, _SAVABLE_2D = 90, 91, 92
_LIST, _LIST_1D, _MAP, _STRING_MAP, _INT_MAP = 100, 101, 105, 106, 107
_FLOATBUFS, _BYTEBUFS, _FLOATBUF, _INTBUF, _BYTEBUF, _SHORTBUF = 110, 111, 120, 121, 122, 123


@dataclass(frozen=True)
class J3OGeometry:
    name: str
    material: str
    base_color_map: str | None
    base_color: tuple[float, float, float, float]
    positions: np.ndarray  # (N, 3)
    normals: np.ndarray  # (N, 3)
    uvs: np.ndarray  # (N, 2)
    triangles: np.ndarray  # (M, 3)


class _Reader:
    def __init__(self, data: bytes) -> None:
        if data[:4] != b"JME3":
            raise ValueError("not a j3o file (no JME3 signature)")
        self.d = data
        version = self._be(4)
        count = self._be(8)
        self.alias_width = int(math.log(count, 256)) + 1
        o = 12
        self.classes: dict[bytes, tuple[str, dict[int, tuple[int, str]]]] = {}
        for _ in range(count):
            alias = data[o:o + self.alias_width]
            o += self.alias_width
            if version >= 1:  # the class hierarchy's versions
                o += 1 + 4 * data[o]
            n = self._be(o)
            name = data[o + 4:o + 4 + n].decode()
            o += 4 + n
            fields = {}
            n_fields = self._be(o)
            o += 4
            for _ in range(n_fields):
                alias_f, kind = data[o], struct.unpack_from("b", data, o + 1)[0]
                n = self._be(o + 2)
                fields[alias_f] = (kind, data[o + 6:o + 6 + n].decode())
                o += 6 + n
            self.classes[alias] = (name, fields)
        self.locations = {}
        for i in range(self._be(o)):
            self.locations[self._be(o + 4 + 8 * i)] = self._be(o + 8 + 8 * i)
        o += 4 + 8 * len(self.locations)
        self.root = self._be(o + 4)
        self.base = o + 8
        self.i = 0
        self.cache: dict[int, dict] = {}

    def _be(self, o: int) -> int:
        return struct.unpack_from(">i", self.d, o)[0]

    def object(self, oid: int) -> dict:
        if oid not in self.cache:
            o = self.base + self.locations[oid]
            name, fields = self.classes[self.d[o:o + self.alias_width]]
            o += self.alias_width
            end = o + 4 + self._be(o)
            self.i = o + 4
            out: dict = {"_class": name}
            while self.i < end:
                alias = self.d[self.i]
                self.i += 1
                kind, field_name = fields[alias]
                out[field_name] = self._value(kind)
            self.cache[oid] = out
        return self.cache[oid]

    def ref(self, value) -> dict | None:
        return self.object(value[1]) if value else None

    def _int(self) -> int:
        first = struct.unpack_from("b", self.d, self.i)[0]
        if first in (-1, -2):  # null, default
            self.i += 1
            return first
        n = self.d[self.i]
        value = int.from_bytes(self.d[self.i + 1:self.i + 1 + n], "big") if n else 0
        if n == 4 and value >= 2 ** 31:
            value -= 2 ** 32
        self.i += 1 + n
        return value

    def _array(self, item):
        n = self._int()
        return None if n == -1 else [item() for _ in range(n)]

    def _buffer(self, dtype: str):
        n = self._int()
        if n == -1:
            return None
        a = np.frombuffer(self.d, dtype=dtype, count=n, offset=self.i).copy()
        self.i += a.nbytes
        return a

    def _fixed(self, fmt: str):
        value = struct.unpack_from(fmt, self.d, self.i)[0]
        self.i += struct.calcsize(fmt)
        return value

    def _value(self, kind: int):
        simple = {_BYTE: lambda: self._fixed("B"), _INT: self._int, _FLOAT: lambda: self._fixed(">f"),
                  _DOUBLE: lambda: self._fixed(">d"), _SHORT: lambda: self._fixed(">h"),
                  _BOOL: lambda: self._fixed("?"), _LONG: self._long, _STRING: self._string,
                  _SAVABLE: self._savable, _FLOATBUF: lambda: self._buffer("<f4"),
                  _INTBUF: lambda: self._buffer("<i4"), _BYTEBUF: lambda: self._buffer("u1"),
                  _SHORTBUF: lambda: self._buffer("<i2")}
        if kind in simple:
            return simple[kind]()
        arrays = {_BYTE_1D: _BYTE, _INT_1D: _INT, _INT_2D: _INT_1D, _FLOAT_1D: _FLOAT, _FLOAT_2D: _FLOAT_1D,
                  _SHORT_1D: _SHORT, _BOOL_1D: _BOOL, _BITSET: _BOOL, _STRING_1D: _STRING, _SAVABLE_1D: _SAVABLE,
                  _LIST: _SAVABLE, _SAVABLE_2D: _SAVABLE_1D, _LIST_1D: _SAVABLE_1D, _MAP: _SAVABLE_1D,
                  _FLOATBUFS: _FLOATBUF, _BYTEBUFS: _BYTEBUF}
        if kind in arrays:
            return self._array(lambda: self._value(arrays[kind]))
        if kind in (_STRING_MAP, _INT_MAP):
            if self._int() == -1:
                return None
            keys = self._value(_STRING_1D if kind == _STRING_MAP else _INT_1D)
            return dict(zip(keys, self._value(_SAVABLE_1D)))
        raise ValueError(f"j3o: field type {kind} not supported")

    def _long(self) -> int:
        n = self.d[self.i]
        value = int.from_bytes(self.d[self.i + 1:self.i + 1 + n], "big")
        self.i += 1 + n
        return value

    def _string(self):
        n = self._int()
        if n == -1:
            return None
        s = self.d[self.i:self.i + n].decode("utf-8", "replace")
        self.i += n
        return s

    def _savable(self):
        v = self._int()
        return None if v == -1 else ("ref", v)


def _quat_matrix(q: dict | None) -> np.ndarray:
    if not q:
        return np.eye(3)
    x, y, z, w = (q.get(k, 0.0 if k != "w" else 1.0) for k in "xyzw")
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def read_j3o(data: bytes) -> list[J3OGeometry]:
    """Every geometry of the model in the root's frame."""
    r = _Reader(data)
    out: list[J3OGeometry] = []

    def vec(v, default):
        o = r.ref(v)
        return np.array([o.get(k, default) for k in "xyz"]) if o else np.full(3, default, float)

    def walk(node: dict, rot: np.ndarray, offset: np.ndarray, scale: np.ndarray) -> None:
        t = r.ref(node.get("transform"))
        if t:
            local_rot = _quat_matrix(r.ref(t.get("rot")))
            local_t, local_s = vec(t.get("translation"), 0.0), vec(t.get("scale"), 1.0)
            offset = offset + rot @ (scale * local_t)
            rot = rot @ local_rot
            scale = scale * local_s
        if node["_class"].endswith(".Geometry"):
            mesh, mat = r.ref(node["mesh"]), r.ref(node["material"])
            buffers = {}
            for ref in (mesh.get("buffers") or {}).values():
                b = r.object(ref[1])
                data = b.get("dataFloat") if b.get("dataFloat") is not None else b.get("dataUnsignedInt")
                if data is None:
                    data = b.get("dataUnsignedShort", b.get("dataShort"))
                buffers[b["buffer_type"]] = np.asarray(data).reshape(-1, b["components"])
            params = {}
            for ref in (mat.get("parameters") or {}).values():
                p = r.object(ref[1])
                if "texture" in p:
                    tex = r.ref(p["texture"])
                    key = r.ref(tex.get("key")) if tex else None
                    params[p["name"]] = key.get("name") if key else None
                else:
                    params[p["name"]] = r.ref(p.get("value_savable"))
            colour = params.get("BaseColor") or {}
            pos = buffers["Position"] * scale @ rot.T + offset
            nrm = buffers.get("Normal", np.zeros_like(pos)) @ rot.T
            out.append(J3OGeometry(node.get("name", ""), mat.get("name", ""), params.get("BaseColorMap"),
                                   tuple(float(colour.get(k, 1.0 if k == "a" else 0.0)) for k in "rgba"),
                                   pos, nrm, buffers.get("TexCoord", np.zeros((len(pos), 2))),
                                   buffers["Index"].reshape(-1, 3).astype(np.int64)))
        for child in node.get("children") or []:
            walk(r.object(child[1]), rot, offset, scale)

    walk(r.object(r.root), np.eye(3), np.zeros(3), np.ones(3))
    return out
