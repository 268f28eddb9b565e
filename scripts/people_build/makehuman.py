"""MakeHuman's file formats, read with NumPy (written from the formats, no MakeHuman code):

* ``.obj`` meshes (the hm08 base mesh with its groups, proxies' meshes),
* ``.target`` shape targets: lines ``index dx dy dz`` (decimetres, MakeHuman's axes),
* the macro targets' weighting (sex, age, muscle, weight, height, proportions; ``macro.json``),
* the MPFB2 rig (``rig.default.json``: each bone's head from a joint cube, a vertex or a mean of
  vertices) and its skin weights (``weights.*.json``: bone -> [[vertex, weight], ...]),
* ``.mhclo`` proxies (clothes, hair, eyebrows): each vertex a weighted sum of three base-mesh
  vertices plus an offset scaled by the mesh's size; ``delete_verts`` the base vertices it hides.

MakeHuman's axes: x the body's left, y up, z forward (the face looks along +z); 1 unit = 1 dm.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ObjMesh:
    """positions (N, 3); faces: list of vertex index lists; face_groups: group name per face;
    uvs (T, 2) and face_uvs (per face, uv index lists, -1 where none)."""

    positions: np.ndarray
    faces: list
    face_groups: list
    uvs: np.ndarray
    face_uvs: list


def read_obj(text: str) -> ObjMesh:
    pos, uvs, faces, fuv, groups = [], [], [], [], []
    group = ""
    for line in text.splitlines():
        if line.startswith("v "):
            pos.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("vt "):
            uvs.append([float(x) for x in line.split()[1:3]])
        elif line.startswith("g "):
            group = line.split()[1] if len(line.split()) > 1 else ""
        elif line.startswith("f "):
            corners = [c.split("/") for c in line.split()[1:]]
            faces.append([int(c[0]) - 1 for c in corners])
            fuv.append([int(c[1]) - 1 if len(c) > 1 and c[1] else -1 for c in corners])
            groups.append(group)
    return ObjMesh(np.array(pos, np.float64), faces, groups, np.array(uvs, np.float64).reshape(-1, 2), fuv)


def triangles(faces) -> np.ndarray:
    """(M, 3) int64: quads and polygons split into fans."""
    out = []
    for f in faces:
        for k in range(1, len(f) - 1):
            out.append((f[0], f[k], f[k + 1]))
    return np.array(out, np.int64).reshape(-1, 3)


def read_target(text: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(indices (K,), offsets (K, 3)) of a ``.target``; indices checked against ``n`` vertices."""
    rows = [line.split() for line in text.splitlines() if line.strip() and not line.startswith("#")]
    if not rows:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    idx = np.array([int(r[0]) for r in rows], np.int64)
    off = np.array([[float(x) for x in r[1:4]] for r in rows])
    if idx.max() >= n:
        raise ValueError(f"target names vertex {idx.max()}, the mesh has {n}")
    return idx, off


# ---------------------------------------------------------------------- macro targets
#: the ends of the macro variables' parts (macro.json gives them with small margins, e.g. 0.49999)
_PART_ENDS = (0.0, 0.1875, 0.5, 1.0)


def _snap(x: float) -> float:
    return min(_PART_ENDS, key=lambda c: abs(c - x))


def _two_ends(value: float, parts) -> dict[str, float]:
    """Weights of the two ends of the part of a macro variable that ``value`` falls in (a linear
    blend between its ``low`` and ``high`` target; an empty end name is the base mesh)."""
    for part in parts:
        lo, hi = _snap(part["lowest"]), _snap(part["highest"])
        if lo <= value <= hi:
            t = float(np.clip((value - lo) / max(hi - lo, 1e-9), 0.0, 1.0))
            out = {}
            if part["low"]:
                out[part["low"]] = out.get(part["low"], 0.0) + 1.0 - t
            if part["high"]:
                out[part["high"]] = out.get(part["high"], 0.0) + t
            return out
    raise ValueError(f"macro value {value} outside every part")


def macro_targets(macro: dict, values: dict[str, float], races: dict[str, float]) -> list[tuple[str, float]]:
    """(target path under ``targets/macrodetails/``, weight) of a body with macro ``values``
    (gender, age, muscle, weight, height, proportions in 0..1) and race shares ``races``
    (african/asian/caucasian, summing to 1): each combination target's weight is the product of
    its variables' end weights (``macro.json``'s ``combinations``)."""
    ends = {name: _two_ends(values[name], spec["parts"]) for name, spec in macro["macrotargets"].items()
            if name in values}
    out: list[tuple[str, float]] = []

    def combine(names, prefix, folder):
        combos = [((), 1.0)]
        for name in names:
            combos = [(c + (end,), w * we) for c, w in combos for end, we in ends[name].items()]
        for combo, w in combos:
            if w > 1e-6:
                out.append((folder + "-".join(prefix + combo) + ".target.gz", w))

    for race, share in races.items():
        if share > 0:
            for combo, w in [((g, a), wg * wa) for g, wg in ends["gender"].items() for a, wa in ends["age"].items()]:
                if w * share > 1e-6:
                    out.append((f"{race}-{combo[0]}-{combo[1]}.target.gz", w * share))
    combine(["gender", "age", "muscle", "weight"], ("universal",), "")
    if "height" in ends:
        combine(["gender", "age", "muscle", "weight", "height"], (), "height/")
    if "proportions" in ends and values.get("age", 0.5) >= 0.1875:  # no baby proportion targets
        combine(["gender", "age", "muscle", "weight", "proportions"], (), "proportions/")
    return out


