"""What the placement says of an object's place in traffic (``Traffic``): the record keeps it
(record version 2), the checker reads it back and holds the pose to it (verdict.py)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Traffic:
    """Where an object stands in traffic, as the record keeps it.

    role       : ``moving`` / ``parked`` (vehicles), ``walking`` / ``standing`` (people), ``sign``
    where      : ``carriageway`` (the ego vehicle's), ``other carriageway``, ``side street``,
                 ``footway``
    lane_side  : ``right`` / ``left`` of the centre line (vehicles; of the street for people
                 and signs); None on a one-way carriageway for vehicles
    direction  : ``with`` / ``against`` the ego vehicle: the way a vehicle faces, a person
                 walks, or the traffic a sign faces; None for a standing person
    along_m, lateral_m : the object's road-frame position (street.py), metres
    heading_deg: the street's direction there (V, degrees, away from the camera; a side
                 street's own direction)
    centre_m   : the centre line's offset (None: one-way)
    lane_m     : the lane's (right, left) offsets (vehicles)
    pose_hint  : ``walking`` or ``standing`` (people; the cast poses the model so); ``away`` (a
                 sign that bars the traffic it faces, no entry: its back to the ego vehicle's way)
    layout     : ``parallel`` / ``angled`` / ``perpendicular`` (parked vehicles)
    """

    role: str
    where: str
    lane_side: str | None
    direction: str | None
    along_m: float
    lateral_m: float
    heading_deg: float
    centre_m: float | None = None
    lane_m: tuple[float, float] | None = None
    pose_hint: str | None = None
    layout: str | None = None

    def to_dict(self) -> dict:
        d = {"role": self.role, "where": self.where, "lane_side": self.lane_side, "direction": self.direction,
             "along_m": round(self.along_m, 3), "lateral_m": round(self.lateral_m, 3),
             "heading_deg": round(self.heading_deg, 3),
             "centre_m": None if self.centre_m is None else round(self.centre_m, 3),
             "lane_m": None if self.lane_m is None else [round(v, 3) for v in self.lane_m],
             "pose_hint": self.pose_hint, "layout": self.layout}
        return d

    @classmethod
    def from_dict(cls, d) -> "Traffic | None":
        """The traffic a record kept (None for a record without)."""
        if not d:
            return None
        lane = d.get("lane_m")
        return cls(str(d["role"]), str(d["where"]), d.get("lane_side"), d.get("direction"), float(d["along_m"]),
                   float(d["lateral_m"]), float(d["heading_deg"]), d.get("centre_m"),
                   None if lane is None else (float(lane[0]), float(lane[1])), d.get("pose_hint"), d.get("layout"))
