"""Recipes of scripts/build_vehicles.py for the models of github:stephengold/jme-vehicles (CC-BY
4.0 models from Sketchfab, kept there converted to jMonkeyEngine's ``.j3o``: read with
``vehicle_j3o``): the modern hatchback (a compact car), and an estate made from it by
lengthening its body behind the rear doors (docs/vehicles.md)."""
from __future__ import annotations

import numpy as np
from vehicle_j3o import read_j3o
from vehicle_mesh import Mesh, concat, corner_samples, face_samples
from vehicle_recipes import Build, Recipe, add_plates, finish, merge, split

HATCH = "MavCommon/src/main/resources/Models/modern_hatchback"
#: the j3o's frame (x left, y up, z forward) -> the build's (x forward, y left, z up)
TO_BUILD = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: the hatchback's wheels (model units): axle positions (the arches' centres, as HatchBack.java
#: places them), half track, tyre radius and width (a 205/55 R16 at the model's scale), the
#: ground under the tyres (the sills 13 cm above it)
AXLES, HALF_TRACK, TYRE_R, TYRE_W, GROUND = (1.2, -1.19), 0.745, 0.30, 0.19, -0.165
#: the body atlas's alloy-wheel image (u0, v0, u1, v1; glTF's v down)
WHEEL_BOX = (0.79, 0.0, 0.995, 0.215)
#: the wheel's face: the atlas's alloy image carries its own baked highlights, so that at the
#: textured factor (0.999) the spokes (linear 0.51-0.60, the 75th-90th percentiles) glowed white
#: next to the real cars' wheels on real frames; the factor takes them to 0.41-0.48, silver
#: wheel paint's albedo (a judgement by eye, not a measurement)
WHEEL_FACTOR = {"textured.wheel": ((0.8, 0.8, 0.8, 1.0), 0.0, 0.4)}
#: the body atlas's headlamp image (u0, v0, u1, v1; the build's v up): the reflectors' bowls,
#: the indicator, the lamp's black housing, which every non-glass face of the headlamps maps into
LAMP_BOX = (0.18, 0.0, 0.32, 0.065)


def hatch_mesh(b: Build) -> tuple[Mesh, np.ndarray, np.ndarray]:
    """The hatchback's geometries as one mesh in the build's frame (groups: the geometry's name),
    its body atlas (RGB, 0-1) and the per-face source material."""
    geoms = read_j3o(b.bytes("jme", f"{HATCH}/hatchback.j3o"))
    meshes, materials = [], []
    for g in geoms:
        uv = np.stack([g.uvs[:, 0], 1.0 - g.uvs[:, 1]], axis=1)  # glTF's v down -> the build's (OBJ) v up
        m = Mesh(g.positions @ TO_BUILD.T, g.triangles, g.normals @ TO_BUILD.T, uv,
                 np.full(len(g.triangles), g.name, object))
        meshes.append(m)
        materials += [g.material] * len(g.triangles)
    atlas = b.image("jme", f"{HATCH}/textures/MODERNHATCH_body_baseColor.png")
    return concat(meshes), atlas, np.array(materials, object)


def hatch_roles(body: Mesh, atlas: np.ndarray, material: np.ndarray) -> np.ndarray:
    """Every face's role: the glass material's faces are panes (the tailgate's tinted), the
    interior's interior; the body atlas's faces by their texel: paint (the light grey key of
    the atlas), black trim, red and amber lenses, the headlamps' chrome reflectors."""
    roles = np.full(len(body.faces), "plastic", object)
    g = body.groups.astype(str)
    glass = material == "GLASS"
    roles[glass] = "glass"
    roles[glass & np.char.startswith(g, "door_rear")] = "glass_privacy"
    roles[glass & np.char.startswith(g, "headlights")] = "glass"
    roles[material == "MODERNHATCH_INTERIOR"] = "interior"
    textured = material == "MODERNHATCH_body"
    col = face_samples(atlas, body)
    corners = corner_samples(atlas, body)
    lum, chroma = col.mean(axis=1), col.max(axis=1) - col.min(axis=1)
    light = (corners.mean(axis=-1) > 0.55).all(axis=1) & (lum > 0.6) & (chroma < 0.08)
    roles[textured & light] = "paint"
    r, gr, bl = col[:, 0], col[:, 1], col[:, 2]
    roles[textured & (r > 0.25) & (r > 2 * gr) & (r > 2 * bl)] = "light_red"
    roles[textured & (r > 0.45) & (gr > 0.2) & (gr < 0.7 * r) & (bl < 0.5 * gr)] = "light_amber"
    # the headlamps keep the atlas's own image (bowls, indicator, housing) under their glass: by
    # face, its texels gave jagged white shards in black (lamp_part)
    roles[textured & np.char.startswith(g, "headlights")] = "textured.lamp"
    return roles


