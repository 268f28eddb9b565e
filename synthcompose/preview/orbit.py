"""The preview window's orbit camera around a target in the vehicle frame (z up)."""
from __future__ import annotations

import math

import numpy as np

from synthcompose.render.transforms import look_at, perspective


class Orbit:
    """Orbit camera around a target in the vehicle frame (z up)."""

    def __init__(self) -> None:
        self.target = np.zeros(3)
        self.yaw, self.pitch, self.distance = math.radians(200.0), math.radians(35.0), 25.0

    @property
    def eye(self) -> np.ndarray:
        cp = math.cos(self.pitch)
        return self.target + self.distance * np.array([cp * math.cos(self.yaw), cp * math.sin(self.yaw),
                                                       math.sin(self.pitch)])

    def matrix(self, aspect: float) -> np.ndarray:
        return perspective(50.0, aspect, 0.1, 1000.0) @ look_at(self.eye, self.target)

    def pan(self, dx: float, dy: float) -> None:
        view = look_at(self.eye, self.target)
        right, up = view[0, :3], view[1, :3]
        k = self.distance * 0.0015
        self.target = self.target - right * dx * k + up * dy * k
