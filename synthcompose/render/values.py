"""What a render takes and gives, without the GL side: the screen rectangle (:class:`Roi`), the
light (:class:`Lighting`), the objects to draw (:class:`RenderObject`), the passes a render
leaves (:class:`RenderPasses`) and the rectangle objects cover (:func:`roi_for`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import moderngl
import numpy as np

from synthcompose.camera import Camera
from synthcompose.lighting.light import Lighting
from synthcompose.models import Model

from .gl import GLContext

NEAR, FAR = 0.5, 500.0  # metres, optical z range rendered
#: a ground plane reaches this far (metres) beyond the object's footprint: past where its
#: occlusion of the sky has faded (render.lit.PLANE_FADE), so the plane's edges never show
PLANE_MARGIN = 1.5
#: and as far as the sun throws the object's shadow, up to this (metres)
SHADOW_REACH = 8.0
#: the id pass writes object index k (1..15) | part label << PART_SHIFT: a part labelled apart
#: from its object (a sign's pole) carries its Cityscapes id there, 0 elsewhere
PART_SHIFT = 8


@dataclass(frozen=True)
class Roi:
    """Screen rectangle in pixels: columns x0..x0+width-1, rows y0..y0+height-1."""

    x0: int
    y0: int
    width: int
    height: int

    @property
    def slices(self) -> tuple[slice, slice]:
        """(rows, columns) slices of a full-frame array."""
        return slice(self.y0, self.y0 + self.height), slice(self.x0, self.x0 + self.width)


@dataclass(frozen=True, eq=False)
class RenderObject:
    """One object to draw: its model, pose and the local ground plane under it."""

    model: Model
    vehicle_from_object: np.ndarray  # (4, 4)
    plane_albedo: tuple[float, float, float]  # linear RGB of the real ground there
    #: the ground plane reaches this far beyond the footprint (plus the shadow), metres
    plane_margin: float = PLANE_MARGIN
    sun_visibility: float = 1.0  # sun reaching the object: 0 when it stands in a real cast shadow (lighting.py)
    recolour: tuple = ()  # ((material key rgba, linear rgb), ...): its paint or clothes (look/appearance.py), at most 3
    plate: str | None = None  # the registration on its number plates (look/plates.py); None: blank plates

    def shadow_reach(self, lighting: "Lighting") -> np.ndarray:
        """(2,) object-frame vector from the footprint's centre: where and how far (at most
        :data:`SHADOW_REACH`) the sun throws the top of the object's shadow."""
        h = self.model.extents[2]
        d = np.asarray(lighting.sun_direction, float)
        flat = math.hypot(d[0], d[1])
        if flat < 1e-6:
            return np.zeros(2)
        length = min(h * flat / max(d[2], 0.05), SHADOW_REACH)
        away = -(self.vehicle_from_object[:3, :3].T @ np.array([d[0], d[1], 0.0]))[:2]
        return away / max(np.linalg.norm(away), 1e-12) * length

    def plane_half(self, lighting: "Lighting") -> tuple[float, float]:
        """Half sizes (x, y) of the rectangular ground plane in the object frame: the footprint,
        the margin, and the object's shadow (:meth:`shadow_reach`, on its side only)."""
        l, w, _ = self.model.extents
        rx, ry = np.abs(self.shadow_reach(lighting))
        return l / 2 + self.plane_margin + rx / 2, w / 2 + self.plane_margin + ry / 2

    def plane_matrix(self, lighting: "Lighting") -> np.ndarray:
        """(4, 4) vehicle <- unit square [-1, 1]^2 at z = 0: the pose of the ground plane, its
        centre moved half the shadow's reach towards the shadow."""
        hx, hy = self.plane_half(lighting)
        cx, cy = self.shadow_reach(lighting) / 2
        square = np.diag([hx, hy, 1.0, 1.0])
        square[:2, 3] = (cx, cy)
        return self.vehicle_from_object @ square

    def corners(self, lighting: "Lighting") -> np.ndarray:
        """(16, 3) vehicle-frame corners of the object's box and of its plane."""
        l, w, h = self.model.extents
        box = np.array([[sx * l / 2, sy * w / 2, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0, h)])
        m = self.vehicle_from_object
        box = box @ m[:3, :3].T + m[:3, 3]
        unit = np.array([[sx, sy, 0.0, 1.0] for sx in (-1, 1) for sy in (-1, 1)])
        plane = (unit @ self.plane_matrix(lighting).T)[:, :3]
        return np.concatenate([box, plane, plane + [0, 0, 0.01]])


