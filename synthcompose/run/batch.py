"""The batch: which image sets, in which process, with progress, resume and a summary.

* selection: the manifest's splits/cities/frames/limit; object choice weights (in
  "balance" mode the class counts are taken once, here, and handed to every worker);
* the output root is locked (``.synthcompose.lock``, an ``flock`` the kernel drops when
  the process dies): a second batch on the same root is refused with a clear message;
* resume: an image set whose record exists with the same configuration hash is complete
  (records are written last) and is not redone; stale ``*.part`` files of a killed run
  are removed;
* engines: in-process (``workers=1``), ``workers=N`` spawned processes (never forked: each
  makes its own EGL context, optionally on its own GPU), or Ray actors (``ray_address``).
  A worker that dies takes only its current image set down: it is reported and replaced.
  Every image set's randomness depends on (seed, image set) only, so the outputs do not
  depend on the engine, the worker count or the order.
"""
from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from synthcompose.cast import preload
from synthcompose.errors import ManifestError, SynthComposeError
from synthcompose.io.dataset import ImageSetId, input_fingerprint
from synthcompose.io.files import PART_TAG, write_json
from synthcompose.manifest import Manifest
from synthcompose.models import load_model
from synthcompose.placement.frequency import count_classes, object_weights
from synthcompose.record import Status, read_record
from synthcompose.write.outputs import discard_outputs, output_paths

from .engines import BatchError, in_process, process_pool, ray_engine, worker_count
from .pipeline import STAGES, Outcome
from .selection import select_image_sets

log = logging.getLogger("synthcompose")

LOCK_NAME = ".synthcompose.lock"
#: the dataset's input folders (Cityscapes layout): an output root must not be or lie in them
INPUT_FOLDERS = ("leftImg8bit", "rightImg8bit", "gtFine", "disparity", "camera", "gtBbox3d")


@dataclass
class Summary:
    outcomes: list[Outcome] = field(default_factory=list)
    wall_s: float = 0.0
    workers: int = 1
    engine: str = "local"
    class_counts: dict[str, int] | None = None  # "balance" mode: the dataset's objects per class
    notes: list[str] = field(default_factory=list)  # what went wrong outside any image set

    def count(self, status: Status) -> int:
        return sum(o.status == status for o in self.outcomes)

    @property
    def resumed(self) -> int:
        return sum(bool(o.resumed) for o in self.outcomes)

    @property
    def exit_code(self) -> int:
        return 1 if self.count(Status.FAILED) else 0

    def stage_means(self) -> dict[str, float]:
        done = [o for o in self.outcomes if o.status == Status.DONE and not o.resumed]
        return {s: (sum(o.timings.get(s, 0.0) for o in done) / len(done) if done else 0.0) for s in STAGES}

    def to_dict(self) -> dict:
        out = {
            "done": self.count(Status.DONE), "skipped": self.count(Status.SKIPPED), "failed": self.count(Status.FAILED),
            "resumed": self.resumed, "engine": self.engine, "workers": self.workers,
            "wall_s": round(self.wall_s, 3),
            "mean_stage_s": {k: round(v, 4) for k, v in self.stage_means().items()},
            "problems": [{"image_set": o.key, "status": o.status, "reason": o.reason}
                         for o in self.outcomes if o.status != Status.DONE],
            "image_sets": [{"image_set": o.key, "status": o.status, "resumed": o.resumed,
                            "stage_s": {k: round(v, 4) for k, v in o.timings.items()}} for o in self.outcomes],
        }
        if self.class_counts is not None:
            out["class_counts"] = self.class_counts
        if self.notes:
            out["notes"] = list(self.notes)
        return out

    def text(self) -> str:
        lines = [f"{self.count('done')} done, {self.count('skipped')} skipped, {self.count('failed')} failed "
                 f"({self.resumed} already complete) in {self.wall_s:.1f} s with {self.workers} "
                 f"{self.engine} worker(s)"]
        worked = sum(not o.resumed for o in self.outcomes)
        if any(o.status == Status.DONE and not o.resumed for o in self.outcomes):
            lines.append(f"{self.wall_s / max(worked, 1) * 1000:.0f} ms per image set; mean stage times "
                         "(stages of consecutive image sets overlap): " +
                         ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in self.stage_means().items()))
        for o in self.outcomes:
            if o.status != Status.DONE:
                lines.append(f"  {o.status}: {o.key}: {o.reason}")
        return "\n".join(lines)


