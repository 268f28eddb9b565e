"""The JSON the writers write (:func:`dumps_json`, through :func:`.fileio.write_json`): objects
and lists indented two spaces a level as ``json.dumps(indent=2)`` lays them out, lists of
numbers (a polygon, a matrix, a box) on one line; NaN and Infinity refused."""
from __future__ import annotations

import json
import re
from typing import Any

_COMPACT = json.JSONEncoder(allow_nan=False, separators=(", ", ": "))


#: what the compact encoding of a list of numbers (or of lists of numbers) may hold
_NUMBER_LIST_CHARS = str.maketrans("", "", "0123456789+-.eE, []truefals")
#: a list opened inside a list that is not closed first: nested more than two deep
_DEEPER = re.compile(r"\[[^\]]*\[")


def _flat(value: list | tuple) -> str | None:
    """The one-line JSON of a list of numbers, or of lists of numbers (a polygon, a matrix, a
    box); None for any other list. Encoded by the C encoder and checked on its text (numbers,
    booleans, at most two levels of brackets), not element by element: a frame's polygons hold
    about 100,000 numbers. A tuple among the elements is not a list of numbers."""
    if any(issubclass(t, (tuple, dict, str)) or t is type(None) for t in set(map(type, value))):
        return None
    try:
        text = _COMPACT.encode(value)
    except (TypeError, ValueError):  # not JSON as it stands: laid out element by element, where it fails
        return None
    if text.translate(_NUMBER_LIST_CHARS) or _DEEPER.search(text, 1, len(text) - 1):
        return None
    return text


def _layout(obj: Any, indent: str, out: list[str]) -> None:
    """``obj`` as JSON into ``out``: objects and other lists indented by two spaces a level, as
    ``json.dumps(indent=2)`` lays them out, but lists of numbers (and of number pairs) on one
    line, encoded by the C encoder: a frame's polygons take a tenth of the CPU, and a tenth of
    the lines."""
    if isinstance(obj, dict) and obj:
        inner = indent + "  "
        out.append("{")
        for k, (key, value) in enumerate(obj.items()):
            name = key if isinstance(key, str) else _COMPACT.encode(key).strip('"')  # as json.dumps names keys
            out.append(("," if k else "") + "\n" + inner + _COMPACT.encode(name) + ": ")
            _layout(value, inner, out)
        out.append("\n" + indent + "}")
    elif isinstance(obj, (list, tuple)) and obj:
        flat = _flat(obj)
        if flat is not None:
            out.append(flat)
            return
        inner = indent + "  "
        out.append("[")
        for k, value in enumerate(obj):
            out.append(("," if k else "") + "\n" + inner)
            _layout(value, inner, out)
        out.append("\n" + indent + "]")
    else:
        out.append(_COMPACT.encode(obj))


def dumps_json(obj: Any) -> bytes:
    """UTF-8 JSON of ``obj`` (NaN and Infinity refused), indented, with lists of numbers on one line."""
    out: list[str] = []
    _layout(obj, "", out)
    out.append("\n")
    return "".join(out).encode("utf-8")
