"""The cast's catalogue: every ``<root>/<group>/<id>/entry.json``, validated and frozen.

The root is the installed package data ``synthcompose.cast_assets`` (``assets/cast/`` of the
checkout, shipped in the wheel): a wheel alone has its cast. An entry names its model (a file
beside it, or ``builtin:sign`` for a traffic sign built in code, :mod:`..models.signs`), its
Cityscapes class and kind, its real size and its share in the default street mix; a bad entry
is a :class:`~synthcompose.errors.ModelError` naming its file.
"""
from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema

from synthcompose.errors import ModelError
from synthcompose.io.files import read_json
from synthcompose.labels import INSERTABLE

#: a manifest's ``"model": "cast:<selector>"`` draws from the catalogue
CAST_PREFIX = "cast:"
#: an entry's model built in code: a German traffic sign (its plate in the entry's ``sign``)
SIGN_MODEL = "builtin:sign"
GROUPS = ("vehicles", "people", "signs")

_AXIS = {"enum": ["+x", "-x", "+y", "-y", "+z", "-z"]}
_POS = {"type": "number", "exclusiveMinimum": 0, "maximum": 1000}
_ID = {"type": "string", "pattern": r"^[a-z0-9][a-z0-9-]*$", "maxLength": 64}
ENTRY_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "type": "object",
    "additionalProperties": False,
    "required": ["id", "class", "kind", "model", "weight", "licence", "source"],
    "properties": {
        "id": _ID,
        "class": {"type": "string", "minLength": 1},
        "kind": {"type": "string", "pattern": r"^[a-z0-9][a-z0-9.-]*$", "maxLength": 64},
        "model": {"type": "string", "minLength": 1},
        "up": _AXIS,
        "forward": _AXIS,
        "size": {"type": "object", "minProperties": 1, "maxProperties": 1, "additionalProperties": False,
                 "properties": {"length": _POS, "width": _POS, "height": _POS}},
        "weight": {"type": "number", "minimum": 0, "maximum": 1e6},
        "licence": {"type": "string", "minLength": 1},
        "source": {"type": "string", "minLength": 1},
        "description": {"type": "string"},
        "rig": {"type": "string", "minLength": 1},
        "body": {"type": "object"},
        "sign": {
            "type": "object", "additionalProperties": False, "required": ["face", "width_mm", "height_mm"],
            "properties": {
                "face": {"type": "string", "minLength": 1},
                "width_mm": {"type": "number", "minimum": 100, "maximum": 5000},
                "height_mm": {"type": "number", "minimum": 100, "maximum": 5000},
                "lower_edge_m": {"type": "array", "minItems": 1, "items": {"type": "number", "minimum": 0.5,
                                                                           "maximum": 6}},
                "faces": {"enum": ["traffic", "away"]},
                "below": {"type": "array", "items": {
                    "type": "object", "additionalProperties": False, "required": ["id", "p"],
                    "properties": {"id": _ID, "p": {"type": "number", "minimum": 0, "maximum": 1}}}},
            },
        },
    },
    # a model file is scaled to its one real dimension; a sign has its plate's size instead
    "if": {"properties": {"model": {"const": SIGN_MODEL}}},
    "then": {"required": ["sign"]},
    "else": {"required": ["size"]},
}
#: a traffic sign's lower edge above the footway when its entry names none (VwV-StVO: 2.0 m as
#: a rule; signs stand a little higher where the pole is older or the footway narrow)
LOWER_EDGE_M = (2.0, 2.1, 2.2)


@dataclass(frozen=True)
class SignSpec:
    """A traffic sign entry's plate: face texture (absolute path), real size (metres), the
    heights its lower edge may have, and the supplementary signs that may hang under it."""

    face: str
    width_m: float
    height_m: float
    lower_edge_m: tuple[float, ...] = LOWER_EDGE_M
    #: (entry id, its kind, probability, its plate) of each supplementary sign that may hang under it
    below: tuple[tuple[str, str, float, "SignSpec"], ...] = ()
    #: ``traffic``: its face towards the traffic of the lane beside it; ``away``: its back to the
    #: ego vehicle's way on either kerb (no entry, no vehicles: facing the cars going our way it
    #: would tell them they should not be there)
    faces: str = "traffic"


@dataclass(frozen=True)
class CastEntry:
    """One model of the catalogue (``entry.json``; see docs/cast.md)."""

    id: str
    class_name: str
    kind: str
    group: str  # vehicles, people or signs: the folder it is in
    model: str  # absolute path of the model file, or "builtin:sign"
    up: str
    forward: str
    size: tuple[tuple[str, float], ...] | None  # one (dimension, metres) pair; None for a sign
    weight: float
    licence: str
    source: str
    folder: Path
    rig: str | None = None  # people: a skinned glTF, posed per object
    body: tuple[tuple[str, Any], ...] = ()  # people: sex, age, build, hair, clothes
    sign: SignSpec | None = None

    @property
    def body_dict(self) -> dict[str, Any]:
        return dict(self.body)