# ----------------------------------------------------------------------- selection, resume
def select(manifest: Manifest) -> tuple[list[ImageSetId], np.ndarray, dict[str, int] | None]:
    """(image sets to consider, object choice probabilities, class counts or None)."""
    m = manifest
    ids = select_image_sets(m)  # a split, city or frame that matches nothing: refused, named
    ids = ids[: m.limit] if m.limit else ids
    counts = None
    if m.object_choice == "balance":
        counts = count_classes(m.dataset, ids)
        weights = object_weights([o.weight for o in m.objects], [o.class_name for o in m.objects], "balance", counts)
        log.info("class counts %s -> object probabilities %s", counts,
                 {o.name: round(float(p), 3) for o, p in zip(m.objects, weights)})
    else:
        weights = object_weights([o.weight for o in m.objects], [], "weights")
    return ids, weights, counts


def completed(manifest: Manifest, ident: ImageSetId) -> Outcome | None:
    """The outcome of an image set a previous run finished with this configuration, or None."""
    path = ident.path(manifest.output, "record")
    if not path.is_file():
        return None
    try:
        record = read_record(path)
    except SynthComposeError:  # damaged, or not a record: redo the set
        return None
    if record.config_sha256 != manifest.config_hash:
        return None
    if dict(record.source_fingerprint) != input_fingerprint(manifest.dataset, ident):
        return None  # an input file changed (or the record predates fingerprints)
    from synthcompose.placement.saved_poses import saved_is_stale  # saved placements: a placement saved since means redo
    if saved_is_stale(manifest.output, ident, record.placement_file):
        return None
    if record.status == Status.DONE:
        return Outcome(ident.key, Status.DONE, None, len(record.objects), resumed=True)
    if record.status == Status.NO_PLACEMENT:
        return Outcome(ident.key, Status.SKIPPED, "no valid placement (earlier run)", resumed=True)
    return None


def remove_partials(out_root: Path, idents: Iterable[ImageSetId] = ()) -> int:
    """Delete the temporary files a killed run of this tool left: named by
    :func:`fileio.write_bytes_atomic` (``.<name>.synthcompose-*.part``), in the output root
    itself and in the folders of the image sets ``idents`` - nothing else (another program's
    ``.part`` files, a batch writing to a folder nested in this root). Returns how many."""
    folders = {Path(out_root)}
    for ident in idents:
        folders.update(p.parent for p in output_paths(out_root, ident))
    n = 0
    for folder in sorted(folders):
        if not folder.is_dir():
            continue
        for p in folder.glob(f".*.{PART_TAG}*.part"):
            if p.is_file() and not p.is_symlink():
                p.unlink(missing_ok=True)
                n += 1
    return n


def refuse_overlap(manifest: Manifest) -> None:
    """Refuse an output root that is the dataset root (or a link to it), or lies inside one of
    its input folders: the outputs keep the inputs' layout, so they would overwrite the photos,
    labels and disparity, or be read as inputs by the next batch."""
    out, data = Path(manifest.output).resolve(), Path(manifest.dataset).resolve()
    inputs = [data / d for d in INPUT_FOLDERS]
    if out == data or any(out == d or d in out.parents for d in inputs):
        raise ManifestError(manifest.path, f"field 'output': {manifest.output} is the dataset's own folder "
                                           f"({manifest.dataset}); the outputs would overwrite the inputs - "
                                           "give another output root")


def preflight(manifest: Manifest) -> None:
    """Load every model once before any work: a bad model file stops the batch at the start
    (with the file named) instead of failing every image set."""
    for spec in manifest.objects:
        if spec.cast:
            preload(spec.cast)
        else:
            load_model(spec.model, spec.size, spec.up, spec.forward)


class OutputLock:
    """Exclusive lock on an output root for the duration of a batch."""

    def __init__(self, out_root: Path) -> None:
        self.path = Path(out_root) / LOCK_NAME
        self._fd: int | None = None

    def __enter__(self) -> "OutputLock":
        if self.path.parent.exists() and not self.path.parent.is_dir():
            raise BatchError(f"{self.path.parent}: output root is a file, not a folder; give a folder")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise BatchError(f"{self.path.parent}: output root is not writable ({exc.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "another process"
            os.close(fd)
            raise BatchError(f"{self.path.parent}: another batch is writing to this output root ({holder}); "
                             "wait for it or choose another output") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} since {time.strftime('%Y-%m-%d %H:%M:%S')}\n".encode(), 0)
        self._fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self._fd is not None:
            os.ftruncate(self._fd, 0)
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None


