"""Mesh tools of the vehicle build (scripts/build_vehicles.py): reading sources out of a git
directory, a small OBJ reader, meshes as plain arrays, selection by face, transforms, texture
look-ups at face UVs, the glass's winding, number-plate UVs, ray casts and the GLB writer.

Coordinates here are the source's vehicle frame as Chrono uses it (ISO 8855: x forward, y left,
z up, metres); the GLB is written in glTF's (x forward, y up, z right: "up": "+y", "forward": "+x").
"""
from __future__ import annotations

import io
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image


# ------------------------------------------------------------------ sources
def git_read(gitdir: Path, commit: str, path: str) -> bytes:
    """The bytes of ``path`` at ``commit`` of the bare repository ``gitdir`` (a clear error when absent)."""
    try:
        return subprocess.run(["git", f"--git-dir={gitdir}", "cat-file", "blob", f"{commit}:{path}"],
                              check=True, capture_output=True).stdout
    except subprocess.CalledProcessError as exc:
        raise SystemExit(f"{gitdir}: cannot read {commit}:{path} ({exc.stderr.decode().strip()})") from None


def git_image(gitdir: Path, commit: str, path: str, mode: str = "RGB") -> np.ndarray:
    """An image of the repository as float32 in [0, 1], (H, W, C) or (H, W) for mode "L"."""
    return np.asarray(Image.open(io.BytesIO(git_read(gitdir, commit, path))).convert(mode), np.float32) / 255.0


# ------------------------------------------------------------------ meshes
@dataclass
class Mesh:
    """Triangles with per-vertex normals and UVs (OBJ convention: v up, 0 at the image bottom)
    and a per-face group (the source material, then the class it is given)."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    normals: np.ndarray  # (N, 3)
    uvs: np.ndarray  # (N, 2)
    groups: np.ndarray = field(default=None)  # (M,) object: a name per face

    def __post_init__(self):
        if self.groups is None:
            self.groups = np.full(len(self.faces), "", object)

    def select(self, mask: np.ndarray) -> "Mesh":
        """The faces where ``mask`` (M,) is true, with only the vertices they use."""
        faces = self.faces[mask]
        used, inverse = np.unique(faces.ravel(), return_inverse=True)
        return Mesh(self.vertices[used], inverse.reshape(-1, 3), self.normals[used], self.uvs[used],
                    self.groups[mask])

    def transformed(self, rot: np.ndarray, offset=(0.0, 0.0, 0.0)) -> "Mesh":
        """Rotated by ``rot`` (3, 3; a mirror flips the winding back) and moved by ``offset``."""
        faces = self.faces if np.linalg.det(rot) > 0 else self.faces[:, ::-1]
        return Mesh(self.vertices @ rot.T + np.asarray(offset, float), faces.copy(), self.normals @ rot.T,
                    self.uvs.copy(), self.groups.copy())

    def face_normals(self) -> np.ndarray:
        """Unit normals from the winding (counter-clockwise seen from the front)."""
        tri = self.vertices[self.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)

    def face_areas(self) -> np.ndarray:
        tri = self.vertices[self.faces]
        return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)

    def centroids(self) -> np.ndarray:
        return self.vertices[self.faces].mean(axis=1)

    def face_uvs(self) -> np.ndarray:
        """(M, 2) UV at each face's centroid."""
        return self.uvs[self.faces].mean(axis=1)


def concat(meshes: list[Mesh]) -> Mesh:
    meshes = [m for m in meshes if len(m.faces)]
    if not meshes:
        return Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)), np.zeros((0, 2)))
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(np.concatenate([m.vertices for m in meshes]),
                np.concatenate([m.faces + o for m, o in zip(meshes, offsets)]),
                np.concatenate([m.normals for m in meshes]), np.concatenate([m.uvs for m in meshes]),
                np.concatenate([m.groups for m in meshes]))


