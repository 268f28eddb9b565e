"""The batch manifest: JSON, validated against a JSON Schema, resolved into typed values.

Relative paths are relative to the manifest file's folder.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jsonschema
from cityscapesscripts.helpers.labels import name2label

from synthcompose.io.files import read_json
from synthcompose.lighting.light import Lighting
from synthcompose.placement.rules import GROUND_LEVEL, ORIENTATIONS, TRAFFIC_SIDES, orientation_for, surfaces_for

from .cast import CAST_PREFIX, CASTS, CastEntry, entry_digest, load_catalogue
from .errors import ManifestError
from .labels import INSERTABLE
from .models import BUILTIN_PREFIX
from .placement import PlacementRules

_AXIS = {"enum": ["+x", "-x", "+y", "-y", "+z", "-z"]}
_POS = {"type": "number", "minimum": 0.01, "maximum": 1000}  # metres: nothing smaller or larger is an object
#: split and city names: one folder level, no path tricks ("..", "/", "\\") nor control
#: characters, no space at either end; spaces and letters of any script are names too
#: ("bad homburg", "münchen", "Zürich-Nord")
_NAME = {"type": "string", "pattern": r"^(?!\.\.?$)(?!\s)(?![\s\S]*\s$)[^/\\\x00-\x1f\x7f]+$"}

SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "type": "object",
    "additionalProperties": False,
    "required": ["dataset", "output"],
    "anyOf": [{"required": ["objects"]}, {"required": ["cast"]}],
    "properties": {
        "dataset": {"type": "string", "minLength": 1, "description": "Cityscapes root"},
        "output": {"type": "string", "minLength": 1, "description": "output root (Cityscapes layout)"},
        "splits": {"type": "array", "items": _NAME, "minItems": 1, "uniqueItems": True},
        "cities": {"type": "array", "items": _NAME, "uniqueItems": True},
        "frames": {"type": "array",
                   "items": {"type": "string", "pattern": r"^(?!\s)(?![\s\S]*\s$)[^_/\\\x00-\x1f\x7f]+_[0-9]+_[0-9]+$"},
                   "uniqueItems": True},
        "limit": {"type": "integer", "minimum": 1},
        "seed": {"type": "integer", "minimum": 0, "maximum": 2**63 - 1},
        "objects_per_image": {"type": "integer", "minimum": 1, "maximum": 15},
        "object_choice": {"enum": ["weights", "balance"]},
        # an object that finds no place is replaced, once, by one drawn from the objects that
        # stand elsewhere in traffic (stages/place.py); false: it is left out
        "redraw_unplaced": {"type": "boolean"},
        # a built-in cast (cast/street.py): stands for a list of objects drawn from the catalogue;
        # "objects", when given too, adds to it
        "cast": {"enum": sorted(CASTS)},
        "objects": {
            "type": "array", "minItems": 1,
            "items": {
                "type": "object", "additionalProperties": False,
                "required": ["model"],
                # a model file or builtin needs its class and real size; a cast pool
                # ("cast:<class, kind or entry id>") has its entries' own
                "if": {"properties": {"model": {"pattern": "^cast:"}}},
                "then": {},
                "else": {"required": ["class", "size"]},
                "properties": {
                    "name": {"type": "string", "minLength": 1},
                    "model": {"type": "string", "minLength": 1},
                    "class": {"type": "string", "minLength": 1},
                    "size": {"type": "object", "minProperties": 1, "maxProperties": 1, "additionalProperties": False,
                             "properties": {"length": _POS, "width": _POS, "height": _POS}},
                    "up": _AXIS,
                    "forward": _AXIS,
                    "weight": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e6},
                    "allowed_surfaces": {"type": "array", "items": {"type": "string"}, "minItems": 1},
                    "orientation": {"enum": list(ORIENTATIONS)},
                    "appearance": {"enum": ["varied", "model"]},
                },
            },
        },
        "placement": {
            "type": "object", "additionalProperties": False,
            "properties": {
                "distance": {"type": "array", "items": {"type": "number", "minimum": 0, "maximum": 10_000},
                             "minItems": 2, "maxItems": 2},
                "max_attempts": {"type": "integer", "minimum": 1, "maximum": 1_000_000},
                "yaw_jitter_deg": {"type": "number", "minimum": 0, "maximum": 180},
                "min_footprint_allowed": {"type": "number", "minimum": 0, "maximum": 1},
                "clearance": {"type": "number", "minimum": 0, "maximum": 10},
                "object_gap": {"type": "number", "minimum": 0, "maximum": 100},
                # an object no pixel of which is seen is never written (stages/write.py)
                "min_visible_pixels": {"type": "integer", "minimum": 1, "maximum": 1 << 30},
                "max_occluded_fraction": {"type": "number", "minimum": 0, "maximum": 1},
                "allow_truncation": {"type": "boolean"},
                "parked_kerb_gap": {"type": "number", "minimum": 0, "maximum": 10},
                # which side of the road traffic keeps to (placement/traffic.py): German
                # Cityscapes frames are right-hand; "left-hand" for other countries' data
                "traffic": {"enum": list(TRAFFIC_SIDES)},
            },
        },
        "lighting": {
            "type": "object", "additionalProperties": False,
            "properties": {
                # --- lighting modes (lighting.py): "estimate" (default) measures each photo's
                # light; "fixed" (also: the sun_* keys without a mode) uses one light for all
                "mode": {"enum": ["estimate", "fixed"]},
                "sun_elevation_deg": {"type": "number", "minimum": 1, "maximum": 90},
                "sun_azimuth_deg": {"type": "number", "minimum": -360, "maximum": 360},
                "sun_fraction": {"type": "number", "minimum": 0, "maximum": 1},
                "match_exposure": {"type": "boolean"},
                "camera_match": {"type": "boolean"},
                # --- end lighting modes
            },
        },
        "render": {
            "type": "object", "additionalProperties": False,
            "properties": {
                # render.py: light shaded per sample of 4x MSAA, or per pixel and filled into the
                # samples (3x cheaper on llvmpipe); auto: per pixel on llvmpipe, per sample on a GPU
                "shading": {"enum": ["auto", "pixel", "sample"]},
                # the right photo of the stereo pair (rightImg8bit) gets the objects too, when the
                # input has one (stages/right.py); false: the left view alone, as before
                "right_view": {"type": "boolean"},
            },
        },
    },
}


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    model: str  # absolute path, "builtin:<name>" or "cast:<selector>"
    class_name: str
    size: tuple[tuple[str, float], ...]  # one (dimension, metres) pair; () for a cast pool at its entries' sizes
    up: str
    forward: str
    weight: float
    allowed_surfaces: tuple[str, ...]  # the class's default when the manifest gives none
    orientation: str  # likewise
    appearance: str = "varied"  # "varied": paint / clothes drawn per object (look/appearance.py); "model": as modelled
    cast: tuple[CastEntry, ...] = ()  # a cast pool: the entries each object of it is drawn from (cast/draw.py)


@dataclass(frozen=True)
class Manifest:
    path: Path
    dataset: Path
    output: Path
    splits: tuple[str, ...] | None  # None: every split folder found
    cities: tuple[str, ...] | None
    frames: tuple[str, ...] | None
    limit: int | None
    seed: int
    objects_per_image: int
    object_choice: str  # "weights" or "balance" (towards classes rare in the dataset)
    objects: tuple[ObjectSpec, ...]
    rules: PlacementRules
    lighting: Lighting
    raw: dict  # the manifest as given, recorded with the outputs
    lighting_keys: tuple[tuple[str, Any], ...] = ()  # the manifest's "lighting" keys as given: a fixed light's record
    # --- lighting modes (lighting.py)
    lighting_mode: str = "estimate"  # "estimate": each photo's own light; "fixed": `lighting` for all
    match_exposure: bool = False  # estimate mode: scale the light to the photo's exposure
    camera_match: bool = True  # give the inserted objects the photo's blur and noise
    # --- end lighting modes
    shading: str = "auto"  # render.py: "pixel", "sample", or "auto" (by the GL device)
    right_view: bool = True  # augment the right photo of the pair too, where the input has one
    redraw_unplaced: bool = True  # an object without a place is replaced by one that stands elsewhere
    _hash: list = field(default_factory=list, init=False, compare=False, repr=False)  # config_hash, once computed

    @property
    def config_hash(self) -> str:
        """sha256 of what decides the outputs (the manifest less its output root and limit, the
        model files' contents, the tool's version): a resumed batch keeps an image set's outputs
        only when its record carries the same. Computed once per manifest."""
        from . import __version__
        from .models import model_digest

        if self._hash:
            return self._hash[0]
        deciding = {k: v for k, v in self.raw.items() if k not in ("output", "limit")}
        # a changed model file (or cast entry, its model, its textures): redo
        models = {o.model: entry_digest(o.cast) if o.cast else model_digest(o.model) for o in self.objects}
        text = json.dumps({"manifest": deciding, "models": models, "version": __version__}, sort_keys=True)
        self._hash.append(hashlib.sha256(text.encode()).hexdigest())
        return self._hash[0]


#: what a field must be, said after the schema's own message about it
_HINTS = {"seed": " (the seed is a whole number from 0 to 2**63 - 1)",
          "limit": " (a whole number of image sets, 1 or more)",
          "objects_per_image": " (a whole number from 1 to 15)"}


def _where(err: jsonschema.ValidationError) -> str:
    return "/".join(str(p) for p in err.absolute_path) or "(top level)"


def _message(err: jsonschema.ValidationError) -> str:
    """The schema's message, said in words where it would show a regular expression, with what
    the field must be where a hint helps."""
    if err.validator == "pattern":
        what = "a frame name <city>_<seq>_<frame>" if err.absolute_path[0] == "frames" else "a folder name"
        return (f"{err.instance!r} is not {what} (one folder level: no '/', '\\', '.' or '..', no control "
                "character, no space at either end)")
    return err.message + _HINTS.get(_where(err), "")


def _whole_numbers(schema: dict, value: Any) -> Any:
    """``value`` with every number the schema types "integer" made an int (JSON Schema counts
    2.0 as an integer; Python's range() and NumPy's seeding do not)."""
    if schema.get("type") == "integer" and isinstance(value, float):
        return int(value)
    if isinstance(value, dict):
        props = schema.get("properties", {})
        return {k: _whole_numbers(props.get(k, {}), v) for k, v in value.items()}
    if isinstance(value, list):
        return [_whole_numbers(schema.get("items", {}), v) for v in value]
    return value


def _check_class(path: Path, i: int, name: str) -> None:
    """An object's class must be a Cityscapes thing (:data:`~.labels.INSERTABLE`): ``sky`` or
    ``road`` would be written as labels no object has, ``unlabeled`` as nothing."""
    if name not in INSERTABLE:
        what = "is not a Cityscapes class" if name not in name2label else \
            f"is Cityscapes' {name2label[name].category!r} class, not a thing an object can be"
        raise ManifestError(path, f"field 'objects/{i}/class': {name!r} {what}; one of {', '.join(map(repr, INSERTABLE))}")


def _check_surfaces(path: Path, where: str, surfaces) -> None:
    """An object's allowed surfaces must be grounds (:data:`~.placement.rules.GROUND_LEVEL`)."""
    for surface in surfaces:
        if surface not in GROUND_LEVEL:
            raise ManifestError(path, f"field '{where}/allowed_surfaces': {surface!r} is not a ground an "
                                      f"object can stand on; one of {', '.join(map(repr, GROUND_LEVEL))}")


