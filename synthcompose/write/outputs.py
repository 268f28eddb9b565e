"""Stage 6 - write: the augmented image set in the Cityscapes layout, plus its record.

Each file is written atomically (temporary name, then rename). The per-image-set record
``synthcompose/<split>/<city>/<name>_synthcompose.json`` is written last, so its presence
means the image set is complete.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from synthcompose.compose import Composed
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import map_threads, write_bytes_atomic, write_json, write_png
from synthcompose.labels import colorize

#: the PNG row filter of each kind of file written (io.png.PNG_FILTERS: the same pixels whatever the
#: filter; these give the smallest files for the CPU, `python benchmarks/bench_png.py`)
PNG_FILTER_OF = {"rgb": "avg", "right": "avg", "disparity": "sub", "labelIds": "up", "instanceIds": "up", "color": "up"}


def write_outputs(out_root: Path, ident: ImageSetId, composed: Composed, camera_json: bytes,
                  right_rgb: np.ndarray | None = None, vehicle_json: bytes | None = None) -> list[Path]:
    """Write the six Cityscapes files of the augmented set, and its right view and vehicle file
    when given; returns their paths."""
    files = {
        "rgb": lambda: composed.rgb,
        "labelIds": lambda: composed.label_ids,
        "instanceIds": lambda: np.asarray(composed.instance_ids, np.uint16),
        "color": lambda: colorize(composed.label_ids),
        "disparity": lambda: composed.disparity,
    }
    if right_rgb is not None:
        files["right"] = lambda: right_rgb

    def write(kind: str) -> Path:
        path = ident.path(out_root, kind)
        write_png(path, files[kind](), PNG_FILTER_OF[kind])
        return path

    written = map_threads(write, files)  # encoded side by side (fileio.map_threads)
    cam = ident.path(out_root, "camera")
    write_bytes_atomic(cam, camera_json)
    written.append(cam)
    if vehicle_json is not None:
        vehicle = ident.path(out_root, "vehicle")
        write_bytes_atomic(vehicle, vehicle_json)
        written.append(vehicle)
    return written


#: the kinds of file written per image set (dataset.ImageSetId.path), the record last
WRITTEN_KINDS = ("rgb", "labelIds", "instanceIds", "color", "disparity", "camera", "vehicle", "right", "polygons",
                 "record")


def output_paths(out_root: Path, ident: ImageSetId) -> list[Path]:
    """Every file this tool may write for one image set under ``out_root`` (the record last)."""
    from .annotations import bbox3d_path

    paths = [ident.path(out_root, kind) for kind in WRITTEN_KINDS]
    return paths[:-1] + [bbox3d_path(out_root, ident), paths[-1]]


def discard_outputs(out_root: Path, ident: ImageSetId, keep_record: bool = False) -> int:
    """Remove one image set's outputs (a failed or skipped set must not leave files of this or
    an earlier run that no record of this run describes); the record stays with
    ``keep_record`` (a skipped set's record says why). Returns how many files were removed."""
    n = 0
    for path in output_paths(out_root, ident)[: -1 if keep_record else None]:
        try:
            path.unlink()
            n += 1
        except FileNotFoundError:
            pass
    return n


def write_record(out_root: Path, ident: ImageSetId, record: dict[str, Any]) -> Path:
    path = ident.path(out_root, "record")
    write_json(path, record)
    return path