def read_obj(data: bytes) -> Mesh:
    """A Wavefront OBJ's triangles (polygons fanned), one vertex per distinct (v, vt, vn) corner;
    each face's group is its ``usemtl`` material. Missing normals are made smooth from the faces."""
    pos, tex, nrm = [], [], []
    corners, mats = [], []
    material = ""
    for raw in data.decode("utf-8", "replace").splitlines():
        parts = raw.split()
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            pos.append([float(c) for c in parts[1:4]])
        elif key == "vt":
            tex.append([float(c) for c in parts[1:3]])
        elif key == "vn":
            nrm.append([float(c) for c in parts[1:4]])
        elif key == "usemtl":
            material = parts[1] if len(parts) > 1 else ""
        elif key == "f":
            idx = []
            for c in parts[1:]:
                f = (c.split("/") + ["", ""])[:3]
                idx.append([int(f[0]) if f[0] else 0, int(f[1]) if f[1] else 0, int(f[2]) if f[2] else 0])
            for k in range(1, len(idx) - 1):
                corners.append([idx[0], idx[k], idx[k + 1]])
                mats.append(material)
    pos, tex, nrm = np.asarray(pos, float), np.asarray(tex, float).reshape(-1, 2), np.asarray(nrm, float).reshape(-1, 3)
    c = np.asarray(corners, np.int64).reshape(-1, 3)  # (3M, 3): v, vt, vn (1-based, negative relative)
    for col, count in ((0, len(pos)), (1, len(tex)), (2, len(nrm))):
        neg = c[:, col] < 0
        c[neg, col] += count + 1
    keys, inverse = np.unique(c, axis=0, return_inverse=True)
    faces = inverse.reshape(-1, 3)
    vertices = pos[keys[:, 0] - 1]
    uvs = tex[keys[:, 1] - 1] if len(tex) and (keys[:, 1] > 0).all() else np.zeros((len(keys), 2))
    mesh = Mesh(vertices, faces, np.zeros_like(vertices), uvs, np.asarray(mats, object))
    if len(nrm) and (keys[:, 2] > 0).all():
        n = nrm[keys[:, 2] - 1]
        mesh.normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    else:
        mesh.normals = smooth_normals(mesh)
    return mesh


def smooth_normals(mesh: Mesh) -> np.ndarray:
    """Per-vertex normals: the area-weighted face normals around each position (welded by position)."""
    _, weld = np.unique(np.round(mesh.vertices, 6), axis=0, return_inverse=True)
    weld = weld.ravel()
    tri = mesh.vertices[mesh.faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    acc = np.zeros((weld.max() + 1, 3))
    np.add.at(acc, weld[mesh.faces].ravel(), np.repeat(fn, 3, axis=0))
    n = acc[weld]
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def crease_normals(mesh: Mesh, angle_deg: float = 35.0) -> Mesh:
    """The mesh with normals made again: at each corner, the area-weighted normals of the faces
    around its position that turn less than ``angle_deg`` from its own face (smooth panels, sharp
    creases). Corners are split where their normals differ."""
    _, weld = np.unique(np.round(mesh.vertices, 6), axis=0, return_inverse=True)
    weld = weld.ravel()
    tri = mesh.vertices[mesh.faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # length: twice the area
    unit = fn / np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-12)
    corner_face = np.repeat(np.arange(len(mesh.faces)), 3)
    corner_pos = weld[mesh.faces].ravel()
    # every (corner, face around its position) pair
    order = np.argsort(corner_pos, kind="stable")
    starts = np.searchsorted(corner_pos[order], np.arange(weld.max() + 2))
    counts = starts[1:] - starts[:-1]
    reps = counts[corner_pos]
    corner_idx = np.repeat(np.arange(len(corner_pos)), reps)
    offs = np.arange(len(corner_idx)) - np.repeat(np.cumsum(reps) - reps, reps)
    other = corner_face[order[starts[corner_pos[corner_idx]] + offs]]
    keep = np.einsum("ij,ij->i", unit[corner_face[corner_idx]], unit[other]) > np.cos(np.radians(angle_deg))
    acc = np.zeros((len(corner_pos), 3))
    np.add.at(acc, corner_idx[keep], fn[other[keep]])
    normals = acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-12)
    corners = mesh.faces.ravel()
    key = np.concatenate([mesh.vertices[corners], mesh.uvs[corners], np.round(normals, 4)], axis=1)
    uniq, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return Mesh(mesh.vertices[corners[first]], inverse.reshape(-1, 3), normals[first], mesh.uvs[corners[first]],
                mesh.groups.copy())


def decimate(mesh: Mesh, faces: int) -> Mesh:
    """An untextured mesh reduced to about ``faces`` triangles by quadric edge collapse
    (fast-simplification, a build-time dependency only), normals made again (35 degree creases)."""
    if len(mesh.faces) <= faces:
        return mesh
    import fast_simplification

    points, weld = np.unique(np.round(mesh.vertices, 6), axis=0, return_inverse=True)
    tris = weld.ravel()[mesh.faces]
    out_pts, out_tris = fast_simplification.simplify(points, tris, target_reduction=1.0 - faces / len(tris))
    reduced = Mesh(np.asarray(out_pts, float), np.asarray(out_tris, np.int64), np.zeros_like(out_pts),
                   np.zeros((len(out_pts), 2)), np.full(len(out_tris), mesh.groups[0] if len(mesh.groups) else "", object))
    return crease_normals(reduced)


