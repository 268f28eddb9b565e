"""The PNG writer (io.png): what any decoder reads back is the array written, for every filter,
sample depth and channel count, and the files are well-formed (chunk CRCs, one IDAT)."""
from __future__ import annotations

import io
import struct
import zlib

import cv2
import numpy as np
import pytest
from PIL import Image

from synthcompose.io.png import DEFAULT_FILTER, PNG_FILTERS, encode_png, filtered_rows
from synthcompose.write.outputs import PNG_FILTER_OF


def _images(rng):
    return [rng.integers(0, 256, (37, 53, 3), np.uint8), rng.integers(0, 65536, (37, 53), np.uint16),
            np.repeat(rng.integers(0, 34, (37, 1), np.uint8), 53, axis=1), rng.integers(0, 256, (37, 53, 4), np.uint8),
            rng.integers(0, 256, (1, 1), np.uint8), rng.integers(0, 256, (1, 9, 3), np.uint8),
            rng.integers(0, 65536, (7, 1), np.uint16), rng.integers(0, 256, (2, 2, 4), np.uint8)]


def _opencv(data: bytes, like: np.ndarray) -> np.ndarray:
    back = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if like.ndim == 3:
        back = cv2.cvtColor(back, cv2.COLOR_BGR2RGB if like.shape[2] == 3 else cv2.COLOR_BGRA2RGBA)
    return back.reshape(like.shape)


def _pillow(data: bytes, like: np.ndarray) -> np.ndarray:
    img = Image.open(io.BytesIO(data))
    img.load()
    return np.asarray(img).astype(like.dtype).reshape(like.shape)


def _chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, at = [], 8
    while at < len(data):
        (n,) = struct.unpack(">I", data[at:at + 4])
        kind, body = data[at + 4:at + 8], data[at + 8:at + 8 + n]
        (crc,) = struct.unpack(">I", data[at + 8 + n:at + 12 + n])
        assert crc == zlib.crc32(kind + body), kind
        out.append((kind, body))
        at += 12 + n
    return out


@pytest.mark.parametrize("png_filter", [None, *PNG_FILTERS])
def test_every_filter_keeps_the_pixels(png_filter):
    for img in _images(np.random.default_rng(3)):
        data = encode_png(img, png_filter)
        for decode in (_opencv, _pillow):
            back = decode(data, img)
            assert back.dtype == img.dtype and np.array_equal(back, img), (decode.__name__, img.shape, img.dtype)
        kinds = [k for k, _ in _chunks(data)]
        assert kinds == [b"IHDR", b"IDAT", b"IEND"]


def test_header_and_rows_follow_the_specification():
    img = np.array([[1, 2, 300], [4, 65535, 6]], np.uint16)
    (ihdr, ihdr_body), (_, idat), _ = _chunks(encode_png(img, "none"))
    assert struct.unpack(">IIBBBBB", ihdr_body) == (3, 2, 16, 0, 0, 0, 0)
    assert zlib.decompress(idat) == bytes([0, 0, 1, 0, 2, 1, 44, 0, 0, 4, 255, 255, 0, 6])
    # by hand: sub, up and avg of a 2x2 grey image
    g = np.array([[10, 7], [3, 250]], np.uint8)
    assert filtered_rows(g, "sub").tolist() == [[1, 10, 253], [1, 3, 247]]
    assert filtered_rows(g, "up").tolist() == [[2, 10, 7], [2, 249, 243]]
    assert filtered_rows(g, "avg").tolist() == [[3, 10, 2], [3, 254, 250 - (3 + 7) // 2]]


def test_views_and_strides_are_written_as_their_pixels():
    rng = np.random.default_rng(5)
    big = rng.integers(0, 256, (40, 60, 4), np.uint8)
    for img in (big[::2, 3:50], big[..., :3], np.flipud(big[..., 0]), big[..., 1].T):
        assert np.array_equal(_opencv(encode_png(img), img), img)


def test_refuses_what_png_cannot_hold():
    for bad in (np.zeros((4, 4), np.float32), np.zeros((4, 4, 2), np.uint8), np.zeros((4, 4, 3), np.uint16),
                np.zeros((0, 4), np.uint8), np.zeros(5, np.uint8)):
        with pytest.raises(ValueError):
            encode_png(bad)
    with pytest.raises(ValueError, match="unknown PNG filter"):
        encode_png(np.zeros((2, 2), np.uint8), "paeth")


def test_the_writer_names_known_filters():
    assert set(PNG_FILTER_OF.values()) <= set(PNG_FILTERS) and DEFAULT_FILTER in PNG_FILTERS


def test_photos_read_as_opencv_reads_them(tmp_path):
    """read_png decodes 8-bit RGB(A) photos with libspng: the pixels OpenCV gives, alpha dropped,
    with and without ancillary chunks (gamma, text) libpng and libspng both leave alone."""
    from synthcompose.errors import InputError
    from synthcompose.io.files import read_png

    rng = np.random.default_rng(11)
    for i, img in enumerate([rng.integers(0, 256, (31, 45, 3), np.uint8), rng.integers(0, 256, (31, 45, 4), np.uint8)]):
        for j, info in enumerate([{}, {"gamma": 0.45455}]):
            path = tmp_path / f"p{i}{j}.png"
            Image.fromarray(img).save(path, **info)
            want = cv2.cvtColor(cv2.imread(str(path), cv2.IMREAD_UNCHANGED),
                                cv2.COLOR_BGR2RGB if img.shape[2] == 3 else cv2.COLOR_BGRA2RGB)
            got = read_png(path, "rgb8")
            assert got.shape == img.shape[:2] + (3,) and got.flags.c_contiguous and np.array_equal(got, want)
    good = encode_png(rng.integers(0, 256, (31, 45, 3), np.uint8), "avg")
    for name, bad in [("cut.png", good[: len(good) // 2]), ("crc.png", good[:60] + bytes([good[60] ^ 1]) + good[61:])]:
        (tmp_path / name).write_bytes(bad)
        with pytest.raises(InputError, match=name):
            read_png(tmp_path / name, "rgb8")


def test_damaged_chunk_names_what_is_wrong():
    from synthcompose.io.png import damaged_chunk

    good = encode_png(np.arange(600, dtype=np.uint8).reshape(20, 30) % 251, "up")
    assert damaged_chunk(good) is None and damaged_chunk(good + b"trailing bytes") is None
    assert "IEND" in damaged_chunk(good[:-12])
    assert "cut short" in damaged_chunk(good[:-20])
    i = good.index(b"IDAT") + 10
    assert "IDAT chunk fails its CRC" in damaged_chunk(good[:i] + bytes([good[i] ^ 4]) + good[i + 1:])


@pytest.mark.parametrize("chunk", [1, 150, 1 << 20])
def test_rows_written_piece_by_piece_keep_the_pixels(chunk, monkeypatch):
    """The encoder filters and deflates the rows a piece at a time (png.CHUNK_BYTES), each piece
    with the row above it: the same pixels at any piece size, a row, a few rows or the image."""
    from synthcompose.io import png

    monkeypatch.setattr(png, "CHUNK_BYTES", chunk)
    for img in _images(np.random.default_rng(21)):
        for png_filter in PNG_FILTERS:
            data = encode_png(img, png_filter)
            assert np.array_equal(_opencv(data, img), img) and [k for k, _ in _chunks(data)] == [b"IHDR", b"IDAT", b"IEND"]
