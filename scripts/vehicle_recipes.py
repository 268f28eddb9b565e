"""The recipes of scripts/build_vehicles.py: per vehicle, which source files it reads and how each
face is given its material role. Common steps (wheels at Chrono's axle positions, plates, glass
winding, the interior) live in :class:`Build`."""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from vehicle_glb import MATERIALS
from vehicle_mesh import (
    Mesh,
    concat,
    corner_samples,
    decimate,
    face_samples,
    git_image,
    git_read,
    plate_quad,
    plate_uvs,
    ray_hits,
    read_obj,
    wind_outwards,
)


@dataclass(frozen=True)
class Source:
    repo: str
    commit: str
    spdx: str
    licence_path: str  # the licence text shipped beside each model (a path in the repository)
    licence_note: str


SOURCES = {
    "chrono": Source("projectchrono/chrono", "7689fbc02d12c5419fa6acad8791100fd89979dd", "BSD-3-Clause", "LICENSE",
                     "the repository's licence; its data files carry no statement of their own"),
    "openmaterial": Source("LudwigFriedmann/OpenMATERIAL", "c1283d565efdbf9f8e4afdc0a593bcabb466378d",
                           "CC-BY-SA-4.0", "", "model_structure/objects/README.md of that commit; ShareAlike: "
                           "the converted model stays under CC-BY-SA 4.0"),
    "jme": Source("stephengold/jme-vehicles", "cd4cc9becf8500499213850777ea6319bc1a4ac4", "CC-BY-4.0",
                  "MavCommon/src/main/resources/Models/modern_hatchback/license.txt",
                  "MavCommon/src/main/resources/Models/modern_hatchback/license.txt of that commit: the model's "
                  "licensing history (author, Sketchfab page, CC-BY-4.0), followed here by the licence's legal code"),
}


class Build:
    """What a recipe reads (recorded for SOURCE.txt) and the steps recipes share."""

    def __init__(self, gits: dict[str, Path]) -> None:
        self.gits = gits
        self.read: list[str] = []
        self.notes: list[str] = []  # what a shared step changed (SOURCE.txt)

    # -------------------------------------------------------------- reading
    def bytes(self, source: str, path: str) -> bytes:
        if path not in self.read:
            self.read.append(path)
        return git_read(self.gits[source], SOURCES[source].commit, path)

    def obj(self, source: str, path: str) -> Mesh:
        return read_obj(self.bytes(source, path))

    def image(self, source: str, path: str, mode: str = "RGB", size: int | None = None) -> np.ndarray:
        self.bytes(source, path)
        img = git_image(self.gits[source], SOURCES[source].commit, path, mode)
        if size and img.shape[0] != size:
            from PIL import Image
            img = np.asarray(Image.fromarray((img * 255).astype(np.uint8)).resize((size, size)), np.float32) / 255
        return img

    def json(self, source: str, path: str) -> dict:
        """A JSON file; // comments (which Chrono's reader allows) are stripped first."""
        text = self.bytes(source, path).decode("utf-8")
        return json.loads(re.sub(r"//[^\n]*", "", text))

    def licence_text(self, source: str) -> bytes:
        s = SOURCES[source]
        legal = Path(__file__).resolve().parent / "licences" / f"{s.spdx}.txt"
        if s.licence_path and s.spdx.startswith("CC-"):
            # the source's statement (author, title, where from), then the licence's legal code
            return git_read(self.gits[source], s.commit, s.licence_path) + b"\n" + b"=" * 79 + b"\n\n" + legal.read_bytes()
        if s.licence_path:
            return git_read(self.gits[source], s.commit, s.licence_path)
        # the repository states the licence in a README only: its legal code, kept in scripts/licences
        return legal.read_bytes()

    # -------------------------------------------------------------- shared steps
    def chrono_wheels(self, vehicle_json: str, tyre_obj: str | None = None, rim_faces: int = 2500,
                      level: bool = True, tyre_faces: int = 3000, heights: tuple | None = None) -> dict[str, Mesh]:
        """Rims and tyres at the wheel centres of a Chrono JSON vehicle: each axle's suspension
        location plus its spindle's COM (y mirrored for the right), the wheel's and tyre's meshes
        as Chrono places them (the file's mesh on the left, turned 180 degrees about z on the
        right). The tyres' lowest 1.5 % of radius are flattened: the contact patch. Rims and tyres
        above ``rim_faces`` / ``tyre_faces`` triangles are reduced to about that. ``level``
        (default): every wheel at the first axle's height. The JSON files give each axle's design
        position, a few centimetres apart in height on some vehicles (the sedan's 12.5 cm):
        Chrono's springs settle the body under its weight, a static model would stand on two
        wheels with the other two in the air. ``heights``: each axle's wheel centre height
        instead (where the JSON's leave the tyres far below their arches)."""
        vehicle = self.json("chrono", f"data/vehicle/{vehicle_json}")
        self.notes.append(f"rims and tyres placed at the wheel centres of data/vehicle/{vehicle_json} (suspension "
                          "location + spindle), " + ("every axle at the first one's height (a static model "
                          "of the settled vehicle), " if level else "") + f"rims above {rim_faces} and tyres above "
                          f"{tyre_faces} triangles reduced to about that (quadric edge collapse), the tyres' "
                          "lowest 1.5 % of radius flattened (the contact patch)")
        rims, tyres = [], []
        first_z = None
        for index, axle in enumerate(vehicle["Axles"]):
            susp = self.json("chrono", f"data/vehicle/{axle['Suspension Input File']}")
            spindle = np.asarray(susp["Spindle"]["COM"], float)
            loc = np.asarray(axle["Suspension Location"], float)
            twin = "Left Outside Wheel Input File" in axle  # twin tyres: outside and inside of the spindle
            key = 'Left Outside Wheel Input File' if twin else 'Left Wheel Input File'
            wheel = self.json("chrono", f"data/vehicle/{axle[key]}")
            rim = self.obj("chrono", f"data/vehicle/{wheel['Visualization']['Mesh Filename']}")
            if rim_faces:
                rim = decimate(rim, rim_faces)
            tyre = decimate(self.obj("chrono", f"data/vehicle/{tyre_obj}"), tyre_faces)
            r = tyre.vertices[:, 2].max()
            tyre.vertices[:, 2] = np.maximum(tyre.vertices[:, 2], -r * 0.985)
            offsets = [(0.0, 1)] if not twin else [(axle["Wheel Separation"] / 2, 1), (-axle["Wheel Separation"] / 2, -1)]
            for side in (1, -1):
                for dy, facing in offsets:
                    centre = loc + spindle * np.array([1.0, side, 1.0]) + np.array([0.0, side * dy, 0.0])
                    first_z = centre[2] if first_z is None else first_z
                    if level:
                        centre[2] = first_z
                    if heights is not None:
                        centre[2] = heights[index]
                    rot = np.eye(3) if side * facing > 0 else np.diag([-1.0, -1.0, 1.0])
                    rims.append(rim.transformed(rot, centre))
                    tyres.append(tyre.transformed(rot, centre))
        return {"rim": concat(rims), "tyre": concat(tyres)}


