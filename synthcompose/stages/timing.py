"""Stage timings: each stage adds its wall time to the image set's :class:`Timings` (seconds)."""
from __future__ import annotations

import time
from contextlib import contextmanager
from typing import Iterator


class Timings:
    """The wall seconds each stage of one image set took, added as the stages run (on the
    preparing, shading and writing threads in turn, never two at once)."""

    __slots__ = ("_seconds",)

    def __init__(self) -> None:
        self._seconds: dict[str, float] = {}

    def add(self, stage: str, seconds: float) -> None:
        self._seconds[stage] = self._seconds.get(stage, 0.0) + seconds

    def seconds(self) -> dict[str, float]:
        """stage -> seconds so far (a copy: the outcome's)."""
        return dict(self._seconds)


@contextmanager
def timed(timings: Timings, stage: str) -> Iterator[None]:
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings.add(stage, time.perf_counter() - t0)
