"""The PNG writer: every PNG the project writes is encoded here.

A PNG is a row filter applied to each row's bytes, a zlib stream of the filtered rows, and three
chunks around it (PNG specification, 2nd edition, sections 5, 6, 9 and 10). The filters used here
look at the row above and the pixel to the left only, so numpy applies them to the whole image
at once; the zlib stream comes from Intel's ISA-L (``isal``), which deflates photos about five
times faster than zlib at its fastest level with a similar ratio. Together about six times less
CPU than OpenCV's libpng at zlib level 1 for the files of an image set, for files about a fifth
larger: ``python benchmarks/bench_png.py``.

Decoding is libspng's (photos) and OpenCV's (``files.read_png``); libspng does not check the
chunks' CRCs, :func:`damaged_chunk` does that first.
"""
from __future__ import annotations

import struct

import numpy as np
from isal import isal_zlib

#: ISA-L's compression level (0-3) for every PNG written; 1 and 2 cost the same on an image set,
#: 2 is a percent smaller, 3 costs half again for nothing on photos
PNG_LEVEL = 2
#: the row filters by name and their PNG filter type (section 9.2); one filter for every row of a
#: file. "avg" suits photos, "up" label images, "sub" disparity: `python benchmarks/bench_png.py`
PNG_FILTERS = {"none": 0, "sub": 1, "up": 2, "avg": 3}
#: the filter of a file whose writer names none
DEFAULT_FILTER = "up"
#: the rows are filtered and deflated this many bytes at a time (a photo's filtered rows are
#: 6 MB; the encoder holds one piece of them and the compressed file)
CHUNK_BYTES = 1 << 20

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOUR_TYPE = {1: 0, 3: 2, 4: 6}  # channels -> PNG colour type: greyscale, RGB, RGBA


def _chunk(kind: bytes, body: bytes) -> tuple[bytes, bytes, bytes]:
    """A chunk's pieces: its length and type, its body, its CRC (joined once, with the file's)."""
    return struct.pack(">I", len(body)) + kind, body, struct.pack(">I", isal_zlib.crc32(body, isal_zlib.crc32(kind)))


def damaged_chunk(data: bytes) -> str | None:
    """What is wrong with the chunk layout of a PNG file's bytes (a chunk cut short, a CRC that
    does not match, no IEND), or None when every chunk is whole."""
    at, view = 8, memoryview(data)
    while at + 12 <= len(data):
        (n,) = struct.unpack_from(">I", data, at)
        kind = bytes(view[at + 4:at + 8])
        if at + 12 + n > len(data):
            return f"its {kind.decode('latin-1')} chunk is cut short"
        (crc,) = struct.unpack_from(">I", data, at + 8 + n)
        if isal_zlib.crc32(view[at + 8:at + 8 + n], isal_zlib.crc32(kind)) != crc:
            return f"its {kind.decode('latin-1')} chunk fails its CRC check"
        if kind == b"IEND":
            return None
        at += 12 + n
    return "it ends before its IEND chunk"


def filtered_rows(img: np.ndarray, png_filter: str) -> np.ndarray:
    """The PNG filter's bytes of ``img``: ``(H, 1 + row bytes)`` uint8, each row led by its
    filter type; 16-bit samples big-endian, as PNG stores them. Raises ValueError for an
    image PNG cannot hold as it is (see :func:`encode_png`)."""
    if png_filter not in PNG_FILTERS:
        raise ValueError(f"unknown PNG filter {png_filter!r}; one of {', '.join(PNG_FILTERS)}")
    if img.dtype == np.uint16:
        img = img.astype(">u2")
    elif img.dtype != np.uint8:
        raise ValueError(f"cannot encode an array of {img.dtype} as PNG (uint8 or uint16)")
    h = img.shape[0]
    bpp = (1 if img.ndim == 2 else img.shape[2]) * img.dtype.itemsize  # bytes per pixel
    raw = np.ascontiguousarray(img).reshape(h, -1).view(np.uint8)
    out = np.empty((h, raw.shape[1] + 1), np.uint8)
    out[:, 0] = PNG_FILTERS[png_filter]
    body = out[:, 1:]
    if png_filter == "none":
        body[:] = raw
    elif png_filter == "sub":  # minus the byte one pixel to the left (0 left of the image)
        body[:, :bpp] = raw[:, :bpp]
        np.subtract(raw[:, bpp:], raw[:, :-bpp], out=body[:, bpp:])
    elif png_filter == "up":  # minus the byte above (0 above the image)
        body[0] = raw[0]
        np.subtract(raw[1:], raw[:-1], out=body[1:])
    else:  # "avg": minus floor((left + above) / 2), as (a & b) + ((a ^ b) >> 1) in 8 bits
        left, above = raw[1:, :-bpp], raw[:-1, bpp:]
        np.subtract(raw[1:, bpp:], (left & above) + ((left ^ above) >> 1), out=body[1:, bpp:])
        np.subtract(raw[1:, :bpp], raw[:-1, :bpp] >> 1, out=body[1:, :bpp])
        np.subtract(raw[0, bpp:], raw[0, :-bpp] >> 1, out=body[0, bpp:])
        body[0, :bpp] = raw[0, :bpp]
    return out


def encode_png(img: np.ndarray, png_filter: str | None = None) -> bytes:
    """Encode ``(H, W)`` uint8/uint16 (greyscale), ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA uint8
    as PNG; ``png_filter``: the row filter of every row, one of :data:`PNG_FILTERS` (None:
    :data:`DEFAULT_FILTER`). The pixels are the same whatever the filter."""
    img = np.asarray(img)
    channels = 1 if img.ndim == 2 else (img.shape[2] if img.ndim == 3 else 0)
    if channels not in _COLOUR_TYPE or img.shape[0] < 1 or img.shape[1] < 1 or (channels > 1 and img.dtype != np.uint8):
        raise ValueError(f"cannot encode an array of {img.dtype} {img.shape} as PNG")
    png_filter = png_filter or DEFAULT_FILTER
    h = img.shape[0]
    step = max(1, CHUNK_BYTES // (img[0].size * img.dtype.itemsize + 1))  # rows a piece
    stream = isal_zlib.compressobj(PNG_LEVEL)
    idat = []
    for r0 in range(0, h, step):  # each piece filtered with the row above it, then dropped
        above = max(r0 - 1, 0)
        idat.append(stream.compress(filtered_rows(img[above:r0 + step], png_filter)[r0 - above:]))
    idat.append(stream.flush())
    data = b"".join(idat)
    del idat
    header = struct.pack(">IIBBBBB", img.shape[1], h, img.dtype.itemsize * 8, _COLOUR_TYPE[channels], 0, 0, 0)
    return b"".join((_SIGNATURE, *_chunk(b"IHDR", header), *_chunk(b"IDAT", data), *_chunk(b"IEND", b"")))
