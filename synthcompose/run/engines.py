"""The engines that run a batch's image sets: in this process, in spawned worker processes (each
with its own GL context, a crashed one replaced), or as Ray actors. Each yields the outcomes."""
from __future__ import annotations

import logging
import multiprocessing as mp
import os
import signal
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from synthcompose.errors import SynthComposeError
from synthcompose.io.dataset import ImageSetId
from synthcompose.manifest import Manifest
from synthcompose.record import Status

from .pipeline import Outcome, Pipeline

log = logging.getLogger("synthcompose")

#: fault injection (tests): a worker process given this image set key crashes with SIGSEGV


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


def run_worker(manifest: Manifest, weights: np.ndarray, gl_device: int | None, conn, wid: int,
                 threads: int) -> None:
    """A spawned worker: its own GL context; takes image sets over its own pipe until None.

    Each worker has a pipe of its own (no queue shared between workers): a worker that dies
    while sending can never leave a lock held that would stall the others. The parent keeps
    :data:`IN_FLIGHT` image sets queued on it, so that the next one is read while one is
    computed and the last one written (:meth:`Pipeline.stream`); the worker says ("begin",
    key) when it starts computing one, which is the one that fails if it dies.
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
        conn.send(("init-failed", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", pipe.gl.renderer_name))

    def begin(ident: ImageSetId) -> None:
        conn.send(("begin", ident.key))

    try:
        for outcome in pipe.stream(iter(conn.recv, None), on_begin=begin):
            conn.send(("done", outcome))
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


def process_pool(manifest: Manifest, weights: np.ndarray, todo: list[ImageSetId], workers: int,
                  gpus: int) -> Iterator[Outcome]:
    """``workers`` spawned processes; a dead worker's image set fails and the worker is replaced."""
    from multiprocessing.connection import wait

    ctx = mp.get_context("spawn")
    pending = list(reversed(todo))
    slots: dict[int, dict] = {}
    next_id = 0
    restarts = 0
    threads = max(1, (os.cpu_count() or 1) // workers)

    def start() -> None:
        nonlocal next_id
        wid = next_id
        next_id += 1
        parent_end, child_end = ctx.Pipe()
        device = (wid % gpus) if gpus else None
        proc = ctx.Process(target=worker_entry, args=(manifest, weights, device, child_end, wid, threads),
                           name=f"synthcompose-worker-{wid}", daemon=True)
        proc.start()
        child_end.close()
        slots[wid] = {"proc": proc, "conn": parent_end, "queued": [], "computing": None, "closed": False}

    def feed(wid: int) -> None:
        """Top the worker's queue up to IN_FLIGHT; None (stop when done) once nothing is left."""
        slot = slots[wid]
        try:
            while pending and not slot["closed"] and len(slot["queued"]) < IN_FLIGHT:
                slot["queued"].append(pending.pop())
                slot["conn"].send(slot["queued"][-1])
            if not pending and not slot["closed"]:
                slot["closed"] = True
                slot["conn"].send(None)
        except (OSError, ValueError):
            pass  # died meanwhile: noticed through its sentinel

    for _ in range(min(workers, len(todo))):
        start()
    outstanding = len(todo)
    try:
        while outstanding:
            if not slots:
                for ident in reversed(pending):
                    yield Outcome(ident.key, Status.FAILED, "no worker left to process it")
                return
            ready = wait([sl["conn"] for sl in slots.values()] + [sl["proc"].sentinel for sl in slots.values()],
                         timeout=5.0)
            for wid, slot in list(slots.items()):
                message = None
                if slot["conn"] in ready or slot["proc"].sentinel in ready:
                    try:
                        if slot["conn"].poll():
                            message = slot["conn"].recv()
                    except (EOFError, OSError):
                        message = None
                if message is not None:
                    kind, payload = message
                    if kind == "init-failed":
                        raise BatchError(f"a worker could not start: {payload}")
                    if kind == "ready":
                        if wid == 0:
                            log.info("GL: %s", payload)
                    elif kind == "begin":
                        slot["computing"] = payload
                    else:
                        slot["queued"] = [i for i in slot["queued"] if i.key != payload.key]
                        outstanding -= 1
                        yield payload
                    feed(wid)
                    continue
                if slot["proc"].sentinel in ready or not slot["proc"].is_alive():
                    slot["proc"].join(timeout=1)
                    del slots[wid]
                    slot["conn"].close()
                    # the image set it was computing fails; the ones queued behind it go to others
                    for ident in reversed(slot["queued"]):
                        if ident.key == slot["computing"]:
                            outstanding -= 1
                            yield Outcome(ident.key, Status.FAILED,
                                          f"worker process died (exit code {slot['proc'].exitcode}) on this image set")
                        else:
                            pending.append(ident)
                    if pending and restarts < 10 * workers:
                        restarts += 1
                        if slot["proc"].exitcode != 0:
                            log.warning("worker %d died (exit code %s); starting a replacement", wid,
                                        slot["proc"].exitcode)
                        start()
    finally:
        for slot in slots.values():
            try:
                slot["conn"].send(None)
            except (OSError, ValueError):
                pass
        for slot in slots.values():
            slot["proc"].join(timeout=10)
            if slot["proc"].is_alive():
                slot["proc"].terminate()


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
