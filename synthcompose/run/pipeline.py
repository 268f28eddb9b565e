"""One image set through every stage: dataset -> geometry -> placement -> lighting -> render ->
compose -> write.

A :class:`Pipeline` owns one GL context (with its renderer and composer) and runs the stages of
:mod:`synthcompose.stages` on image sets one after the other; it only orchestrates them. Each
stage is a public call with typed values between them:

    prepare(manifest, ident)                 -> Prepared   read, geometry
    place(manifest, weights, prepared)       -> Placed     the objects' poses and instance ids
    measure_light(manifest, prepared)        -> PhotoLight the photo's light and camera (if placed)
    shade(renderer, composer, ..., placed)   -> Shaded     lit, rendered and composed (the GL thread)
    write_done(manifest, ident, shaded)      -> Outcome    files, annotations, the record last
    write_skipped(manifest, ident, placed)   -> Outcome    no object found a place: the record alone

:mod:`synthcompose.run.batch` decides which image sets, in which process; the preview and
``compare-lighting`` call the same stages. A bad image set is reported (a ``failed`` outcome),
never raised. :meth:`Pipeline.stream` runs the stages on three image sets at once.
"""
from __future__ import annotations

import logging
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from synthcompose.compose import Composer
from synthcompose.errors import SynthComposeError
from synthcompose.io.dataset import ImageSetId
from synthcompose.io.files import codec_threads
from synthcompose.manifest import Manifest
from synthcompose.placement.frequency import object_weights
from synthcompose.placement.saved_poses import read_saved
from synthcompose.record import Status
from synthcompose.render import Renderer
from synthcompose.render.gl import GLContext
from synthcompose.stages import (
    Outcome,
    PhotoLight,
    Placed,
    Prepared,
    Shaded,
    StageOptions,
    measure_light,
    place,
    prepare,
    shade,
    write_done,
    write_skipped,
)
from synthcompose.stages.timing import Timings

from .malloc import release_free_memory, steady_malloc

log = logging.getLogger("synthcompose")

STAGES = ("read", "geometry", "placement", "lighting", "render", "compose", "right", "write")

__all__ = ["Outcome", "Pipeline", "STAGES"]


def _guarded(ident: ImageSetId, timings: Timings, step: Callable):
    """``step()``, or a ``failed`` outcome when it raises: bad input is reported, never raised."""
    try:
        return step()
    except SynthComposeError as exc:
        return Outcome(ident.key, Status.FAILED, str(exc), timings=timings.seconds())
    except Exception as exc:  # a bug must not take the rest of the batch down
        log.debug("internal error on %s", ident.key, exc_info=True)
        return Outcome(ident.key, Status.FAILED, f"internal error: {type(exc).__name__}: {exc}", timings=timings.seconds())


@contextmanager
def opencv_on_one_thread():
    """OpenCV's own functions on one thread, the PNG codec's files still side by side on the
    threads OpenCV had (:func:`~synthcompose.io.files.codec_threads`); restored after.

    In a batch the cores are kept busy by the stream's three threads and by the other workers;
    OpenCV's pool only adds its threads' waiting: they spin before they sleep, and on a 2048x1024
    label image a morphology or a connected-components call is split into pieces shorter than
    that spin. On 2 cores placement's and the light measure's CPU-seconds per image set fell by
    about a tenth and the batch's by 3 %, the images the same bytes (docs/performance.md)."""
    threads = cv2.getNumThreads()
    previous = codec_threads(threads)
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)
        codec_threads(previous)


@dataclass(frozen=True, eq=False)
class _Ready:
    """An image set ready for the GL context: prepared, placed, its light measured."""

    prep: Prepared
    light: PhotoLight
    placed: Placed


