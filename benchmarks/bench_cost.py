"""Cost per image set in CPU-seconds (all threads, user + system), next to the PNG codec's own.

    python benchmarks/bench_cost.py [--count 12] [--size 2048x1024] [--workers 1,2] [--scale 10,100]
                                    [--real /path/to/cityscapes] [--cast]

In one run, on generated image sets that measure like real ones (cached under out/bench/; one
car each) and, with --real, on a real Cityscapes root:

* the codec: decoding each image set's 4 input PNGs and encoding its 5 output PNGs on one
  thread with OpenCV (the settings the pipeline writes with), CPU-seconds per set;
* the whole batch (`synthcompose batch` in a child process, fresh output root): CPU-seconds
  per set of the child and its workers, and their ratio to the codec's - the headline;
* per stage, CPU-seconds per set: the stages run one after the other in this process
  (``Pipeline.process``), each charged the process's CPU time (every thread: llvmpipe's too)
  spent while it ran;
* for each worker count: wall time per set, wall against CPU / cores (the cores kept busy:
  1.0 is perfect), peak RSS per worker;
* with --scale, CPU and wall per set and peak RSS for each batch size (linear: flat per set);
* with --cars, instead of all that: the batch's CPU-seconds per set with each of the cars named
  (one object per set, the same sets and seed), run in turn --repeat times, medians, and their
  ratio to the first car's: what a model costs against another, e.g.
  ``--cars current=assets/models/openmaterial_car/vehicle_example.gltf@4.4:+y:+x,audi=assets/cast/vehicles/chrono-audi/audi.glb@4.88``

With --cast, only the cast's cost: the demo's objects from before the cast (a roadster, a toy
truck, a mannequin, the built-in stop sign) against ``"cast": "street"``, and the built-in stop
sign against the cast's German signs (``cast:traffic sign``); 2 objects per set, one worker,
the batches in turn twice; CPU-seconds per set and the ratios (issue 28: at most 1.15).

The machine, its core count and the date are printed with the table. Never commit outputs made
from real frames.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from statistics import median
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from synthcompose.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.fileio import encode_png  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402
from synthcompose.synthetic import make_sample  # noqa: E402

CAR = str(ROOT / "assets/models/openmaterial_car/vehicle_example.gltf")


def cpu_s() -> float:
    """CPU-seconds of this process, every thread, user + system."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def dataset(count: int, width: int, height: int, right: bool = False) -> Path:
    data = ROOT / "out" / "bench" / f"cityscapes-{width}x{height}-{count}{'-stereo' if right else ''}"
    if not (data / ".complete").exists():
        print(f"generating {count} image sets at {width}x{height} in {data} ...", flush=True)
        make_sample(data, count=count, width=width, height=height, seed=123, right=right)
        (data / ".complete").touch()
    return data


def codec_cpu(root: Path, count: int) -> float:
    """CPU-seconds per image set to decode its input PNGs and encode its 5 outputs, one thread."""
    cv2.setNumThreads(0)
    try:
        idents = find_image_sets(root)[:count]
        t0 = cpu_s()
        for ident in idents:
            s = read_image_set(root, ident)
            for img in (s.rgb, s.label_ids, s.instance_ids.astype("uint16"), colorize(s.label_ids), s.disparity):
                encode_png(img)
        return (cpu_s() - t0) / len(idents)
    finally:
        cv2.setNumThreads(-1)


