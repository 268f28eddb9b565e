"""The stages of one image set, each a call with typed inputs and outputs (see
:mod:`synthcompose.run.pipeline`, which runs them): :func:`prepare` -> :class:`Prepared`,
:func:`place` -> :class:`Placed`, :func:`measure_light` -> :class:`PhotoLight` (only where
something was placed), :func:`shade` -> :class:`Shaded`, :func:`write_done` /
:func:`write_skipped` -> :class:`Outcome`."""
from .options import PlaceOptions, ReadOptions, ShadeOptions, StageOptions, WriteOptions
from .place import NotPlaced, Placed, PlacedObject, PoseCheck, new_instance_id, place
from .prepare import PhotoLight, Prepared, image_set_rng, measure_light, prepare
from .shade import ObjectLook, Shaded, ground_albedo, shade
from .write import Outcome, object_records, write_done, write_skipped

__all__ = ["NotPlaced", "ObjectLook", "Outcome", "PhotoLight", "PlaceOptions", "Placed", "PlacedObject", "PoseCheck",
           "Prepared", "ReadOptions", "ShadeOptions", "StageOptions", "WriteOptions", "measure_light", "Shaded",
           "ground_albedo", "image_set_rng", "new_instance_id", "object_records", "place", "prepare", "shade", "write_done",
           "write_skipped"]
