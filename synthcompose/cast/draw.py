"""One inserted object's model drawn from a cast pool, and loaded: a model file, a traffic sign
built in code, or a person posed from its skeleton.

Every draw comes from :func:`cast_rng`, a function of (manifest seed, image set, object index)
alone: never the placement's generator, so a manifest without cast pools draws exactly what it
drew before, and the same object gets the same model whatever was placed before it.
"""
from __future__ import annotations

import logging
import zlib
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from synthcompose.models import Model, load_model
from synthcompose.models.signs import Plate, sign_model

from .catalogue import SIGN_MODEL, CastEntry

log = logging.getLogger("synthcompose")


def cast_rng(seed: int, image_set: str, index: int) -> np.random.Generator:
    """The cast's draws for object ``index`` (0-based, among the objects placed) of an image set."""
    return np.random.default_rng([int(seed), zlib.crc32(image_set.encode()), int(index), 0x63617374])


def draw_entry(entries: Sequence[CastEntry], rng: np.random.Generator) -> CastEntry:
    """One entry of a pool, by weight."""
    w = np.array([e.weight for e in entries], float)
    return entries[int(rng.choice(len(entries), p=w / w.sum()))]


@dataclass(frozen=True)
class CastDraw:
    """What one object got from the cast: its entry, and what the record's ``appearance`` says
    of it (``model``; ``sign`` for a sign; ``body`` and ``pose`` for a person)."""

    entry: CastEntry
    appearance: Mapping[str, Any] = field(default_factory=dict)


def posed_person(entry: CastEntry, size: tuple[tuple[str, float], ...], rng: np.random.Generator,
                 pose: str | None = None) -> tuple[Model, dict]:
    """A person entry posed for one object: ``models.skinning.posed_model`` where that module
    is installed and the entry is rigged; else its file in the pose it was saved in (rest)."""
    try:
        from synthcompose.models.skinning import posed_model
    except ImportError:
        posed_model = None
    if posed_model is None or entry.rig is None:
        return load_model(entry.model, size, entry.up, entry.forward), {"pose": "rest"}
    model, described = posed_model(entry.model, size, entry.up, entry.forward, rng, pose)
    return model, dict(described)


def _sign(entry: CastEntry, size: tuple[tuple[str, float], ...] | None,
          rng: np.random.Generator, lowest: bool = False) -> tuple[Model, dict]:
    """The sign's pole with its plate, a supplementary sign under it or not, its lower edge
    at one of its heights; ``lowest``: its lowest mounting (the least lower edge, no plate
    under it), drawn with the same draws."""
    spec = entry.sign
    plates = [Plate(entry.kind, spec.face, spec.width_m, spec.height_m)]
    u = float(rng.random())
    for _, kind, p, below in spec.below:  # at most one, each with its own probability
        if u < p:
            plates.append(Plate(kind, below.face, below.width_m, below.height_m))
            break
        u -= p
    lower = float(spec.lower_edge_m[int(rng.integers(len(spec.lower_edge_m)))])
    if lowest:
        plates, lower = plates[:1], float(min(spec.lower_edge_m))
    described = {"code": entry.kind, "below": [p.code for p in plates[1:]], "lower_edge_m": lower}
    if spec.faces != "traffic":
        described["faces"] = spec.faces
    return sign_model(tuple(plates), lower, size), described


def cast_model(entry: CastEntry, size: tuple[tuple[str, float], ...] | None,
               rng: np.random.Generator, pose: str | None = None,
               lowest: bool = False) -> tuple[Model, CastDraw]:
    """The model of ``entry`` for one object (at ``size`` when the manifest gives one, else at
    the entry's real size) and what the record says of it. ``pose``: a person's pose kind
    (``standing`` / ``walking``; None: any); ``lowest``: a sign at its lowest mounting."""
    if entry.model == SIGN_MODEL:
        model, sign = _sign(entry, size, rng, lowest)
        return model, CastDraw(entry, {"model": entry.id, "sign": sign})
    real = size or entry.size
    if entry.group == "people":
        model, posed = posed_person(entry, real, rng, pose)
        return model, CastDraw(entry, {"model": entry.id, "body": entry.body_dict, "pose": posed})
    return load_model(entry.model, real, entry.up, entry.forward), CastDraw(entry, {"model": entry.id})


def preload(entries: Sequence[CastEntry]) -> None:
    """Load each entry's model once (a bad file stops a batch at its start, naming the file)."""
    for entry in entries:
        cast_model(entry, None, np.random.default_rng(0))


def mounted_higher(drawn: CastDraw | None) -> bool:
    """Whether a drawn sign hangs higher than its entry's lowest mounting (a plate under it, or
    a lower edge above the least): a view with too little footway far enough off for it may
    still show the sign mounted lowest."""
    sign = None if drawn is None else drawn.appearance.get("sign")
    if not sign:
        return False
    return bool(sign["below"]) or sign["lower_edge_m"] > min(drawn.entry.sign.lower_edge_m)
