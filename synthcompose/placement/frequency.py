"""Which object to insert: by the manifest's weights, or balanced towards rare classes.

"balance" counts how often each class occurs in the dataset's ground truth (objects in
``gtFine_polygons.json`` where present, else distinct instance ids in ``instanceIds``) over
up to ``max_sets`` evenly spread image sets, and divides each object's weight by
(1 + count of its class): a class the dataset has few of gets inserted more often.
"""
from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Sequence

import numpy as np

from synthcompose.errors import InputError
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import read_json, read_png
from synthcompose.labels import INSTANCE_FACTOR, label_name


def count_classes(root: Path, ids: Sequence[ImageSetId], max_sets: int = 500) -> dict[str, int]:
    """Objects per class name in the ground truth of (a deterministic sample of) ``ids``."""
    counts: Counter[str] = Counter()
    if not ids:
        return {}
    step = max(1, len(ids) // max_sets)
    for ident in list(ids)[::step][:max_sets]:
        polygons = ident.path(root, "polygons")
        try:
            if polygons.is_file():
                data = read_json(polygons)
                counts.update(str(o.get("label", "")) for o in data.get("objects", []) if isinstance(o, dict))
                continue
            inst = read_png(ident.path(root, "instanceIds"), "gray16")
        except InputError:
            continue  # a bad set is reported when it is processed; counting goes on
        for value in np.unique(inst[inst >= INSTANCE_FACTOR]):
            try:
                counts[label_name(int(value) // INSTANCE_FACTOR)] += 1
            except KeyError:
                pass
    return dict(counts)


def object_weights(weights: Sequence[float], classes: Sequence[str], mode: str,
                   counts: dict[str, int] | None = None) -> np.ndarray:
    """Normalised probabilities of choosing each object."""
    w = np.asarray(weights, float)
    if mode == "balance":
        w = w / np.array([1.0 + (counts or {}).get(c, 0) for c in classes])
    elif mode != "weights":
        raise ValueError(f"unknown object choice {mode!r}")
    return w / w.sum()
