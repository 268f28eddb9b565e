"""The Cityscapes camera: intrinsics, extrinsics and every frame change we use.

Frames (all right-handed, metres)::

    vehicle V (ISO 8855)        camera C             optical S            image I
    origin: ground below the    origin: optical      same origin as C     origin: top-left
    rear axle centre            centre               x right, y down,     pixel centre;
         z ^  ^ x               axes as V after      z forward (depth)    u right, v down
           | /                  rotation R                                (pixels)
     y <---+
                                p_V = R @ p_C + t     p_S = M @ p_C        u = fx*x/z + u0
                                t = (x, y, z) and     M = [[0,-1, 0],      v = fy*y/z + v0
                                R = Rz(yaw) Ry(pitch)      [0, 0,-1],
                                    Rx(roll)              [1, 0, 0]]

    GL clip space: :meth:`Camera.gl_projection` maps optical S straight to clip space so that
    framebuffer row 0 is image row 0 (v = 0, the top); arrays read back need no flip.

The extrinsic block of a Cityscapes ``camera.json`` gives (baseline, x, y, z, yaw, pitch,
roll); the intrinsic block (fx, fy, u0, v0). Values differ between frames.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from synthcompose.io.files import read_json

from .errors import InputError

#: optical S from camera C: x_S = -y_C, y_S = -z_C, z_S = x_C (cityscapesScripts' K multiplier)
OPTICAL_FROM_CAMERA = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], float)


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], float)


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], float)


#: the range each camera field must lie in (low, high, unit): focal lengths and the principal
#: point in image widths (fx, u0) or heights (fy, v0), the rest as given. Cityscapes: fx ~ 1.1
#: widths, u0 ~ 0.53 widths, baseline 0.21 m, the camera 1.2-1.7 m up, angles of a few degrees
CAMERA_LIMITS: dict[str, tuple[float, float, str]] = {
    "fx": (0.05, 100.0, "px"), "fy": (0.05, 100.0, "px"), "u0": (-10.0, 10.0, "px"), "v0": (-10.0, 10.0, "px"),
    "baseline": (0.0, 10.0, "m"), "x": (-100.0, 100.0, "m"), "y": (-100.0, 100.0, "m"), "z": (-100.0, 100.0, "m"),
    "yaw": (-2 * math.pi, 2 * math.pi, "rad"), "pitch": (-2 * math.pi, 2 * math.pi, "rad"),
    "roll": (-2 * math.pi, 2 * math.pi, "rad"),
}


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None (a bool, a string, an integer beyond a float)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:
        return None
    return value if math.isfinite(value) else None


@dataclass(frozen=True)
class Camera:
    """A calibrated Cityscapes camera for one frame of size ``width`` x ``height`` pixels."""

    fx: float
    fy: float
    u0: float
    v0: float
    baseline: float  # metres
    x: float  # camera position in V, metres
    y: float
    z: float
    yaw: float  # radians
    pitch: float
    roll: float
    width: int
    height: int

    # ----------------------------------------------------------------- reading
    @classmethod
    def from_dict(cls, data: Any, width: int, height: int, path: str | Path = "<camera>") -> "Camera":
        """Build from the parsed content of a Cityscapes camera JSON, checking every field: a
        number (not a string), finite, within :data:`CAMERA_LIMITS`."""
        if not isinstance(data, dict):
            raise InputError(path, "camera JSON must be an object with 'intrinsic' and 'extrinsic'")
        values: dict[str, float] = {}
        for block, keys in (("intrinsic", ("fx", "fy", "u0", "v0")),
                            ("extrinsic", ("baseline", "x", "y", "z", "yaw", "pitch", "roll"))):
            sub = data.get(block)
            if not isinstance(sub, dict):
                raise InputError(path, f"camera JSON has no '{block}' object")
            for key in keys:
                if key not in sub:
                    raise InputError(path, f"camera JSON '{block}' has no '{key}'")
                val = _number(sub[key])
                if val is None:
                    found = repr(sub[key]) if not isinstance(sub[key], (dict, list)) else type(sub[key]).__name__
                    raise InputError(path, f"camera JSON '{block}.{key}' must be a finite number, found "
                                           f"{found[:40]}" + (" (a string)" if isinstance(sub[key], str) else ""))
                values[key] = val
        for key in ("fx", "fy", "baseline"):
            if values[key] <= 0:
                raise InputError(path, f"camera JSON '{key}' must be positive, found {values[key]!r}")
        size = {"fx": width, "fy": height, "u0": width, "v0": height}
        for key, (lo, hi, unit) in CAMERA_LIMITS.items():
            scale = size.get(key, 1)
            if not lo * scale <= values[key] <= hi * scale:
                raise InputError(path, f"camera JSON '{key}' is {values[key]:g} {unit}, outside "
                                       f"[{lo * scale:g}, {hi * scale:g}]: not a street camera's calibration")
        return cls(width=int(width), height=int(height), **values)

    @classmethod
    def read(cls, path: str | Path, width: int, height: int) -> "Camera":
        return cls.from_dict(read_json(path), width, height, path)

    def to_dict(self) -> dict[str, Any]:
        """The Cityscapes camera JSON content of this camera."""
        return {
            "extrinsic": {"baseline": self.baseline, "pitch": self.pitch, "roll": self.roll,
                          "x": self.x, "y": self.y, "yaw": self.yaw, "z": self.z},
            "intrinsic": {"fx": self.fx, "fy": self.fy, "u0": self.u0, "v0": self.v0},
        }

    def right_camera(self) -> "Camera":
        """The rectified right camera of the stereo pair: the same intrinsics and orientation,
        ``baseline`` metres along the optical x axis. A point at depth z seen at column u in the
        left image is at column u - fx * baseline / z in the right one (its disparity)."""
        x, y, z = self.position + self.vehicle_from_optical[:3, :3] @ np.array([self.baseline, 0.0, 0.0])
        return replace(self, x=float(x), y=float(y), z=float(z))

    # -------------------------------------------------------------- transforms
    @property
    def K(self) -> np.ndarray:
        """(3, 3) intrinsic matrix, pixels."""
        return np.array([[self.fx, 0, self.u0], [0, self.fy, self.v0], [0, 0, 1.0]])

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) R with p_V = R @ p_C + t."""
        return _rot_z(self.yaw) @ _rot_y(self.pitch) @ _rot_x(self.roll)

    @property
    def position(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])

    @cached_property
    def _vehicle_from_optical(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.rotation @ OPTICAL_FROM_CAMERA.T
        m[:3, 3] = self.position
        return m

    @cached_property
    def _optical_from_vehicle(self) -> np.ndarray:
        r = OPTICAL_FROM_CAMERA @ self.rotation.T
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = -r @ self.position
        return m

    @property
    def vehicle_from_optical(self) -> np.ndarray:
        """(4, 4) homogeneous transform taking optical-frame points to the vehicle frame (a
        copy of the one worked out once per camera: placement asks for it thousands of times)."""
        return self._vehicle_from_optical.copy()

    @property
    def optical_from_vehicle(self) -> np.ndarray:
        """(4, 4) inverse of :attr:`vehicle_from_optical`."""
        return self._optical_from_vehicle.copy()

    def project(self, points_optical: np.ndarray) -> np.ndarray:
        """(N, 3) optical-frame points -> (N, 2) pixel coordinates (u, v); z must be > 0."""
        p = np.asarray(points_optical, float)
        return np.stack([self.fx * p[:, 0] / p[:, 2] + self.u0, self.fy * p[:, 1] / p[:, 2] + self.v0], axis=1)

    def gl_projection(self, near: float, far: float) -> np.ndarray:
        """(4, 4) matrix: optical frame -> GL clip space for a ``width`` x ``height`` target.

        Pixel (u, v) in Cityscapes convention (integer = pixel centre) lands on window
        coordinate (u + 0.5, v + 0.5), with window row 0 = image row 0. Depth is mapped
        from [near, far] to NDC [-1, 1]. Flipping y this way reverses triangle winding, so
        render without face culling (or cull front faces).
        """
        w, h = self.width, self.height
        p = np.zeros((4, 4))
        p[0, 0] = 2 * self.fx / w
        p[0, 2] = (2 * self.u0 + 1) / w - 1
        p[1, 1] = 2 * self.fy / h
        p[1, 2] = (2 * self.v0 + 1) / h - 1
        p[2, 2] = (far + near) / (far - near)
        p[2, 3] = -2 * far * near / (far - near)
        p[3, 2] = 1.0
        return p
