"""The record of one image set (``synthcompose/<split>/<city>/<name>_synthcompose.json``), typed.

Every writer and reader of records goes through :class:`ImageSetRecord` and
:class:`ObjectRecord`: the pipeline's stages build them, :meth:`ImageSetRecord.to_json` gives
the JSON document (key order fixed, written last: its presence means the set is complete),
and :meth:`ImageSetRecord.from_json` reads one back for resume, the COCO file, ``report``,
``check-placement`` and ``compare-lighting``, raising :class:`RecordError` (naming the file)
on a document that is not a record.

Units and frames: metres; poses as 4x4 matrices (rounded to 6 decimals in the JSON) in the
vehicle frame V (ISO 8855) and the optical camera frame (:mod:`synthcompose.camera`); 2D
boxes ``[x0, y0, x1, y1]`` in pixels, x1/y1 exclusive; colours linear RGB. The lighting,
camera match, appearance and camera-look entries are the documents their own modules write
(``to_dict``), kept as mappings.

``record_version`` counts changes of this layout; records without it are version 0 (read
the same way: the layout did not change, the key was added). Version 2 added, per object,
``traffic`` (where it stands in traffic: role moving / parked / walking / standing / sign, lane
side, direction with or against the ego vehicle, its road-frame position, the pose hint of a
person: ``placement.claim.Traffic``), and per image set ``street`` (the street found: axis,
carriageways, centre lines, markings, crossings; ``placement.street``) and ``placement_rules``
(the rules the objects were placed by, which check-placement checks them by); version 1
records read without them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .errors import InputError

RECORD_VERSION = 2


class Status(StrEnum):
    """One vocabulary for what became of an image set: its batch outcome (``done``, ``skipped``,
    ``failed``) and its record's status (``done``, ``no valid placement``: the record of a
    skipped set). A ``str``: written to JSON and compared as its value."""

    DONE = "done"
    SKIPPED = "skipped"
    FAILED = "failed"
    NO_PLACEMENT = "no valid placement"

Box = tuple[int, int, int, int]


class RecordError(InputError):
    """A record file that is not a record this version can read."""


def _matrix(m) -> list[list[float]]:
    return [[round(float(v), 6) for v in row] for row in m]


def _rounded(values, digits: int) -> list[float]:
    return [round(float(v), digits) for v in values]


@dataclass(frozen=True)
class ObjectPose:
    """An object's pose: ``vehicle`` = V <- object (4x4), ``optical`` = camera optical <- object."""

    vehicle: tuple[tuple[float, ...], ...]
    vehicle_position: tuple[float, float, float]
    yaw_deg: float
    optical: tuple[tuple[float, ...], ...]
    optical_position: tuple[float, float, float]

    @classmethod
    def of(cls, vehicle_from_object, optical_from_vehicle, position, yaw_rad: float) -> "ObjectPose":
        """The pose of a placement (V <- object, its contact point, its yaw in radians) under a
        camera (``optical_from_vehicle``), rounded as the record keeps it."""
        opt = optical_from_vehicle @ vehicle_from_object
        return cls(tuple(map(tuple, _matrix(vehicle_from_object))), tuple(_rounded(position, 4)),
                   round(math.degrees(yaw_rad), 3), tuple(map(tuple, _matrix(opt))),
                   tuple(_rounded((optical_from_vehicle @ np.append(position, 1.0))[:3], 4)))

    def to_json(self) -> dict[str, Any]:
        return {"vehicle": {"matrix": [list(r) for r in self.vehicle], "position_m": list(self.vehicle_position),
                            "yaw_deg": self.yaw_deg},
                "camera_optical": {"matrix": [list(r) for r in self.optical],
                                   "position_m": list(self.optical_position)}}

    @classmethod
    def from_json(cls, d: Mapping) -> "ObjectPose":
        v, o = d["vehicle"], d["camera_optical"]
        return cls(tuple(tuple(float(x) for x in r) for r in v["matrix"]), tuple(v["position_m"]), v["yaw_deg"],
                   tuple(tuple(float(x) for x in r) for r in o["matrix"]), tuple(o["position_m"]))


