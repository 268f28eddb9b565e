"""The preview's objects as geometry, and the PLY export of a view.

:func:`box_mesh` and :func:`plane_quad` give an object's oriented box and its fitted ground plane in
the vehicle frame (the window's 3D view draws them as lines, :data:`BOX_EDGES`); :func:`export_ply`
writes the scene's point cloud with them as one PLY file, with trimesh's exporter (trimesh is
imported only when a PLY is written).
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .session import View

BOX_RGB, PLANE_RGB = (255, 0, 0), (0, 200, 0)  # in the PLY


def box_mesh(m: np.ndarray, extents) -> tuple[np.ndarray, np.ndarray]:
    """(8, 3) corners (V) and (12, 3) triangles of an object's oriented box."""
    l, w, h = extents
    local = np.array([[sx * l / 2, sy * w / 2, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, h)])
    # corner index = 4*ix + 2*iy + iz
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], np.int32)
    return local @ m[:3, :3].T + m[:3, 3], tris


BOX_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]


def plane_quad(m: np.ndarray, extents, margin: float = 1.0) -> np.ndarray:
    """(4, 3) corners (V) of the object's fitted ground plane, ``margin`` beyond its footprint."""
    l, w, _ = extents
    hx, hy = l / 2 + margin, w / 2 + margin
    local = np.array([[-hx, -hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0], [-hx, hy, 0.0]])
    return local @ m[:3, :3].T + m[:3, 3]


def export_ply(path: str | Path, view: View, colours: np.ndarray) -> dict[str, int]:
    """Binary PLY (vehicle frame, metres; trimesh's exporter, float32 positions, RGBA uchar colours):
    every cloud point with its colour, then per object its box (8 red vertices, 12 triangles) and its
    ground plane (4 green vertices, 2 triangles). Loads in trimesh (``process=False`` keeps the
    unreferenced cloud points) and MeshLab.

    The cloud is a ``trimesh.PointCloud``; trimesh's PLY export of a Scene, like
    ``trimesh.util.concatenate``, keeps only the meshes, so the cloud goes in as a mesh without
    faces, concatenated before the objects' meshes."""
    import trimesh

    cloud = trimesh.PointCloud(np.asarray(view.frame.cloud.vehicle, np.float64), colors=np.asarray(colours, np.uint8))
    parts = []
    if len(cloud.vertices):  # (an empty cloud would take the others' colours away)
        parts.append(trimesh.Trimesh(cloud.vertices, np.empty((0, 3), np.int64), vertex_colors=cloud.colors,
                                     process=False))
    for o in view.objects:
        m = o.placement.matrix
        corners, tris = box_mesh(m, o.extents)
        parts += [trimesh.Trimesh(corners, tris, vertex_colors=np.tile(BOX_RGB, (8, 1)), process=False),
                  trimesh.Trimesh(plane_quad(m, o.extents), [[0, 1, 2], [0, 2, 3]],
                                  vertex_colors=np.tile(PLANE_RGB, (4, 1)), process=False)]
    mesh = trimesh.util.concatenate(parts)
    data = trimesh.exchange.ply.export_ply(mesh, encoding="binary", vertex_normal=False)
    # our comments after the format line (the header is ASCII; the binary body is left as it is)
    magic, fmt, rest = data.split(b"\n", 2)
    comments = (f"comment synthcompose preview: {view.ident.key}, vehicle frame (ISO 8855), metres\n"
                f"comment {len(cloud.vertices)} scene points, then per object 8 box corners and 4 ground-plane "
                "corners\n").encode("ascii")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\n".join((magic, fmt, comments + rest)))
    return {"points": len(cloud.vertices), "objects": len(view.objects), "vertices": len(mesh.vertices),
            "faces": len(mesh.faces)}