def add_plates(parts: dict[str, Mesh], plates: list[tuple], width: float = 0.52,
               height: float = 0.11) -> dict[str, Mesh]:
    """EU number plates (520 x 110 mm) added at the front (sign +1) and the rear (-1): each
    (sign, centre z[, centre y]) stands 5 mm proud of the outermost body surface that rays from
    outside meet over its face."""
    body = concat([m for k, m in parts.items() if not k.startswith("glass")])
    new = []
    for sign, z, *rest in plates:
        y = rest[0] if rest else 0.0
        hits = []
        for dy in (-width / 2, 0.0, width / 2):
            for dz in (-height / 2, 0.0, height / 2):
                t = ray_hits(body, (sign * 20.0, y + dy, z + dz), (-sign, 0.0, 0.0))
                if len(t):
                    hits.append(sign * (20.0 - t[0]))
        if not hits:
            raise SystemExit(f"no body surface found for the plate at x sign {sign}, z {z}")
        x = sign * (max(h * sign for h in hits) + 0.005)
        new.append(plate_quad((x, y, z), (sign, 0.0, 0.0), width, height))
    return merge(parts, {"plate": concat(new)})


def split(mesh: Mesh, roles: np.ndarray) -> dict[str, Mesh]:
    """The mesh's faces by role (``roles`` (M,) object array; "" and "delete" dropped)."""
    return {r: mesh.select(roles == r) for r in np.unique(roles) if r not in ("", "delete")}


def merge(*dicts: dict[str, Mesh]) -> dict[str, Mesh]:
    out: dict[str, list[Mesh]] = {}
    for d in dicts:
        for k, m in d.items():
            out.setdefault(k, []).append(m)
    return {k: concat(v) for k, v in out.items()}


def finish(parts: dict[str, Mesh]) -> dict[str, Mesh]:
    """The steps every vehicle ends with: glass wound to face out of the vehicle; plates given
    UVs over each plate (front and rear separately)."""
    body = concat(list(parts.values()))
    centre = (body.vertices.min(0) + body.vertices.max(0)) / 2
    for name in list(parts):
        if name.startswith("glass"):
            parts[name] = wind_outwards(parts[name], centre)
    if "plate" in parts and len(parts["plate"].faces):
        parts = plates_with_uvs(parts, centre)
    return parts


def plates_with_uvs(parts: dict[str, Mesh], centre) -> dict[str, Mesh]:
    """Each plate's faces that face out of the vehicle (front plate forward, rear plate back) get
    UVs over that plate; the plate's other faces (its edges and back) become plastic."""
    plate = parts.pop("plate")
    c, n = plate.centroids(), plate.face_normals()
    front = c[:, 0] > centre[0]
    out = np.where(front, n[:, 0], -n[:, 0]) > 0.7
    faces = [plate_uvs(plate.select(out & side)) for side in (front, ~front) if (out & side).any()]
    return merge(parts, {"plate": concat(faces), "plastic": plate.select(~out)})


