"""Cityscapes' vehicle file (``vehicle/<split>/<city>/<name>_vehicle.json``): the car's GPS
position and compass heading when the frame was taken. Optional: most copies of the dataset
leave it out; where it is there, the light estimate knows where the sun can stand."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from synthcompose.errors import InputError

from .files import read_json


@dataclass(frozen=True)
class Vehicle:
    """heading: degrees clockwise from north (``gpsHeading``); latitude and longitude: degrees
    (``gpsLatitude``, ``gpsLongitude``)."""

    heading: float
    latitude: float
    longitude: float


def read_vehicle(path: Path) -> Vehicle | None:
    """The vehicle file at ``path``; None where there is none or its GPS fields are null or
    missing (no fix); an :class:`InputError` naming it and the field where it is not a vehicle
    file (not JSON, a field not a number or out of its range)."""
    if not Path(path).exists():
        return None
    data = read_json(path)
    if not isinstance(data, dict):
        raise InputError(path, "is not a JSON object (a Cityscapes vehicle file has gpsHeading, gpsLatitude, ...)")
    values = {}
    for key, low, high in (("gpsHeading", -360.0, 360.0), ("gpsLatitude", -90.0, 90.0),
                           ("gpsLongitude", -180.0, 180.0)):
        v = data.get(key)
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(path, f"{key} is {v!r}: a number is needed")
        if not low <= v <= high:
            raise InputError(path, f"{key} is {v}: outside {low:g}..{high:g} degrees")
        values[key] = float(v)
    return Vehicle(values["gpsHeading"] % 360.0, values["gpsLatitude"], values["gpsLongitude"])