@dataclass(frozen=True)
class ObjectRecord:
    """One inserted object: what was placed, where, how it looks and what it covers."""

    index: int  # 1-based; the value of the object in the composed ``visible`` map
    name: str
    model: str
    class_name: str
    allowed_surfaces: tuple[str, ...]
    orientation: str
    label_id: int
    instance_id: int
    extents_m: tuple[float, float, float]  # length, width, height
    pose: ObjectPose
    ground: Mapping[str, Any]  # normal, rms_m, albedo_linear, sun_visibility
    distance_m: float
    road_yaw_deg: float | None
    pixel: tuple[int, int]
    bbox_2d: Box | None  # the visible part
    visible_pixels: int
    rendered_pixels: int
    occluded_fraction: float
    truncated: bool
    placement: Mapping[str, Any]  # attempts, rejections
    appearance: Mapping[str, Any]
    camera_look: Mapping[str, Any] | None
    placement_source: str  # "random" or "saved"
    placement_check: Mapping[str, Any] | None  # saved poses: whether the rules accept them
    bbox_2d_amodal: Box | None = None  # the whole rendered silhouette
    mask_rle: Mapping[str, Any] | None = None  # the visible mask, COCO RLE
    traffic: Mapping[str, Any] | None = None  # placement.claim.Traffic.to_dict(); None: no traffic sense

    def to_json(self) -> dict[str, Any]:
        d = {"index": self.index, "name": self.name, "model": self.model, "class": self.class_name,
             "allowed_surfaces": list(self.allowed_surfaces), "orientation": self.orientation,
             "label_id": self.label_id, "instance_id": self.instance_id, "extents_m": list(self.extents_m),
             "pose": self.pose.to_json(), "ground": dict(self.ground), "distance_m": self.distance_m,
             "road_yaw_deg": self.road_yaw_deg, "pixel": list(self.pixel),
             "bbox_2d": None if self.bbox_2d is None else list(self.bbox_2d),
             "visible_pixels": self.visible_pixels, "rendered_pixels": self.rendered_pixels,
             "occluded_fraction": self.occluded_fraction, "truncated": self.truncated,
             "placement": dict(self.placement), "appearance": dict(self.appearance)}
        if self.camera_look is not None:
            d["camera_look"] = dict(self.camera_look)
        d["placement_source"] = self.placement_source
        if self.placement_check is not None:
            d["placement_check"] = dict(self.placement_check)
        if self.mask_rle is not None:
            d["bbox_2d_amodal"] = None if self.bbox_2d_amodal is None else list(self.bbox_2d_amodal)
            d["mask_rle"] = dict(self.mask_rle)
        if self.traffic is not None:
            d["traffic"] = dict(self.traffic)
        return d

    @classmethod
    def from_json(cls, d: Mapping) -> "ObjectRecord":
        box = d.get("bbox_2d")
        amodal = d.get("bbox_2d_amodal")
        return cls(int(d["index"]), str(d["name"]), str(d["model"]), str(d["class"]),
                   tuple(str(s) for s in d["allowed_surfaces"]), str(d["orientation"]), int(d["label_id"]),
                   int(d["instance_id"]), tuple(float(v) for v in d["extents_m"]), ObjectPose.from_json(d["pose"]),
                   dict(d["ground"]), float(d["distance_m"]), d.get("road_yaw_deg"), tuple(d["pixel"]),
                   None if box is None else tuple(int(v) for v in box), int(d["visible_pixels"]),
                   int(d["rendered_pixels"]), float(d["occluded_fraction"]), bool(d["truncated"]),
                   dict(d.get("placement", {})), dict(d.get("appearance", {})), d.get("camera_look"),
                   str(d.get("placement_source", "random")), d.get("placement_check"),
                   None if amodal is None else tuple(int(v) for v in amodal), d.get("mask_rle"), d.get("traffic"))


