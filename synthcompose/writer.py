"""Stage 6 - write: the augmented image set in the Cityscapes layout, plus its record.

Each file is written atomically (temporary name, then rename). The per-image-set record
``synthcompose/<split>/<city>/<name>_synthcompose.json`` is written last, so its presence
means the image set is complete.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from .compose import Composed
from .dataset import ImageSetId
from .fileio import map_threads, write_bytes_atomic, write_json, write_png
from .labels import colorize


def write_outputs(out_root: Path, ident: ImageSetId, composed: Composed, camera_json: bytes) -> list[Path]:
    """Write the six Cityscapes files of the augmented set; returns their paths."""
    files = {
        "rgb": lambda: composed.rgb,
        "labelIds": lambda: composed.label_ids,
        "instanceIds": lambda: composed.instance_ids.astype("uint16"),
        "color": lambda: colorize(composed.label_ids),
        "disparity": lambda: composed.disparity,
    }

    def write(kind: str) -> Path:
        path = ident.path(out_root, kind)
        write_png(path, files[kind]())
        return path

    written = map_threads(write, files)  # encoded side by side (fileio.map_threads)
    cam = ident.path(out_root, "camera")
    write_bytes_atomic(cam, camera_json)
    written.append(cam)
    return written


def write_record(out_root: Path, ident: ImageSetId, record: dict[str, Any]) -> Path:
    path = ident.path(out_root, "record")
    write_json(path, record)
    return path
