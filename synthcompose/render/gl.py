"""The one class that owns the OpenGL context.

Backend choice lives in :func:`create_context` alone: headless EGL by default (a GPU
driver where present, Mesa llvmpipe elsewhere), overridable by argument or by the
``SYNTHCOMPOSE_GL_BACKEND`` environment variable.
"""
from __future__ import annotations

import ctypes
import os
import re
from importlib import resources
from typing import Callable

import moderngl
import numpy as np

from synthcompose.errors import GLContextError, ShaderError

BACKENDS = ("egl", "x11")
_INSTALL_HINT = ("install Mesa's EGL (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 "
                 "libgl1-mesa-dri) or a GPU driver with EGL")


def create_context(backend: str | None = None, device: int | None = None) -> moderngl.Context:
    """Create a standalone OpenGL >= 3.3 core context; the only place contexts are made.

    ``device``: EGL device index (one GPU of several; default: the first usable one).
    """
    backend = backend or os.environ.get("SYNTHCOMPOSE_GL_BACKEND", "egl")
    if backend not in BACKENDS:
        raise GLContextError(f"unknown GL backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    extra = {"device_index": int(device)} if device is not None and backend == "egl" else {}
    try:
        return moderngl.create_standalone_context(backend=backend, require=330, **extra)
    except Exception as exc:
        raise GLContextError(f"cannot create an OpenGL context with the {backend} backend ({exc}); "
                             f"{_INSTALL_HINT}") from None


def _gil_free_finish() -> Callable[[], None] | None:
    """``glFinish`` called through ctypes, which releases Python's GIL for the call (moderngl
    holds it through every call, waits included), or None where no GL library exports it.
    The EGL loader's address works for any current context; libOpenGL/libGL (glvnd) dispatch
    to the current context too."""
    try:
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        address = egl.eglGetProcAddress(b"glFinish")
        if address:
            return ctypes.CFUNCTYPE(None)(address)
    except (OSError, AttributeError):
        pass
    for name in ("libOpenGL.so.0", "libGL.so.1"):
        try:
            return getattr(ctypes.CDLL(name), "glFinish")
        except (OSError, AttributeError):
            continue
    return None


def shader_source(name: str, _depth: int = 0) -> str:
    """Text of ``shaders/<name>`` with ``#include "file"`` lines resolved."""
    if _depth > 8:
        raise ShaderError(f"shaders/{name}: #include nested too deeply")
    try:
        text = (resources.files("synthcompose.shaders") / name).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ShaderError(f"shaders/{name}: shader file is missing from the installed package") from None
    return re.sub(r'^#include\s+"([^"]+)"\s*$', lambda m: shader_source(m[1], _depth + 1), text, flags=re.M)


class GLContext:
    """Owns a moderngl context and every GL object made through it.

    All GL work, readback included, happens through this object while its context is
    current. :meth:`release` frees programs, buffers and textures in reverse order.
    """

    def __init__(self, backend: str | None = None, device: int | None = None, *,
                 context: moderngl.Context | None = None) -> None:
        # ``context``: an existing context (a window's) to work in instead of making one; see wrap()
        self.ctx = context if context is not None else create_context(backend, device)
        self._external = context is not None
        self._programs: dict[str, moderngl.Program] = {}
        self._owned: list = []
        # bound before a framebuffer is released, so no deleted framebuffer stays current
        self._idle_fbo = self.own(self.ctx.framebuffer([self.own(self.ctx.renderbuffer((1, 1)))]))
        self._finish = _gil_free_finish() or self.ctx.finish

    def wait(self) -> None:
        """Wait for the GL work queued so far without holding Python's GIL, so that other
        threads run meanwhile (Pipeline.stream). Call it before a call that waits for the
        results (a texture read, a blit from a framebuffer just drawn): moderngl would wait
        holding the GIL, and Mesa's llvmpipe rasterises at that point."""
        self._finish()

    @classmethod
    def wrap(cls, ctx: moderngl.Context) -> "GLContext":
        """Work in an existing moderngl context (a preview window's, from ``moderngl.create_context()``).
        :meth:`release` then frees what was made through this object and leaves the context
        itself to its owner."""
        return cls(context=ctx)

    def activate(self) -> "GLContext":
        """Make this context current. Every entry point that does GL work calls this first, so
        several contexts can live in one process (another one may have been made current
        since). Deliberately not a ``with`` block: objects are read after the work ends."""
        self.ctx.__enter__()
        return self

    @property
    def renderer_name(self) -> str:
        return f"{self.ctx.info['GL_RENDERER']} / {self.ctx.info['GL_VERSION']}"

    def program(self, name: str, **defines: int | float | str) -> moderngl.Program:
        """Compile ``shaders/<name>.glsl`` once; its sections are chosen with VERTEX_SHADER etc."""
        key = name + "".join(f"|{k}={v}" for k, v in sorted(defines.items()))
        if key in self._programs:
            return self._programs[key]
        source = shader_source(f"{name}.glsl")
        version, _, body = source.partition("\n")
        if not version.startswith("#version"):
            raise ShaderError(f"shaders/{name}.glsl: first line must be a #version directive")
        extra = "".join(f"#define {k} {v}\n" for k, v in defines.items())

        def stage(macro: str) -> str | None:
            if f"defined {macro}" not in body:
                return None
            return f"{version}\n#define {macro} 1\n{extra}{body}"

        try:
            prog = self.ctx.program(vertex_shader=stage("VERTEX_SHADER"),
                                    fragment_shader=stage("FRAGMENT_SHADER"),
                                    geometry_shader=stage("GEOMETRY_SHADER"))
        except moderngl.Error as exc:
            raise ShaderError(f"shaders/{name}.glsl: {exc}") from None
        self._programs[key] = prog
        return prog

    def own(self, obj):
        """Register a GL object to be released with the context; returns it."""
        self._owned.append(obj)
        return obj

    def free(self, obj) -> None:
        """Release a GL object early."""
        if isinstance(obj, moderngl.Framebuffer):
            self._idle_fbo.use()
        try:
            self._owned.remove(obj)
        except ValueError:
            pass
        obj.release()

    def texture(self, size: tuple[int, int], components: int, data: np.ndarray | bytes | None = None,
                dtype: str = "f1", filter_linear: bool = False) -> moderngl.Texture:
        """A 2D texture whose memory row 0 is image row 0 (the top); an array ``data`` is read
        in place when C-contiguous (moderngl takes the buffer), copied once when not."""
        if isinstance(data, np.ndarray):
            data = np.ascontiguousarray(data)
        tex = self.ctx.texture(size, components, data, dtype=dtype)
        f = moderngl.LINEAR if filter_linear else moderngl.NEAREST
        tex.filter = (f, f)
        tex.repeat_x = tex.repeat_y = False
        return self.own(tex)

    def check_error(self) -> None:
        err = self.ctx.error
        if err != "GL_NO_ERROR":
            raise RuntimeError(f"OpenGL error: {err}")

    def release(self) -> None:
        self.activate()
        for obj in reversed(self._owned):
            obj.release()
        self._owned.clear()
        for prog in reversed(list(self._programs.values())):
            prog.release()
        self._programs.clear()
        if not self._external:
            self.ctx.release()

    def __enter__(self) -> "GLContext":
        return self

    def __exit__(self, *exc) -> None:
        self.release()
