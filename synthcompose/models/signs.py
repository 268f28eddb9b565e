"""German traffic signs built in code: plates of the StVO shapes and sizes with their faces on a
grey galvanised pole (:func:`sign_model`).

A plate's outline is the convex hull of its face texture's opaque pixels (a circle, the stop
octagon, a triangle or diamond with rounded corners, a rectangle: every German sign plate is
convex), at the real size the catalogue entry gives (VwV-StVO size 2). The face is
retroreflective sheeting: fairly matte, a little gloss; its white is kept below paper white
(:data:`FACE_ALBEDO`). The plate's folded rim and its back are painted grey (RAL 7043, as the
VwV-StVO asks: grey backs), the pole is a 76 mm galvanised steel tube, the plates held on it
by two clamps each; the pole and clamps are labelled "pole" (:attr:`MeshPart.label`), as
Cityscapes labels them. Supplementary signs hang under the main one; the lowest plate's lower
edge is ``lower_edge_m`` above the ground (VwV-StVO: 2.0 m over a footway, 2.25 m over a cycle
path, as a rule).

Frame O (:mod:`.mesh`): the faces look along +x, the pole stands at the footprint's back.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from synthcompose.colour import srgb_to_linear
from synthcompose.errors import ModelError

from .mesh import MeshPart, Model, finish_part

#: the pole's radius: 76 mm tube (Rohrpfosten)
POLE_RADIUS = 0.038
#: the plate's depth: its rim folded back (Randform), metres
PLATE_DEPTH = 0.02
#: from the pole's surface to the plate's back: the clamp and the plate's rails, metres
STANDOFF = 0.03
#: between two plates on one pole, metres
PLATE_GAP = 0.04
#: the pole ends this share of the top plate's height above that plate's centre (behind it)
POLE_TOP = 0.3
#: the face's colour factor (linear): retroreflective white sheeting reflects 0.27-0.5 of
#: daylight diffusely (EN 12899-1 asks at least 0.27 of class RA2's white, 0.35 of RA1's; a
#: sign's face gathers dirt), so that the face's white sits among the real signs' whites
#: (measured against the footway's tone on the development frames: docs/cast.md)
FACE_ALBEDO = 0.45
FACE_MATERIAL = (0.0, 0.45)
#: the back and rim (RAL 7043 traffic grey B) and the galvanised pole and clamps: sRGB, (metallic, roughness)
BACK_SRGB, BACK_MATERIAL = (0.31, 0.33, 0.32), (0.0, 0.6)
POLE_SRGB, POLE_MATERIAL = (0.45, 0.46, 0.46), (0.3, 0.55)
#: Cityscapes labels a sign's plate "traffic sign" and the pole that carries it "pole"
POLE_LABEL = "pole"


@dataclass(frozen=True)
class Plate:
    """One sign plate: its code, its face texture (PNG path) and its real size in metres."""

    code: str
    face: str
    width_m: float
    height_m: float


@functools.lru_cache(maxsize=64)
def _face(path: str) -> tuple[np.ndarray, np.ndarray]:
    """The face texture (H, W, 4) uint8 and its outline: the convex hull of the opaque pixels,
    (N, 2) texture coordinates (u right, v down, 0..1), counter-clockwise as seen from the front."""
    import cv2
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            tex = np.ascontiguousarray(np.asarray(img.convert("RGBA"), np.uint8))
    except (OSError, UnidentifiedImageError) as exc:
        raise ModelError(path, f"sign face cannot be read as an image ({exc})") from None
    h, w = tex.shape[:2]
    opaque = (tex[..., 3] >= 128).astype(np.uint8)
    contours, _ = cv2.findContours(opaque, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if opaque.sum() < 16 or not contours:
        raise ModelError(path, "sign face has no opaque shape (alpha channel)")
    # the outer pixels' corners: the hull of the shape, not of the pixel centres
    edge = np.concatenate(contours)[:, 0, :]
    pts = np.concatenate([edge + [dx, dy] for dx in (0, 1) for dy in (0, 1)])
    hull = cv2.convexHull(pts.astype(np.float32))
    hull = cv2.approxPolyDP(hull, 0.35, True)[:, 0, :].astype(np.float64)
    uv = hull / [w, h]
    # seen from the front u grows to the viewer's right (+y of O) and v downwards (-z): a
    # polygon counter-clockwise in (u, -v) is counter-clockwise from the front
    area = 0.5 * np.sum(uv[:, 0] * np.roll(-uv[:, 1], -1) - np.roll(uv[:, 0], -1) * -uv[:, 1])
    return tex, (uv if area > 0 else uv[::-1]).copy()


def _uniform(n: int, srgb, material) -> tuple[np.ndarray, np.ndarray]:
    col = np.tile(np.append(srgb_to_linear(np.asarray(srgb, np.float32)), 1.0), (n, 1)).astype(np.float32)
    return col, np.tile(np.asarray(material, np.float32), (n, 1))


def _plate_parts(plate: Plate, centre_z: float, front_x: float) -> list[MeshPart]:
    """The face (textured), and the back with the rim (grey) of one plate centred at
    (front_x, 0, centre_z), its face looking along +x."""
    tex, uv = _face(plate.face)
    y = (uv[:, 0] - 0.5) * plate.width_m
    z = centre_z + (0.5 - uv[:, 1]) * plate.height_m
    n = len(uv)
    fan = np.array([[0, i, i + 1] for i in range(1, n - 1)], np.uint32)
    front = np.column_stack([np.full(n, front_x), y, z])
    back = front - [PLATE_DEPTH, 0.0, 0.0]
    col, mat = _uniform(n, (1.0, 1.0, 1.0), FACE_MATERIAL)
    col[:, :3] = FACE_ALBEDO
    face = finish_part(front, np.tile([1.0, 0.0, 0.0], (n, 1)), uv, col, mat, fan, tex)
    # rim: one quad per outline edge, flat shaded (its own four corners), normal outwards
    a, b = np.arange(n), (np.arange(n) + 1) % n
    quads = np.stack([front[a], front[b], back[b], back[a]], axis=1)  # (n, 4, 3)
    edge = front[b] - front[a]
    out = np.cross(edge, [1.0, 0.0, 0.0])  # outwards for a counter-clockwise outline
    out /= np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-12)
    rim_pos = np.concatenate([quads.reshape(-1, 3), back])
    rim_nrm = np.concatenate([np.repeat(out, 4, axis=0), np.tile([-1.0, 0.0, 0.0], (n, 1))])
    k = 4 * np.arange(n)[:, None]
    rim_tri = np.concatenate([np.concatenate([k + [0, 2, 1], k + [0, 3, 2]]),
                              4 * n + fan[:, [0, 2, 1]]]).astype(np.uint32)  # the back faces -x
    col, mat = _uniform(len(rim_pos), BACK_SRGB, BACK_MATERIAL)
    rim = finish_part(rim_pos, rim_nrm, np.zeros((len(rim_pos), 2)), col, mat, rim_tri, None)
    return [face, rim]


def _metal(positions, normals, faces) -> MeshPart:
    """A galvanised part (pole, clamp), labelled "pole" as Cityscapes labels a sign's pole."""
    col, mat = _uniform(len(positions), POLE_SRGB, POLE_MATERIAL)
    return finish_part(positions, normals, np.zeros((len(positions), 2)), col, mat, faces, None, label=POLE_LABEL)


