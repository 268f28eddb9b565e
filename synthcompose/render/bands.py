"""A large region of interest rendered in bands of rows, so that the lit pass's intermediate
targets (about 220 bytes per pixel at their peak: the per-pixel colours, the multisampled
targets) exist for one band at a time; the passes the compose reads stay whole.

A band draws the whole region's geometry with the region's projection into a framebuffer of
its own rows: the viewport puts the region's row ``a0`` at the band's row 0 (:func:`viewport`),
so every fragment lands where it lands in the whole region, one whole number of rows up. A band
carries :data:`APRON` rows of its neighbours above and below, for the passes that read a
pixel's neighbours (fill.glsl's NEIGHBOURS), and gives only its own rows to the whole passes
(:func:`copy_rows`).
"""
from __future__ import annotations

import ctypes
from typing import Sequence

import moderngl

from .gl import GLContext

#: a region of interest of more pixels than this is rendered in bands of about this many. The
#: lit pass's targets take about 220 bytes a band pixel at their peak (28 MB at 2^17 pixels);
#: each band draws the region's geometry again (its vertices and the setup of each draw), so a
#: smaller band costs CPU: on 12 generated sets 2^16 took about 5 % more CPU per set than 2^18
#: and 2^17 the same within this machine's spread, for 40-50 MB less peak memory per worker
#: (docs/performance.md, fourth round)
BAND_PIXELS = 1 << 17
#: the compose's bands (:mod:`synthcompose.compose`): its outputs, the real scene's layers, the
#: blur's layers and the noise, about 70 bytes a pixel (18 MB at 2^18 pixels), with the blur's
#: reach drawn again around each band; the same bytes out whatever the size
COMPOSE_BAND_PIXELS = 1 << 17
#: rows of the neighbouring bands each band draws too (NEIGHBOURS reads one pixel around)
APRON = 1
_READ_FRAMEBUFFER, _DRAW_FRAMEBUFFER = 0x8CA8, 0x8CA9
_COLOR_BUFFER_BIT, _NEAREST = 0x4000, 0x2600


def row_bands(width: int, height: int, band_pixels: int = BAND_PIXELS) -> list[tuple[int, int]]:
    """[(y0, y1), ...]: the rows of each band of a ``width`` x ``height`` region, top first; one
    band (the whole) when it has at most ``band_pixels`` pixels."""
    if width * height <= band_pixels:
        return [(0, height)]
    n = -(-width * height // band_pixels)
    step = -(-height // n)
    return [(y, min(y + step, height)) for y in range(0, height, step)]


def with_apron(band: tuple[int, int], height: int) -> tuple[int, int]:
    """The rows a band draws: its own and :data:`APRON` more on each side, within the region."""
    return max(band[0] - APRON, 0), min(band[1] + APRON, height)


def viewport(drawn: tuple[int, int], width: int, height: int) -> tuple[int, int, int, int]:
    """The viewport that maps a ``width`` x ``height`` region's rows ``drawn`` onto a framebuffer
    of those rows alone."""
    return (0, -drawn[0], width, height)


class _Blit:
    """glBlitFramebuffer with source and destination rectangles (moderngl copies whole
    framebuffers only), through the EGL loader: it works on the current context."""

    _fns = None

    @classmethod
    def fns(cls):
        if cls._fns is None:
            egl = ctypes.CDLL("libEGL.so.1")
            egl.eglGetProcAddress.restype = ctypes.c_void_p
            egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
            u, i = ctypes.c_uint, ctypes.c_int
            address = {name: egl.eglGetProcAddress(name) for name in
                       (b"glBindFramebuffer", b"glBlitFramebuffer", b"glGetError")}
            if not all(address.values()):
                raise RuntimeError("glBlitFramebuffer is not available through EGL")
            cls._fns = (ctypes.CFUNCTYPE(None, u, u)(address[b"glBindFramebuffer"]),
                        ctypes.CFUNCTYPE(None, i, i, i, i, i, i, i, i, u, u)(address[b"glBlitFramebuffer"]),
                        ctypes.CFUNCTYPE(u)(address[b"glGetError"]))
        return cls._fns


def copy_rows(gl: GLContext, sources: Sequence[moderngl.Texture], targets: Sequence[moderngl.Texture],
              src_y: int, dst_y: int, rows: int) -> None:
    """Copy ``rows`` rows of each texture of ``sources`` from row ``src_y`` into the texture of
    ``targets`` of the same format at row ``dst_y`` (whole rows, the values as they are)."""
    bind, blit, error = _Blit.fns()
    ctx = gl.ctx
    error()  # earlier errors are not ours
    for src, dst in zip(sources, targets):
        read, draw = gl.own(ctx.framebuffer([src])), gl.own(ctx.framebuffer([dst]))
        bind(_READ_FRAMEBUFFER, read.glo)
        bind(_DRAW_FRAMEBUFFER, draw.glo)
        blit(0, src_y, src.width, src_y + rows, 0, dst_y, dst.width, dst_y + rows, _COLOR_BUFFER_BIT, _NEAREST)
        code = error()
        gl.free(read)
        gl.free(draw)
        if code:
            raise RuntimeError(f"copying a band of rows between textures failed (GL error {code:#x})")
