"""The placement rules and the typed values placement hands on: rules, poses, rejections."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .claim import Traffic

#: default allowed surfaces per Cityscapes class
ALLOWED_SURFACES: dict[str, tuple[str, ...]] = {
    "car": ("road",), "truck": ("road",), "bus": ("road",), "motorcycle": ("road",),
    "bicycle": ("road",), "rider": ("road",), "caravan": ("road",), "trailer": ("road",),
    "person": ("sidewalk",), "traffic sign": ("sidewalk", "terrain"), "traffic light": ("sidewalk", "terrain"),
    "pole": ("sidewalk", "terrain"),
}
#: default orientation rule per class (others: along-road): vehicles in traffic (moving in a
#: lane or parked at the kerb, facing their lane's direction), people walking or standing on
#: the footway, signs at the kerb facing the traffic they regulate (traffic.py)
ORIENTATION: dict[str, str] = {"person": "pedestrian", "rider": "along-road", "traffic sign": "facing-traffic",
                               "traffic light": "facing-traffic", "pole": "facing-traffic"}
#: along-road: a vehicle moving in its lane or parked, as the lane drawn is; moving / parked:
#: only so; pedestrian: walking or standing on the footway; facing-traffic: a sign at the kerb;
#: face-camera and random: turned towards the camera or at random, without traffic sense
ORIENTATIONS = ("along-road", "moving", "parked", "pedestrian", "facing-traffic", "face-camera", "random")
#: the traffic directions a manifest may ask for (placement.traffic)
TRAFFIC_SIDES = ("right-hand", "left-hand")


def surfaces_for(class_name: str, given=None) -> tuple[str, ...]:
    """The surfaces an object of a class may stand on: ``given``, else the class's default."""
    return tuple(given) if given else ALLOWED_SURFACES.get(class_name, ("road",))


#: classes that stand on a pole: only the pole's foot needs ground under it (its plate may
#: reach over a verge's edge, a wall's foot or a hedge), a square this wide, metres
POLE_MOUNTED, POLE_FOOT = ("traffic sign", "traffic light", "pole"), 0.3
#: a person stands on their feet: the box's length (the stride) by at most this width (two
#: feet at hip width, in shoes), metres; the swinging or hanging arms may reach over a kerb's
#: edge, as a real pedestrian's do
PERSON_STANCE = 0.4
#: classes that stand plumb whatever the ground's slope (a vehicle lies on the ground's plane)
UPRIGHT = POLE_MOUNTED + ("person",)


def standing_footprint(class_name: str, extents) -> tuple[float, float]:
    """(length, width) of the part of an object of ``extents`` that stands on the ground,
    centred like its box: the whole footprint, a pole-mounted object's pole foot (the cast's
    and the built-in signs stand their pole under the plate's middle) or a person's feet."""
    l, w = float(extents[0]), float(extents[1])
    if class_name in POLE_MOUNTED:
        return min(l, POLE_FOOT), min(w, POLE_FOOT)
    if class_name == "person":
        return l, min(w, PERSON_STANCE)
    return l, w


def orientation_for(class_name: str, given: str | None = None) -> str:
    """An object's orientation rule: ``given``, else the class's default."""
    return given or ORIENTATION.get(class_name, "along-road")
#: ground-level labels: where an allowed surface meets another of these there is a kerb line
GROUND_LEVEL = ("road", "sidewalk", "parking", "rail track", "terrain", "ground")
#: the footprint must stay this far from a kerb line of its own surface, metres
KERB_CLEARANCE = 0.2
#: a ground point is on the fitted plane when within this height of it (or within the stereo
#: noise band at its depth, whichever is larger), metres
INLIER_BAND = 0.04
#: the real ground under a footprint sample may differ from the pose's plane by this much (or
#: the stereo noise band), metres: a 10-15 cm kerb is a step, the noise at 40 m is not
SUPPORT_BAND = 0.06
#: a point of the object is hidden when the real depth is nearer by more than this (or the
#: stereo noise band)
OCCLUSION_TOL_REL = 0.01
OCCLUSION_TOL_ABS = 0.05
#: the deepest a real scene point may reach into an accepted object's box, metres (the
#: checker's limit: check-placement --strict)
MAX_PENETRATION = 0.05
#: a pose given outright may be this far above or below the ground it is checked against, metres
POSE_GROUND_SEARCH = 2.0


def box_corners(m: np.ndarray, extents, grow: float = 0.0) -> np.ndarray:
    """(8, 3) vehicle-frame corners of an object's box, its sides pushed out by ``grow``."""
    l, w, h = extents[0] / 2 + grow, extents[1] / 2 + grow, extents[2] + grow
    local = np.array([[sx * l, sy * w, z] for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, h)])
    return local @ m[:3, :3].T + m[:3, 3]


