"""The engines that run a batch's image sets: in this process, in spawned worker processes (each
with its own GL context, a crashed one replaced), or as Ray actors. Each yields the outcomes."""
from __future__ import annotations

import logging
import multiprocessing as mp
import os
import signal
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from synthcompose.errors import SynthComposeError
from synthcompose.io.dataset import ImageSetId
from synthcompose.manifest import Manifest
from synthcompose.record import Status

from .pipeline import Outcome, Pipeline

log = logging.getLogger("synthcompose")

class BatchError(SynthComposeError):
    """The batch as a whole cannot run (the message says why)."""


#: memory one worker process may take at the most, bytes: a whole batch in one process peaked at
#: 0.79 GB on real 2048x1024 frames and 0.62 GB on generated ones (three image sets in the
#: works; ``/usr/bin/time -v``), 0.32 GB on 320x160 ones
WORKER_BYTES = 1 << 30


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity: a container's share, not the host's)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def available_memory() -> int | None:
    """Bytes of memory free for new work (MemAvailable, less within a cgroup's limit), or None."""
    found = []
    try:
        with open("/proc/meminfo") as fh:
            found += [int(line.split()[1]) * 1024 for line in fh if line.startswith("MemAvailable:")]
    except (OSError, ValueError, IndexError):
        pass
    try:
        cgroup = Path("/sys/fs/cgroup")
        limit = (cgroup / "memory.max").read_text().strip()
        if limit.isdigit():
            found.append(int(limit) - int((cgroup / "memory.current").read_text().strip()))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


#: worker processes per core at the most: beyond a few they only share the cores (and the GPU)
WORKERS_PER_CORE = 4


