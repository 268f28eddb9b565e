"""What the cost work must not change: the optimised paths give the bytes (or the pixels) the
plain ones give (docs/performance.md). No timing is asserted here."""
from __future__ import annotations

import json
import random

import cv2
import numpy as np
import pytest

from synthcompose.fileio import PNG_FILTERS, dumps_json, encode_png
from synthcompose.writer import PNG_FILTER_OF


def _reference_layout(obj, indent: str, out: list[str]) -> None:
    """dumps_json's layout checked element by element (what it did before its text check)."""
    enc = json.JSONEncoder(allow_nan=False, separators=(", ", ": "))
    flat = lambda v: all(isinstance(x, (int, float)) or (isinstance(x, list) and  # noqa: E731
                         all(isinstance(y, (int, float)) for y in x)) for x in v)
    if isinstance(obj, dict) and obj:
        out.append("{")
        for k, (key, value) in enumerate(obj.items()):
            name = key if isinstance(key, str) else enc.encode(key).strip('"')
            out.append(("," if k else "") + "\n" + indent + "  " + enc.encode(name) + ": ")
            _reference_layout(value, indent + "  ", out)
        out.append("\n" + indent + "}")
    elif isinstance(obj, (list, tuple)) and obj and not flat(obj):
        out.append("[")
        for k, value in enumerate(obj):
            out.append(("," if k else "") + "\n" + indent + "  ")
            _reference_layout(value, indent + "  ", out)
        out.append("\n" + indent + "]")
    else:
        out.append(enc.encode(obj))


def _random_document(rng: random.Random, depth: int = 0):
    leaves = [lambda: rng.randint(-5, 10 ** 6), lambda: rng.random() * 10 ** rng.randint(-8, 8), lambda: True,
              lambda: None, lambda: 'a "b"\n', lambda: 1e-7, lambda: -0.0, lambda: 12345678901234567890]
    r = rng.random()
    if depth > 3 or r < 0.35:
        return rng.choice(leaves)()
    if r < 0.55:
        return {(str(rng.randint(0, 9)) if rng.random() < 0.8 else rng.randint(0, 3)): _random_document(rng, depth + 1)
                for _ in range(rng.randint(0, 4))}
    if r < 0.65:
        return tuple(_random_document(rng, depth + 1) for _ in range(rng.randint(0, 4)))
    if r < 0.8:
        return [[rng.randint(0, 2000), rng.randint(0, 1000)] for _ in range(rng.randint(0, 5))]
    return [_random_document(rng, depth + 1) for _ in range(rng.randint(0, 5))]


def test_json_layout_is_the_element_by_element_one():
    rng = random.Random(7)
    docs = [_random_document(rng) for _ in range(3000)]
    docs += [[(1, 2), (3, 4)], [[1, [2]]], [[1, 2], [3, (4, 5)]], [1, None], [[True, False]], [[], [1]], ((1, 2),)]
    for doc in docs:
        out: list[str] = []
        _reference_layout(doc, "", out)
        assert dumps_json(doc) == ("".join(out) + "\n").encode("utf-8"), doc
    for bad in ([1.0, float("nan")], [[1, 2], {3}], {"x": [float("inf")]}):
        with pytest.raises((ValueError, TypeError)):
            dumps_json(bad)


@pytest.mark.parametrize("png_filter", [None, *PNG_FILTERS])
def test_png_filters_keep_the_pixels(png_filter):
    rng = np.random.default_rng(3)
    images = [rng.integers(0, 256, (37, 53, 3), np.uint8), rng.integers(0, 65536, (37, 53), np.uint16),
              np.repeat(rng.integers(0, 34, (37, 1), np.uint8), 53, axis=1),
              rng.integers(0, 256, (37, 53, 4), np.uint8)]
    for img in images:
        back = cv2.imdecode(np.frombuffer(encode_png(img, png_filter), np.uint8), cv2.IMREAD_UNCHANGED)
        if img.ndim == 3:
            back = cv2.cvtColor(back, cv2.COLOR_BGR2RGB if img.shape[2] == 3 else cv2.COLOR_BGRA2RGBA)
        assert back.dtype == img.dtype and np.array_equal(back, img)
    assert set(PNG_FILTER_OF.values()) <= set(PNG_FILTERS)