@dataclass(frozen=True)
class Recipe:
    title: str
    source: str
    folder: str
    cls: str
    kind: str
    length: float
    weight: float
    make: Callable[[Build], tuple]  # -> (parts, textures[, material overrides])
    changes: tuple[str, ...] = field(default=())


# ------------------------------------------------------------------ the Audi (Chrono data/vehicle/audi)
AUDI = "data/vehicle/audi"


def make_audi(b: Build):
    body = b.obj("chrono", f"{AUDI}/audi_chassis.obj")
    b.bytes("chrono", f"{AUDI}/audi_chassis.mtl")
    tex = f"{AUDI}/textures/Audi_Whole_Texturing_031021_Chassis1_BaseColor_"
    variants = [b.image("chrono", tex + v, size=1024) for v in ("Red.jpg", "Blue.png", "Green.png")]
    opacity = b.image("chrono", f"{AUDI}/textures/Chassis1_Opacity.jpg", "L")
    aux = b.image("chrono", f"{AUDI}/textures/Audi_Whole_Texturing_031021_Interior_Aux_BaseColor.jpg")
    # paint: the texels the paint variants disagree on
    paint_mask = np.max([np.abs(v - variants[0]).max(-1) for v in variants[1:]], axis=0) > 0.08
    roles = np.full(len(body.faces), "", object)
    chassis = body.groups == "phong1SG"
    col = face_samples(variants[0], body)
    op = face_samples(opacity, body)
    paint = face_samples(paint_mask.astype(np.float32), body) > 0.5
    lum = col.mean(axis=1)
    red = (col[:, 0] > 0.35) & (col[:, 1] < 0.15)
    roles[chassis] = "plastic"
    roles[chassis & (lum > 0.4)] = "chrome"
    roles[chassis & (op < 0.75) & (lum > 0.3)] = "light_white"
    roles[chassis & red] = "light_red"
    roles[chassis & paint] = "paint"
    # glass: the navy texels (the opacity map marks the windscreen and front panes 0.4, the rear
    # window 0.6, the rear side panes not at all: clear in front, tinted behind), found by the
    # face's centroid or a corner, so that a pane reaches its frame without a jagged border
    navy = lambda c: (c[..., 2] - c[..., 0] > 0.04) & (c.mean(axis=-1) < 0.2)
    pane = chassis & (navy(col) | navy(corner_samples(variants[0], body)).any(axis=1))
    roles[pane] = "glass_privacy"
    roles[pane & (op < 0.5)] = "glass"
    inner = ~chassis
    acol = face_samples(aux, body)
    alum = acol.mean(axis=1)
    roles[inner] = "plastic"
    # the source's plates (a US-sized plate with a blue band) and the four rings: deleted; EU
    # plates are added in their place
    band = (acol[:, 2] > 0.6) & (acol[:, 0] < 0.3)
    grey = (np.abs(acol - 0.78) < 0.08).all(axis=1)
    roles[inner & (band | grey | (alum > 0.9))] = "delete"
    parts = merge(split(body, roles), b.chrono_wheels("audi/json/audi_Vehicle.json", "audi/audi_tire.obj"))
    parts = add_plates(parts, [(1, 0.30), (-1, 0.61)])
    return finish(parts), {}


def lamp_roles(col: np.ndarray) -> np.ndarray:
    """Lamp faces by their texel colour: red lenses, amber lenses, clear lenses over reflectors
    (bright), housings (dark)."""
    r, g, bl = col[:, 0], col[:, 1], col[:, 2]
    roles = np.full(len(col), "plastic", object)
    roles[col.mean(axis=1) > 0.25] = "light_white"
    roles[(r > 0.35) & (g < 0.25) & (bl < 0.25)] = "light_red"
    roles[(r > 0.45) & (g > 0.2) & (g < 0.6) & (bl < 0.2)] = "light_amber"
    return roles


def paint_mask(images: list[np.ndarray], threshold: float = 0.08) -> np.ndarray:
    """Texels where the source's paint variants disagree: the paint."""
    return np.max([np.abs(v - images[0]).max(-1) for v in images[1:]], axis=0) > threshold


def textured_wheels(b: Build, vehicle_json: str, tyre_obj: str, texture: str) -> tuple[dict, dict]:
    """Chrono wheels whose rim is a textured disc: the rim keeps the wheel texture, the tyre is rubber."""
    wheels = b.chrono_wheels(vehicle_json, tyre_obj)
    image = (b.image("chrono", texture) * 255).astype(np.uint8)
    return {"textured.wheel": wheels["rim"], "tyre": wheels["tyre"]}, {"textured.wheel": image}