def _pool(path: Path, where: str, selector: str, o: dict) -> ObjectSpec:
    """The object spec of a cast pool ``cast:<selector>`` (manifest object ``o``, at ``where``)."""
    catalogue = load_catalogue()
    entries = catalogue.pool(selector)
    if not entries:
        raise ManifestError(path, f"field '{where}/model': no cast entry matches {selector!r} "
                                  f"(known: {', '.join(catalogue.selectors())})")
    classes = sorted({e.class_name for e in entries})
    if len(classes) > 1:
        raise ManifestError(path, f"field '{where}/model': cast {selector!r} mixes classes {classes}; "
                                  "name a class or a kind")
    if o.get("class", classes[0]) != classes[0]:
        raise ManifestError(path, f"field '{where}/class': cast {selector!r} is class {classes[0]!r}, "
                                  f"not {o['class']!r}")
    _check_surfaces(path, where, o.get("allowed_surfaces", []))
    return ObjectSpec(
        name=o.get("name", selector), model=CAST_PREFIX + selector, class_name=classes[0],
        size=tuple((k, float(v)) for k, v in o.get("size", {}).items()), up="+z", forward="+x",
        weight=float(o.get("weight", 1.0)), allowed_surfaces=surfaces_for(classes[0], o.get("allowed_surfaces")),
        orientation=orientation_for(classes[0], o.get("orientation")), appearance=o.get("appearance", "varied"),
        cast=entries)


