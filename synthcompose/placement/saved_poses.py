"""Saved placements: poses accepted by hand in ``synthcompose preview`` that a batch then uses.

File: ``<output>/placements/<split>/<city>/<city_seq_frame>_placement.json``::

    {"format": "synthcompose-placement/1",
     "image_set": "train/aachen/aachen_000000_000019",
     "objects": [{"name": "car",                       # an object name of the manifest
                  "matrix": [[...], [...], [...], [...]]}]}  # 4x4 vehicle <- object (ISO 8855, metres)

Optional per object: ``"yaw_deg"``, ``"position_m"`` (informative; the matrix decides).
When such a file exists for an image set, the batch inserts exactly these objects at these
poses instead of drawing a random placement, records ``"placement_file"`` (path and sha256)
and ``"placement_source": "saved"`` per object, and a resumed batch redoes the image set when
the file changed since its record was written.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synthcompose.errors import InputError
from synthcompose.geometry.depth import Frame
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import read_json, write_json
from synthcompose.labels import label_id

from . import GROUND_LEVEL, Placement, PlacementResult, box_corners, fit_ground, ground_points, pose_matrix, visibility_of

FORMAT = "synthcompose-placement/1"
#: PreviewSession.load override: draw a random placement even where a file is saved
IGNORE_SAVED = object()


def placement_path(out_root: Path, ident: ImageSetId) -> Path:
    return Path(out_root) / "placements" / ident.split / ident.city / f"{ident.name}_placement.json"


@dataclass(frozen=True)
class SavedObject:
    name: str
    matrix: tuple[tuple[float, ...], ...]  # (4, 4) vehicle <- object


@dataclass(frozen=True)
class SavedPlacement:
    image_set: str
    objects: tuple[SavedObject, ...]
    path: Path | None = None
    sha256: str | None = None

    def to_dict(self) -> dict:
        objs = []
        for o in self.objects:
            m = np.array(o.matrix, float)
            objs.append({"name": o.name, "matrix": [[round(float(v), 6) for v in r] for r in m],
                         "yaw_deg": round(math.degrees(math.atan2(m[1, 0], m[0, 0])), 3),
                         "position_m": [round(float(v), 4) for v in m[:3, 3]]})
        return {"format": FORMAT, "image_set": self.image_set, "objects": objs}


#: a saved pose farther than this from the vehicle frame's origin is refused, metres (the
#: manifest's placement distance reaches 10 km at most)
MAX_POSE_DISTANCE = 10_000.0
#: a saved pose whose box is nearer the camera plane than this everywhere is behind it, metres
NEAR_M = 0.1


def _number_rows(rows) -> bool:
    """A list of lists of JSON numbers (not strings, not booleans, within a float)."""
    return isinstance(rows, list) and all(
        isinstance(r, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= 1.7e308
                                    for v in r) for r in rows)


def pose_problem(frame: Frame, extents, matrix) -> str | None:
    """What makes a pose given outright (saved) unusable in a frame, or None: its box wholly
    behind the camera, or wholly outside its view."""
    m = np.asarray(matrix, float)
    corners = frame.to_optical(box_corners(m, extents))
    if (corners[:, 2] <= NEAR_M).all():
        return f"is behind the camera (its box lies {-corners[:, 2].max():.2f} m or more behind the image plane)"
    front = corners[corners[:, 2] > NEAR_M]
    uv = frame.camera.project(front)
    H, W = frame.shape
    if (uv[:, 0].max() < 0 or uv[:, 0].min() > W - 1 or uv[:, 1].max() < 0 or uv[:, 1].min() > H - 1) and \
            (corners[:, 2] > NEAR_M).all():
        return "is outside the camera's view (no corner of its box projects into the image)"
    return None


def _bad(path: Path, why: str) -> InputError:
    return InputError(path, f"saved placement {why}")


def read_saved(out_root: Path, ident: ImageSetId) -> SavedPlacement | None:
    """The saved placement of an image set, or None when there is none."""
    path = placement_path(out_root, ident)
    if not path.is_file():
        return None
    raw = path.read_bytes()
    data = read_json(path)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise _bad(path, f"is not in the {FORMAT} format")
    if data.get("image_set") != ident.key:
        raise _bad(path, f"is for {data.get('image_set')!r}, not {ident.key!r}")
    objs = data.get("objects")
    if not isinstance(objs, list) or not objs:
        raise _bad(path, "has no objects")
    out = []
    for i, o in enumerate(objs):
        rows = o.get("matrix") if isinstance(o, dict) else None
        if not isinstance(o, dict) or not isinstance(o.get("name"), str) or not _number_rows(rows):
            raise _bad(path, f"object {i}: needs a 'name' string and a 4x4 'matrix' of numbers")
        m = np.array(rows, float)
        if m.shape != (4, 4) or not np.isfinite(m).all() or not np.allclose(m[3], [0, 0, 0, 1]):
            raise _bad(path, f"object {i}: 'matrix' must be a finite 4x4 rigid transform")
        if not np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-3):
            raise _bad(path, f"object {i}: 'matrix' rotation is not orthonormal")
        if np.linalg.det(m[:3, :3]) < 0:
            raise _bad(path, f"object {i}: 'matrix' mirrors the object (its rotation's determinant is -1): "
                             "a pose turns an object, it cannot turn it inside out")
        if np.abs(m[:3, 3]).max() > MAX_POSE_DISTANCE:
            raise _bad(path, f"object {i}: 'matrix' puts the object {np.abs(m[:3, 3]).max():.3g} m away, more than "
                             f"the {MAX_POSE_DISTANCE:g} m a placement may reach")
        out.append(SavedObject(o["name"], tuple(tuple(float(v) for v in r) for r in m)))
    return SavedPlacement(ident.key, tuple(out), path, hashlib.sha256(raw).hexdigest())


def write_saved(out_root: Path, ident: ImageSetId, objects: list[tuple[str, np.ndarray]]) -> Path:
    """Write (atomically) the placement file of an image set: [(manifest object name, 4x4 matrix)]."""
    saved = SavedPlacement(ident.key, tuple(SavedObject(n, tuple(tuple(float(v) for v in r) for r in np.asarray(m)))
                                            for n, m in objects))
    path = placement_path(out_root, ident)
    write_json(path, saved.to_dict())
    return path


def saved_is_stale(out_root: Path, ident: ImageSetId, placement_file: dict | None) -> bool:
    """True when the image set's saved placement (or its absence) differs from the one a record
    was made with (its ``placement_file`` entry): a resumed batch must then redo the set."""
    path = placement_path(out_root, ident)
    now = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
    before = (placement_file or {}).get("sha256")
    return now != before


def placement_from_pose(frame: Frame, class_name: str, extents, matrix: np.ndarray,
                        road_yaw: float | None = None) -> Placement:
    """A :class:`Placement` for a pose given outright (saved, or moved by hand): the derived
    fields (distance, pixel, occlusion estimate, truncation) computed as placement does."""
    m = np.asarray(matrix, float)
    cam = frame.camera
    pos = m[:3, 3]
    uv = cam.project(frame.to_optical(pos[None]))[0]
    H, W = frame.shape
    row = int(np.clip(round(uv[1]), 0, H - 1)) if np.isfinite(uv).all() else 0
    col = int(np.clip(round(uv[0]), 0, W - 1)) if np.isfinite(uv).all() else 0
    in_image, hidden, _ = visibility_of(frame, m, extents)
    return Placement(
        class_name=class_name, extents=tuple(float(e) for e in extents),
        vehicle_from_object=tuple(tuple(float(v) for v in r) for r in m),
        yaw=float(math.atan2(m[1, 0], m[0, 0])), road_yaw=road_yaw,
        ground_normal=tuple(float(v) for v in m[:3, 2]), ground_rms=0.0,
        distance=float(math.hypot(pos[0] - cam.x, pos[1] - cam.y)),
        pixel=(row, col), occluded_estimate=hidden, truncated=in_image < 1.0)


def saved_result(frame: Frame, class_name: str, extents, saved: SavedObject) -> PlacementResult:
    """The placement stage's result for a saved pose: no attempts, no rejections."""
    return PlacementResult(placement_from_pose(frame, class_name, extents, np.array(saved.matrix)), 0, {})


def ground_pose(frame: Frame, x: float, y: float, yaw: float, extents, allowed_ids=None,
                fallback_z: float | None = None, fallback_normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) pose standing at ground position (x, y) (V) with heading ``yaw``: on the robust
    plane (placement's :func:`fit_ground`) of the ground points around it (of ``allowed_ids``
    labels when given, else every ground-level label); the fallback height and normal when
    too few points are seen there."""
    l, w, _ = extents
    reach = math.hypot(l, w) / 2 + 0.5
    z0 = fallback_z if fallback_z is not None else 0.0
    normal, z = np.asarray(fallback_normal, float), z0
    ids = allowed_ids if allowed_ids is not None and len(allowed_ids) else [label_id(n) for n in GROUND_LEVEL]
    pts = ground_points(frame, np.array([x, y, z0], float), reach, ids, dz=0.5)
    if len(pts):
        fit = fit_ground(pts, np.array([x, y, z0])) if len(pts) >= 30 else None
        if fit is not None:
            (a, b, c), _, _ = fit
            normal = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
            z = a * x + b * y + c
    return pose_matrix(np.array([x, y, z], float), normal, yaw)
