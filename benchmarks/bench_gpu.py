"""Throughput where the GL passes run on a GPU (issue 33): image sets per second with 1, 2, 4, 8
and 16 workers on the whole machine, the CPU side per set, and where the time goes.

    python benchmarks/bench_gpu.py [--count 128] [--workers 1,2,4,8,16] [--size 2048x1024] [--json FILE]

The issue's measurement: generated stereo image sets at 2048x1024, one car each to insert, the
right view on (Cityscapes' default). In one run:

* the GL renderer that EGL gives (the figures are a GPU's only where it names one);
* ``--count`` image sets generated side by side (one process per core, each its own seed and
  city; cached under out/bench/);
* the codec on the same files (bench_cost's yardstick: decode the inputs, encode the 6 outputs,
  one thread, level 1);
* CPU-seconds per set of each stage, the stages one after the other in this process, the GL
  passes' own CPU apart (bench_cost's ``stage_cpu``): the CPU side is everything but the GL
  passes;
* for each worker count W: a batch of W sets (the start-up: imports, GL contexts, shaders,
  models; about one set a worker) and a batch of N = min(count, max(16, 8 W)) sets, each in a
  child process; image sets per second with the start-up (N / wall) and without it
  ((N - W) / (wall - start-up's wall)), CPU-seconds per set of the whole machine, peak RSS per
  worker, the GPU's mean utilisation (nvidia-smi, where there is one) and the batch's mean wall
  time per stage in a worker.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_cost import codec_cpu, run_batch, stage_cpu, stage_table  # noqa: E402

from synthcompose.io.dataset import find_image_sets  # noqa: E402

VIEW = {"render": {"right_view": True}}


def gl_info() -> dict:
    """What EGL gives this process: renderer, vendor, version."""
    from synthcompose.render.gl import create_context

    ctx = create_context()
    try:
        return {k: ctx.info.get(k, "") for k in ("GL_RENDERER", "GL_VENDOR", "GL_VERSION")}
    finally:
        ctx.release()


def _make(job: tuple) -> int:
    from synthcompose.synthetic import make_sample

    root, count, width, height, j = job
    make_sample(Path(root), count=count, width=width, height=height, seed=1000 + j, city=f"gpu{j:02d}", right=True)
    return count


def dataset(count: int, width: int, height: int) -> Path:
    """``count`` stereo image sets, made side by side (one job per core, each with its own seed
    and city) under out/bench/, or those made by an earlier run."""
    data = ROOT / "out" / "bench" / f"gpu-{width}x{height}-{count}"
    if (data / ".complete").exists():
        return data
    shutil.rmtree(data, ignore_errors=True)
    jobs = min(os.cpu_count() or 1, count)
    sizes = [count // jobs + (j < count % jobs) for j in range(jobs)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        list(pool.map(_make, [(str(data), n, width, height, j) for j, n in enumerate(sizes)]))
    (data / ".complete").touch()
    print(f"generated {count} stereo image sets at {width}x{height} in {time.perf_counter() - t0:.0f} s ({data})",
          flush=True)
    return data


class GpuSampler:
    """The GPU's utilisation (%) sampled every 200 ms by nvidia-smi while a batch runs; none
    where there is no nvidia-smi."""

    def __init__(self) -> None:
        self.proc, self.file = None, None

    def __enter__(self) -> GpuSampler:
        if shutil.which("nvidia-smi"):
            self.file = tempfile.TemporaryFile(mode="w+")
            self.proc = subprocess.Popen(["nvidia-smi", "--query-gpu=utilization.gpu,memory.used",
                                          "--format=csv,noheader,nounits", "-lms", "200"],
                                         stdout=self.file, stderr=subprocess.DEVNULL, text=True)
        return self

    def __exit__(self, *exc) -> None:
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait()

    def mean(self) -> tuple[float, float] | None:
        """Mean utilisation (%) and the most GPU memory used (MiB) over the samples."""
        if self.file is None:
            return None
        self.file.seek(0)
        rows = [line.split(",") for line in self.file.read().splitlines() if line.count(",") == 1]
        values = [(float(u), float(m)) for u, m in rows if u.strip().isdigit()]
        if not values:
            return None
        return sum(u for u, _ in values) / len(values), max(m for _, m in values)


def throughput(data: Path, workers: int, count: int) -> dict:
    """A start-up batch of ``workers`` sets, then one of N sets; see the module's docstring."""
    n = min(count, max(16, 8 * workers))
    start = run_batch(data, workers, workers, **VIEW)
    with GpuSampler() as gpu:
        r = run_batch(data, workers, n, **VIEW)
    steady = (r["sets"] - start["sets"]) / max(r["wall_s"] - start["wall_s"], 1e-9)
    util = gpu.mean()
    return {"workers": workers, "sets": r["sets"], "wall_s": r["wall_s"], "sets_per_s": r["sets"] / r["wall_s"],
            "sets_per_s_steady": steady, "start_wall_s": start["wall_s"], "cpu_s_per_set": r["cpu_s"] / r["sets"],
            "cpu_s_per_set_steady": (r["cpu_s"] - start["cpu_s"]) / max(r["sets"] - start["sets"], 1),
            "peak_rss_mb": r["peak_mb"], "gpu_util_pct": util[0] if util else None,
            "gpu_mem_mib": util[1] if util else None, "failed": r["summary"]["failed"],
            "mean_stage_s": r["summary"]["mean_stage_s"]}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=128, help="image sets generated (the largest batch)")
    ap.add_argument("--workers", default="1,2,4,8,16")
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--stage-sets", type=int, default=9, help="sets for the per-stage figures (the first warms up)")
    ap.add_argument("--json", type=Path, help="write every figure here too")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    info = gl_info()
    print(f"{platform.node()}: {os.cpu_count()} cores, {datetime.date.today()}; GL: {info['GL_RENDERER']} "
          f"({info['GL_VENDOR']}, {info['GL_VERSION']})", flush=True)
    data = dataset(args.count, width, height)
    count = len(find_image_sets(data))
    codec = codec_cpu(data, min(12, count), right=True)
    print(f"codec (decode the inputs, encode the 6 outputs, one thread, level 1): {codec:.3f} CPU-s per set", flush=True)
    stages, n = stage_cpu(data, args.stage_sets, **VIEW)
    print(f"CPU-s per set by stage, one after the other in one process ({n} sets after one to warm up):")
    stage_table(stages, codec)
    side = sum(v for k, v in stages.items() if not k.startswith("gl ")) - \
        sum(v for k, v in stages.items() if k.startswith("gl "))
    rows = []
    for w in [int(v) for v in args.workers.split(",")]:
        rows.append(throughput(data, w, count))
        r = rows[-1]
        util = "-" if r["gpu_util_pct"] is None else f"{r['gpu_util_pct']:.0f} % ({r['gpu_mem_mib']:.0f} MiB)"
        print(f"workers {w:>2}: {r['sets']:>4} sets in {r['wall_s']:6.1f} s = {r['sets_per_s']:6.2f} sets/s "
              f"({r['sets_per_s_steady']:6.2f} without the start-up of {r['start_wall_s']:.1f} s); "
              f"CPU {r['cpu_s_per_set']:.3f} s/set ({r['cpu_s_per_set_steady']:.3f} steady, "
              f"{r['cpu_s_per_set_steady'] / codec:.2f} x codec); peak RSS/worker {r['peak_rss_mb']:.0f} MB; "
              f"GPU {util}; failed {r['failed']}", flush=True)
    print("mean wall s per stage in a worker (stages of consecutive sets overlap):")
    for r in rows:
        print(f"  {r['workers']:>2} workers: " + ", ".join(f"{k} {v:.3f}" for k, v in r["mean_stage_s"].items()))
    if args.json:
        args.json.write_text(json.dumps({"gl": info, "cores": os.cpu_count(), "codec_cpu_s": codec,
                                         "stages_cpu_s": stages, "cpu_side_s": side, "batches": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
