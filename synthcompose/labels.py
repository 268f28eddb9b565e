"""Cityscapes label table, taken from cityscapesScripts (the authority), as lookup arrays."""
from __future__ import annotations

import cv2
import numpy as np
from cityscapesscripts.helpers.labels import id2label, labels, name2label

#: (256, 3) uint8 RGB colour of each label id; ids Cityscapes does not define are black.
COLOR_LUT: np.ndarray = np.zeros((256, 3), np.uint8)
#: (256,) bool: the label id has per-object instances (instance id = id * 1000 + k).
HAS_INSTANCES: np.ndarray = np.zeros(256, bool)
#: (256,) bool: the label id is defined by Cityscapes.
KNOWN_IDS: np.ndarray = np.zeros(256, bool)

for _label in labels:
    if 0 <= _label.id < 256:
        COLOR_LUT[_label.id] = _label.color
        HAS_INSTANCES[_label.id] = _label.hasInstances
        KNOWN_IDS[_label.id] = True
#: (256, 1, 4) uint8: COLOR_LUT with alpha 255, as cv2.LUT takes it (colorize)
_RGBA_LUT = np.concatenate([COLOR_LUT, np.full((256, 1), 255, np.uint8)], axis=1)[:, None, :].copy()

#: the classes an inserted object may have: Cityscapes' things (categories human, vehicle and
#: object), not a group label ("polegroup") nor one without an id of its own ("license plate")
INSERTABLE: tuple[str, ...] = tuple(lab.name for lab in labels if lab.category in ("human", "vehicle", "object")
                                    and lab.id >= 0 and not lab.name.endswith("group"))

#: Instance ids are class_id * INSTANCE_FACTOR + k (cityscapesScripts json2instanceImg).
INSTANCE_FACTOR = 1000


def label_id(name: str) -> int:
    """Cityscapes label id of a class name such as ``"car"`` or ``"traffic sign"``."""
    try:
        return int(name2label[name].id)
    except KeyError:
        known = ", ".join(sorted(n for n in name2label if id2label[name2label[n].id].id >= 0))
        raise KeyError(f"unknown Cityscapes class {name!r}; known classes: {known}") from None


def label_ids(*names: str) -> tuple[int, ...]:
    """The label ids of class names, in the order given (:func:`label_id` of each)."""
    return tuple(label_id(n) for n in names)


def category_ids(*categories: str) -> tuple[int, ...]:
    """The label ids (>= 0) of every class in the given Cityscapes categories (``"vehicle"``,
    ``"human"``, ``"construction"``, ...), in id order."""
    return tuple(sorted(lab.id for lab in labels if lab.category in categories and lab.id >= 0))


def labels_in(labels: np.ndarray, ids) -> np.ndarray:
    """Bool, ``labels``' shape: each label is one of ``ids`` (``np.isin``, by a 256-entry table;
    OpenCV's LUT on a frame's uint8 labels, a third of NumPy's indexing with its int64 copy)."""
    labels = np.asarray(labels)
    if labels.dtype != np.uint8:
        return np.isin(labels, list(ids))
    table = np.zeros(256, np.uint8)
    table[list(ids)] = 1
    if labels.ndim == 2 and labels.flags.c_contiguous and labels.size:
        return cv2.LUT(labels, table).view(bool)
    return table.astype(bool)[labels]


def byte_counts(values: np.ndarray) -> np.ndarray:
    """(256,) int64: how many of ``values`` (uint8, any shape) hold each byte value; what
    ``np.bincount(values.ravel(), minlength=256)`` gives, without its int64 copy of the array
    (16 MB for a 2048x1024 frame, fresh pages each time): OpenCV's histogram, exact up to 2^24
    values (its float32 counts), ``np.bincount`` beyond."""
    values = np.asarray(values)
    if values.dtype != np.uint8:
        raise TypeError(f"byte_counts takes uint8 values, not {values.dtype}")
    if values.size >= 1 << 24 or values.size == 0:
        return np.bincount(values.ravel(), minlength=256)
    flat = np.ascontiguousarray(values).reshape(1, -1)
    return cv2.calcHist([flat], [0], None, [256], [0, 256]).ravel().astype(np.int64)


def label_name(label: int) -> str:
    return id2label[int(label)].name


def colorize(label_ids: np.ndarray) -> np.ndarray:
    """(H, W) uint8 label ids -> (H, W, 4) uint8 RGBA Cityscapes colour image (gtFine_color)."""
    grey4 = cv2.cvtColor(np.ascontiguousarray(label_ids, np.uint8), cv2.COLOR_GRAY2RGBA)  # alpha 255
    return cv2.LUT(grey4, _RGBA_LUT)  # alpha 255 -> 255
