"""Every encoder and decoder of the project, in one place.

Readers check what they read and raise :class:`InputError` naming the file; writers are
atomic: they write a temporary file beside the target and rename it, so a final name only
ever holds a complete file.
"""
from __future__ import annotations

import json
import os
import re
import stat
import struct
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Iterable, Literal, TypeVar

import cv2
import numpy as np
import pyspng
from pycocotools import mask as coco_mask

from synthcompose.errors import InputError, OutputError

from .json_layout import dumps_json
from .png import PNG_FILTERS, damaged_chunk, encode_png  # noqa: F401  (the writer; PNG_FILTERS for its callers)

PngKind = Literal["rgb8", "gray8", "gray16"]
T, R = TypeVar("T"), TypeVar("R")


#: threads that code an image set's files side by side (:func:`map_threads`); None: as many as
#: OpenCV may use. Set apart from OpenCV's own pool by :func:`codec_threads`.
_CODEC_THREADS: int | None = None


def codec_threads(n: int | None) -> int | None:
    """Code an image set's files on ``n`` threads from now on (None: as many as OpenCV may use,
    ``cv2.getNumThreads``); returns the setting it replaces. A batch runs OpenCV's own functions
    on one thread (its pool's threads spin while they wait: CPU-seconds for no image) and still
    codes its PNGs side by side (:meth:`synthcompose.run.pipeline.Pipeline.stream`)."""
    global _CODEC_THREADS
    previous, _CODEC_THREADS = _CODEC_THREADS, (None if n is None else max(1, int(n)))
    return previous


def codec_thread_count() -> int:
    """The threads :func:`map_threads` codes files on now (at least 1)."""
    return max(1, cv2.getNumThreads() if _CODEC_THREADS is None else _CODEC_THREADS)


