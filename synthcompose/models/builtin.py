"""Models built in code (``builtin:<name>`` in a manifest): a stop sign (its plate from the STL
files shipped in ``synthcompose/builtin/``) and a box."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synthcompose.colour import srgb_to_linear

from .mesh import MeshPart, part_from_trimesh

#: the built-in models' files, shipped in the package (a wheel alone can draw them)
_BUILTIN_FILES = Path(__file__).resolve().parent.parent / "builtin"


def _coloured(mesh, rgb_srgb, metallic=0.0, roughness=0.6, smooth=True) -> MeshPart:
    import trimesh

    m = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    part = part_from_trimesh(m, smooth)
    n = len(part.positions)
    col = np.tile(np.append(srgb_to_linear(np.asarray(rgb_srgb, np.float32)), 1.0), (n, 1)).astype(np.float32)
    return MeshPart(part.positions, part.normals, part.uvs, col,
                    np.tile(np.array([metallic, roughness], np.float32), (n, 1)), part.indices, None)


def traffic_sign_parts(plate_height: float = 2.0, pole_radius: float = 0.035) -> list[MeshPart]:
    """A stop sign on a pole, built in code; the sign's face looks along +x.

    The plate comes from ``synthcompose/builtin/stop_sign_*.stl`` (MIT, see LICENSE-stop_sign
    there; the source and full model stay in ``assets/models/stop_sign``); the pole is a
    cylinder. ``plate_height`` is the height of the plate's centre above the ground.
    """
    import trimesh

    pole = trimesh.creation.cylinder(radius=pole_radius, height=plate_height + 0.1, sections=24)
    pole.apply_translation([0, 0, (plate_height + 0.1) / 2])
    parts = [_coloured(pole, (0.55, 0.56, 0.57), metallic=0.8, roughness=0.4)]
    # plate files: octagon in their x/y plane, front towards +z, text upright along +y
    to_o = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # file z -> O x, x -> y, y -> z
    red = trimesh.load(str(_BUILTIN_FILES / "stop_sign_red.stl"), process=False)
    white = trimesh.load(str(_BUILTIN_FILES / "stop_sign_white.stl"), process=False)
    centre = red.bounds.mean(axis=0)
    for mesh, rgb in ((red, (0.70, 0.05, 0.06)), (white, (0.92, 0.92, 0.92))):
        m = mesh.copy()
        m.apply_translation(-centre)
        transform = np.eye(4)
        transform[:3, :3] = to_o
        transform[:3, 3] = [pole_radius + 0.004, 0, plate_height]
        m.apply_transform(transform)
        parts.append(_coloured(m, rgb, roughness=0.5, smooth=False))
    return parts


def box_parts() -> list[MeshPart]:
    """A 1 m cube standing on z = 0 (for tests and placement debugging)."""
    import trimesh

    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    box.apply_translation([0, 0, 0.5])
    return [_coloured(box, (0.8, 0.8, 0.8), smooth=False)]


BUILTINS = {"traffic-sign": traffic_sign_parts, "box": box_parts}
