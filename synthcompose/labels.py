"""Cityscapes label table, taken from cityscapesScripts (the authority), as lookup arrays."""
from __future__ import annotations

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

#: Instance ids are class_id * INSTANCE_FACTOR + k (cityscapesScripts json2instanceImg).
INSTANCE_FACTOR = 1000


def label_id(name: str) -> int:
    """Cityscapes label id of a class name such as ``"car"`` or ``"traffic sign"``."""
    try:
        return int(name2label[name].id)
    except KeyError:
        known = ", ".join(sorted(n for n in name2label if id2label[name2label[n].id].id >= 0))
        raise KeyError(f"unknown Cityscapes class {name!r}; known classes: {known}") from None


def label_name(label: int) -> str:
    return id2label[int(label)].name


def colorize(label_ids: np.ndarray) -> np.ndarray:
    """(H, W) uint8 label ids -> (H, W, 4) uint8 RGBA Cityscapes colour image (gtFine_color)."""
    rgba = np.empty(label_ids.shape + (4,), np.uint8)
    rgba[..., :3] = COLOR_LUT[label_ids]
    rgba[..., 3] = 255
    return rgba