def map_threads(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """``[fn(x) for x in items]`` on the codec's threads (:func:`codec_threads`; by default as
    many as OpenCV may use, ``cv2.setNumThreads``: all cores, or a worker's share of them). PNG
    decoding and encoding release the GIL, so an image set's files are coded side by side.
    Results in order; the first failing item's exception (in order) is raised, as a plain loop
    would."""
    items = list(items)
    n = min(codec_thread_count(), len(items))
    if n <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(n, thread_name_prefix="synthcompose-io") as pool:
        return list(pool.map(fn, items))


#: input files larger than this are refused before they are read (bytes); a 2048x1024 16-bit
#: PNG is a few MB, a camera JSON a few hundred bytes
#: Cityscapes disparity PNG: a 16-bit value p > 0 encodes d = (p - 1) / DISPARITY_SCALE pixels;
#: p = 0 is invalid (p = 1: d = 0, infinitely far)
DISPARITY_SCALE = 256.0


def decode_disparity(png: np.ndarray) -> np.ndarray:
    """(H, W) uint16 Cityscapes disparity -> float32 pixels ((p - 1) / 256; <= 0 where unknown)."""
    return (png.astype(np.float32) - 1.0) / DISPARITY_SCALE


def encode_disparity(d: np.ndarray) -> np.ndarray:
    """Disparities in pixels (> 0) -> their uint16 Cityscapes values (rounded, clipped to 1..65535)."""
    return np.clip(np.rint(d * DISPARITY_SCALE) + 1.0, 1, 65535).astype(np.uint16)


MAX_INPUT_BYTES = 256 << 20
#: PNGs whose header declares more pixels than this are refused before they are decoded (a
#: decompression bomb: a few KB that decode to gigabytes)
MAX_PIXELS = 64 << 20


def read_input_bytes(path: str | Path, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of an input file: a regular file (a named pipe would block, a device never
    end) of at most ``limit`` bytes, or an :class:`InputError` naming it."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise InputError(path, "file is missing") from None
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(path, "is not a regular file (a pipe, device or folder cannot be an input)")
        if st.st_size > limit:
            raise InputError(path, f"is {st.st_size} bytes, more than the {limit} an input may have")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            # the size fstat saw and a byte more, not the limit: a read of n bytes allocates n
            # at once (256 MB a file, five files decoded at a time)
            data = fh.read(st.st_size + 1)
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    if len(data) > limit:
        raise InputError(path, f"is more than the {limit} bytes an input may have")
    return data


def read_png(path: str | Path, kind: PngKind) -> np.ndarray:
    """Read a PNG and check its layout (8-bit RGB and RGBA photos decoded by libspng, a third
    less CPU than OpenCV's libpng; everything else by OpenCV).

    Returns ``(H, W, 3) uint8`` RGB for ``rgb8``, ``(H, W) uint8`` for ``gray8`` and
    ``(H, W) uint16`` for ``gray16``.
    """
    path = Path(path)
    data = read_input_bytes(path)
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        raise InputError(path, "is not a PNG file")
    depth = colour = None
    if len(data) >= 26 and data[12:16] == b"IHDR":  # the size, before decoding anything
        width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
        if width * height > MAX_PIXELS:
            raise InputError(path, f"declares {width}x{height} pixels, more than the {MAX_PIXELS} an input may have")
    if kind == "rgb8" and depth == 8 and colour in (2, 6):  # 8-bit RGB(A): libspng, RGB order already
        damage = damaged_chunk(data)  # (libspng does not check the CRCs)
        try:
            img = None if damage else pyspng.load(data)
        except RuntimeError:
            damage = "its image data cannot be decoded"
        if damage:
            raise InputError(path, f"PNG data is corrupt or truncated: {damage}")
        if img.ndim == 3 and img.shape[2] == 4:
            img = np.ascontiguousarray(img[..., :3])
        return img
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError(path, "PNG data is corrupt or truncated")
    if kind == "rgb8":
        if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] not in (3, 4):
            raise InputError(path, f"expected an 8-bit RGB image, found {_describe(img)}")
        return cv2.cvtColor(img, cv2.COLOR_BGR2RGB if img.shape[2] == 3 else cv2.COLOR_BGRA2RGB)
    want = np.uint8 if kind == "gray8" else np.uint16
    if img.ndim != 2 or img.dtype != want:
        bits = 8 if kind == "gray8" else 16
        raise InputError(path, f"expected a {bits}-bit single-channel image, found {_describe(img)}")
    return img


def _describe(img: np.ndarray) -> str:
    channels = 1 if img.ndim == 2 else img.shape[2]
    return f"{img.dtype.itemsize * 8}-bit, {channels} channel(s), {img.shape[1]}x{img.shape[0]}"


#: temporary files are named ``.<name>.<PART_TAG><random>.part``: the clean-up of a killed run
#: removes these and nothing else (other programs' ``.part`` files are theirs)
PART_TAG = "synthcompose-"


def _file_mode() -> int:
    """The mode a new file gets from the process's umask (0666 less it), as open() would give;
    mkstemp's own 0600 would leave every output unreadable to the job's other users."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


_FILE_MODE = _file_mode()  # read once, at import (os.umask is process-wide: not from threads)


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that ``path`` never holds a partial file: a temporary file
    beside it, synced to disk, then renamed over it; mode as the umask gives."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{PART_TAG}", suffix=".part", dir=path.parent)
    except OSError as exc:
        raise OutputError(path, f"cannot be written ({exc.strerror or exc})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fchmod(fh.fileno(), _FILE_MODE)
            os.fsync(fh.fileno())  # the data is on disk before the name says the file is complete
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise OutputError(path, f"cannot be written ({exc.strerror or exc})") from None
        raise


def write_png(path: str | Path, img: np.ndarray, png_filter: str | None = None) -> None:
    write_bytes_atomic(path, encode_png(img, png_filter))


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


#: JSON inputs nested deeper than this are refused (a Cityscapes polygons file has 4 levels; code
#: walking a deeper tree would recurse as deep)
MAX_JSON_DEPTH = 64
#: the largest magnitude a JSON number may have: every number is used as a 64-bit float
_FLOAT_MAX = sys.float_info.max


class _Repeated(dict):
    """A JSON object that gave one key twice (:func:`read_json` refuses it, naming the key)."""

    repeated = ""


def _where(keys: tuple) -> str:
    return "'" + "/".join(str(k) for k in keys) + "'" if keys else "the top level"


def _bad_number(value: Any) -> str | None:
    """What is wrong with a parsed JSON scalar as a number this package uses, or None."""
    if type(value) is int and not -_FLOAT_MAX <= value <= _FLOAT_MAX:
        return (f"is too large (an integer of {len(str(abs(value)))} digits; numbers are used as 64-bit "
                "floats, up to 1.8e308)")
    if type(value) is float and not -_FLOAT_MAX <= value <= _FLOAT_MAX:
        return "is beyond the range of a 64-bit float (up to 1.8e308)"
    return None


_NUMBERS = {int, float}
_CONTAINERS = (dict, list, _Repeated)


def _checked_tree(path: Path, data: Any) -> Any:
    """``data`` when every object has distinct keys, every number fits a 64-bit float and it is
    nested at most :data:`MAX_JSON_DEPTH` deep; an :class:`InputError` naming the file and the
    field otherwise. Walks with a stack of its own (no recursion, whatever the depth); a list
    or object of numbers alone (a polygon, a matrix) is checked at once, by its extremes."""
    if not isinstance(data, (dict, list)):
        why = _bad_number(data)
        if why:
            raise InputError(path, f"number at {_where(())} {why}")
        return data
    stack: list[tuple[Any, tuple]] = [(data, ())]
    while stack:
        node, keys = stack.pop()
        if len(keys) >= MAX_JSON_DEPTH:
            raise InputError(path, f"is nested more than {MAX_JSON_DEPTH} levels deep (at {_where(keys[:6])}...)")
        if type(node) is _Repeated:
            raise InputError(path, f"gives the key {node.repeated!r} twice in the object at {_where(keys)} "
                                   "(only one may stay)")
        values = node.values() if isinstance(node, dict) else node
        kinds = set(map(type, values))
        if kinds <= _NUMBERS and (not values or -_FLOAT_MAX <= min(values) and max(values) <= _FLOAT_MAX):
            continue
        for key, value in (node.items() if isinstance(node, dict) else enumerate(node)):
            if type(value) in _CONTAINERS:
                stack.append((value, keys + (key,)))
            else:
                why = _bad_number(value)
                if why:
                    raise InputError(path, f"number at {_where(keys + (key,))} {why}")
    return data


#: a JSON string once its escapes are taken out (blanked before the text is scanned)
_STRING = re.compile(r'"[^"]*"')
#: an exponent of 100 or more: the number may be beyond a float
_LONG_EXPONENT = re.compile(r"[eE][+-]?0*[1-9][0-9]{2}")


def _may_be_bad(text: str) -> bool:
    """A quick look at valid JSON text, strings blanked: False when it surely nests less than
    :data:`MAX_JSON_DEPTH` deep and holds no number beyond a float (most inputs: the tree is
    then not walked, which would take a polygons file's parsing time again)."""
    bare = _STRING.sub('""', text.replace("\\\\", "").replace('\\"', ""))  # escapes out, left to right
    b = np.frombuffer(bare.encode("utf-8"), np.uint8)
    if not len(b):
        return False
    depth = np.cumsum((b == 91) | (b == 123), dtype=np.int64) - np.cumsum((b == 93) | (b == 125), dtype=np.int64)
    if depth.max() >= MAX_JSON_DEPTH:
        return True
    digit = np.concatenate([[0], ((b >= 48) & (b <= 57)).view(np.int8), [0]])
    edges = np.flatnonzero(np.diff(digit))
    return bool(len(edges) and (edges[1::2] - edges[::2]).max() >= 300) or _LONG_EXPONENT.search(bare) is not None


def loads_json(text: str, path: str | Path = "<json>") -> Any:
    """Parse JSON ``text`` as :func:`read_json` does (``path`` names it in errors)."""
    path = Path(path)
    repeated: list[str] = []

    def pairs(items: list[tuple[str, Any]]) -> dict:
        obj = dict(items)
        if len(obj) != len(items):  # the last would win, silently: marked, refused below
            seen: set[str] = set()
            obj = _Repeated(obj)
            obj.repeated = next(k for k, _ in items if k in seen or seen.add(k))
            repeated.append(obj.repeated)
        return obj

    try:
        data = json.loads(text, parse_constant=_no_constant, object_pairs_hook=pairs)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    except RecursionError:
        raise InputError(path, f"is nested more than {MAX_JSON_DEPTH} levels deep") from None
    except ValueError as exc:  # NaN, Infinity; an integer of thousands of digits
        if "integer string conversion" in str(exc):
            raise InputError(path, "holds an integer of more than 4300 digits (numbers are used as 64-bit floats, "
                                   "up to 1.8e308)") from None
        raise InputError(path, f"is not valid JSON ({exc})") from None
    return _checked_tree(path, data) if repeated or _may_be_bad(text) else data


def read_json(path: str | Path) -> Any:
    """A JSON input file: a regular file of at most 16 MB, UTF-8 (a byte order mark allowed);
    refused naming the file (and the field) when it is not JSON, holds NaN or Infinity, a number
    beyond a 64-bit float, a key twice in one object, or nests deeper than :data:`MAX_JSON_DEPTH`."""
    path = Path(path)
    try:
        text = read_input_bytes(path, 16 << 20).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(path, f"cannot be read ({exc})") from None
    return loads_json(text, path)


def write_json(path: str | Path, obj: Any) -> None:
    write_bytes_atomic(path, dumps_json(obj))


# ------------------------------------------------------------------- COCO RLE (masks in JSON)
def encode_rle(mask: np.ndarray) -> dict[str, Any]:
    """COCO compressed RLE of an (H, W) mask (pycocotools): {"size": [H, W], "counts": str}.
    The column-major bytes pycocotools reads are OpenCV's transpose of the mask's bytes (one
    pass, a third of NumPy's cast and Fortran copy)."""
    mask = np.asarray(mask)
    raw = np.ascontiguousarray(mask).view(np.uint8) if mask.dtype == bool else np.ascontiguousarray(mask.astype(np.uint8))
    if raw.ndim != 2:
        raise ValueError(f"a mask is (H, W), not {raw.shape}")
    rle = coco_mask.encode(cv2.transpose(raw).T if raw.size else np.asfortranarray(raw))
    return {"size": [int(v) for v in rle["size"]], "counts": rle["counts"].decode("ascii")}


def decode_rle(rle: dict[str, Any]) -> np.ndarray:
    """Inverse of :func:`encode_rle`: (H, W) bool."""
    return coco_mask.decode({"size": list(rle["size"]), "counts": rle["counts"].encode("ascii")}).astype(bool)