@dataclass(frozen=True)
class ImageSetRecord:
    """One image set's record. ``status``: ``done``, ``no valid placement``, or None while the
    stages are still adding to it (never written so)."""

    image_set: str  # split/city/city_seq_frame
    synthcompose_version: str
    config_sha256: str
    seed: int
    source: Mapping[str, str]  # input kind -> path
    source_fingerprint: Mapping[str, Any]  # input kind -> [size, mtime_ns] (resume)
    labels: Any  # "gtFine", or the surfaces found on an unlabelled frame
    stereo_noise: Mapping[str, Any]
    lighting: Mapping[str, Any]
    objects: tuple[ObjectRecord, ...] = ()
    not_placed: tuple[Mapping[str, Any], ...] = ()
    placement_file: Mapping[str, Any] | None = None
    camera_match: Mapping[str, Any] | None = None
    image: Mapping[str, Any] | None = None  # file_name (relative to the output root), width, height
    status: Status | None = None
    record_version: int = field(default=RECORD_VERSION)
    views: tuple[str, ...] = ("left",)  # the photos the objects were composed into: "left", and "right"
    street: Mapping[str, Any] | None = None  # placement.street.Street.to_dict(): the street found
    placement_rules: Mapping[str, Any] | None = None  # the PlacementRules the objects were placed by
    not_drawn: Mapping[str, str] | None = None  # manifest objects not drawn here -> why (they stand nowhere)

    def with_(self, **changes) -> "ImageSetRecord":
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        d: dict[str, Any] = {"synthcompose_version": self.synthcompose_version, "record_version": self.record_version,
                             "image_set": self.image_set, "config_sha256": self.config_sha256, "seed": self.seed,
                             "source": dict(self.source), "source_fingerprint": dict(self.source_fingerprint),
                             "labels": self.labels, "stereo_noise": dict(self.stereo_noise),
                             "lighting": dict(self.lighting), "objects": [o.to_json() for o in self.objects],
                             "not_placed": [dict(f) for f in self.not_placed]}
        for key in ("placement_file", "camera_match", "image", "street", "placement_rules", "not_drawn"):
            value = getattr(self, key)
            if value is not None:
                d[key] = dict(value)
        if self.status == Status.DONE:
            d["views"] = list(self.views)
        d["status"] = self.status
        return d

    @classmethod
    def from_json(cls, d: Any, path: Path | None = None) -> "ImageSetRecord":
        """The record of a JSON document; :class:`RecordError` naming ``path`` if it is not one."""
        try:
            if not isinstance(d, Mapping):
                raise TypeError("not a JSON object")
            return cls(str(d["image_set"]), str(d.get("synthcompose_version", "")), str(d["config_sha256"]),
                       int(d["seed"]), dict(d["source"]), dict(d.get("source_fingerprint") or {}), d.get("labels"),
                       dict(d.get("stereo_noise") or {}), dict(d.get("lighting") or {}),
                       tuple(ObjectRecord.from_json(o) for o in d.get("objects", [])),
                       tuple(d.get("not_placed", [])), d.get("placement_file"), d.get("camera_match"), d.get("image"),
                       None if d.get("status") is None else Status(d["status"]), int(d.get("record_version", 0)),
                       tuple(str(v) for v in d.get("views", ["left"])), d.get("street"), d.get("placement_rules"),
                       d.get("not_drawn"))
        except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
            raise RecordError(path or Path("<record>"),
                              f"is not a synthcompose record ({type(exc).__name__}: {exc})") from None

    @property
    def done(self) -> bool:
        return self.status == Status.DONE


def read_record(path: Path) -> ImageSetRecord:
    """The record in a file (:class:`RecordError` / :class:`InputError` naming it if unreadable)."""
    from synthcompose.io.files import read_json
    return ImageSetRecord.from_json(read_json(path), path)