def _entry(path: Path, group: str) -> CastEntry:
    data = read_json(path)
    errors = sorted(jsonschema.Draft202012Validator(ENTRY_SCHEMA).iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        where = ["/".join(str(p) for p in e.absolute_path) or "(top level)" for e in errors[:3]]
        raise ModelError(path, "; ".join(f"field '{w}': {e.message}" for w, e in zip(where, errors)))
    if data["id"] != path.parent.name:
        raise ModelError(path, f"id {data['id']!r} must be the name of its folder ({path.parent.name!r})")
    if data["class"] not in INSERTABLE:
        raise ModelError(path, f"field 'class': {data['class']!r} is not a Cityscapes class an object can be; "
                               f"one of {', '.join(map(repr, INSERTABLE))}")
    folder = path.parent
    model = data["model"]
    if model != SIGN_MODEL:
        if Path(model).name != model:
            raise ModelError(path, f"field 'model': {model!r} must be a file beside entry.json (or {SIGN_MODEL!r})")
        if not (folder / model).is_file():
            raise ModelError(path, f"field 'model': {folder / model} is missing")
        model = str((folder / model).resolve())
    sign = None
    if "sign" in data:
        s = data["sign"]
        face = folder / s["face"]
        if Path(s["face"]).name != s["face"] or not face.is_file():
            raise ModelError(path, f"field 'sign/face': {face} is missing")
        sign = SignSpec(str(face.resolve()), s["width_mm"] / 1000.0, s["height_mm"] / 1000.0,
                        tuple(float(v) for v in s.get("lower_edge_m", LOWER_EDGE_M)),
                        tuple((b["id"], "", float(b["p"]), None) for b in s.get("below", [])),  # resolved by load_catalogue
                        s.get("faces", "traffic"))
    return CastEntry(
        id=data["id"], class_name=data["class"], kind=data["kind"], group=group, model=model,
        up=data.get("up", "+y"), forward=data.get("forward", "+x"),
        size=tuple((k, float(v)) for k, v in data["size"].items()) if "size" in data else None,
        weight=float(data["weight"]), licence=data["licence"], source=data["source"], folder=folder.resolve(),
        rig=data.get("rig"), body=tuple(sorted(data.get("body", {}).items())), sign=sign)


def cast_root() -> Path:
    """Where the installed cast is (the package data ``synthcompose.cast_assets``)."""
    return Path(str(resources.files("synthcompose.cast_assets")))


@dataclass(frozen=True)
class Catalogue:
    """Every entry under one root, by id."""

    root: Path
    entries: tuple[CastEntry, ...]

    def get(self, entry_id: str) -> CastEntry:
        for e in self.entries:
            if e.id == entry_id:
                return e
        raise KeyError(f"no cast entry {entry_id!r}")

    def pool(self, selector: str) -> tuple[CastEntry, ...]:
        """The entries a ``cast:<selector>`` draws from: those of that class, else of that kind
        (weight above 0), else the one with that id; empty when none matches."""
        for field in ("class_name", "kind"):
            found = tuple(e for e in self.entries if getattr(e, field) == selector and e.weight > 0)
            if found:
                return found
        return tuple(e for e in self.entries if e.id == selector)

    def selectors(self) -> list[str]:
        """Every class and kind that has entries with a weight (for error messages)."""
        return sorted({e.class_name for e in self.entries if e.weight > 0} |
                      {e.kind for e in self.entries if e.weight > 0 and e.group != "signs"} | {"<entry id>"})


@functools.lru_cache(maxsize=4)
def load_catalogue(root: Path | None = None) -> Catalogue:
    """Read and check every entry under ``root`` (default: the installed cast); cached."""
    root = Path(root) if root is not None else cast_root()
    entries, seen = [], {}
    for path in sorted(root.glob("*/*/entry.json")):
        group = path.parent.parent.name
        if group not in GROUPS:
            raise ModelError(path, f"cast entries live under {', '.join(GROUPS)}, not {group!r}")
        entry = _entry(path, group)
        if entry.id in seen:
            raise ModelError(path, f"id {entry.id!r} is taken by {seen[entry.id]}")
        seen[entry.id] = path
        entries.append(entry)
    by_id = {e.id: e for e in entries}
    for i, e in enumerate(entries):
        if e.sign is None or not e.sign.below:
            continue
        below = []
        for entry_id, _, p, _ in e.sign.below:
            other = by_id.get(entry_id)
            if other is None or other.sign is None:
                raise ModelError(e.folder / "entry.json", f"field 'sign/below': {entry_id!r} is not a sign entry")
            below.append((entry_id, other.kind, p, other.sign))
        entries[i] = replace(e, sign=replace(e.sign, below=tuple(below)))
    return Catalogue(root, tuple(entries))


def entry_digest(entries) -> str:
    """sha256 of every file in the entries' folders (entry.json, model, textures, licence) and
    in those of the signs that may hang under them: what decides how they render (a resumed
    batch redoes its image sets when one changes)."""
    h = hashlib.sha256()
    folders = {e.folder for e in entries} | {Path(b[3].face).parent for e in entries if e.sign for b in e.sign.below}
    for folder in sorted(folders):
        for f in sorted(p for p in folder.rglob("*") if p.is_file()):
            h.update(f.relative_to(folder.parent).as_posix().encode() + b"\0")
            h.update(f.read_bytes())
    return h.hexdigest()