# ------------------------------------------------------------------ the Nissan Patrol (Chrono data/vehicle/Nissan_Patrol)
PATROL = "data/vehicle/Nissan_Patrol"


def make_patrol(b: Build):
    body = b.obj("chrono", f"{PATROL}/suv_chassis.obj")
    b.bytes("chrono", f"{PATROL}/suv_chassis.mtl")
    t = f"{PATROL}/textures/Nissan_Chassis_"
    variants = [b.image("chrono", t + v, size=2048) for v in
                ("OBJ_0331_Nissan_Chassis_BaseColor.jpg", "BaseColor_Red.jpg", "BaseColor_Brown.jpg")]
    opacity = b.image("chrono", t + "Opacity.jpg", "L", size=2048)
    exterior = b.image("chrono", t + "OBJ_0331_Nissan_Exterior_BaseColor.jpg")
    lights = b.image("chrono", t + "OBJ_0331_Nissan_Lights_BaseColor.jpg")
    roles = np.full(len(body.faces), "plastic", object)
    g = body.groups
    chassis = g == "lambert5SG"
    col = face_samples(variants[0], body)
    paint = face_samples(paint_mask(variants).astype(np.float32), body) > 0.5
    roles[chassis & (col.mean(axis=1) > 0.5)] = "chrome"
    roles[chassis & paint] = "paint"
    pane = chassis & ((face_samples(opacity, body) < 0.6) | (corner_samples(opacity, body) < 0.6).any(axis=1))
    roles[pane] = "glass"
    ext = g == "lambert6SG"
    ecol = face_samples(exterior, body)
    roles[ext & (np.abs(ecol - 0.65).max(axis=1) < 0.08)] = "paint"  # the flares and bumpers: body colour
    old_plate = ext & (ecol.mean(axis=1) > 0.85)  # the source's (US) plates
    roles[old_plate] = "delete"
    c = body.centroids()
    # the off-road kit: the roof rack and the bull bar in front of the grille (and its lamps)
    roles[ext & ((c[:, 2] > 1.5) | ((c[:, 0] > 0.6) & (c[:, 2] > 0.47)))] = "delete"
    lamps = np.isin(g, ["lambert2SG", "lambert3SG", "lambert4SG"])
    roles[lamps] = lamp_roles(face_samples(lights, body))[lamps]
    roles[lamps & (c[:, 0] > 0.72)] = "delete"
    roles[lamps & (c[:, 0] < -3.5)] = "light_red"  # the tail lamps (the source's lamp texture is grey)
    # the headlamps: silver texels of the body's atlas at the front
    silver = (corner_samples(variants[0], body).mean(axis=-1) > 0.5).any(axis=1) & ~paint
    roles[chassis & silver & (c[:, 0] > 0.3) & (c[:, 2] > 0.35) & (c[:, 2] < 0.75)] = "light_white"
    roles[g == "lambert8SG"] = "interior"
    roles[g == "lambert7SG"] = "tyre"  # the spare wheel on the tailgate
    wheels, textures = textured_wheels(b, "Nissan_Patrol/json/suv_Vehicle.json", "Nissan_Patrol/suv_tire.obj",
                                       f"{PATROL}/textures/Nissan_Chassis_OBJ_0331_Nissan_Wheel_BaseColor.jpg")
    parts = merge(split(body, roles), wheels)
    # the rear plate in the tailgate's recess left of the spare wheel (its place measured on the mesh)
    parts = add_plates(parts, [(1, 0.45), (-1, 0.585, 0.6)])
    return finish(parts), textures


# ------------------------------------------------------------------ the VW T2 (Chrono data/vehicle/VW_microbus)
VAN = "data/vehicle/VW_microbus"