def _cast_objects(path: Path, name: str) -> list[ObjectSpec]:
    """The objects a built-in cast stands for: its pools that have entries in the catalogue."""
    catalogue = load_catalogue()
    objects = [_pool(path, "cast", selector, {"name": label, "weight": weight})
               for label, selector, weight in CASTS[name] if catalogue.pool(selector)]
    if not objects:
        raise ManifestError(path, f"field 'cast': the catalogue ({catalogue.root}) has no model for cast {name!r}")
    return objects


def parse_manifest(data: Any, path: Path) -> Manifest:
    """Validate ``data`` (parsed JSON) and resolve it; raises :class:`ManifestError` naming the field."""
    path = Path(path)
    if isinstance(data, dict) and "objects" not in data and "cast" not in data:
        raise ManifestError(path, "field 'objects' is required (or a built-in cast: \"cast\": \"street\")")
    validator = jsonschema.Draft202012Validator(SCHEMA)
    errors = sorted(validator.iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        msgs = "; ".join(f"field '{_where(e)}': {_message(e)}" for e in errors[:5])
        raise ManifestError(path, msgs)
    data = _whole_numbers(SCHEMA, data)  # 2.0 where an integer is asked (JSON Schema accepts it) -> 2
    base = path.parent
    objects = _cast_objects(path, data["cast"]) if "cast" in data else []
    for i, o in enumerate(data.get("objects", [])):
        if o["model"].startswith(CAST_PREFIX):
            objects.append(_pool(path, f"objects/{i}", o["model"][len(CAST_PREFIX):], o))
            continue
        _check_class(path, i, o["class"])
        _check_surfaces(path, f"objects/{i}", o.get("allowed_surfaces", []))
        model = o["model"] if o["model"].startswith(BUILTIN_PREFIX) else str((base / o["model"]).resolve())
        objects.append(ObjectSpec(
            name=o.get("name", Path(o["model"]).stem), model=model, class_name=o["class"],
            size=tuple((k, float(v)) for k, v in o["size"].items()),
            up=o.get("up", "+y" if not o["model"].startswith(BUILTIN_PREFIX) else "+z"),
            forward=o.get("forward", "+x"), weight=float(o.get("weight", 1.0)),
            allowed_surfaces=surfaces_for(o["class"], o.get("allowed_surfaces")),
            orientation=orientation_for(o["class"], o.get("orientation")), appearance=o.get("appearance", "varied")))
    p = data.get("placement", {})
    dist = tuple(float(v) for v in p.get("distance", PlacementRules.distance))
    if dist[0] >= dist[1]:
        raise ManifestError(path, f"field 'placement/distance': minimum {dist[0]} must be below maximum {dist[1]}")
    rules = PlacementRules(distance=dist, **{k: v for k, v in p.items() if k != "distance"})
    lt = data.get("lighting", {})
    lighting = Lighting.daylight(lt.get("sun_elevation_deg", 50.0), lt.get("sun_azimuth_deg", 135.0),
                                 lt.get("sun_fraction", 0.35))
    # --- lighting modes: the sun_* keys alone (the old form) mean a fixed light
    sun_keys = [k for k in ("sun_elevation_deg", "sun_azimuth_deg", "sun_fraction") if k in lt]
    lighting_mode = lt.get("mode", "fixed" if sun_keys else "estimate")
    if lighting_mode == "estimate" and sun_keys:
        raise ManifestError(path, f"field 'lighting/{sun_keys[0]}': only with \"mode\": \"fixed\" "
                                  "(\"estimate\" measures the sun in each photo)")
    if lighting_mode == "fixed" and "match_exposure" in lt:
        raise ManifestError(path, "field 'lighting/match_exposure': only with \"mode\": \"estimate\"")
    # --- end lighting modes
    return Manifest(
        path=path, dataset=(base / data["dataset"]).resolve(), output=(base / data["output"]).resolve(),
        splits=tuple(data["splits"]) if "splits" in data else None,
        cities=tuple(data["cities"]) if "cities" in data else None,
        frames=tuple(data["frames"]) if "frames" in data else None,
        limit=data.get("limit"), seed=int(data.get("seed", 0)),
        objects_per_image=int(data.get("objects_per_image", 1)),
        object_choice=data.get("object_choice", "weights"), objects=tuple(objects),
        rules=rules, lighting=lighting, raw=data, lighting_keys=tuple(lt.items()),
        lighting_mode=lighting_mode, match_exposure=bool(lt.get("match_exposure", False)),  # lighting modes
        camera_match=bool(lt.get("camera_match", True)),
        shading=data.get("render", {}).get("shading", "auto"),
        right_view=bool(data.get("render", {}).get("right_view", True)),
        redraw_unplaced=bool(data.get("redraw_unplaced", True)))


def load_manifest(path: str | Path) -> Manifest:
    path = Path(path)
    return parse_manifest(read_json(path), path)
