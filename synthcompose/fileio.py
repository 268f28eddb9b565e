"""Every encoder and decoder of the project, in one place.

Readers check what they read and raise :class:`InputError` naming the file; writers are
atomic: they write a temporary file beside the target and rename it, so a final name only
ever holds a complete file.
"""
from __future__ import annotations

import json
import os
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Iterable, Literal, TypeVar

import cv2
import numpy as np

from .errors import InputError, OutputError

#: zlib level for every PNG we write (OpenCV's scale, 0-9). Low: PNG encoding dominates a batch.
PNG_COMPRESSION = 1
#: zlib strategy: run-length matches only (after PNG's row filters). On a 2048x1024 image set
#: it is faster than the default for every output (the photo 140 -> 108 ms) and smaller too
#: (3.5 -> 3.1 MB; the label images to half): `python benchmarks/bench_png.py`
PNG_STRATEGY = cv2.IMWRITE_PNG_STRATEGY_RLE

PngKind = Literal["rgb8", "gray8", "gray16"]
T, R = TypeVar("T"), TypeVar("R")


def map_threads(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """``[fn(x) for x in items]`` on as many threads as OpenCV may use (``cv2.setNumThreads``:
    all cores, or a worker's share of them). PNG decoding and encoding release the GIL, so an
    image set's files are coded side by side. Results in order; the first failing item's
    exception (in order) is raised, as a plain loop would."""
    items = list(items)
    n = min(max(1, cv2.getNumThreads()), len(items))
    if n <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(n, thread_name_prefix="synthcompose-io") as pool:
        return list(pool.map(fn, items))


def read_png(path: str | Path, kind: PngKind) -> np.ndarray:
    """Read a PNG and check its layout.

    Returns ``(H, W, 3) uint8`` RGB for ``rgb8``, ``(H, W) uint8`` for ``gray8`` and
    ``(H, W) uint16`` for ``gray16``.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(path, "file is missing") from None
    except OSError as exc:
        raise InputError(path, f"cannot be read ({exc.strerror})") from None
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        raise InputError(path, "is not a PNG file")
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


def encode_png(img: np.ndarray) -> bytes:
    """Encode ``(H, W)`` uint8/uint16, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA uint8 as PNG."""
    img = np.ascontiguousarray(img)
    if img.ndim == 3:  # OpenCV writes BGR(A)
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR if img.shape[2] == 3 else cv2.COLOR_RGBA2BGRA)
    ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESSION,
                                         cv2.IMWRITE_PNG_STRATEGY, PNG_STRATEGY])
    if not ok:  # pragma: no cover - OpenCV only fails on unsupported dtypes
        raise ValueError(f"cannot encode array of {img.dtype} {img.shape} as PNG")
    return buf.tobytes()


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


def write_png(path: str | Path, img: np.ndarray) -> None:
    write_bytes_atomic(path, encode_png(img))


def read_json(path: str | Path) -> Any:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(path, "file is missing") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot be read ({exc})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None


def dumps_json(obj: Any) -> bytes:
    return (json.dumps(obj, indent=2, sort_keys=False, allow_nan=False) + "\n").encode("utf-8")


def write_json(path: str | Path, obj: Any) -> None:
    write_bytes_atomic(path, dumps_json(obj))