def make_van(b: Build):
    body = b.obj("chrono", f"{VAN}/van_chassis_cream.obj")
    b.bytes("chrono", f"{VAN}/van_chassis_cream.mtl")
    t = f"{VAN}/textures/"
    variants = [b.image("chrono", t + v, size=2048) for v in ("Volks_Van_Texturing_Volks_Van_Chassis_BaseColor.jpg",
                                                   "Volks_Van_Chassis_BaseColor_Cream.jpg",
                                                   "Volks_Van_Chassis_BaseColor_Yellow.jpg")]
    opacity = b.image("chrono", t + "Volks_Van_Chassis_Opacity.jpg", "L", size=2048)
    exterior = b.image("chrono", t + "Volks_Van_Texturing_Volks_Van_Exteriors_BaseColor.jpg")
    g = body.groups
    c = body.centroids()
    roles = np.full(len(body.faces), "plastic", object)
    chassis = g == "lambert13SG"
    col = face_samples(variants[0], body)
    paint = face_samples(paint_mask(variants).astype(np.float32), body) > 0.5
    roles[chassis & (col.mean(axis=1) > 0.6)] = "white"  # the two-tone's white roof and waist
    roles[chassis & paint] = "paint"
    pane = chassis & ((face_samples(opacity, body) < 0.6) | (corner_samples(opacity, body) < 0.6).any(axis=1))
    roles[pane] = "glass"
    ext = g == "lambert14SG"
    ecol = face_samples(exterior, body)
    roles[ext] = lamp_roles(ecol)[ext]
    # bumpers and trim strips: bright grey -> chrome; the white of this atlas is painted
    roles[ext & (roles == "light_white") & (np.abs(ecol[:, 0] - ecol[:, 2]) < 0.05)] = "chrome"
    roles[ext & (ecol.mean(axis=1) > 0.85)] = "white"
    # the lamps: at the front the round headlamps, amber indicators; red at the back
    front, back = c[:, 0] > 0.75, c[:, 0] < -3.2
    lamp = ext & front & (np.abs(c[:, 1]) > 0.4) & (c[:, 2] > 0.45) & (c[:, 2] < 0.8) & (ecol.mean(axis=1) > 0.25)
    roles[lamp] = "light_white"
    # the brand's roundel on the engine lid (a raised disc): deleted, the lid is whole behind it;
    # the one on the grille is a relief in the grille's colour
    small = body.face_areas() < 0.0015
    roles[back & small & (np.abs(c[:, 1]) < 0.11) & (c[:, 2] > 0.72) & (c[:, 2] < 0.93)] = "delete"
    # the source's blank plate under the bumper handle: an EU plate takes its place
    roles[back & (roles == "white") & (np.abs(c[:, 1]) < 0.3) & (c[:, 2] > 0.3) & (c[:, 2] < 0.55)] = "paint"
    wheels = b.chrono_wheels("VW_microbus/json/van_Vehicle.json", "VW_microbus/van_tire.obj")
    parts = merge(split(body, roles), wheels)
    parts = add_plates(parts, [(1, 0.42), (-1, 0.42)])
    return finish(parts), {}, {"paint": (MATERIALS["paint"][0], 0.0, 0.45)}


# ------------------------------------------------------------------ the city bus (Chrono data/vehicle/citybus)
BUS = "data/vehicle/citybus"


def make_bus(b: Build):
    body = b.obj("chrono", f"{BUS}/CityBus_Vis.obj")
    b.bytes("chrono", f"{BUS}/CityBus_Vis.mtl")
    tex = b.image("chrono", f"{BUS}/textures/Bus_Texturing_Bus_Chassis_BaseColor.jpg")
    opacity = b.image("chrono", f"{BUS}/textures/Bus_Chassis_Opacity.jpg", "L", size=tex.shape[0])
    c = body.centroids()
    col = face_samples(tex, body)
    lum = col.mean(axis=1)
    # a plain German city bus: the US livery (blue roof, white sides with the operator's and
    # the state's names) becomes one ivory livery, the black band of the windows stays
    roles = np.full(len(body.faces), "livery", object)
    roles[lum < 0.12] = "livery_band"
    front, back = c[:, 0] > c[:, 0].max() - 0.25, c[:, 0] < c[:, 0].min() + 0.25
    low = c[:, 2] < 1.4
    r, g = col[:, 0], col[:, 1]
    amber = (r > 0.6) & (g > 0.25) & (g < 0.7) & (col[:, 2] < 0.25)
    red = (r > 0.45) & (g < 0.2)
    roles[(front | back) & low & amber] = "light_amber"
    roles[back & low & red] = "light_red"
    roles[front & low & (lum > 0.55) & (lum < 0.9) & (np.abs(r - col[:, 2]) < 0.06)] = "light_white"
    pane = (face_samples(opacity, body) < 0.6) | (corner_samples(opacity, body) < 0.6).any(axis=1)
    roles[pane] = "glass_privacy"  # a bus's panes are tinted; the empty saloon shows less through them
    roles[c[:, 2] < 0.45] = "plastic"  # the skirts' and bumpers' lowest strip
    wheels = b.chrono_wheels("citybus/vehicle/CityBus_Vehicle.json", "citybus/CityBusTire.obj", rim_faces=1500)
    parts = merge(split(body, roles), wheels)
    parts = add_plates(parts, [(1, 0.55), (-1, 0.75)])
    return finish(parts), {}


# ------------------------------------------------------------------ the generic saloon (Chrono data/vehicle/sedan)
SEDAN = "data/vehicle/sedan"
#: its 12 flat materials -> roles, told by where their faces are: .001 the body (red paint), .002
#: the steering wheel, .003 and .009-.012 the five seats, .004 the glass, .005 the seals and
#: trim, .006 the mirrors' glass, .007 / .008 the head and tail lamps' lenses
SEDAN_ROLES = {"Material.001": "paint", "Material.002": "interior", "Material.003": "interior",
               "Material.004": "glass", "Material.005": "rubber", "Material.006": "mirror",
               "Material.007": "light_white", "Material.008": "light_red", "Material.009": "interior",
               "Material.010": "interior", "Material.011": "interior", "Material.012": "interior"}


