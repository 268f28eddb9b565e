"""The built-in street cast (``"cast": "street"`` in a manifest): what a German town street
shows, as pools of the catalogue and their shares of the inserted objects.

Cars are most of the traffic, compact cars and saloons the most of them (the German fleet:
about a quarter compact class, a fifth lower-middle and middle class saloons, an SUV or
off-roader for every six cars, estates common, few vans); buses and lorries are few in town;
people are on every footway; signs stand at every junction. Within a pool each entry counts
by its own ``weight``. A pool without entries in the catalogue is left out, so the mix takes
whatever models are installed.
"""
from __future__ import annotations

#: (name, selector, weight): each inserted object is one of these (by weight), then one entry
#: of its pool (by the entries' weights)
STREET: tuple[tuple[str, str, float], ...] = (
    ("compact car", "compact", 3.0),
    ("saloon", "saloon", 3.0),
    ("estate car", "estate", 1.5),
    ("suv", "suv", 1.5),
    ("van", "van", 0.6),
    ("classic car", "classic", 0.1),
    ("bus", "bus", 0.25),
    ("lorry", "lorry", 0.35),
    ("person", "person", 4.0),
    ("traffic sign", "traffic sign", 2.5),
)
CASTS = {"street": STREET}