def lamp_part(parts: dict[str, Mesh], atlas: np.ndarray) -> tuple[dict[str, Mesh], np.ndarray]:
    """The headlamps' faces with UVs onto the crop of the atlas (LAMP_BOX), and that crop (sRGB
    bytes)."""
    u0, v0, u1, v1 = LAMP_BOX
    lamp = parts["textured.lamp"]
    lamp.uvs = (lamp.uvs - np.array([u0, v0])) / np.array([u1 - u0, v1 - v0])
    assert lamp.uvs.min() > -1e-6 and lamp.uvs.max() < 1 + 1e-6, "headlamp UVs outside LAMP_BOX"
    h, w = atlas.shape[:2]
    crop = atlas[round((1 - v1) * h):round((1 - v0) * h), round(u0 * w):round(u1 * w)]
    return parts, (crop * 255).round().astype(np.uint8)


def tyre_and_rim(radius: float, width: float, segments: int = 64) -> tuple[Mesh, Mesh, Mesh]:
    """A tyre (a surface of revolution about y: a rounded section from the rim's edge over the
    shoulder to the tread), the wheel's outer face (a shallow dish, UVs onto the atlas's wheel
    image: the alloy rim inside the tyre's sidewall) and an inner disc closing the wheel from
    behind; the outer face at +y, centred at the origin."""
    rim_r = 0.64 * radius
    # the section: (y across the tyre, r from the axle), from the outer rim edge round to the inner
    half = width / 2
    section = [(0.88 * half, rim_r), (0.97 * half, 0.78 * radius), (half, 0.9 * radius), (0.93 * half, 0.97 * radius),
               (0.75 * half, radius), (0.0, radius * 1.002)]
    section = section + [(-y, r) for y, r in reversed(section[:-1])]
    a = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ys = np.array([s[0] for s in section])
    rs = np.array([s[1] for s in section])
    verts = np.stack([np.outer(np.cos(a), rs).ravel(), np.tile(ys, segments), np.outer(np.sin(a), rs).ravel()], axis=1)
    n = len(section)
    faces = []
    for i in range(segments):
        j = (i + 1) % segments
        for k in range(n - 1):
            p, q, r_, s = i * n + k, j * n + k, j * n + k + 1, i * n + k + 1
            faces += [(p, r_, q), (p, s, r_)]
    tyre = Mesh(verts, np.array(faces), _radial_normals(verts), np.zeros((len(verts), 2)))
    # the outer face: rings from the centre (dished 2.5 cm) out to the sidewall's middle, UVs by
    # the atlas's wheel image (its circle: u = 0.892 - 0.1926 z/R_img, v = 0.1107 + 0.1994 y/R_img,
    # R_img = 0.5 the image's tyre edge, glTF's v down, measured on the source's wheel.j3o)
    rings = np.array([0.0, 0.15, 0.45, 0.8, 1.0, 1.15]) * rim_r
    depth = np.interp(rings, [0.0, rim_r, rings[-1]], [0.78 * half, 0.9 * half, 0.9 * half])
    disc_v = [np.array([0.0, depth[0], 0.0])]
    for ring, d in zip(rings[1:], depth[1:]):
        disc_v += [np.array([np.cos(t) * ring, d, np.sin(t) * ring]) for t in a]
    disc_v = np.array(disc_v)
    faces = [(0, 1 + (i + 1) % segments, 1 + i) for i in range(segments)]
    for k in range(len(rings) - 2):
        o = 1 + k * segments
        for i in range(segments):
            j = (i + 1) % segments
            faces += [(o + i, o + j, o + segments + j), (o + i, o + segments + j, o + segments + i)]
    scale = 0.5 / (radius * 1.0)
    u = (0.892 + 0.1926 * disc_v[:, 2] * scale - WHEEL_BOX[0]) / (WHEEL_BOX[2] - WHEEL_BOX[0])
    v = (0.1107 + 0.1994 * disc_v[:, 0] * scale - WHEEL_BOX[1]) / (WHEEL_BOX[3] - WHEEL_BOX[1])
    uv = np.stack([u, 1.0 - v], axis=1)  # on the crop of the atlas (wheel_image), v up
    face = Mesh(disc_v, np.array(faces)[:, ::-1], np.tile([0.0, 1.0, 0.0], (len(disc_v), 1)), uv)
    back = Mesh(disc_v * np.array([1.0, -1.0, 1.0]) + np.array([0.0, 0.1 * half, 0.0]), np.array(faces),
                np.tile([0.0, -1.0, 0.0], (len(disc_v), 1)), np.zeros((len(disc_v), 2)))
    return tyre, face, back


