"""Where the sun can stand (lighting.solar) and how the estimate uses it: the sun's elevation at
a compass azimuth over a year at a latitude, checked against the closed forms, and the side of
a shadow axis the sun cannot stand on not taken."""
from __future__ import annotations

import math

import numpy as np
import pytest

from synthcompose.lighting.solar import MIN_ELEVATION, OBLIQUITY, SunSite, elevations_at


def test_the_sun_stands_highest_in_the_south_at_its_summer_height():
    e = elevations_at(51.0, 180.0)
    assert e.max() == pytest.approx(90.0 - 51.0 + OBLIQUITY, abs=0.3)
    assert e.min() == pytest.approx(90.0 - 51.0 - OBLIQUITY, abs=0.3)
    for compass in range(0, 360, 5):  # nowhere higher
        there = elevations_at(51.0, float(compass))
        assert not len(there) or there.max() <= 90.0 - 51.0 + OBLIQUITY + 0.3


def test_due_east_the_sun_stands_only_in_summer_and_never_high():
    # due east (the prime vertical) sin(e) = sin(declination) / sin(latitude)
    top = math.degrees(math.asin(math.sin(math.radians(OBLIQUITY)) / math.sin(math.radians(51.0))))
    e = elevations_at(51.0, 90.0)
    assert e.max() == pytest.approx(top, abs=0.5)
    assert e.min() >= MIN_ELEVATION
    np.testing.assert_allclose(np.sort(e), np.sort(elevations_at(51.0, 270.0)), atol=0.5)  # noon's mirror


@pytest.mark.parametrize("compass", [0.0, 30.0, 330.0])
def test_in_germany_the_sun_never_stands_in_the_north(compass):
    assert not len(elevations_at(51.0, compass))
    assert len(elevations_at(-51.0, compass))  # in the south it does


def test_a_vehicle_azimuth_turns_with_the_heading():
    site = SunSite(latitude=51.0, heading=90.0)  # heading east
    assert site.compass(0.0) == pytest.approx(90.0)  # ahead: east
    assert site.compass(90.0) == pytest.approx(0.0)  # left (the vehicle frame's y): north
    assert site.compass(-90.0) == pytest.approx(180.0)  # right: south
    assert not len(site.elevations(90.0)) and len(site.elevations(270.0))


def test_an_untold_side_is_the_one_where_the_sun_can_stand_highest():
    """Where no cue tells the sun's side of a shadow axis, the estimate takes the side where the
    sun stands highest at the site: its shadow the shortest, the least seen if it is the wrong
    side. Heading east-north-east at 51 degrees north, the axis 149/329 (vehicle frame) points
    west-south-west / east-south-east: the sun stands at most ~24 degrees high in the WSW
    (evenings) and ~38 in the ESE (mornings)."""
    from synthcompose.lighting.estimate import unsure_side

    site = SunSite(latitude=51.0, heading=69.0)
    low, high = site.elevations(149.3).max(), site.elevations(329.3).max()
    assert low < 26.0 < 36.0 < high
    assert unsure_side(site, 149.3) == pytest.approx(329.3)
    assert unsure_side(site, 329.3) == pytest.approx(329.3)
    north = SunSite(latitude=51.0, heading=0.0)
    # heading north, an east-west axis (left: west, right: east): both sides as high, kept
    assert unsure_side(north, 90.0) == pytest.approx(90.0)
    assert unsure_side(north, 270.0) == pytest.approx(270.0)
    # ahead (vehicle azimuth 0) the sun never stands, behind (180, south) it does
    assert unsure_side(north, 0.0) == pytest.approx(180.0)
    assert unsure_side(north, 180.0) == pytest.approx(180.0)