def make_sedan(b: Build):
    body = b.obj("chrono", f"{SEDAN}/sedan_chassis_vis.obj")
    b.bytes("chrono", f"{SEDAN}/sedan_chassis_vis.mtl")
    roles = np.array([SEDAN_ROLES[g] for g in body.groups], object)
    # the JSON's wheel centres leave 13-20 cm between tyre and arch: raised to about 5 cm, and
    # the whole car pitched so that both axles stand on level ground (nose down 1.1 degrees)
    front, rear = (1.388, 0.21), (-1.388, 0.155)
    wheels = b.chrono_wheels("sedan/vehicle/Sedan_Vehicle.json", "sedan/sedan_tire.obj", heights=(front[1], rear[1]))
    parts = add_plates(merge(split(body, roles), wheels), [(1, 0.22), (-1, 0.42)])
    t = np.arctan2(front[1] - rear[1], front[0] - rear[0])
    pitch = np.array([[np.cos(t), 0.0, np.sin(t)], [0.0, 1.0, 0.0], [-np.sin(t), 0.0, np.cos(t)]])
    return finish({k: m.transformed(pitch) for k, m in parts.items()}), {}


# ------------------------------------------------------------------ the Jeep Cherokee (Chrono data/vehicle/jeep)
JEEP = "data/vehicle/jeep"
#: its 18 flat materials (no glass of its own, no textures) -> roles, told by where their faces
#: are: _1 the body's paint, _0 the lower cladding and bumpers, _2 the glass above the waist line
#: and the wheel-arch flares below it, _15 the tinted rear panes, _4 the lettering ("Jeep",
#: "Cherokee", "4x4": thousands of tiny faces), _9/_10/_11 the tail lamp (amber, red, reverse),
#: _12/_13/_17 the front lamps, _8 the seats
JEEP_ROLES = {"material_0": "plastic", "material_1": "paint", "material_2": "glass", "material_3": "plastic",
              "material_4": "delete", "material_5": "plastic", "material_6": "underbody", "material_7": "plastic",
              "material_8": "interior", "material_9": "light_amber", "material_10": "light_red",
              "material_11": "light_white", "material_12": "light_amber", "material_13": "light_white",
              "material_14": "underbody", "material_15": "glass_privacy", "material_16": "plastic",
              "material_17": "light_white"}
#: the waist line (m, the source's z): _2's faces below it are the flares
JEEP_WAIST = 0.74


def make_jeep(b: Build):
    body = b.obj("chrono", f"{JEEP}/JeepCherokee.obj")
    b.bytes("chrono", f"{JEEP}/JeepCherokee.mtl")
    roles = np.array([JEEP_ROLES[g] for g in body.groups], object)
    roles[(body.groups == "material_2") & (body.centroids()[:, 2] < JEEP_WAIST)] = "plastic"
    wheels = jeep_wheels(b)
    parts = add_plates(merge(split(body, roles), wheels), [(1, 0.3), (-1, 0.55)])
    return finish(parts), {}


def jeep_wheels(b: Build) -> dict[str, Mesh]:
    """The Cherokee has no JSON vehicle: its wheel centres come from its C++ model, the axles'
    locations in Cherokee_Vehicle.cpp (front at x = 0, rear at -2.578) and the spindles' in
    Cherokee_SolidAxleFront.cpp / _Rear.cpp (read from those files)."""
    src = "src/chrono_models/vehicle/jeep/"
    vehicle = self_text(b, src + "Cherokee_Vehicle.cpp")
    rear_x = float(re.search(r"m_axles\[1\]->Initialize\(m_chassis, nullptr, nullptr, ChVector3d\(([-\d.]+)", vehicle).group(1))
    centres = []
    for x, name in ((0.0, "Cherokee_SolidAxleFront.cpp"), (rear_x, "Cherokee_SolidAxleRear.cpp")):
        text = self_text(b, src + name)
        spindle = r"case SPINDLE:\s*return ChVector3d\(\s*[-\d.]+\s*,\s*([-\d.]+)\s*,\s*([-\d.]+)\)"
        y, z = (float(v) for v in re.search(spindle, text).groups())
        centres.append((x, y, z))
    rim = b.obj("chrono", f"{JEEP}/Cherokee_Wheel.obj")
    tyre = decimate(b.obj("chrono", f"{JEEP}/Cherokee_Tire.obj"), 3000)
    rim = decimate(rim, 2500)
    r = tyre.vertices[:, 2].max()
    tyre.vertices[:, 2] = np.maximum(tyre.vertices[:, 2], -r * 0.985)
    rims, tyres = [], []
    for x, y, z in centres:
        for side in (1, -1):
            rot = np.eye(3) if side > 0 else np.diag([-1.0, -1.0, 1.0])
            rims.append(rim.transformed(rot, (x, side * y, z)))
            tyres.append(tyre.transformed(rot, (x, side * y, z)))
    return {"rim": concat(rims), "tyre": concat(tyres)}


