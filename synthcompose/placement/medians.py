"""Medians of many groups at once: the values of each group (a bin of depths, an image row) as
``np.median`` gives them one group at a time, from one sort instead of a call per group."""
from __future__ import annotations

import numpy as np


def group_medians(groups: np.ndarray, values: np.ndarray, n: int, least: int = 1) -> np.ndarray:
    """(n,) float64: for each group g in 0..n-1, ``np.median(values[groups == g])`` (the mean of
    the two middle values in ``values``' own type for an even count; NaN where the group holds a
    NaN), NaN where it has fewer than ``least`` values. ``groups``: ints in 0..n-1, one per
    value."""
    groups = np.asarray(groups, np.int64)
    values = np.asarray(values)
    out = np.full(n, np.nan)
    if values.size == 0:
        return out
    # by value (NaN last), then stably by group: each group's values in order (two sorts, the
    # second a radix sort of small ints, cost a third of np.lexsort's)
    by_value = np.argsort(values)
    small = groups[by_value].astype(np.uint16) if n <= 1 << 16 else groups[by_value]
    v = values[by_value[np.argsort(small, kind="stable")]]
    counts = np.bincount(groups, minlength=n)[:n]
    starts = np.cumsum(counts) - counts
    full = np.flatnonzero(counts >= max(least, 1))
    c, s = counts[full], starts[full]
    a, b = v[s + (c - 1) // 2], v[s + c // 2]
    if np.issubdtype(v.dtype, np.floating):
        two = v.dtype.type(2)
        with np.errstate(invalid="ignore", over="ignore"):
            mid = np.where(c % 2 == 1, a, (a + b) / two)
        mid = np.where(np.isnan(v[s + c - 1]), np.nan, mid)
    else:  # np.median of integers: the mean in float64
        mid = np.where(c % 2 == 1, a.astype(np.float64), (a.astype(np.float64) + b) / 2.0)
    out[full] = mid
    return out
