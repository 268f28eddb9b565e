"""Appearance variety: the paint of a vehicle, the clothes of a person, drawn per object (seeded)
and recorded, so that a dataset teaches a class, not one model's colour.

A model's recolourable materials are found from its geometry and materials alone:

* vehicles: the **paint** - the material named ``paint`` (the cast's vehicles name their
  materials by role, docs/vehicles.md); none in a model whose body is a ``livery`` (a bus in
  its operator's colours); in a model with neither, the opaque, untextured, non-metallic
  material with the largest surface among the glossy ones (roughness below
  :data:`PAINT_MAX_ROUGHNESS`: paint is clear coated; tyres, trims and plastics are rough);
* people: the **clothes** - the materials named ``clothes_top``, ``clothes_bottom`` and ``shoes``
  (the cast's people, docs/people.md; skin, hair, an inner layer keep their colours); in a model
  without them, the three opaque, untextured materials with the largest surface that are not
  skin-coloured (top, trousers, a vest or jacket).

Paint is drawn from the share of car colours on European roads (white, grey, black and silver
about four in five; then blue, red, and a few others - the paint makers' yearly popularity
reports give these shares within a few points), clothes from a street's muted palette. Colours
are linear albedos; the render replaces the material's base colour with them (lit.glsl).
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from synthcompose.colour import LUM
from synthcompose.models import Model

from .plates import draw_registration

#: (name, share, linear albedo) of car paints
PAINTS = (
    ("white", 0.26, (0.62, 0.63, 0.62)),
    ("grey", 0.20, (0.13, 0.135, 0.14)),
    ("black", 0.18, (0.022, 0.022, 0.024)),
    ("silver", 0.12, (0.34, 0.35, 0.36)),
    ("blue", 0.10, (0.025, 0.05, 0.15)),
    ("red", 0.07, (0.30, 0.025, 0.02)),
    ("brown", 0.03, (0.10, 0.06, 0.035)),
    ("green", 0.02, (0.03, 0.08, 0.04)),
    ("beige", 0.02, (0.35, 0.28, 0.18)),
)
#: (name, share, linear albedo) of clothes
CLOTHES = (
    ("black", 0.30, (0.02, 0.02, 0.022)),
    ("navy", 0.15, (0.02, 0.03, 0.07)),
    ("grey", 0.15, (0.12, 0.12, 0.12)),
    ("denim", 0.12, (0.05, 0.08, 0.16)),
    ("white", 0.08, (0.55, 0.55, 0.53)),
    ("beige", 0.07, (0.30, 0.24, 0.16)),
    ("olive", 0.05, (0.07, 0.08, 0.03)),
    ("red", 0.04, (0.25, 0.03, 0.03)),
    ("brown", 0.04, (0.08, 0.045, 0.025)),
)
#: (name, share, linear albedo) of shoes
SHOES = (
    ("black", 0.40, (0.02, 0.02, 0.022)),
    ("brown", 0.18, (0.07, 0.04, 0.022)),
    ("white", 0.20, (0.55, 0.55, 0.53)),
    ("grey", 0.12, (0.12, 0.12, 0.125)),
    ("navy", 0.10, (0.025, 0.03, 0.07)),
)
#: the people's recolourable materials, by name, and the palette each is drawn from
NAMED_CLOTHES = (("clothes_top", CLOTHES), ("clothes_bottom", CLOTHES), ("shoes", SHOES))
VEHICLES = ("car", "truck", "bus", "caravan", "trailer", "train", "motorcycle", "bicycle")
PEOPLE = ("person", "rider")
#: paint is clear coated: glossier than this (glTF roughness)
PAINT_MAX_ROUGHNESS = 0.4
#: the material name that marks a vehicle's paint (docs/vehicles.md)
PAINT_NAME = "paint"
#: ... and a body in fixed colours (a bus's livery): without a paint, nothing is recoloured
LIVERY_NAME = "livery"


@dataclass(frozen=True)
class Appearance:
    """The colours one object is drawn with: ``recolour`` pairs (material key: its base colour
    factor, linear RGBA; new linear RGB), and their names."""

    recolour: tuple[tuple[tuple[float, float, float, float], tuple[float, float, float]], ...] = ()
    names: tuple[str, ...] = ()
    #: where the first colour stands in its palette (0 .. 1, by shares): in lightness and in
    #: colourfulness; the camera look places the object's tone there among the frame's own
    #: objects of its class (lighting.camera.object_tones)
    rank: tuple[float, float] = (0.5, 0.5)
    #: the registration on its number plates (a vehicle whose model has them, :mod:`.plates`)
    plate: str | None = None

    def to_dict(self) -> dict:
        out = {} if self.plate is None else {"plate": self.plate}
        if not self.names:
            return out
        kind = "paint" if len(self.names) == 1 else "clothes"
        return {kind: self.names[0] if kind == "paint" else list(self.names),
                "albedo_linear": [[round(float(c), 4) for c in rgb] for _, rgb in self.recolour],
                "rank": [round(v, 3) for v in self.rank]} | out


def _materials(model: Model) -> list[tuple[tuple[float, ...], float, float, float, bool]]:
    """(key rgba, surface m^2, metallic, roughness, textured) per distinct material of ``model``."""
    acc: dict[tuple, list] = {}
    for part in model.parts:
        if len(part.indices) == 0:
            continue
        tri = part.positions[part.indices]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        first = part.indices[:, 0]
        keys = np.round(part.colors[first], 4)
        mats = part.material[first]
        for key in np.unique(keys, axis=0):
            sel = np.all(keys == key, axis=1)
            k = tuple(float(v) for v in key)
            entry = acc.setdefault(k, [0.0, float(mats[sel][0, 0]), float(mats[sel][0, 1]), part.texture is not None])
            entry[0] += float(area[sel].sum())
    return [(k, *v) for k, v in acc.items()]


def _skin(rgb) -> bool:
    r, g, b = rgb[:3]
    return r > g > b > 0.01 and 1.5 <= r / b <= 6.0 and 0.1 <= float(LUM @ np.array([r, g, b], float)) <= 0.7


_FOUND: dict[tuple[str, str], list] = {}
#: models whose recolourable materials are remembered (a person posed per object is a new model)
FOUND_KEPT = 256


def _named(model: Model) -> list[tuple[tuple[float, float, float, float], tuple]]:
    """(material key, palette) of the people's named clothes materials in ``model``, in
    :data:`NAMED_CLOTHES`' order (none for a model without them)."""
    out = []
    for name, palette in NAMED_CLOTHES:
        part = next((p for p in model.parts if p.name == name and len(p.colors)), None)
        if part is not None:
            out.append((tuple(float(c) for c in np.round(part.colors[0], 4)), palette))
    return out