def _radial_normals(v: np.ndarray) -> np.ndarray:
    n = v * np.array([1.0, 0.0, 1.0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)


def hatch_wheels(axles=AXLES) -> dict[str, Mesh]:
    tyre, face, back = tyre_and_rim(TYRE_R, TYRE_W)
    out: dict[str, list[Mesh]] = {"tyre": [], "textured.wheel": [], "rim_steel": []}
    for x in axles:
        for side in (1.0, -1.0):
            rot = np.eye(3) if side > 0 else np.diag([-1.0, -1.0, 1.0])  # the right wheel turned about z
            centre = (x, side * HALF_TRACK, GROUND + TYRE_R)
            out["tyre"].append(tyre.transformed(rot, centre))
            out["textured.wheel"].append(face.transformed(rot, centre))
            out["rim_steel"].append(back.transformed(rot, centre))
    return {k: concat(v) for k, v in out.items()}


def wheel_image(atlas: np.ndarray) -> np.ndarray:
    """The atlas's wheel image (WHEEL_BOX), sRGB bytes."""
    h, w = atlas.shape[:2]
    u0, v0, u1, v1 = WHEEL_BOX
    return (atlas[round(v0 * h):round(v1 * h), round(u0 * w):round(u1 * w)] * 255).round().astype(np.uint8)


def make_hatchback(b: Build, shift=None):
    """The compact; ``shift`` (vertices -> how far back each moves, model units) lengthens it."""
    body, atlas, material = hatch_mesh(b)
    roles = hatch_roles(body, atlas, material)
    if shift is not None:
        body.vertices[:, 0] -= shift(body.vertices)
    parts = merge(split(body, roles), hatch_wheels())
    parts = add_plates(parts, [(1, 0.2), (-1, 0.53)])
    parts, lamp = lamp_part(parts, atlas)
    b.notes.append("tyres (surfaces of revolution, 205/55 R16 at the model's scale) and the wheels' faces (the "
                   "source's alloy-wheel image of its body atlas) made by the script at the axle positions of "
                   "HatchBack.java; the source's wheel.j3o (a 178-triangle disc) not used")
    return finish(parts), {"textured.wheel": wheel_image(atlas), "textured.lamp": lamp}, WHEEL_FACTOR


#: the estate: the hatchback lengthened by ESTATE_STRETCH (model units) behind the rear doors'
#: windows above the waist (roof, windows, tailgate) and behind the rear wheel arch below it
ESTATE_STRETCH = 0.40


def estate_shift(v: np.ndarray) -> np.ndarray:
    """How far back each vertex moves (0 .. ESTATE_STRETCH): the whole tail behind the arch
    (ramping over 20 cm behind it), everything above the arch's top (ramping over 25 cm up to
    the waist) behind the rear doors' windows (ramping over 15 cm), so that the arch keeps
    its shape round the wheel, the rear side windows, the roof and the rear overhang lengthen
    and the tail keeps its shape: the long roof of an estate."""
    x, z = v[:, 0], v[:, 2]
    tail = np.clip((-1.5 - x) / 0.2, 0.0, 1.0)
    upper = np.clip((-0.85 - x) / 0.15, 0.0, 1.0) * np.clip((z - 0.5) / 0.25, 0.0, 1.0)
    return ESTATE_STRETCH * np.maximum(tail, upper)


def make_estate(b: Build):
    return make_hatchback(b, shift=estate_shift)


JME_RECIPES = {
    "jme-hatchback": Recipe(
        "Compact hatchback (five doors, of the 2010s), 'Modern Hatchback - Low Poly model' by Daniel Zhabotinsky "
        "(Sketchfab), as kept in jme-vehicles", "jme", f"{HATCH}/", "car", "compact", 4.05, 1.0, make_hatchback,
        ("converted from jMonkeyEngine's j3o (the Sketchfab glTF as jme-vehicles converted it) to one GLB; "
         "faces given material roles by their source material (glass, interior) and their texels in the body "
         "atlas (paint on its light grey, black trim, red and amber lenses); the headlamps keep the atlas's own image "
         "(reflector bowls, indicator) under their glass",
         "EU plates added at both ends")),
    "jme-estate": Recipe(
        "Compact estate, made from 'Modern Hatchback - Low Poly model' by Daniel Zhabotinsky (Sketchfab), as kept "
        "in jme-vehicles, by lengthening it", "jme", f"{HATCH}/", "car", "estate", 4.49, 1.0, make_estate,
        ("converted from jMonkeyEngine's j3o to one GLB, material roles as for jme-hatchback",
         "lengthened into an estate: everything above the rear wheel arch's top behind the rear doors' windows "
         "(roof, rear side windows, tailgate) and the whole tail behind the arch moved 0.40 model units "
         "(42 cm) back, the faces between stretched (vehicle_recipes_jme.estate_shift); the arch and the "
         "wheelbase unchanged", "EU plates added at both ends")),
}
