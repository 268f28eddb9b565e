"""Stage 3 - placement: the manifest's objects drawn and placed in one prepared frame
-> :class:`Placed` (the objects with their poses and instance ids, those that found no place,
and the record's first part)."""
from __future__ import annotations

import logging
import zlib
from collections import Counter
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from synthcompose import __version__
from synthcompose.cast import CastDraw, cast_model, cast_rng, draw_entry, mounted_higher
from synthcompose.errors import InputError, SynthComposeError
from synthcompose.io.dataset import ImageSetId, input_fingerprint, polygon_instance_counts
from synthcompose.labels import HAS_INSTANCES, INSTANCE_FACTOR, label_id
from synthcompose.manifest import ObjectSpec
from synthcompose.models import Model, load_model, posable, pose_rng, posed_model
from synthcompose.models.poses import KINDS, WALKING_SHARE
from synthcompose.placement import Placement, PlacementResult, check_pose, frame_noise, no_ground, place_object
from synthcompose.placement.ends import end_record
from synthcompose.placement.lanes import lanes
from synthcompose.placement.noise import StereoNoise
from synthcompose.placement.rules import orientation_for, rules_dict
from synthcompose.placement.saved_poses import SavedPlacement, pose_problem, saved_result
from synthcompose.placement.traffic import hand_of
from synthcompose.record import ImageSetRecord

from .options import PlaceOptions
from .prepare import Prepared
from .timing import Timings, timed

log = logging.getLogger("synthcompose")