def self_text(b: Build, path: str) -> str:
    return b.bytes("chrono", path).decode("utf-8")


# ------------------------------------------------------------------ glTF sources (OpenMATERIAL)
def gltf_meshes(b: Build, source: str, folder: str, name: str, files: tuple[str, ...]) -> list[tuple[str, str, Mesh]]:
    """(node name, material name, mesh) of every mesh of a glTF read out of the repository
    (its buffers and images beside it), node transforms applied, in the vehicle frame: glTF's
    x stays, its up (y) becomes z, its z becomes -y."""
    import tempfile

    import trimesh

    with tempfile.TemporaryDirectory() as tmp:
        for f in (name,) + files:
            target = Path(tmp) / f
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(b.bytes(source, f"{folder}/{f}"))
        scene = trimesh.load(str(Path(tmp) / name), force="scene", process=False)
        out = []
        to_vehicle = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
        for m in scene.dump():
            mat = getattr(m.visual, "material", None)
            uv = getattr(m.visual, "uv", None)
            mesh = Mesh(np.asarray(m.vertices, float) @ to_vehicle.T, np.asarray(m.faces, np.int64),
                        np.asarray(m.vertex_normals, float) @ to_vehicle.T,
                        np.asarray(uv, float) if uv is not None else np.zeros((len(m.vertices), 2)))
            out.append((str(m.metadata.get("name", "")), str(getattr(mat, "name", "") or ""), mesh))
        return out


# ------------------------------------------------------------------ the lorry (OpenMATERIAL truck_example)
OM = "model_structure/objects"
#: OpenMATERIAL's named materials -> roles (the cab's grey is its paint; the bed, canvas and the
#: dark blue chassis keep their colours)
LORRY_ROLES = {"Paint_Grey": "paint", "Chrome": "chrome", "Glass": "glass", "Plastic_Orange": "light_amber",
               "Plastic_Clear": "light_white", "Plastic_White": "light_white", "Plastic_Red": "light_red",
               "Number_Plate": "plate", "Paint_Blue": "underbody", "Rubber_Black": "tyre",
               "Plastic_Black": "plastic", "Tissue_Grey": "canvas", "Tissue_Blue": "interior"}


ROADSTER_ROLES = {"Paint_Red": "paint", "Tissue_Black": "rubber", "Glass": "glass", "Plastic_Orange": "light_amber",
                  "Chrome": "chrome", "Plastic_Red": "light_red", "Plastic_Clear": "light_white",
                  "Number_Plate": "plate", "Rubber_Black": "tyre", "Tissue_Sand": "interior", "Wood_Dark": "interior"}


def openmaterial(b: Build, name: str, roles: dict[str, str], rename) -> dict[str, Mesh]:
    """An OpenMATERIAL example's meshes by role (``rename(node, role)`` may change a node's role),
    turned to face +x, glass wound outwards, plates with UVs over each plate."""
    b.bytes("openmaterial", f"{OM}/README.md")
    meshes = gltf_meshes(b, "openmaterial", OM, f"{name}.gltf", (f"{name}.bin", "Textures/Number_Plate.png"))
    parts: dict[str, list[Mesh]] = {}
    for node, material, mesh in meshes:
        role = roles.get(material)
        if role is None:
            raise SystemExit(f"{name}.gltf: material {material!r} of node {node!r} has no role")
        parts.setdefault(rename(node, role), []).append(mesh)
    merged = {k: concat(v) for k, v in parts.items()}
    allv = np.concatenate([m.vertices for m in merged.values()])
    lamps = merged["light_white"].vertices[:, 0].mean()
    if lamps < (allv[:, 0].min() + allv[:, 0].max()) / 2:  # the headlamps at -x: turn it to face +x
        merged = {k: m.transformed(np.diag([-1.0, -1.0, 1.0])) for k, m in merged.items()}
    return finish(merged)


def make_lorry(b: Build):
    def rename(node, role):
        if role == "paint" and node.startswith("Truck_Bed"):
            return "livery"  # the bed's boards: a fixed grey, not the cab's paint
        if node.startswith("Rim_"):
            return "rim"
        return "rim_steel" if node.startswith("Spare_Wheel_Rim") else role
    return openmaterial(b, "truck_example", LORRY_ROLES, rename), {}


def make_roadster(b: Build):
    return openmaterial(b, "vehicle_example", ROADSTER_ROLES,
                        lambda node, role: "rim" if node.startswith("Rim_") else role), {}


