"""The stages of one image set, each a call with typed inputs and outputs (see
:mod:`synthcompose.pipeline`, which runs them): :func:`prepare` -> :class:`Prepared`,
:func:`place` -> :class:`Placed`, :func:`shade` -> :class:`Shaded`, :func:`write_done` /
:func:`write_skipped` -> :class:`Outcome`."""
from .place import Placed, PlacedObject, new_instance_id, place
from .prepare import Prepared, image_set_rng, prepare
from .shade import ObjectLook, Shaded, ground_albedo, shade
from .write import Outcome, object_records, write_done, write_skipped

__all__ = ["ObjectLook", "Outcome", "Placed", "PlacedObject", "Prepared", "Shaded", "ground_albedo", "image_set_rng",
           "new_instance_id", "object_records", "place", "prepare", "shade", "write_done", "write_skipped"]