def _tube(radius: float, height: float, sections: int = 20) -> MeshPart:
    """The pole: an upright tube from z = 0 to ``height``, smooth sides, a flat cap on top."""
    t = np.linspace(0.0, 2.0 * np.pi, sections, endpoint=False)
    ring = np.column_stack([np.cos(t), np.sin(t), np.zeros(sections)])
    side = np.concatenate([ring * [radius, radius, 0], ring * [radius, radius, 0] + [0, 0, height]])
    cap = np.concatenate([ring * [radius, radius, 0] + [0, 0, height], [[0.0, 0.0, height]]])
    i, j = np.arange(sections), (np.arange(sections) + 1) % sections
    faces = np.concatenate([np.column_stack([i, j, j + sections]), np.column_stack([i, j + sections, i + sections]),
                            2 * sections + np.column_stack([i, j, np.full(sections, sections)])])
    normals = np.concatenate([ring, ring, np.tile([0.0, 0.0, 1.0], (sections + 1, 1))])
    return _metal(np.concatenate([side, cap]), normals, faces)


def _box(lo, hi) -> MeshPart:
    """An axis-aligned box from corner ``lo`` to ``hi``, flat shaded (a clamp)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pos, nrm, faces = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [a for a in range(3) if a != axis]
            quad = []
            for cu, cv in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = lo.copy()
                p[axis] = hi[axis] if sign > 0 else lo[axis]
                p[u] = hi[u] if cu else lo[u]
                p[v] = hi[v] if cv else lo[v]
                quad.append(p)
            n0 = len(pos)
            pos += quad
            nrm += [np.eye(3)[axis] * sign] * 4
            faces += [[n0, n0 + 1, n0 + 2], [n0, n0 + 2, n0 + 3]]
    return _metal(np.array(pos), np.array(nrm), np.array(faces))


@functools.lru_cache(maxsize=128)
def sign_model(plates: tuple[Plate, ...], lower_edge_m: float = 2.0,
               size: tuple[tuple[str, float], ...] | None = None) -> Model:
    """A pole carrying ``plates`` (the main sign first, then the ones hanging under it), the
    lowest plate's lower edge ``lower_edge_m`` above the ground, at real size; or scaled
    uniformly to ``size`` (one (dimension, metres) pair, as :func:`load_model` takes)."""
    from .load import normalise

    if not plates:
        raise ValueError("a sign needs at least one plate")
    front_x = POLE_RADIUS + STANDOFF + PLATE_DEPTH
    # faces, then the grey rims, then the metal: the plain parts run together in a draw each
    # (the lit pass's runs of parts with the same maps, the id pass's runs of one label)
    faces: list[MeshPart] = []
    rims: list[MeshPart] = []
    metal: list[MeshPart] = []
    top = lower_edge_m + sum(p.height_m for p in plates) + PLATE_GAP * (len(plates) - 1)
    edge = top
    centres = []
    for plate in plates:
        centre = edge - plate.height_m / 2
        centres.append(centre)
        face, rim = _plate_parts(plate, centre, front_x)
        faces.append(face)
        rims.append(rim)
        for dz in (-0.3, 0.3):  # two clamps: a bar from the pole's axis to the plate's back
            z = centre + dz * plate.height_m
            metal.append(_box((0.0, -0.025, z - 0.0175), (front_x - PLATE_DEPTH, 0.025, z + 0.0175)))
        edge -= plate.height_m + PLATE_GAP
    pole_top = centres[0] + POLE_TOP * plates[0].height_m
    metal.append(_tube(POLE_RADIUS, pole_top))
    parts = faces + rims + metal
    codes = "+".join(p.code for p in plates)
    key = f"sign:{codes}|{lower_edge_m:.3f}|{size}"
    real = (("height", float(max(top, pole_top))),)
    return normalise(parts, np.eye(3), dict(size or real), key, f"sign {codes}")