# ---------------------------------------------------------------------- skeleton
def vertex_groups(meta: dict) -> dict[str, np.ndarray]:
    """Group name -> vertex indices (``basemesh_vertex_groups.json``: inclusive ranges)."""
    return {name: np.concatenate([np.arange(a, b + 1) for a, b in ranges]) for name, ranges in meta.items()}


def bone_heads(rig: dict, positions: np.ndarray, groups: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each bone's head on the (shaped) mesh ``positions``: the mean of its joint cube, one vertex
    or the mean of vertices (MPFB2's strategies)."""
    heads = {}
    for name, bone in rig.items():
        head = bone["head"]
        strategy = head["strategy"]
        if strategy == "CUBE":
            heads[name] = positions[groups[head["cube_name"]]].mean(0)
        elif strategy == "VERTEX":
            heads[name] = positions[head["vertex_index"]]
        elif strategy == "MEAN":
            heads[name] = positions[head["vertex_indices"]].mean(0)
        else:
            raise ValueError(f"bone {name}: unknown head strategy {strategy!r}")
    return heads


def dense_weights(weights: dict, bones: list[str], n: int) -> np.ndarray:
    """(n, len(bones)) float32 skin weights from ``weights.json``'s bone -> [[vertex, w], ...]."""
    col = {b: i for i, b in enumerate(bones)}
    out = np.zeros((n, len(bones)), np.float32)
    for bone, pairs in weights.items():
        if bone not in col or not pairs:
            continue
        arr = np.asarray(pairs, np.float64)
        out[arr[:, 0].astype(np.int64), col[bone]] += arr[:, 1]
    return out


# ---------------------------------------------------------------------- mhclo proxies
@dataclass(frozen=True)
class Proxy:
    """A ``.mhclo``: ``refs`` (N, 3) base vertices, ``weights`` (N, 3), ``offsets`` (N, 3) per
    vertex; ``scales``: axis -> (vertex a, vertex b, reference length); ``delete``: base vertices
    it hides; ``obj_file``, ``material``, ``z_depth`` as in the file."""

    name: str
    refs: np.ndarray
    weights: np.ndarray
    offsets: np.ndarray
    scales: dict
    delete: np.ndarray
    obj_file: str
    z_depth: int


def read_mhclo(text: str) -> Proxy:
    refs, wts, offs, delete = [], [], [], []
    scales, meta = {}, {}
    section = None
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        key = words[0]
        if key in ("x_scale", "y_scale", "z_scale"):
            scales[key[0]] = (int(words[1]), int(words[2]), float(words[3]))
        elif key == "verts":
            section = "verts"
        elif key == "delete_verts":
            section = "delete"
        elif key in ("name", "obj_file", "material", "z_depth"):
            meta[key] = words[1]
        elif section == "verts" and _numeric(words):
            if len(words) == 1:  # a vertex that follows one base vertex exactly
                refs.append([int(words[0])] * 3)
                wts.append([1.0, 0.0, 0.0])
                offs.append([0.0, 0.0, 0.0])
            else:
                refs.append([int(w) for w in words[:3]])
                wts.append([float(w) for w in words[3:6]])
                offs.append([float(w) for w in words[6:9]])
        elif section == "delete" and _numeric(words, dash=True):
            k = 0
            while k < len(words):
                if k + 2 < len(words) and words[k + 1] == "-":
                    delete.extend(range(int(words[k]), int(words[k + 2]) + 1))
                    k += 3
                else:
                    delete.append(int(words[k]))
                    k += 1
        # other keywords (a "tag" may even follow "verts") leave the section as it is
    return Proxy(meta.get("name", ""), np.array(refs, np.int64), np.array(wts), np.array(offs), scales,
                 np.array(sorted(set(delete)), np.int64), meta.get("obj_file", ""), int(meta.get("z_depth", 50)))


def _numeric(words, dash: bool = False) -> bool:
    for w in words:
        if dash and w == "-":
            continue
        try:
            float(w)
        except ValueError:
            return False
    return True


def fit_proxy(proxy: Proxy, base: np.ndarray) -> np.ndarray:
    """(N, 3) the proxy's vertices on the shaped base mesh ``base``: w . base[refs] + offset,
    each offset component scaled by the mesh's size along that axis now over its reference."""
    scale = np.ones(3)
    for axis, (a, b, ref) in proxy.scales.items():
        i = "xyz".index(axis)
        scale[i] = abs(base[a, i] - base[b, i]) / ref
    return np.einsum("nk,nkd->nd", proxy.weights, base[proxy.refs]) + proxy.offsets * scale


def proxy_weights(proxy: Proxy, base_weights: np.ndarray) -> np.ndarray:
    """(N, J) skin weights of the proxy's vertices: the same combination of its three base
    vertices' weights (negative coefficients clipped), normalised."""
    w = np.clip(proxy.weights, 0.0, None)
    out = np.einsum("nk,nkj->nj", w, base_weights[proxy.refs])
    total = out.sum(1, keepdims=True)
    return np.where(total > 0, out / np.maximum(total, 1e-12), 0.0).astype(np.float32)


def load_json(data: bytes) -> dict:
    return json.loads(data.decode("utf-8"))
