"""Stage 6 - write: the augmented image set's files, its annotations, and its record, last
(its presence means the image set is complete) -> :class:`Outcome`. Touches no GL object:
runs on the writer thread."""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

from synthcompose.errors import SynthComposeError
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import encode_rle
from synthcompose.labels import byte_counts, label_id
from synthcompose.record import ObjectPose, ObjectRecord, Status
from synthcompose.render import mask_box
from synthcompose.write.annotations import write_frame_annotations
from synthcompose.write.outputs import write_outputs, write_record

from .options import WriteOptions
from .place import Placed
from .shade import Shaded
from .timing import Timings, timed


@dataclass(frozen=True)
class Outcome:
    """What happened to one image set (:class:`Status`: done, skipped for no valid placement, failed)."""

    key: str
    status: Status
    reason: str | None = None
    objects: int = 0
    timings: Mapping[str, float] = field(default_factory=dict)  # stage -> wall seconds
    resumed: bool = False  # complete from an earlier run with the same configuration


def object_records(s: Shaded) -> tuple[ObjectRecord, ...]:
    """The record of each shaded object (with its visible mask as COCO RLE)."""
    visible = s.composed.visible
    opt_from_v = s.camera.optical_from_vehicle
    out = []
    for k, (obj, look) in enumerate(zip(s.placed.objects, s.looks), start=1):
        pl, spec = obj.placement, obj.spec
        mask = visible == k
        if any(p.label for p in obj.model.parts):  # its own class's pixels, not those of a part labelled apart
            mask &= s.composed.label_ids == label_id(spec.class_name)
        bbox = mask_box(mask)
        visible_pixels = int(mask.sum())
        out.append(ObjectRecord(
            index=k, name=spec.name, model=spec.model if obj.cast is None else f"cast:{obj.cast.entry.id}",
            class_name=spec.class_name,
            allowed_surfaces=tuple(spec.allowed_surfaces), orientation=spec.orientation,
            label_id=label_id(spec.class_name), instance_id=obj.instance_id, extents_m=tuple(pl.extents),
            pose=ObjectPose.of(pl.matrix, opt_from_v, pl.position, pl.yaw),
            ground={"normal": [round(v, 5) for v in pl.ground_normal], "rms_m": round(pl.ground_rms, 4),
                    "albedo_linear": [round(v, 4) for v in look.plane_albedo],
                    "sun_visibility": round(look.sun_visibility, 3)},
            distance_m=round(pl.distance, 3),
            road_yaw_deg=None if pl.road_yaw is None else round(math.degrees(pl.road_yaw), 3),
            pixel=tuple(pl.pixel), bbox_2d=None if bbox is None else tuple(bbox), visible_pixels=visible_pixels,
            rendered_pixels=int(s.rendered[k]),
            occluded_fraction=round(1.0 - visible_pixels / max(int(s.rendered[k]), 1), 4),
            truncated=pl.truncated,
            placement={"attempts": obj.result.attempts, "rejections": obj.result.rejections},
            appearance=look.appearance.to_dict() | (dict(obj.cast.appearance) if obj.cast is not None else {})
            | ({"pose": dict(obj.pose)} if obj.pose is not None else {}),
            camera_look=None if look.camera_look is None else
            {k2: (round(v, 4) if isinstance(v, float) else v) for k2, v in look.camera_look.items()},
            placement_source="saved" if s.placed.saved is not None else "random",
            placement_check=None if obj.check is None else obj.check.to_json(),
            bbox_2d_amodal=None if s.amodal[k - 1] is None else tuple(s.amodal[k - 1]),
            mask_rle=encode_rle(mask), traffic=None if pl.traffic is None else pl.traffic.to_dict()))
    return tuple(out)


def check_visible(s: Shaded) -> None:
    """Refuse to write an image set with an object no pixel of which is seen (hidden, too far,
    or a model that draws nothing): it would be annotated with nothing, yet change the photo
    (its shadow). Raised before any file is written; the image set fails, naming the object."""
    counts = byte_counts(s.composed.visible)
    for k, obj in enumerate(s.placed.objects, start=1):
        if counts[k] == 0:
            raise SynthComposeError(f"{obj.spec.model}: object {k} ({obj.spec.name!r}, {obj.spec.class_name}) has 0 "
                                    f"visible pixels once rendered ({int(s.rendered[k])} drawn before occlusion): "
                                    "the image set is not written")


def write_done(o: WriteOptions, ident: ImageSetId, s: Shaded, timings: Timings) -> Outcome:
    """The image set's files, annotations and record (last); none with an unseen object."""
    composed = s.composed
    check_visible(s)
    with timed(timings, "write"):
        write_outputs(o.output, ident, composed, s.camera_json, s.right_rgb, s.vehicle_json)
        objects = object_records(s)
        h, w = composed.visible.shape
        record = s.record.with_(objects=objects, status=Status.DONE, views=("left", "right") if s.right_rgb is not None
                                else ("left",), image={
            "file_name": ident.path(Path("."), "rgb").as_posix(), "width": w, "height": h})
        # gtFine polygons and gtBbox3d files; before the record, which is written last
        write_frame_annotations(o.output, o.dataset, ident, objects, [o.placement.matrix for o in s.placed.objects],
                                composed.visible, composed.label_ids, composed.instance_ids, s.camera)
        write_record(o.output, ident, record.to_json())
    return Outcome(ident.key, Status.DONE, None, len(objects), timings.seconds())


def write_skipped(o: WriteOptions, ident: ImageSetId, placed: Placed, timings: Timings) -> Outcome:
    """No object found a place: the record alone, saying why."""
    with timed(timings, "write"):
        write_record(o.output, ident, placed.record.with_(status=Status.NO_PLACEMENT).to_json())
    reasons: Counter[str] = Counter()
    for f in placed.failures:
        reasons.update(dict(f.rejections))
    why = ", ".join(f"{k} x{v}" for k, v in reasons.most_common(3)) or "no candidates"
    return Outcome(ident.key, Status.SKIPPED, f"no valid placement ({why})", timings=timings.seconds())