# -------------------------------------------------------------------------------- the batch
def _consume(stream: Iterable[Outcome], summary: Summary, bar, show_bar: bool, total: int, manifest: Manifest,
             by_key: dict[str, ImageSetId], on_outcome: Callable[[Outcome], None] | None) -> None:
    """Take the outcomes as they come: the summary, the progress, and a failed or skipped set's
    leftovers removed."""
    for i, outcome in enumerate(stream, start=1):
        summary.outcomes.append(outcome)
        bar.update(1)
        if on_outcome:
            on_outcome(outcome)
        if outcome.status != Status.DONE:
            log.warning("%s %s: %s", outcome.status, outcome.key, outcome.reason)
            if not outcome.resumed:  # nothing of it outlives its record: this run's, or none
                discard_outputs(manifest.output, by_key[outcome.key], keep_record=outcome.status == Status.SKIPPED)
        if show_bar:
            bar.set_postfix(done=summary.count(Status.DONE), failed=summary.count(Status.FAILED))
        else:
            log.info("[%d/%d] %s %s (%.2f s)", i, total, outcome.status, outcome.key, sum(outcome.timings.values()))


def run_batch(manifest: Manifest, workers: int = 1, progress: bool | None = None, ray_address: str | None = None,
              use_ray: bool = False, gpus: int = 0, gpus_per_actor: float = 0.0, resume: bool = True,
              on_outcome: Callable[[Outcome], None] | None = None) -> Summary:
    """Process every image set the manifest selects; writes ``summary.json`` in the output root.

    ``workers``: processes (or Ray actors; 0 = one per Ray CPU); ``gpus``: spread the local
    workers over this many EGL devices; ``resume``: keep image sets a previous run completed.
    """
    from tqdm import tqdm
    from tqdm.contrib.logging import logging_redirect_tqdm

    t0 = time.perf_counter()
    if not use_ray:  # 0: one per core; no more than the cores and the memory allow
        workers, note = worker_count(workers)
        if note:
            log.info("%s", note)
    engine = "ray" if use_ray else ("local" if workers <= 1 else "process")
    summary = Summary(workers=max(workers, 1), engine=engine)
    refuse_overlap(manifest)  # inputs are never written, whatever the manifest says
    preflight(manifest)  # a bad model or a selector that selects nothing: refused before the
    ids, weights, summary.class_counts = select(manifest)  # output root is even made
    with OutputLock(manifest.output):
        stale = remove_partials(manifest.output, ids)
        if stale:
            log.info("removed %d partial files left by an interrupted run", stale)
        todo = []
        by_key = {ident.key: ident for ident in ids}
        for ident in ids:
            earlier = completed(manifest, ident) if resume else None
            if earlier is not None:
                summary.outcomes.append(earlier)
            else:
                todo.append(ident)
        log.info("%d image sets from %s -> %s: %d to do, %d already complete", len(ids), manifest.dataset,
                 manifest.output, len(todo), len(ids) - len(todo))
        if use_ray:
            stream: Iterable[Outcome] = ray_engine(manifest, weights, todo, workers, ray_address, gpus_per_actor)
        elif workers <= 1:
            stream = in_process(manifest, weights, todo, 0 if gpus else None)
        else:
            stream = process_pool(manifest, weights, todo, workers, gpus)
        show_bar = sys.stderr.isatty() if progress is None else progress
        bar = tqdm(total=len(todo), unit="set", disable=not show_bar, dynamic_ncols=True)
        # log lines go above the bar, not onto it
        redirect = logging_redirect_tqdm() if show_bar else contextlib.nullcontext()
        with redirect:
            _consume(stream, summary, bar, show_bar, len(todo), manifest, by_key, on_outcome)
        bar.close()
        summary.outcomes.sort(key=lambda o: o.key)
        from synthcompose.write.annotations import write_coco  # annotations: COCO instances of every done record
        try:
            write_coco(manifest.output)
        except SynthComposeError as exc:  # the summary is written whatever the COCO file meets
            log.error("%s", exc)
            summary.notes.append(str(exc))
        summary.wall_s = time.perf_counter() - t0
        write_json(manifest.output / "summary.json", summary.to_dict())
    return summary
