"""Where a worker's resident memory goes: RSS sampled every few milliseconds while a batch
streams image sets (Pipeline.stream, three sets in the works) or runs them one after the other
(``--sequential``), each sample tagged with the stages running at that moment.

    python benchmarks/bench_rss.py [--count 12] [--size 2048x1024] [--sequential] [--timeline]

Uses the benchmarks' generated data (`bench_cost.dataset`, one car per set, the right view on).
Prints the peak, the highest RSS seen under each combination of stages running at once, and
with ``--timeline`` each change of that combination (seconds, MB, stages). Linux only (reads
/proc/self/statm). The shade's steps on the GL thread (the left view's render and compose, the
right view) are shown as ``shade:<step>``.
"""
from __future__ import annotations

import argparse
import collections
import contextlib
import importlib
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import bench_cost  # noqa: E402

from synthcompose.io.dataset import find_image_sets  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.run import pipeline  # noqa: E402

STAGES = ("prepare", "place", "measure_light", "shade", "write_done")
#: the GL thread's steps within "shade" (stages.shade's timed stages), shown as shade:<step>
SHADE_STEPS = ("render", "compose", "right")
PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * PAGE / 2 ** 20


def traced(count: int, width: int, height: int, sequential: bool) -> list[tuple[float, float, tuple[str, ...]]]:
    """(seconds, RSS MB, stages running) samples of one batch in this process."""
    active: collections.Counter[str] = collections.Counter()
    lock = threading.Lock()

    def wrap(name, fn):
        def call(*args, **kwargs):
            with lock:
                active[name] += 1
            try:
                return fn(*args, **kwargs)
            finally:
                with lock:
                    active[name] -= 1
        return call

    for name in STAGES:  # the pipeline calls the stages by the names it imported
        setattr(pipeline, name, wrap(name, getattr(pipeline, name)))
    shade_module = importlib.import_module("synthcompose.stages.shade")
    timed = shade_module.timed

    @contextlib.contextmanager
    def tagged(timings, stage):
        with lock:
            active[f"shade:{stage}"] += 1
        try:
            with timed(timings, stage):
                yield
        finally:
            with lock:
                active[f"shade:{stage}"] -= 1

    shade_module.timed = tagged
    names = STAGES + tuple(f"shade:{step}" for step in SHADE_STEPS)
    samples: list[tuple[float, float, tuple[str, ...]]] = []
    done = threading.Event()

    def sample() -> None:
        t0 = time.perf_counter()
        while not done.is_set():
            with lock:
                running = tuple(k for k in names if active[k])
            samples.append((time.perf_counter() - t0, rss_mb(), running))
            time.sleep(0.003)

    data = bench_cost.dataset(count, width, height, right=True)
    with tempfile.TemporaryDirectory() as tmp:
        manifest = load_manifest(bench_cost.manifest_for(data, Path(tmp) / "out", Path(tmp),
                                                         render={"right_view": True}))
        idents = list(find_image_sets(manifest.dataset))[:count]
        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        with pipeline.Pipeline(manifest) as pipe:
            if sequential:
                for ident in idents:
                    pipe.process(ident)
                    pipeline.release_free_memory()
            else:
                for _ in pipe.stream(idents):
                    pass
        done.set()
        sampler.join()
    return samples


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--sequential", action="store_true", help="the stages one after the other (Pipeline.process)")
    ap.add_argument("--timeline", action="store_true")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    samples = traced(args.count, width, height, args.sequential)
    print(f"{args.count} generated sets, {'one after the other' if args.sequential else 'streamed'}: "
          f"peak RSS {max(s[1] for s in samples):.0f} MB")
    most: dict[tuple[str, ...], float] = collections.defaultdict(float)
    for _, mb, running in samples:
        most[running] = max(most[running], mb)
    print(f"{'highest MB':>10}  stages running at once")
    for running, mb in sorted(most.items(), key=lambda kv: -kv[1]):
        print(f"{mb:10.0f}  {', '.join(running) or '(between sets)'}")
    if args.timeline:
        last = None
        for t, mb, running in samples:
            if running != last:
                print(f"{t:7.2f} s {mb:6.0f} MB  {', '.join(running) or '-'}")
                last = running
    return 0


if __name__ == "__main__":
    sys.exit(main())
