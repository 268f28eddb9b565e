"""4x4 matrices for OpenGL, written once: row-major NumPy (4, 4) float64, applied to column
vectors (``m @ [x, y, z, 1]``), and :func:`gl_mat4` to hand one to a GLSL ``mat4`` uniform.

:func:`look_at`, :func:`ortho` and :func:`perspective` follow OpenGL's eye-space convention
(the eye looks down its -z, +y up; clip z from -1 at ``near`` to +1 at ``far``): the renderer's
light views (sun, sky and underside maps) and the preview's orbit camera. The photo's own
camera does not use them: it draws in the optical frame (z forward, y down) with
:meth:`synthcompose.camera.Camera.gl_projection`.
"""
from __future__ import annotations

import math

import numpy as np

#: clip space [-1, 1]^3 -> [0, 1]^3: texture coordinates and depth of a shadow-map lookup
TEXTURE_FROM_CLIP = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """(4, 4) view matrix: world -> eye space of an eye at ``eye`` looking at ``target``, with
    ``up`` (default +z, the vehicle frame's up) showing upwards; ``up`` must not be parallel to
    the line of sight (the sideways axis is then ill-defined; its length is floored at 1e-9)."""
    eye = np.asarray(eye, float)
    f = np.asarray(target, float) - eye
    f = f / np.linalg.norm(f)
    s = np.cross(f, up)
    s = s / max(np.linalg.norm(s), 1e-9)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def ortho(half: float, near: float, far: float) -> np.ndarray:
    """(4, 4) orthographic projection of the square [-half, half]^2 (metres, eye space) and
    depths ``near``..``far`` in front of the eye."""
    m = np.eye(4)
    m[0, 0] = m[1, 1] = 1.0 / half
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def perspective(fovy_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """(4, 4) perspective projection (``gluPerspective``): vertical field of view ``fovy_deg``
    degrees, ``aspect`` = width / height, depths ``near``..``far`` in front of the eye."""
    f = 1.0 / math.tan(math.radians(fovy_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0], m[1, 1] = f / aspect, f
    m[2, 2], m[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def gl_mat4(m: np.ndarray) -> bytes:
    """Row-major NumPy matrix -> column-major float32 bytes for a GLSL mat4 uniform."""
    return np.ascontiguousarray(np.asarray(m, np.float32).T).tobytes()