@dataclass(frozen=True)
class PlacementRules:
    distance: tuple[float, float] = (6.0, 45.0)  # ground distance from the camera, metres
    max_attempts: int = 200
    yaw_jitter_deg: float = 5.0
    clearance: float = 0.12  # scene points lower than this above the ground are not obstacles, metres
    margin: float = 0.10  # the collision box is this much larger than the object, metres
    object_gap: float = 0.6  # least ground distance between two inserted objects, metres
    min_collision_points: int = 3  # fewer points inside the box count as depth noise
    min_footprint_allowed: float = 0.97  # share of the visible footprint on allowed labels
    footprint_margin: float = 0.15  # the supporting ground must reach this far beyond the footprint, metres
    max_ground_rms: float = 0.05  # metres (or the stereo noise at the object's depth)
    max_ground_tilt_deg: float = 12.0
    min_ground_points: int = 30
    min_ground_inliers: float = 0.6  # share of the local ground points on the fitted plane
    min_visible_pixels: int = 150
    max_occluded_fraction: float = 0.7
    allow_truncation: bool = False  # objects may be cut by the image border
    parked_kerb_gap: float = 0.8  # (kept for manifests of earlier versions; parked cars stand traffic.PARK_GAP from the kerb)
    traffic: str = "right-hand"  # or "left-hand": which side of the road traffic keeps to


def rules_dict(rules: PlacementRules) -> dict:
    """The rules as the record keeps them (check-placement reads them back: :func:`rules_from`)."""
    from dataclasses import asdict

    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(rules).items()}


def rules_from(d) -> PlacementRules:
    """The rules a record kept (defaults for a record without them, or for keys it lacks)."""
    known = {f for f in PlacementRules.__dataclass_fields__}
    given = {k: (tuple(v) if isinstance(v, list) else v) for k, v in (d or {}).items() if k in known}
    return PlacementRules(**given)


@dataclass(frozen=True)
class Placement:
    """An accepted pose. Frames: vehicle V (ISO 8855) and optical S (see camera.py)."""

    class_name: str
    extents: tuple[float, float, float]  # object length, width, height, metres
    vehicle_from_object: tuple[tuple[float, ...], ...]  # (4, 4), object frame O -> V
    yaw: float  # radians about V's z, 0 = facing +x (driving direction)
    road_yaw: float | None  # local road direction estimated from the kerb lines, radians (mod pi)
    ground_normal: tuple[float, float, float]
    ground_rms: float  # metres
    distance: float  # ground distance from the camera, metres
    pixel: tuple[int, int]  # (row, column) of the chosen ground point
    occluded_estimate: float  # share of the object hidden by the real scene (box samples)
    truncated: bool  # the object crosses the image border
    traffic: "Traffic | None" = None  # where it stands in traffic (traffic.py); None: no traffic sense asked

    @property
    def pose_hint(self) -> str | None:
        """A person's pose for where it stands: ``walking`` (along the footway, ``yaw`` its
        walking direction) or ``standing`` (waiting at the kerb facing the road, or by a door);
        None for other objects. The cast poses the model so."""
        return None if self.traffic is None else self.traffic.pose_hint

    @property
    def matrix(self) -> np.ndarray:
        return np.array(self.vehicle_from_object)

    @property
    def position(self) -> np.ndarray:
        """Ground contact point (centre of the footprint) in V."""
        return self.matrix[:3, 3]

    def box_corners(self, grow: float = 0.0) -> np.ndarray:
        """(8, 3) corners of the object's box in V (grown by ``grow`` metres, not below z = 0)."""
        return box_corners(self.matrix, self.extents, grow)


@dataclass(frozen=True)
class PlacementResult:
    placement: Placement | None
    attempts: int
    rejections: dict[str, int] = field(default_factory=dict)


#: the placement rule each rejection reason belongs to (the preview names it)
RULE_OF: dict[str, str] = {
    "outside the distance range": "distance",
    "partly behind the camera": "in view",
    "not fully inside the image": "truncation",
    "footprint outside the image": "ground support",
    "footprint hidden": "ground support",
    "footprint off the allowed surface": "ground support",
    "footprint off the ground plane (step or kerb)": "ground support",
    "footprint crosses a kerb line": "ground support",
    "too few ground points": "ground plane",
    "ground not planar (step or kerb)": "ground plane",
    "ground not flat (rms too high)": "ground plane",
    "ground too steep": "ground plane",
    "candidate point is off the fitted ground (kerb face, noise)": "ground plane",
    "object is off the fitted ground": "ground plane",
    "too much hidden by the scene": "max occluded share",
    "too few visible pixels": "min visible pixels",
    "would hide an object placed before": "max occluded share",
    "overlaps another inserted object": "collision",
    "sign hidden behind an inserted object": "max occluded share",
    "would hide a sign placed before": "max occluded share",
    "intersects the scene": "collision",
}


@dataclass(frozen=True)
class Rejection:
    """Why a pose breaks a placement rule: ``reason`` as the record counts it, ``detail`` the
    measurement behind it (for people; empty where there is nothing to add)."""

    reason: str
    detail: str = ""

    @property
    def rule(self) -> str:
        return RULE_OF.get(self.reason, "placement")

    def __str__(self) -> str:
        return f"{self.rule}: {self.reason}" + (f" ({self.detail})" if self.detail else "")


def label_mask(ids) -> np.ndarray:
    """(256,) bool lookup table of label ids: ``label_mask(ids)[labels]`` is a fast np.isin."""
    lut = np.zeros(256, bool)
    lut[np.asarray(ids, int)] = True
    return lut
