"""The cast's hook for people (docs/people.md): :func:`posed_model` poses a skinned GLB with
MakeHuman's skeleton for one object, from its own seeded draw (:mod:`.poses`); :func:`posable`
tells such a file; :func:`pose_rng` is the object's draw. Reading and skinning: :mod:`.skin`."""
from __future__ import annotations

import functools
import hashlib
import json
import struct
import zlib
from pathlib import Path

import numpy as np

from synthcompose.errors import ModelError

from .mesh import Model
from .poses import draw_pose
from .skin import Skin, SkinPart, pose_skin, read_skin, skinning_matrices, to_model

__all__ = ["RIG_JOINTS", "Skin", "SkinPart", "pose_rng", "pose_skin", "posable", "posed_model", "read_skin",
           "skinning_matrices"]


def posed_model(path: str, size: tuple[tuple[str, float], ...], up: str, forward: str,
                rng: np.random.Generator, pose: str | None = None) -> tuple[Model, dict]:
    """A person posed at run time (the cast's hook): the skinned GLB ``path`` posed from
    parameters drawn from ``rng`` (``pose``: None any natural pose, "standing" or "walking"),
    scaled to ``size`` (``(("height", metres),)``: the bind pose's height; or length / width of
    the bind pose), in O. Returns the Model (its ``key`` unique per pose) and the pose's
    JSON-able description (``pose``, ``variant``, its parameters and ``pose_id``)."""
    skin = read_skin(path, up, forward)
    dims = {"length": 0, "width": 1, "height": 2}
    if len(size) != 1 or size[0][0] not in dims:
        raise ModelError(path, f"size must give exactly one of length/width/height, got {dict(size)}")
    dim, target = size[0]
    height = float(target) * float(skin.extents[2] / skin.extents[dims[dim]])
    posed = draw_pose(skin, rng, pose)
    meshes = pose_skin(skin, posed.rotations, posed.root_offset)
    desc = dict(posed.description)
    pose_id = hashlib.sha256(json.dumps(desc, sort_keys=True).encode()).hexdigest()[:16]
    desc["pose_id"] = pose_id
    key = f"{path}|{size}|{up}|{forward}|pose:{pose_id}"
    return to_model(skin, meshes, key, height, posed.props(skin, meshes)), desc


#: joints a skeleton must have to be posed by :mod:`.poses` (MakeHuman's default skeleton's names)
RIG_JOINTS = ("root", "spine05", "spine01", "neck01", "head", "upperleg01.L", "lowerleg01.L", "foot.L",
              "upperleg01.R", "lowerleg01.R", "foot.R", "upperarm01.L", "lowerarm01.L", "wrist.L",
              "upperarm01.R", "lowerarm01.R", "wrist.R", "finger3-1.L", "finger3-1.R")


@functools.lru_cache(maxsize=64)
def posable(path: str) -> bool:
    """Whether ``path`` is a GLB with one skin over MakeHuman's skeleton (:data:`RIG_JOINTS`): a
    person :func:`posed_model` poses. Any other model (an OBJ, a glTF in a T-pose from elsewhere)
    is drawn as it is modelled."""
    p = Path(path)
    if p.suffix.lower() != ".glb" or not p.is_file():
        return False
    try:
        with open(p, "rb") as f:
            head = f.read(20)
            magic, _, _, length, kind = struct.unpack("<5I", head)
            if magic != 0x46546C67 or kind != 0x4E4F534A:
                return False
            doc = json.loads(f.read(length))
        skins = doc.get("skins") or []
        if len(skins) != 1:
            return False
        names = {doc["nodes"][j].get("name") for j in skins[0].get("joints", [])}
    except (OSError, struct.error, ValueError, KeyError, IndexError, TypeError, AttributeError):
        return False
    return all(n in names for n in RIG_JOINTS)


def pose_rng(seed: int, image_set: str, index: int) -> np.random.Generator:
    """The pose draws of object ``index`` of an image set: a function of (seed, image set, index)
    only, apart from the placement's and the appearance's draws."""
    return np.random.default_rng([int(seed), zlib.crc32(image_set.encode()), int(index), 0x706F7365])
