"""Where the sun can stand: its elevation at each compass azimuth over a year, at the place a
photo was taken (Cityscapes' vehicle file: GPS latitude and heading).

A shadow edge on the ground gives the sun's azimuth up to its side (the sun or the point
opposite) and no height. The sun's path is fixed by the latitude and the day: at 51 degrees
north it never stands in the north, stands in the east or west only in summer and at most 31
degrees high, and never higher than 62 degrees. Knowing the camera's compass heading turns the
two candidate sides into compass azimuths, one of which the sun may never reach, and bounds the
height at the other.

Angles: compass azimuths in degrees clockwise from north; the vehicle frame's azimuths (x
ahead, y left, as everywhere in :mod:`synthcompose.lighting`) counter-clockwise from ahead, so a
direction at vehicle azimuth ``a`` points to compass ``heading - a``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: degrees: the Earth's axial tilt (the declination's range over a year)
OBLIQUITY = 23.44
#: degrees: a sun lower than this lights no street (its shadows are nearly six times as long as
#: what casts them: the houses shade the road) and the shadow edges it throws are not read here
MIN_ELEVATION = 10.0
#: days of the year: where the sun passes at least MIN_ELEVATION high on fewer days than this
#: (a sliver near the sunrise and sunset azimuths of midsummer, minutes a day), it is not taken
#: to stand there
MIN_DAYS = 30


@dataclass(frozen=True)
class SunSite:
    """The place and the camera's compass heading of one photo."""

    latitude: float  # degrees, north positive
    heading: float  # degrees clockwise from north: where the vehicle (and the camera) points

    @classmethod
    def of(cls, vehicle) -> "SunSite | None":
        """The site of a photo's vehicle file (:class:`~synthcompose.io.vehicle.Vehicle`), None
        without one."""
        return None if vehicle is None else cls(float(vehicle.latitude), float(vehicle.heading))

    def compass(self, vehicle_azimuth: float) -> float:
        """Compass azimuth (degrees) of a direction at ``vehicle_azimuth`` in the vehicle frame."""
        return (self.heading - vehicle_azimuth) % 360.0

    def elevations(self, vehicle_azimuth: float) -> np.ndarray:
        """The sun's elevations (degrees) when it stands at ``vehicle_azimuth``, one per day of a
        year on which it passes there at least :data:`MIN_ELEVATION` high; empty when it never
        does."""
        return elevations_at(self.latitude, self.compass(vehicle_azimuth))


def declinations() -> np.ndarray:
    """The sun's declination (degrees) on each day of a year (the cosine approximation)."""
    day = np.arange(365)
    return -OBLIQUITY * np.cos(2.0 * math.pi * (day + 10) / 365.0)


def elevations_at(latitude: float, compass_azimuth: float) -> np.ndarray:
    """The sun's elevations (degrees) at ``compass_azimuth`` on the days of a year it passes
    there at least :data:`MIN_ELEVATION` high; empty where those are fewer than
    :data:`MIN_DAYS`.

    On the celestial sphere, sin(declination) = sin(latitude) sin(e) + cos(latitude) cos(e)
    cos(azimuth): for a day's declination, a sin e + b cos e = c, whose solution in [0, 90]
    degrees, e = asin(c / R) - psi or 180 - asin(c / R) - psi (R, psi the amplitude and phase
    of a sin e + b cos e), is where that day's path crosses the azimuth (at most once a day
    outside the tropics)."""
    phi, az = math.radians(latitude), math.radians(compass_azimuth)
    a, b = math.sin(phi), math.cos(phi) * math.cos(az)
    amplitude, psi = math.hypot(a, b), math.atan2(b, a)
    c = np.sin(np.radians(_DECLINATIONS)) / amplitude
    c = c[np.abs(c) <= 1.0]
    roots = np.degrees(np.concatenate([np.arcsin(c) - psi, math.pi - np.arcsin(c) - psi]))
    e = roots[(roots >= MIN_ELEVATION) & (roots <= 90.0)]
    return e if len(e) >= MIN_DAYS else np.empty(0)


_DECLINATIONS = declinations()