@dataclass(frozen=True, eq=False)
class RenderPasses:
    """GL textures of one render (ROI-sized), owned by the renderer's GLContext."""

    roi: Roi
    camera: Camera  # cropped to the ROI
    textures: dict[str, moderngl.Texture] = field(repr=False)
    gl: GLContext = field(repr=False)

    def read(self, name: str, widen: bool = True) -> np.ndarray:
        """Read one pass back: (H, W, C) float32 (half floats widened; ``widen`` False: as
        stored, float16 for a pass of colour), or (H, W) uint32 for ``id`` (the object
        index) and ``part`` (the Cityscapes id of a part labelled apart from its object, else 0:
        both kept in the id texture)."""
        self.gl.activate().wait()
        tex = self.textures["id" if name == "part" else name]
        dtype = {"u4": np.uint32, "u2": np.uint16, "f2": np.float16}.get(tex.dtype, np.float32)
        arr = np.frombuffer(tex.read(), dtype).reshape(tex.height, tex.width, tex.components)
        if dtype is np.float16 and widen:  # a pass of colour resolved in half floats (render.COLOUR_PASSES)
            arr = arr.astype(np.float32)
        arr = arr[..., 0] if tex.components == 1 else arr
        if name == "id":
            return arr & np.uint32((1 << PART_SHIFT) - 1)
        return arr >> np.uint32(PART_SHIFT) if name == "part" else arr


def crop_camera(camera: Camera, roi: Roi) -> Camera:
    """The camera of a sub-image: same pose, principal point shifted, size of the ROI."""
    return replace(camera, u0=camera.u0 - roi.x0, v0=camera.v0 - roi.y0, width=roi.width, height=roi.height)


def roi_for(camera: Camera, objects: Sequence[RenderObject], lighting: Lighting, margin: int = 4) -> Roi | None:
    """Screen rectangle holding every object and plane, or None when nothing is on screen."""
    pts = np.concatenate([o.corners(lighting) for o in objects])
    optical = pts @ camera.optical_from_vehicle[:3, :3].T + camera.optical_from_vehicle[:3, 3]
    if (optical[:, 2] <= NEAR).any():
        x0, y0, x1, y1 = 0, 0, camera.width, camera.height
    else:
        uv = camera.project(optical)
        x0 = int(math.floor(uv[:, 0].min())) - margin
        y0 = int(math.floor(uv[:, 1].min())) - margin
        x1 = int(math.ceil(uv[:, 0].max())) + margin + 1
        y1 = int(math.ceil(uv[:, 1].max())) + margin + 1
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, camera.width), min(y1, camera.height)
    if x1 <= x0 or y1 <= y0:
        return None
    return Roi(x0, y0, x1 - x0, y1 - y0)


def mask_box(mask: np.ndarray, x_offset: int = 0, y_offset: int = 0) -> list[int] | None:
    """[x0, y0, x1, y1] of the True pixels of an (H, W) mask (+ offsets), or None if empty."""
    cols = np.flatnonzero(mask.any(axis=0))
    if cols.size == 0:
        return None
    rows = np.flatnonzero(mask.any(axis=1))
    return [int(cols[0]) + x_offset, int(rows[0]) + y_offset, int(cols[-1]) + 1 + x_offset,
            int(rows[-1]) + 1 + y_offset]


def amodal_boxes(ids: np.ndarray, roi: Roi, count: int) -> list[list[int] | None]:
    """Amodal 2D box of each object 1..count in the full frame.

    ``ids`` (roi.height, roi.width) uint32: the render's ``id`` pass (object index 1..K of the
    full silhouette at each pixel centre, before occlusion by the real scene). The ROI lies
    inside the image, so the boxes are clipped to it. Returns a list of length ``count``.
    """
    return [mask_box(ids == k, roi.x0, roi.y0) for k in range(1, count + 1)]