def worker_count(requested: int) -> tuple[int, str | None]:
    """The local worker processes to start for ``--workers requested`` and a note when it is not
    what was asked or more than the cores: 0 means one per core; at most :data:`WORKERS_PER_CORE`
    per core, and no more than the memory free holds at :data:`WORKER_BYTES` each. More workers
    than cores run (a worker waits on its GPU or its writes part of the time) with a note."""
    cores = usable_cores()
    want = cores if requested == 0 else requested
    memory = available_memory()
    by_memory = max(1, memory // WORKER_BYTES) if memory is not None else want
    n = max(1, min(want, WORKERS_PER_CORE * cores, by_memory))
    if n < want:
        why = f"{cores} cores, {WORKERS_PER_CORE} each" if n == WORKERS_PER_CORE * cores \
            else f"{memory / 2**30:.1f} GiB free, ~1 GiB each"
        return n, f"--workers {requested}: {n} worker(s), as many as this machine allows ({why})"
    if requested == 0:
        return n, f"--workers 0: one per core, {n}"
    if n > cores:
        return n, f"--workers {requested}: more workers than the {cores} cores; they share them"
    return n, None


def in_process(manifest: Manifest, weights: np.ndarray, todo: list[ImageSetId], gl_device: int | None) -> Iterator[Outcome]:
    with Pipeline(manifest, weights, gl_device=gl_device) as pipe:
        log.info("GL: %s", pipe.gl.renderer_name)
        yield from pipe.stream(todo)


@dataclass(frozen=True)
class WorkerReady:
    """A worker made its GL context (the renderer's name)."""

    renderer: str


@dataclass(frozen=True)
class WorkerFailed:
    """A worker could not start (why)."""

    reason: str


@dataclass(frozen=True)
class WorkerBegins:
    """A worker begins computing an image set: the one that fails if the worker dies."""

    key: str


@dataclass(frozen=True)
class WorkerDone:
    """A worker finished an image set."""

    outcome: Outcome


WorkerMessage = WorkerReady | WorkerFailed | WorkerBegins | WorkerDone


def run_worker(manifest: Manifest, weights: np.ndarray, gl_device: int | None, conn, wid: int,
               threads: int) -> None:
    """A spawned worker: its own GL context; takes image sets over its own pipe until None.

    Each worker has a pipe of its own (no queue shared between workers): a worker that dies
    while sending can never leave a lock held that would stall the others. The parent keeps
    :data:`IN_FLIGHT` image sets queued on it, so that the next one is read while one is
    computed and the last one written (:meth:`Pipeline.stream`); the worker says
    :class:`WorkerBegins` when it starts computing one, which is the one that fails if it dies.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the parent, which stops the batch
    # share the cores between workers: llvmpipe's and OpenCV's thread pools would
    # otherwise each take every core in every worker
    os.environ.setdefault("LP_NUM_THREADS", str(threads))
    import cv2

    cv2.setNumThreads(threads)
    try:
        pipe = Pipeline(manifest, weights, gl_device=gl_device)
    except BaseException as exc:  # noqa: BLE001 - report, the parent decides
        conn.send(WorkerFailed(f"{type(exc).__name__}: {exc}"))
        return
    conn.send(WorkerReady(pipe.gl.renderer_name))

    def begin(ident: ImageSetId) -> None:
        conn.send(WorkerBegins(ident.key))

    try:
        for outcome in pipe.stream(iter(conn.recv, None), on_begin=begin):
            conn.send(WorkerDone(outcome))
    except (BrokenPipeError, EOFError, ConnectionResetError, KeyboardInterrupt):
        # the parent is gone (SIGTERM, Ctrl-C): it reports; a worker just stops, without a
        # traceback of its own (what it wrote is complete or a temporary file: a rerun resumes)
        pass
    finally:
        pipe.close()


#: what a worker process runs (spawned: a module-level callable taking :func:`run_worker`'s
#: arguments); the tests put a wrapper here that injects a fault
worker_entry: Callable[..., None] = run_worker

#: image sets queued on each worker process: one computed, one read ahead
IN_FLIGHT = 2


@dataclass(eq=False)
class _Worker:
    """The parent's side of one worker process: its pipe, the image sets queued on it and the
    one it computes."""

    wid: int
    proc: Any  # multiprocessing's SpawnProcess
    conn: Any  # the parent's end of the pipe
    queued: list[ImageSetId] = field(default_factory=list)
    computing: str | None = None  # the key of the image set it said it begins
    closed: bool = False  # told to stop once its queue is done

    def feed(self, pending: list[ImageSetId]) -> None:
        """Top the queue up to IN_FLIGHT from ``pending``; None (stop when done) once nothing is left."""
        try:
            while pending and not self.closed and len(self.queued) < IN_FLIGHT:
                self.queued.append(pending.pop())
                self.conn.send(self.queued[-1])
            if not pending and not self.closed:
                self.closed = True
                self.conn.send(None)
        except (OSError, ValueError):
            pass  # died meanwhile: noticed through its sentinel

    def receive(self, ready: list) -> WorkerMessage | None:
        """Its message, if one is waiting."""
        if self.conn not in ready and self.proc.sentinel not in ready:
            return None
        try:
            return self.conn.recv() if self.conn.poll() else None
        except (EOFError, OSError):
            return None

    def dead(self, ready: list) -> bool:
        return self.proc.sentinel in ready or not self.proc.is_alive()

    def bury(self) -> tuple[list[Outcome], list[ImageSetId]]:
        """After its death: the outcome of the image set it was computing (failed), and the ones
        queued behind it, for the others."""
        self.proc.join(timeout=1)
        self.conn.close()
        failed, requeue = [], []
        for ident in reversed(self.queued):
            if ident.key == self.computing:
                failed.append(Outcome(ident.key, Status.FAILED,
                                      f"worker process died (exit code {self.proc.exitcode}) on this image set"))
            else:
                requeue.append(ident)
        return failed, requeue

    def stop(self) -> None:
        try:
            self.conn.send(None)
        except (OSError, ValueError):
            pass


def process_pool(manifest: Manifest, weights: np.ndarray, todo: list[ImageSetId], workers: int,
                 gpus: int) -> Iterator[Outcome]:
    """``workers`` spawned processes; a dead worker's image set fails and the worker is replaced."""
    from multiprocessing.connection import wait

    ctx = mp.get_context("spawn")
    pending = list(reversed(todo))
    slots: dict[int, _Worker] = {}
    started = restarts = 0
    threads = max(1, (os.cpu_count() or 1) // workers)

    def start() -> None:
        nonlocal started
        wid, started = started, started + 1
        parent_end, child_end = ctx.Pipe()
        device = (wid % gpus) if gpus else None
        proc = ctx.Process(target=worker_entry, args=(manifest, weights, device, child_end, wid, threads),
                           name=f"synthcompose-worker-{wid}", daemon=True)
        proc.start()
        child_end.close()
        slots[wid] = _Worker(wid, proc, parent_end)

    for _ in range(min(workers, len(todo))):
        start()
    outstanding = len(todo)
    try:
        while outstanding:
            if not slots:
                for ident in reversed(pending):
                    yield Outcome(ident.key, Status.FAILED, "no worker left to process it")
                return
            ready = wait([w.conn for w in slots.values()] + [w.proc.sentinel for w in slots.values()], timeout=5.0)
            for wid, worker in list(slots.items()):
                message = worker.receive(ready)
                if message is not None:
                    if isinstance(message, WorkerFailed):
                        raise BatchError(f"a worker could not start: {message.reason}")
                    if isinstance(message, WorkerReady) and wid == 0:
                        log.info("GL: %s", message.renderer)
                    elif isinstance(message, WorkerBegins):
                        worker.computing = message.key
                    elif isinstance(message, WorkerDone):
                        worker.queued = [i for i in worker.queued if i.key != message.outcome.key]
                        outstanding -= 1
                        yield message.outcome
                    worker.feed(pending)
                    continue
                if worker.dead(ready):
                    del slots[wid]
                    failed, requeue = worker.bury()
                    outstanding -= len(failed)
                    yield from failed
                    pending.extend(requeue)
                    if pending and restarts < 10 * workers:
                        restarts += 1
                        if worker.proc.exitcode != 0:
                            log.warning("worker %d died (exit code %s); starting a replacement", wid,
                                        worker.proc.exitcode)
                        start()
    finally:
        for worker in slots.values():
            worker.stop()
        for worker in slots.values():
            worker.proc.join(timeout=10)
            if worker.proc.is_alive():
                worker.proc.terminate()


def ray_engine(manifest: Manifest, weights: np.ndarray, todo: list[ImageSetId], workers: int,
                address: str | None, gpus_per_actor: float) -> Iterator[Outcome]:
    """Ray actors, one GL context each (GPUs as Ray resources); a dead actor is replaced."""
    try:
        import ray
    except ImportError:
        raise BatchError("--ray needs Ray: pip install 'synthcompose[ray]'") from None
    started_here = not ray.is_initialized()
    if started_here:
        ray.init(address=address or None, include_dashboard=False, logging_level=logging.WARNING,
                 log_to_driver=False)
    try:
        Actor = ray.remote(num_cpus=1, num_gpus=gpus_per_actor)(_RayWorker)
        n = max(1, min(workers or int(ray.cluster_resources().get("CPU", 1)), len(todo)))
        actors = [Actor.remote(manifest, weights) for _ in range(n)]
        pending = list(reversed(todo))
        running: dict = {}

        def submit(actor) -> None:
            if pending:
                ident = pending.pop()
                running[actor.process.remote(ident)] = (actor, ident)

        for actor in actors:
            submit(actor)
        while running:
            ready, _ = ray.wait(list(running), num_returns=1)
            ref = ready[0]
            actor, ident = running.pop(ref)
            try:
                yield ray.get(ref)
            except ray.exceptions.RayError as exc:
                yield Outcome(ident.key, Status.FAILED, f"Ray worker failed on this image set: {type(exc).__name__}")
                ray.kill(actor, no_restart=True)
                actor = Actor.remote(manifest, weights)
            submit(actor)
    finally:
        if started_here:
            ray.shutdown()


class _RayWorker:
    """Body of a Ray actor: one Pipeline (one GL context) for its lifetime."""

    def __init__(self, manifest: Manifest, weights: np.ndarray) -> None:
        logging.basicConfig(level=logging.WARNING)
        self.pipe = Pipeline(manifest, weights)

    def process(self, ident: ImageSetId) -> Outcome:
        return self.pipe.process(ident)