class Pipeline:
    """Processes image sets of one manifest with one GL context."""

    def __init__(self, manifest: Manifest, weights: np.ndarray | None = None, gl_backend: str | None = None,
                 gl_device: int | None = None, gl: GLContext | None = None) -> None:
        """``weights``: probability of choosing each manifest object (default: their weights);
        ``gl_device``: EGL device index (a GPU) for this pipeline's context; ``gl``: work in this
        context instead of making one (the preview window's, :meth:`GLContext.wrap`)."""
        self.manifest = manifest
        self.options = StageOptions.of(manifest)  # the slice of the manifest each stage reads
        self.gl = gl if gl is not None else GLContext(gl_backend, device=gl_device)
        self._own_gl = gl is None  # a context given is its owner's to release
        self.renderer = Renderer(self.gl, shading=manifest.shading)
        self.composer = Composer(self.gl)
        if weights is None:
            weights = object_weights([o.weight for o in manifest.objects], [], "weights")
        self.weights = np.asarray(weights, float)

    def close(self) -> None:
        if self._own_gl:
            self.gl.release()

    def __enter__(self) -> "Pipeline":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def process(self, ident: ImageSetId) -> Outcome:
        """Run every stage for one image set; never raises for bad input (returns ``failed``)."""
        timings = Timings()

        def run() -> Outcome:
            ahead = self._ahead(ident, timings)
            return self._write(ident, ahead if isinstance(ahead, Placed) else self._shade(ahead, timings), timings)
        return _guarded(ident, timings, run)

    def stream(self, idents: Iterable[ImageSetId], on_begin: Callable[[ImageSetId], None] | None = None
               ) -> Iterator[Outcome]:
        """Outcomes of ``idents``, in order, with three image sets in the works at once.

        While one image set is rendered and composed (on this thread: it owns the GL context),
        the next one is read, its geometry made, its objects placed and, when any were, its
        light and camera measured (no GL), and the previous one written, each on a thread of
        its own. OpenCV's codecs and NumPy's array operations release the GIL, so where a core is
        spare the batch is bound by the slowest of the three instead of their sum. The outcome
        of an image set comes after its files are all written. ``idents`` is pulled one ahead
        (by the preparing thread: it may block, e.g. on a worker's pipe); ``on_begin`` is
        called on this thread before an image set's render starts.
        """
        steady_malloc()
        source = iter(idents)

        def prepare_next() -> tuple[ImageSetId, Timings, "Prepared | Outcome"] | None:
            ident = next(source, None)
            if ident is None:
                return None
            timings = Timings()
            return ident, timings, _guarded(ident, timings, lambda: self._ahead(ident, timings))

        # BLAS thread pools on top of these threads only contend: our matrices are skinny
        # ((N, 3) by (3, 3)), and OpenBLAS threads spin while waiting - with a pool per process
        # an (N, 3) product took 196 ms instead of 11 on this machine's two busy cores
        with threadpool_limits(limits=1, user_api="blas"), opencv_on_one_thread(), \
                ThreadPoolExecutor(1, "synthcompose-prepare") as preparer, \
                ThreadPoolExecutor(1, "synthcompose-write") as writer:
            preparing = preparer.submit(prepare_next)
            writing = None
            while (item := preparing.result()) is not None:
                preparing = preparer.submit(prepare_next)
                ident, timings, prepared = item
                if on_begin is not None:
                    on_begin(ident)
                result = prepared if isinstance(prepared, (Outcome, Placed)) else \
                    _guarded(ident, timings, lambda: self._shade(prepared, timings))
                release_free_memory()  # the render's buffers, before the next set's are made
                if writing is not None:
                    yield writing.result()
                    writing = None
                if isinstance(result, Outcome):
                    yield result
                else:
                    writing = writer.submit(lambda r=result, t=timings, i=ident: _guarded(i, t, lambda: self._write(i, r, t)))
                # drop this set's arrays here, not when the next set's take their names: while the
                # next one is awaited, its photo, depth and frame would be held twice (the writer
                # holds what it writes)
                del item, prepared, result
            if writing is not None:
                yield writing.result()

    def _ahead(self, ident: ImageSetId, timings: Timings) -> "_Ready | Placed":
        """Everything before the GL context: read, geometry, placement (the image set's saved
        poses, if any) and, when anything was placed, the photo's light (no GL: runs on the
        preparing thread)."""
        o = self.options
        prep = prepare(o.read, ident, timings)
        placed = place(o.place, self.weights, prep, timings, saved=read_saved(o.write.output, ident))
        if not placed.objects:
            return placed
        return _Ready(prep, measure_light(o.read, prep, timings), placed)

    def _shade(self, ready: "_Ready", timings: Timings) -> Shaded:
        """Light, render and compose (this thread owns the GL context)."""
        return shade(self.renderer, self.composer, self.options.shade, ready.prep, ready.light, ready.placed, timings)

    def _write(self, ident: ImageSetId, result: "Shaded | Placed", timings: Timings) -> Outcome:
        """The write stage (thread-safe: touches no GL and no state of self)."""
        if isinstance(result, Placed):
            return write_skipped(self.options.write, ident, result, timings)
        try:
            return write_done(self.options.write, ident, result, timings)
        finally:
            release_free_memory()  # the encoders' and polygons' buffers