# ------------------------------------------------------------------ textures at faces
def sample(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``image`` (H, W[, C]) at OBJ UVs (v up; wrapped), nearest texel."""
    h, w = image.shape[:2]
    u = np.mod(uv[:, 0], 1.0)
    v = np.mod(uv[:, 1], 1.0)
    x = np.clip((u * w).astype(int), 0, w - 1)
    y = np.clip(((1.0 - v) * h).astype(int), 0, h - 1)
    return image[y, x]


def face_samples(image: np.ndarray, mesh: Mesh) -> np.ndarray:
    """``image`` at each face: the texel at its centroid's UV (OBJ atlases paint each region of a
    part in one flat colour, so the centroid names it)."""
    return sample(image, mesh.face_uvs())


def corner_samples(image: np.ndarray, mesh: Mesh, inset: float = 0.25) -> np.ndarray:
    """``image`` near each face's corners (moved ``inset`` of the way to its centroid): (M, 3, ...).
    A face that straddles the edge of a region (a pane's border) is found by any of them."""
    uv = mesh.uvs[mesh.faces]  # (M, 3, 2)
    uv = uv + inset * (uv.mean(axis=1, keepdims=True) - uv)
    return sample(image, uv.reshape(-1, 2)).reshape(len(mesh.faces), 3, *image.shape[2:])


# ------------------------------------------------------------------ glass and plates
def wind_outwards(mesh: Mesh, centre) -> Mesh:
    """Each face wound (and its vertex normals turned) to face away from ``centre``: the renderer
    draws the panes facing away from the camera first (docs/vehicles.md)."""
    out = Mesh(mesh.vertices.copy(), mesh.faces.copy(), mesh.normals.copy(), mesh.uvs.copy(), mesh.groups.copy())
    inward = np.einsum("ij,ij->i", out.face_normals(), out.centroids() - np.asarray(centre, float)) < 0
    out.faces[inward] = out.faces[inward][:, ::-1]
    # the vertex normals follow their faces (a vertex of an inward face only)
    flip = np.zeros(len(out.vertices), bool)
    flip[out.faces[inward].ravel()] = True
    keep = np.zeros(len(out.vertices), bool)
    keep[out.faces[~inward].ravel()] = True
    flip &= ~keep
    out.normals[flip] *= -1
    return out


def plate_uvs(mesh: Mesh) -> Mesh:
    """UVs spanning [0, 1] over the plate face ``mesh`` (one plate): u from the left to the right
    as a viewer in front of it sees it, v from the bottom (0) to the top (1), OBJ convention."""
    areas = mesh.face_areas()
    n = (mesh.face_normals() * areas[:, None]).sum(axis=0)
    n /= np.linalg.norm(n)
    up = np.array([0.0, 0.0, 1.0])
    right = np.cross(up, n)
    right /= np.linalg.norm(right)
    top = np.cross(n, right)
    p = mesh.vertices
    u, v = p @ right, p @ top
    out = Mesh(p.copy(), mesh.faces.copy(), mesh.normals.copy(), np.zeros((len(p), 2)), mesh.groups.copy())
    out.uvs[:, 0] = (u - u.min()) / max(np.ptp(u), 1e-9)
    out.uvs[:, 1] = (v - v.min()) / max(np.ptp(v), 1e-9)
    return out


def plate_quad(centre, normal, width: float = 0.52, height: float = 0.11) -> Mesh:
    """A number plate (a quad with UVs over it) at ``centre`` facing ``normal`` (horizontal)."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    right = np.cross([0.0, 0.0, 1.0], n)
    right /= np.linalg.norm(right)
    top = np.array([0.0, 0.0, 1.0])
    c = np.asarray(centre, float)
    corners = [c + sx * width / 2 * right + sy * height / 2 * top for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    return Mesh(np.asarray(corners), np.array([[0, 1, 2], [0, 2, 3]]), np.tile(n, (4, 1)), uvs,
                np.full(2, "plate", object))


def ray_hits(mesh: Mesh, origin, direction) -> np.ndarray:
    """Distances along the ray (origin, unit direction) to every face it crosses (Moller-Trumbore)."""
    o, d = np.asarray(origin, float), np.asarray(direction, float)
    tri = mesh.vertices[mesh.faces]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - tri[:, 0]
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.sort(t[hit])


# ------------------------------------------------------------------ boxes
def in_box(points: np.ndarray, lo, hi) -> np.ndarray:
    return np.all((points >= np.asarray(lo, float)) & (points <= np.asarray(hi, float)), axis=1)