def manifest_for(data: Path, out: Path, folder: Path, objects: int = 1, specs: list | None = None,
                 cars: list[dict] | None = None, **extra) -> Path:
    """A manifest of one car per set (``objects``; ``specs``: other manifest objects, [] none:
    a ``cast`` in ``extra``; ``cars``: the same as ``specs``, the cars to compare) over ``data``;
    the left view alone unless ``extra`` says otherwise (the codec's figure counts the left view's
    files: eval_stereo.py measures what the right view adds)."""
    extra = {"render": {"right_view": False}} | extra
    path = folder / "bench.json"
    splits = sorted({i.split for i in find_image_sets(data)})
    specs = cars or specs
    specs = [{"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}}] if specs is None else specs
    path.write_text(json.dumps({
        "dataset": str(data), "output": str(out), "seed": 1, "splits": splits, "objects_per_image": objects}
        | ({"objects": specs} if specs else {}) | extra))
    return path


# the child runs the batch and reports peak RSS of itself and of its worker processes
_CHILD = """
import json, resource, sys
from dataclasses import replace
from synthcompose.batch import run_batch
from synthcompose.manifest import load_manifest
m = load_manifest(sys.argv[1]); workers = int(sys.argv[2]); limit = int(sys.argv[3])
if limit: m = replace(m, limit=limit)
s = run_batch(m, workers=workers, progress=False)
me = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(json.dumps({"summary": s.to_dict(), "rss_self_mb": me / 1024, "rss_children_mb": kids / 1024}))
"""


def run_batch(data: Path, workers: int, limit: int, keep: Path | None = None, **extra) -> dict:
    """One `synthcompose batch` in a child process: wall, CPU of the child and its workers, RSS.
    ``keep``: the output root to write (and keep); ``extra``: manifest fields."""
    with tempfile.TemporaryDirectory() as tmp:
        manifest = manifest_for(data, keep or Path(tmp) / "out", Path(tmp), **extra)
        c0, t0 = children_cpu_s(), time.perf_counter()
        out = subprocess.run([sys.executable, "-c", _CHILD, str(manifest), str(workers), str(limit)],
                             check=True, capture_output=True, text=True).stdout
        wall, cpu = time.perf_counter() - t0, children_cpu_s() - c0
        result = json.loads(out.strip().splitlines()[-1])
        done = result["summary"]["done"] + result["summary"]["skipped"]
        result.update(wall_s=wall, cpu_s=cpu, sets=max(done, 1))
        return result


def stage_cpu(data: Path, count: int, objects: int = 1, **extra) -> tuple[dict[str, float], int]:
    """CPU-seconds per image set of each stage, the stages one after the other in this process."""
    from synthcompose.manifest import load_manifest
    from synthcompose.pipeline import Pipeline
    from synthcompose.stages import timing

    totals: dict[str, float] = {}
    real_timed = timing.timed

    @contextmanager
    def charged(timings, stage):
        c0 = cpu_s()
        with real_timed(timings, stage):
            yield
        totals[stage] = totals.get(stage, 0.0) + cpu_s() - c0

    modules = [m for name, m in sys.modules.items() if name.startswith("synthcompose.stages.")]
    with tempfile.TemporaryDirectory() as tmp:
        manifest = load_manifest(manifest_for(data, Path(tmp) / "out", Path(tmp), objects, **extra))
        idents = find_image_sets(data)[:count]
        with Pipeline(manifest) as pipe:
            pipe.process(idents[0])  # warm-up: shaders, the model
            totals.clear()
            for m in modules + [sys.modules["synthcompose.stages.timing"]]:
                if hasattr(m, "timed"):
                    m.timed = charged
            try:
                outcomes = [pipe.process(i) for i in idents[1:]]
            finally:
                for m in modules:
                    if hasattr(m, "timed"):
                        m.timed = real_timed
    n = max(len(outcomes), 1)
    return {k: v / n for k, v in totals.items()}, n


#: the demo's objects before the cast (a roadster, a toy truck, a mannequin, the built-in stop sign)
MODELS = [
    {"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}, "weight": 3},
    {"name": "truck", "model": str(ROOT / "assets/models/kenney_vehicles/vehicle-truck-red.glb"), "class": "truck",
     "size": {"width": 2.5}, "forward": "+z"},
    {"name": "person", "model": str(ROOT / "assets/models/openmaterial_human/human_example.gltf"), "class": "person",
     "size": {"height": 1.75}},
    {"name": "stop sign", "model": "builtin:traffic-sign", "class": "traffic sign", "size": {"height": 2.5}},
]


def compare_cast(name: str, data: Path, count: int, objects: int = 2, repeat: int = 2) -> None:
    """CPU-seconds per image set of the demo's old objects and of the street cast, and of the
    built-in stop sign and the cast's German signs: the same number of objects per set, one
    worker, the batches in turn ``repeat`` times."""
    configs = {"models": {"specs": MODELS}, "street cast": {"specs": [], "cast": "street"},
               "stop sign": {"specs": MODELS[-1:]}, "cast signs": {"specs": [{"model": "cast:traffic sign"}]}}
    runs: dict[str, list[float]] = {label: [] for label in configs}
    for _ in range(repeat):
        for label, extra in configs.items():
            r = run_batch(data, 1, count, objects=objects, **extra)
            runs[label].append(r["cpu_s"] / r["sets"])
    print(f"\n== {name}: the cast's cost, {count} image sets, {objects} objects each, {repeat} runs in turn")
    for label, v in runs.items():
        print(f"  {label:<12} CPU-s per image set " + ", ".join(f"{x:.3f}" for x in v) + f"  (median {median(v):.3f})")
    for new, old in (("street cast", "models"), ("cast signs", "stop sign")):
        print(f"  {new} / {old}: {median(runs[new]) / median(runs[old]):.3f} (target <= 1.15)")


def report(name: str, data: Path, count: int, workers: list[int], scale: list[int]) -> None:
    cores = os.cpu_count() or 1
    codec = codec_cpu(data, count)
    rows = []
    for w in workers:
        r = run_batch(data, w, count)
        per_cpu, per_wall = r["cpu_s"] / r["sets"], r["wall_s"] / r["sets"]
        peak = r["rss_self_mb"] if w == 1 else r["rss_children_mb"]
        rows.append((w, per_cpu, per_wall, per_wall / (per_cpu / cores), peak))
    best = min(rows, key=lambda r: r[2])
    print(f"\n== {name}: {count} image sets, {data}")
    print(f"HEADLINE  CPU-s per image set {rows[0][1]:.3f} = {rows[0][1] / codec:.2f} x the PNG codec's "
          f"{codec:.3f} CPU-s (target <= 1.5)")
    print(f"{'workers':>8}{'CPU-s/set':>11}{'x codec':>9}{'wall s/set':>12}{'wall/(CPU/cores)':>18}{'peak RSS MB':>13}")
    for w, c, wall, busy, peak in rows:
        print(f"{w:>8}{c:>11.3f}{c / codec:>9.2f}{wall:>12.3f}{busy:>18.2f}{peak:>13.0f}")
    print(f"best worker count: {best[0]} (wall {best[2]:.3f} s per set)")
    stages, n = stage_cpu(data, count)
    print(f"CPU-s per image set by stage (one after the other, {n} sets):")
    for stage, v in stages.items():
        print(f"  {stage:<10}{v:>8.3f}")
    print(f"  {'sum':<10}{sum(stages.values()):>8.3f}")
    for size in scale:
        r = run_batch(data, 1, size)
        print(f"scale {size:>4} sets: CPU {r['cpu_s'] / r['sets']:.3f} s/set, wall {r['wall_s'] / r['sets']:.3f} s/set, "
              f"peak RSS {r['rss_self_mb']:.0f} MB")


def car_object(spec: str) -> dict:
    """A manifest object from NAME=PATH@LENGTH[:UP:FORWARD] (glTF axes by default)."""
    name, rest = spec.split("=", 1)
    path, size = rest.rsplit("@", 1)
    length, up, forward = (size.split(":") + ["+y", "+x"])[:3]
    return {"name": name, "model": str((ROOT / path) if not Path(path).is_absolute() else path), "class": "car",
            "size": {"length": float(length)}, "up": up, "forward": forward}


def compare_cars(name: str, data: Path, count: int, cars: list[dict], repeat: int) -> None:
    """The batch's CPU-seconds per set with each car alone, the cars run in turn ``repeat`` times
    (the machine's load drifts alike for all), medians and ratios to the first."""
    import statistics

    runs = {c["name"]: [] for c in cars}
    for _ in range(repeat):
        for car in cars:
            r = run_batch(data, 1, count, cars=[car])
            runs[car["name"]].append(r["cpu_s"] / r["sets"])
    first = statistics.median(runs[cars[0]["name"]])
    print(f"{name}: {count} sets, 1 worker, CPU-s per set (median of {repeat}), ratio to {cars[0]['name']}")
    for car in cars:
        med = statistics.median(runs[car["name"]])
        print(f"  {car['name']:>12}: {med:6.2f} CPU-s per set  x{med / first:.3f}  runs {[round(v, 2) for v in runs[car['name']]]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--workers", default="1,2")
    ap.add_argument("--scale", default="", help="batch sizes for the linearity check, e.g. 10,100")
    ap.add_argument("--real", type=Path, help="a Cityscapes root (real frames) to measure too")
    ap.add_argument("--cast", action="store_true",
                    help="only the cast's cost: the demo's old objects against the street cast (docs/cast.md)")
    ap.add_argument("--cars", default="", help="NAME=PATH@LENGTH[:UP:FORWARD],...: compare what each costs")
    ap.add_argument("--repeat", type=int, default=3, help="--cars: runs of each car, in turn")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    if args.cars:
        cars = [car_object(spec) for spec in args.cars.split(",")]
        compare_cars("generated", dataset(args.count, width, height), args.count, cars, args.repeat)
        if args.real is not None:
            compare_cars("real", args.real, min(args.count, len(find_image_sets(args.real))), cars, args.repeat)
        return 0
    scale = [int(v) for v in args.scale.split(",") if v]
    workers = [int(v) for v in args.workers.split(",")]
    print(f"{platform.node()}: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{datetime.date.today()}; llvmpipe unless a GPU is named by EGL")
    if args.cast:
        if args.real is not None:
            compare_cast("real", args.real, min(args.count, len(find_image_sets(args.real))))
        compare_cast("generated", dataset(args.count, width, height), args.count)
        return 0
    report("generated", dataset(max([args.count] + scale), width, height), args.count, workers, scale)
    if args.real is not None:
        report("real", args.real, min(args.count, len(find_image_sets(args.real))), workers, [])
    return 0


if __name__ == "__main__":
    sys.exit(main())