def recolourable(model: Model, class_name: str) -> list[tuple[float, float, float, float]]:
    """The material keys of ``model`` that vary for its class (module docstring); may be empty.
    Found once per model and class (the :data:`FOUND_KEPT` latest)."""
    key = (model.key, class_name)
    if key not in _FOUND:
        while len(_FOUND) >= FOUND_KEPT:
            _FOUND.pop(next(iter(_FOUND)))
        _FOUND[key] = _recolourable(model, class_name)
    return list(_FOUND[key])


def _named_paint(model: Model) -> list[tuple[float, float, float, float]]:
    """The base colour factors of the parts whose material is named ``paint`` (most surface first)."""
    keys: dict[tuple, float] = {}
    for part in model.parts:
        if part.name.strip().lower() != PAINT_NAME or len(part.indices) == 0 or part.transmission > 0:
            continue
        tri = part.positions[part.indices]
        area = float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
        key = tuple(float(v) for v in np.round(part.colors[part.indices[0, 0]], 4))
        keys[key] = keys.get(key, 0.0) + area
    return sorted(keys, key=lambda k: -keys[k])


def _recolourable(model: Model, class_name: str) -> list[tuple[float, float, float, float]]:
    if class_name in VEHICLES:
        named = _named_paint(model)
        if named:
            return named[:1]
        if any(part.name.strip().lower() == LIVERY_NAME for part in model.parts):
            return []
    if class_name in PEOPLE and _named(model):
        return [k for k, _ in _named(model)]
    mats = [m for m in _materials(model) if m[0][3] >= 0.99 and not m[4] and m[2] < 0.5]
    if class_name in VEHICLES:
        glossy = [m for m in mats if m[3] < PAINT_MAX_ROUGHNESS]
        return [max(glossy, key=lambda m: m[1])[0]] if glossy else []
    if class_name in PEOPLE:
        cloth = sorted((m for m in mats if not _skin(m[0])), key=lambda m: -m[1])
        return [m[0] for m in cloth[:3]]
    return []


def appearance_rng(seed: int, image_set: str, index: int) -> np.random.Generator:
    """The draws of object ``index`` of an image set: a function of (seed, image set, index) only,
    so that they do not move the placement's draws."""
    return np.random.default_rng([int(seed), zlib.crc32(image_set.encode()), int(index), 0x70616E74])


def draw_appearance(model: Model, class_name: str, rng: np.random.Generator) -> Appearance:
    """Colours for one object of ``class_name`` (none for a class or model without any), and the
    registration on its plates (a vehicle whose model has plates), drawn after the colours."""
    keys = recolourable(model, class_name)
    if not keys:
        return Appearance(plate=_plate(model, class_name, rng))
    palette = PAINTS if class_name in VEHICLES else CLOTHES
    palettes = dict(_named(model)) if class_name in PEOPLE else {}
    pairs, names = [], []
    for key in keys:
        pal = palettes.get(key, palette)
        shares = np.array([p[1] for p in pal])
        name, _, rgb = pal[int(rng.choice(len(pal), p=shares / shares.sum()))]
        # the same paint varies a little from car to car (age, make, dirt)
        rgb = np.clip(np.asarray(rgb) * float(rng.uniform(0.85, 1.15)), 0.0, 0.9)
        pairs.append((key, tuple(float(c) for c in rgb)))
        names.append(name)
    return Appearance(tuple(pairs), tuple(names), palette_rank(palette, names[0]), _plate(model, class_name, rng))


def _plate(model: Model, class_name: str, rng: np.random.Generator) -> str | None:
    """A registration for a vehicle whose model has number plates, else None."""
    return draw_registration(rng) if class_name in VEHICLES and any(p.plate for p in model.parts) else None


def _chroma(rgb) -> float:
    rgb = np.asarray(rgb, float)
    return float((rgb.max() - rgb.min()) / max(rgb.max(), 1e-6))


def palette_rank(palette, name: str) -> tuple[float, float]:
    """(lightness, colourfulness) rank of colour ``name`` in ``palette``: the share of the
    palette below it plus half its own share, by luminance and by chroma."""
    shares = np.array([p[1] for p in palette]) / sum(p[1] for p in palette)
    lum = np.array([np.dot(p[2], LUM) for p in palette])
    chroma = np.array([_chroma(p[2]) for p in palette])
    i = [p[0] for p in palette].index(name)
    rank = []
    for key in (lum, chroma):
        below = shares[key < key[i]].sum() + 0.5 * shares[key == key[i]].sum()
        rank.append(float(below))
    return rank[0], rank[1]