def new_instance_id(instance_ids: np.ndarray, class_id: int, taken: set[int]) -> int:
    """class_id * 1000 + k with k above every instance of that class in the frame (and in
    ``taken``); classes without instances keep their plain id (cityscapesScripts rule)."""
    if not HAS_INSTANCES[class_id]:
        return class_id
    ids = np.unique(instance_ids[instance_ids >= INSTANCE_FACTOR])
    existing = [int(i) % INSTANCE_FACTOR for i in ids if int(i) // INSTANCE_FACTOR == class_id]
    existing += [i % INSTANCE_FACTOR for i in taken if i // INSTANCE_FACTOR == class_id]
    k = max(existing, default=-1) + 1
    if k >= INSTANCE_FACTOR:
        raise SynthComposeError(f"holds instance {class_id * INSTANCE_FACTOR + k - 1} of class {class_id} already: "
                                f"no instance id is left for another (ids end at {class_id * INSTANCE_FACTOR + 999})")
    return class_id * INSTANCE_FACTOR + k


@dataclass(frozen=True)
class NotPlaced:
    """An object that found no place: why, after how many candidates, and each rejection's count."""

    name: str
    class_name: str
    reason: str
    attempts: int
    rejections: tuple[tuple[str, int], ...]  # (reason, candidates rejected for it), in the order first met
    replaced_by: str | None = None  # the object of another kind drawn and placed instead (its name)
    substitute_for: str | None = None  # this was drawn instead of that object, and found no place either

    def to_json(self) -> dict:
        return {"name": self.name, "class": self.class_name, "reason": self.reason, "attempts": self.attempts,
                "rejections": dict(self.rejections)} \
            | ({"replaced_by": self.replaced_by} if self.replaced_by else {}) \
            | ({"substitute_for": self.substitute_for} if self.substitute_for else {})


@dataclass(frozen=True)
class PoseCheck:
    """Whether the batch's rules accept a saved pose (used as it is); the rule it breaks if not."""

    ok: bool
    rule: str | None = None
    reason: str | None = None
    detail: str | None = None

    def to_json(self) -> dict:
        return {"ok": True} if self.ok else {"ok": False, "rule": self.rule, "reason": self.reason,
                                             "detail": self.detail}


@dataclass(frozen=True, eq=False)
class PlacedObject:
    """One object with a place: its manifest entry, model, pose and instance id."""

    spec: ObjectSpec
    model: Model
    result: PlacementResult  # the pose and the candidates' rejections
    instance_id: int
    check: PoseCheck | None  # a saved pose: whether the batch's rules accept it
    cast: CastDraw | None = None  # a cast pool's object: the entry it got (the record's appearance)
    pose: Mapping[str, Any] | None = None  # a person posed for this object: its pose (models.poses), for the record

    @property
    def placement(self) -> Placement:
        return self.result.placement


@dataclass(frozen=True, eq=False)
class Placed:
    """The placement of one frame."""

    objects: tuple[PlacedObject, ...]
    failures: tuple[NotPlaced, ...]  # each object without a place
    saved: SavedPlacement | None  # the poses came from a saved placement
    noise: StereoNoise  # the frame's stereo error: in the record, and the compose's ground band
    record: ImageSetRecord  # the record so far (no objects, no status)


def saved_spec(objects: tuple[ObjectSpec, ...], saved: SavedPlacement, k: int) -> ObjectSpec:
    """The manifest object a saved placement names (placement/saved_poses.py)."""
    name = saved.objects[k].name
    for spec in objects:
        if spec.name == name:
            return spec
    raise InputError(saved.path, f"saved placement names object {name!r}, which the manifest does not have "
                                 f"({', '.join(repr(s.name) for s in objects)})")


def object_model(seed: int, spec: ObjectSpec, key: str, index: int, pose: str | None = None,
                 lowest: bool = False) -> tuple[Model, CastDraw | None, dict | None]:
    """The model of the ``index``-th object placed in image set ``key``: for a cast pool, an entry
    drawn (and posed) with the cast's own generator; a person's file with MakeHuman's skeleton
    posed for it (its own seeded draw, models.skinning) with its pose; else the spec's file or
    builtin as it is. ``pose``: a person's pose kind (``walking`` / ``standing``; None: any);
    ``lowest``: a cast sign at its lowest mounting (the same draw)."""
    if spec.cast:
        rng = cast_rng(seed, key, index)
        model, drawn = cast_model(draw_entry(spec.cast, rng), spec.size or None, rng, pose, lowest)
        return model, drawn, None
    if spec.class_name in ("person", "rider") and posable(spec.model):
        model, posed = posed_model(spec.model, spec.size, spec.up, spec.forward, pose_rng(seed, key, index), pose)
        return model, None, posed
    return load_model(spec.model, spec.size, spec.up, spec.forward), None, None


def pose_kind(seed: int, spec: ObjectSpec, key: str, index: int) -> str | None:
    """A person who follows the footway (orientation ``pedestrian``): ``walking`` or
    ``standing``, decided before the placement (its own draw of (seed, image set, index)) so
    that the model is posed so and the placement's checks use the posed model's extents; the
    placement then puts the pose where it fits (walking along the footway, standing facing the
    road). None for other objects."""
    if spec.class_name != "person" or orientation_for(spec.class_name, spec.orientation) != "pedestrian":
        return None
    rng = np.random.default_rng([int(seed), zlib.crc32(key.encode()), int(index), 0x6B696E64])
    return "walking" if rng.random() < WALKING_SHARE else "standing"


def _posed_as(drawn: CastDraw | None, pose: dict | None) -> str | None:
    """The pose kind a model was given (``walking`` / ``standing``), or ``away`` for a sign
    that shows its back to the ego vehicle's way (the cast's ``faces``); None otherwise."""
    if drawn is not None and (drawn.appearance.get("sign") or {}).get("faces") == "away":
        return "away"
    kind = (pose or (drawn.appearance.get("pose") if drawn is not None else None) or {}).get("pose")
    return kind if kind in KINDS else None


def _taken_by_polygons(dataset: Path, ident: ImageSetId) -> set[int]:
    """With an input polygons file, the ids its entries number (cityscapesScripts counts them):
    an inserted instance appended after them gets the next."""
    source = ident.path(dataset, "polygons")
    if not source.is_file():
        return set()
    return {cid * INSTANCE_FACTOR + n - 1 for cid, n in polygon_instance_counts(source).items() if n}


def _place_one(o: PlaceOptions, prep: Prepared, spec: ObjectSpec, objects: list, taken: set[int],
               saved_object=None, trace: list | None = None,
               saved_from: SavedPlacement | None = None) -> "PlacedObject | NotPlaced":
    """One object placed among ``objects`` (placed before it): its PlacedObject, or the
    failure."""
    ident, image_set, frame = prep.ident, prep.image_set, prep.frame
    kind = pose_kind(o.seed, spec, ident.key, len(objects)) if saved_object is None else None
    model, drawn, pose = object_model(o.seed, spec, ident.key, len(objects), kind)
    if saved_object is not None and (problem := pose_problem(frame, model.extents, saved_object.matrix)):
        raise InputError(saved_from.path, f"saved placement object {saved_from.objects.index(saved_object)} "
                                          f"({spec.name!r}) {problem}")
    others = [o.placement for o in objects]
    result = _search(o, prep, spec, model.extents, others, trace, _posed_as(drawn, pose)) \
        if saved_object is None else saved_result(frame, spec.class_name, model.extents, saved_object)
    if result.placement is None and saved_object is None and mounted_higher(drawn):
        model, drawn, result = _mounted_lowest(o, prep, spec, len(objects), others, drawn, result, trace)
    if result.placement is None:
        return NotPlaced(spec.name, spec.class_name, "no valid placement", result.attempts,
                         tuple(result.rejections.items()))
    check = None
    if saved_object is not None:  # a saved pose is used as it is; the record says whether the
        # batch's rules accept it (Shift+S in the preview saves a pose that breaks them)
        why = check_pose(frame, spec.class_name, model.extents, result.placement.matrix, o.rules,
                         spec.allowed_surfaces, others)
        check = PoseCheck(True)
        if why is not None:
            check = PoseCheck(False, why.rule, why.reason, why.detail)
            log.warning("%s: saved pose of %s breaks a placement rule: %s", ident.key, spec.name, why)
    try:
        inst = new_instance_id(image_set.instance_ids, label_id(spec.class_name), taken)
    except SynthComposeError as exc:  # the frame's instance ids (or its polygons) use them all
        raise InputError(ident.path(o.dataset, "instanceIds"), str(exc)) from None
    taken.add(inst)
    return PlacedObject(spec, model, result, inst, check, drawn, None if pose is None else MappingProxyType(pose))


def _search(o: PlaceOptions, prep: Prepared, spec: ObjectSpec, extents, others: list, trace: list | None,
            hint: str | None) -> PlacementResult:
    """The placement's search for one object of ``extents`` among ``others`` (the frame's
    generator goes on from the objects placed before it)."""
    return place_object(prep.frame, spec.class_name, extents, prep.rng, o.rules, spec.allowed_surfaces,
                        spec.orientation, others, trace=trace, pose_hint=hint)


def _mounted_lowest(o: PlaceOptions, prep: Prepared, spec: ObjectSpec, index: int, others: list, drawn: CastDraw,
                    failed: PlacementResult, trace: list | None) -> tuple[Model, CastDraw, PlacementResult]:
    """A sign drawn higher than its lowest mounting that found no place, placed again mounted
    lowest (its least lower edge, no plate under it): a sign must stand farther off the taller
    it is to be seen whole (the top of the view looks about 10 degrees up), and a view with
    little footway far enough off holds it lower. Its model, draw (``lowered_from``: the
    mounting first drawn) and result, or, placed nowhere either, the attempts of both."""
    model, low, _ = object_model(o.seed, spec, prep.ident.key, index, lowest=True)
    result = _search(o, prep, spec, model.extents, others, trace, _posed_as(low, None))
    if result.placement is None:
        rejections = Counter(dict(failed.rejections)) + Counter(dict(result.rejections))
        return model, low, PlacementResult(None, failed.attempts + result.attempts, dict(rejections))
    first = drawn.appearance["sign"]
    sign = dict(low.appearance["sign"], lowered_from={"below": first["below"], "lower_edge_m": first["lower_edge_m"]})
    return model, replace(low, appearance={**low.appearance, "sign": sign}), result


def where_it_stands(class_name: str) -> str:
    """The kind of place an object of this class takes in traffic: its class's own orientation
    rule (vehicles in a lane or at the kerb, people on a footway, signs at the kerb's edge)."""
    return orientation_for(class_name)


#: the places in traffic (:func:`where_it_stands`) taken first in a frame: the footway's edge
#: and the footway are narrow and a vehicle in the lane beside them hides them (it may stand a
#: little further on), while a person or a sign placed first rarely leaves a car no lane
FOOTWAY_FIRST = ("pedestrian", "facing-traffic")
#: a slot whose object found no place gets up to this many substitutes, each its own draw
REDRAWS = 2
#: vehicles that need more free road than a car: one of them finding no place does not mean
#: that a car finds none
LARGE_VEHICLES = ("bus", "truck", "caravan", "trailer")


def stands_like(class_name: str, failed: str) -> bool:
    """Whether an object of ``class_name`` needs what one of class ``failed`` found nowhere in
    the frame: the same kind of place in traffic (:func:`where_it_stands`), and at least its
    size (a car may fit in a lane where a bus did not)."""
    if where_it_stands(class_name) != where_it_stands(failed):
        return False
    return not (failed in LARGE_VEHICLES and class_name not in LARGE_VEHICLES)


def _redraw(o: PlaceOptions, weights: np.ndarray, prep: Prepared, objects: list, failures: list[NotPlaced],
            taken: set[int], trace: list | None) -> list[NotPlaced]:
    """Each object that found no place is replaced by one drawn by ``weights`` from the
    manifest's objects that need something else than any that failed in this frame
    (:func:`stands_like`): a street whose lanes are taken gets a person or a sign instead of a
    third car, a frame without footway a car instead of a person, a lane too short for a bus a
    car. A substitute that finds no place either is followed by another, up to ``REDRAWS``.
    The failures, each with what replaced it (or its substitutes' own failures), for the record."""
    failed = [f.class_name for f in failures]
    out: list[NotPlaced] = []
    for f in failures:
        tried: list[NotPlaced] = []
        for _ in range(REDRAWS):
            pick = [i for i, s in enumerate(o.objects)
                    if weights[i] > 0 and not any(stands_like(s.class_name, c) for c in failed)]
            if not pick:
                break
            p = weights[pick] / weights[pick].sum()
            spec = o.objects[pick[int(prep.rng.choice(len(pick), p=p))]]
            done = _place_one(o, prep, spec, objects, taken, None, trace)
            if isinstance(done, PlacedObject):
                objects.append(done)
                f = replace(f, replaced_by=spec.name)
                break
            failed.append(spec.class_name)
            tried.append(replace(done, substitute_for=f.name))
        out += [f, *tried]
    return out


def drawable(o: PlaceOptions, weights: np.ndarray, prep: Prepared) -> tuple[np.ndarray, dict[str, str]]:
    """The weights the frame's objects are drawn by, and what is not drawn, by name, and why.
    With ``redraw_unplaced`` (the manifest asks for a number of objects, not for each kind) an
    object whose surfaces the frame does not show in the distance range (a person where no
    footway is seen) is not drawn: it could stand nowhere (the search's own first test). Where
    every object can stand, or none can, the weights as they are (the same draws)."""
    if not o.redraw_unplaced:
        return weights, {}
    why = {s.name: no_ground(prep.frame, s.class_name, s.allowed_surfaces, o.rules)
           for s, w in zip(o.objects, weights) if w > 0}
    nowhere = {name: reason for name, reason in why.items() if reason is not None}
    if not nowhere or len(nowhere) == len(why):
        return weights, {}
    kept = np.array([w if s.name not in nowhere else 0.0 for s, w in zip(o.objects, weights)])
    return kept / kept.sum(), nowhere


def place(o: PlaceOptions, weights: np.ndarray, prep: Prepared, timings: Timings,
          saved: SavedPlacement | None = None, trace: list | None = None) -> Placed:
    """Draw ``o.objects_per_image`` objects (by ``weights``) and place each in the frame, the
    ones placed before it standing, people and signs first (:data:`FOOTWAY_FIRST`; the record
    lists them as drawn); or, with ``saved``, use its objects and poses as they are (the record
    says whether the rules accept them). ``trace``: a list that gets (candidate point, rejection
    reason) of every rejected candidate (the preview shows them)."""
    ident, image_set, frame, rng = prep.ident, prep.image_set, prep.frame, prep.rng
    objects: list[PlacedObject] = []
    taken = _taken_by_polygons(o.dataset, ident)  # instance ids given
    with timed(timings, "placement"):
        not_drawn: dict[str, str] = {}
        if saved is None:  # drawn first, then placed: those that stand on a footway before vehicles
            weights, not_drawn = drawable(o, weights, prep)
            specs = [o.objects[int(rng.choice(len(o.objects), p=weights))] for _ in range(o.objects_per_image)]
            order = sorted(range(len(specs)), key=lambda k: where_it_stands(specs[k].class_name) not in FOOTWAY_FIRST)
        else:
            specs = [saved_spec(o.objects, saved, k) for k in range(len(saved.objects))]
            order = list(range(len(specs)))
        slots = {}
        for k in order:
            slots[k] = done = _place_one(o, prep, specs[k], objects, taken,
                                         saved.objects[k] if saved is not None else None, trace, saved)
            if isinstance(done, PlacedObject):
                objects.append(done)  # the next ones are placed among it
        drawn = [slots[k] for k in sorted(slots)]  # the record lists them as they were drawn
        objects = [d for d in drawn if isinstance(d, PlacedObject)]
        failures: list[NotPlaced] = [d for d in drawn if not isinstance(d, PlacedObject)]
        if saved is None and not objects and failures:
            # a frame that got none of its objects tries each of them once more (twice the
            # attempts): a frame with free road or footway gets an object where one fits
            again, failures = failures, []
            for f in again:
                spec = next(s for s in o.objects if s.name == f.name)
                done = _place_one(o, prep, spec, objects, taken, None, trace)
                if isinstance(done, PlacedObject):
                    objects.append(done)
                else:
                    rejections = Counter(dict(f.rejections)) + Counter(dict(done.rejections))
                    failures.append(replace(done, attempts=f.attempts + done.attempts,
                                            rejections=tuple(rejections.items())))
        if saved is None and failures and o.redraw_unplaced:
            failures = _redraw(o, weights, prep, objects, failures, taken, trace)
    noise = frame_noise(frame)
    hand = hand_of(o.rules.traffic)
    street = frame.made(("street", hand))  # found when an object asked for it
    record = ImageSetRecord(
        image_set=ident.key, synthcompose_version=__version__, config_sha256=o.config_hash, seed=o.seed,
        source={k: str(ident.path(o.dataset, k)) for k in ("rgb", "labelIds", "instanceIds", "disparity", "camera")}
        | ({"right": str(ident.path(o.dataset, "right"))} if prep.image_set.right_rgb is not None else {}),
        source_fingerprint=input_fingerprint(o.dataset, ident),  # resume: a changed input is redone
        labels="gtFine" if image_set.labelled else prep.surfaces.to_dict(),
        stereo_noise=noise.to_dict(),
        lighting=dict(o.light_record),  # an estimate replaces it when the objects are shaded
        not_placed=tuple(f.to_json() for f in failures),
        placement_file=None if saved is None else {"path": str(saved.path) if saved.path else None,
                                                   "sha256": saved.sha256},
        street=None if street is None else street.to_dict() | {
            "lanes": [lane.to_dict() for lane in lanes(frame, street, hand)], "end": end_record(frame, street)},
        placement_rules=rules_dict(o.rules), not_drawn=not_drawn or None)
    return Placed(tuple(objects), tuple(failures), saved, noise, record)