RECIPES = {
    "chrono-audi": Recipe(
        "Four-door saloon (a liftback of the Audi A7 kind), Project Chrono's 'audi' vehicle", "chrono",
        "data/vehicle/audi/", "car", "saloon", 4.88, 1.0, make_audi,
        ("converted from OBJ + textures to one GLB; every face given a material role by its texels "
         "(paint where the red, blue and green paint variants differ; glass on the navy texels, clear "
         "where the opacity map is below 0.5, tinted behind; lamps, chrome, trim)",
         "the brand's rings deleted; the source's US-sized plates deleted, EU plates added",
         "rims and tyres added at the axle positions of json/audi_Vehicle.json, reduced to about "
         "2500 / 1600 triangles each (quadric edge collapse)")),
    "chrono-patrol": Recipe(
        "Large off-road SUV (a Nissan Patrol Y61), Project Chrono's 'Nissan_Patrol' vehicle", "chrono",
        "data/vehicle/Nissan_Patrol/", "car", "suv", 5.05, 0.3, make_patrol,
        ("converted from OBJ + textures to one GLB; faces given material roles by their texels "
         "(paint where the paint variants differ, glass by the opacity map, lamps by colour)",
         "the source's plate deleted, EU plates added", "rims and tyres added at the axle positions of "
         "json/suv_Vehicle.json")),
    "chrono-van": Recipe(
        "Van (a 1970s VW T2 'microbus', two-tone), Project Chrono's 'VW_microbus' vehicle", "chrono",
        "data/vehicle/VW_microbus/", "car", "van", 4.50, 0.3, make_van,
        ("converted from OBJ + textures to one GLB; faces given material roles by their texels "
         "(paint where the paint variants differ, the white of the two-tone kept, glass by the opacity map)",
         "the brand's roundel on the engine lid deleted", "EU plates added",
         "the paint less glossy than the others' (roughness 0.45: its panels are coarse)",
         "rims and tyres added at the axle positions of json/van_Vehicle.json")),
    "chrono-citybus": Recipe(
        "City bus (a 12 m low-floor bus), Project Chrono's 'citybus' vehicle, in a plain German livery", "chrono",
        "data/vehicle/citybus/", "bus", "bus", 12.10, 1.0, make_bus,
        ("converted from OBJ + texture to one GLB; the US operator's livery (blue roof, names and "
         "emblems on the sides) replaced by one ivory livery with the dark window band",
         "glass by the opacity map (tinted); lamps by colour at the ends", "EU plates added",
         "the rims reduced from 7876 to about 1500 triangles (quadric edge collapse)",
         "rims and tyres (twin at the rear) added at the axle positions of vehicle/CityBus_Vehicle.json")),
    "chrono-sedan": Recipe(
        "Four-door saloon (generic, of the 2000s), Project Chrono's 'sedan' vehicle", "chrono",
        "data/vehicle/sedan/", "car", "saloon", 4.60, 1.0, make_sedan,
        ("converted from OBJ to one GLB; its 12 flat materials given roles (paint, glass, lenses, "
         "trim, seats)", "EU plates added",
         "rims and tyres added (below) but raised into the arches: wheel centres at z 0.21 (front) and "
         "0.155 (rear) instead of the JSON's 0.130 / 0.005, which leave 13-20 cm between tyre and arch; "
         "the car pitched 1.1 degrees nose down so that both axles stand on level ground")),
    "chrono-jeep": Recipe(
        "Compact SUV (a Jeep Cherokee XJ), Project Chrono's 'jeep' vehicle", "chrono",
        "data/vehicle/jeep/", "car", "suv", 4.25, 0.5, make_jeep,
        ("converted from OBJ to one GLB; its 18 flat materials given roles by where their faces are "
         "(glass above the waist line, flares below it, lamps, seats)", "the brand's and the model's "
         "lettering deleted", "EU plates added", "rims and tyres added at the wheel centres of its C++ "
         "model (src/chrono_models/vehicle/jeep/Cherokee_Vehicle.cpp, Cherokee_SolidAxleFront.cpp, "
         "Cherokee_SolidAxleRear.cpp)")),
    "openmaterial-roadster": Recipe(
        "Classic roadster coupe (1950s), OpenMATERIAL's vehicle_example", "openmaterial",
        "model_structure/objects/vehicle_example.gltf", "car", "classic", 4.14, 0.05, make_roadster,
        ("converted from glTF (+ .bin) to one GLB, node transforms applied",
         "its named materials given roles: the red is the paint drawn per object, the lamps' "
         "translucent lenses opaque red, amber and clear over their reflectors, the hubcaps metal rims",
         "the number plates' UVs made again over each plate (each object draws its own registration)")),
    "openmaterial-lorry": Recipe(
        "Tarpaulin lorry (a European two-axle cab-over truck), OpenMATERIAL's truck_example", "openmaterial",
        "model_structure/objects/truck_example.gltf", "truck", "lorry", 8.44, 1.0, make_lorry,
        ("converted from glTF (+ .bin) to one GLB, node transforms applied",
         "its 13 named materials given roles and colours: the cab's grey is the paint drawn per "
         "object, the bed a fixed grey, the canvas a grey tarpaulin, the dark blue frame dark",
         "the number plates' UVs made again over each plate (each object draws its own registration)")),
}
