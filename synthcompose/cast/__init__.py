"""The cast: the models a batch inserts, drawn per object from a catalogue of entries
(:mod:`.catalogue`), the built-in street mix (:mod:`.street`), and the per-object draw and
load (:mod:`.draw`). See docs/cast.md."""
from .catalogue import CAST_PREFIX, SIGN_MODEL, CastEntry, Catalogue, SignSpec, cast_root, entry_digest, load_catalogue
from .draw import CastDraw, cast_model, cast_rng, draw_entry, mounted_higher, posed_person, preload
from .street import CASTS, STREET

__all__ = ["CASTS", "CAST_PREFIX", "SIGN_MODEL", "STREET", "CastDraw", "CastEntry", "Catalogue", "SignSpec",
           "cast_model", "cast_rng", "cast_root", "draw_entry", "entry_digest", "load_catalogue", "mounted_higher",
           "posed_person", "preload"]
