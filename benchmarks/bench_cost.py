"""Cost per image set in CPU-seconds (all threads, user + system), next to the PNG codec's own.

    python benchmarks/bench_cost.py [--count 12] [--size 2048x1024] [--workers 1] [--scale 12,100]
                                    [--no-right] [--street] [--real /path/to/cityscapes ...] [--cast]
                                    [--baseline /path/to/a/checkout/of/main]

In one run, on generated image sets that measure like real ones (with right photos; cached
under out/bench/; one car each, or with --street the demo's street cast, 2 objects each) and,
with --real, on real Cityscapes roots:

* the codec: decoding each image set's input PNGs (the right photo too when the right view is
  on) and encoding its outputs (the 5 left ones, and the right photo) on one thread with OpenCV
  at zlib level 1, run-length strategy and libpng's own choice of row filter (the settings the
  writer had when the cost issue was filed: a fixed yardstick), CPU-seconds per set;
* the whole batch (`synthcompose batch` in a child process, fresh output root, the right view
  on unless --no-right): CPU-seconds per set of the child and its workers and their ratio to
  the codec's - the headline - with the batch's start-up (imports, GL context, shaders, model)
  removed by a 1-set batch of the same manifest, and with it;
* per stage, CPU-seconds per set: the stages one after the other in this process
  (``Pipeline.process``, OpenCV's own functions on one thread as in the batch's stream), each
  charged the process's CPU (every thread: llvmpipe's too) spent while it ran; the GL passes
  (``Renderer.render``, ``Composer.compose_roi``, reading and releasing passes) apart, for the
  left view and the right view (stage ``right``); "CPU side" is every stage less its GL passes
  (read, geometry, placement, light, camera match, tones, annotations, polygons, write);
* for each worker count: wall time per set, wall against CPU / cores, peak RSS per worker;
* with --scale, CPU per set and peak RSS for each batch size (flat per set: no growth);
* with --baseline, all of that for another checkout's code too (e.g. ``git worktree add <dir>
  main``), each of its batches right after this checkout's (the machine's load alike for both).
* with --cars, instead of all that: the batch's CPU-seconds per set with each of the cars named
  (one object per set, the same sets and seed), run in turn --repeat times, medians, and their
  ratio to the first car's: what a model costs against another, e.g.
  ``--cars current=assets/models/openmaterial_car/vehicle_example.gltf@4.4:+y:+x,
  audi=assets/cast/vehicles/chrono-audi/audi.glb@4.88`` (one argument)

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
from pathlib import Path
from statistics import median

import cv2

ROOT = Path(__file__).resolve().parent.parent
#: the code measured: this checkout, or (--baseline's children) the checkout named by the variable
CODE = Path(os.environ.get("SYNTHCOMPOSE_BENCH_CODE", ROOT))
sys.path.insert(0, str(CODE))

from synthcompose.io.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402
from synthcompose.synthetic import make_sample  # noqa: E402

CAR = str(ROOT / "assets/models/openmaterial_car/vehicle_example.gltf")
#: the codec the costs are measured against: OpenCV's PNG at zlib level 1, run-length matches,
#: libpng's row filter chosen per row (what the writer used when the cost targets were set)
CODEC = [cv2.IMWRITE_PNG_COMPRESSION, 1, cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_RLE]


def cpu_s() -> float:
    """CPU-seconds of this process, every thread, user + system."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def dataset(count: int, width: int, height: int, right: bool = False) -> Path:
    """``count`` generated image sets (seed 123) at ``width`` x ``height``, with right photos when
    ``right``: the first of a larger set already made, or made now under out/bench/."""
    tag = "-stereo" if right else ""
    found = (ROOT / "out" / "bench").glob(f"cityscapes-{width}x{height}-*")
    made = sorted((int(p.name.split("-")[2]), p) for p in found
                  if p.name.endswith(f"-{p.name.split('-')[2]}{tag}") and (p / ".complete").exists())
    for n, path in made:
        if n >= count:
            return path
    data = ROOT / "out" / "bench" / f"cityscapes-{width}x{height}-{count}{tag}"
    if not (data / ".complete").exists():
        print(f"generating {count} image sets at {width}x{height} in {data} ...", flush=True)
        make_sample(data, count=count, width=width, height=height, seed=123, right=right)
        (data / ".complete").touch()
    return data


def codec_cpu(root: Path, count: int, right: bool = False) -> float:
    """CPU-seconds per image set to decode its input PNGs and encode its outputs (:data:`CODEC`),
    one thread; ``right``: the right photo too, read and written."""
    cv2.setNumThreads(0)
    try:
        idents = find_image_sets(root)[:count]
        t0 = cpu_s()
        for ident in idents:
            s = read_image_set(root, ident, right=right)
            images = [cv2.cvtColor(s.rgb, cv2.COLOR_RGB2BGR), s.label_ids, s.instance_ids.astype("uint16"),
                      cv2.cvtColor(colorize(s.label_ids), cv2.COLOR_RGBA2BGRA), s.disparity]
            if s.right_rgb is not None:
                images.append(cv2.cvtColor(s.right_rgb, cv2.COLOR_RGB2BGR))
            for img in images:
                cv2.imencode(".png", img, CODEC)
        return (cpu_s() - t0) / len(idents)
    finally:
        cv2.setNumThreads(-1)


def manifest_for(data: Path, out: Path, folder: Path, objects: int = 1, specs: list | None = None,
                 cars: list[dict] | None = None, **extra) -> Path:
    """A manifest of one car per set (``objects``; ``specs``: other manifest objects, [] none:
    a ``cast`` in ``extra``; ``cars``: the same as ``specs``, the cars to compare) over ``data``;
    the left view alone unless ``extra`` says otherwise (``render={"right_view": True}``)."""
    extra = {"render": {"right_view": False}} | extra
    path = folder / "bench.json"
    splits = sorted({i.split for i in find_image_sets(data)})
    specs = cars or specs
    specs = [{"name": "car", "model": CAR, "class": "car", "size": {"length": 4.4}}] if specs is None else specs
    path.write_text(json.dumps({
        "dataset": str(Path(data).resolve()), "output": str(out), "seed": 1, "splits": splits,
        "objects_per_image": objects}
        | ({"objects": specs} if specs else {}) | extra))
    return path


# the child runs the batch and reports peak RSS of itself and of its worker processes
_CHILD = """
import json, resource, sys
from dataclasses import replace
from synthcompose.run.batch import run_batch
from synthcompose.manifest import load_manifest
m = load_manifest(sys.argv[1]); workers = int(sys.argv[2]); limit = int(sys.argv[3])
if limit: m = replace(m, limit=limit)
s = run_batch(m, workers=workers, progress=False)
me = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(json.dumps({"summary": s.to_dict(), "rss_self_mb": me / 1024, "rss_children_mb": kids / 1024}))
"""


def python_of(code: Path | None) -> str:
    """The interpreter that runs ``code``: another checkout's own virtual environment (its
    package installed from it, shaders included: a package path alone would load this one's)."""
    if code is None:
        return sys.executable
    python = code / ".venv" / "bin" / "python"
    if not python.exists():
        raise SystemExit(f"--baseline {code}: no .venv/bin/python there (python3 -m venv .venv && "
                         f".venv/bin/pip install -e . in that checkout)")
    return str(python)


def code_env(code: Path | None) -> dict | None:
    """The environment of a child that runs ``code`` (another checkout) instead of this one."""
    return None if code is None else os.environ | {"SYNTHCOMPOSE_BENCH_CODE": str(code)}


def run_batch(data: Path, workers: int, limit: int, keep: Path | None = None, code: Path | None = None,
              **extra) -> dict:
    """One `synthcompose batch` in a child process: wall, CPU of the child and its workers, RSS.
    ``keep``: the output root to write (and keep); ``code``: another checkout to run (--baseline);
    ``extra``: manifest fields."""
    with tempfile.TemporaryDirectory() as tmp:
        manifest = manifest_for(data, keep or Path(tmp) / "out", Path(tmp), **extra)
        c0, t0 = children_cpu_s(), time.perf_counter()
        out = subprocess.run([python_of(code), "-c", _CHILD, str(manifest), str(workers), str(limit)],
                             check=True, capture_output=True, text=True, cwd=code, env=code_env(code)).stdout
        wall, cpu = time.perf_counter() - t0, children_cpu_s() - c0
        result = json.loads(out.strip().splitlines()[-1])
        done = result["summary"]["done"] + result["summary"]["skipped"]
        if result["summary"]["failed"]:  # a failed set is not charged: say so, it changes the figures
            print(f"  ({code or 'this'}: {result['summary']['failed']} of {limit} image sets failed: "
                  f"{result['summary']['problems'][:2]})", flush=True)
        result.update(wall_s=wall, cpu_s=cpu, sets=max(done, 1))
        result["peak_mb"] = result["rss_self_mb"] if workers == 1 else result["rss_children_mb"]
        return result


#: the GL passes: (owner module, class, method) whose CPU is charged to "gl" (see stage_cpu)
_GL_CALLS = (("synthcompose.render.renderer", "Renderer", "render"),
             ("synthcompose.render.renderer", "Renderer", "release"),
             ("synthcompose.compose", "Composer", "compose_roi"),
             ("synthcompose.render.values", "RenderPasses", "read"))


def _as_the_batch_threads():
    """The threads the batch's stream runs its stages on (OpenCV's own on one), where the code
    measured sets them (an older checkout: as it is)."""
    from contextlib import nullcontext

    from synthcompose.run import pipeline
    return getattr(pipeline, "opencv_on_one_thread", nullcontext)()


def stage_cpu(data: Path, count: int, objects: int = 1, **extra) -> tuple[dict[str, float], int]:
    """CPU-seconds per image set of each stage, the stages one after the other in this process;
    with "gl <stage>": the CPU of the GL passes within each stage (render and compose for the
    left view in "render" and "compose", the right view's in "right")."""
    import importlib

    from synthcompose.manifest import load_manifest
    from synthcompose.run.pipeline import Pipeline
    from synthcompose.stages import timing

    totals: dict[str, float] = {}
    state = {"stage": None, "depth": 0}
    real_timed = timing.timed

    @contextmanager
    def charged(timings, stage):
        c0, outer = cpu_s(), state["stage"]
        state["stage"] = stage
        try:
            with real_timed(timings, stage):
                yield
        finally:
            state["stage"] = outer
            totals[stage] = totals.get(stage, 0.0) + cpu_s() - c0
            if outer is not None:  # a stage timed inside another (none today): not twice
                totals[outer] = totals.get(outer, 0.0) - (cpu_s() - c0)

    def gl_charged(fn):
        def call(*args, **kwargs):
            if state["depth"]:
                return fn(*args, **kwargs)
            state["depth"] += 1
            c0 = cpu_s()
            try:
                return fn(*args, **kwargs)
            finally:
                state["depth"] -= 1
                key = f"gl {state['stage']}"
                totals[key] = totals.get(key, 0.0) + cpu_s() - c0
        return call

    stages = [m for name, m in sys.modules.items() if name.startswith("synthcompose.stages.")]
    originals = []
    with tempfile.TemporaryDirectory() as tmp:
        manifest = load_manifest(manifest_for(data, Path(tmp) / "out", Path(tmp), objects, **extra))
        idents = find_image_sets(data)[:count]
        with Pipeline(manifest) as pipe, _as_the_batch_threads():
            pipe.process(idents[0])  # warm-up: shaders, the model
            totals.clear()
            for m in stages + [sys.modules["synthcompose.stages.timing"]]:
                if hasattr(m, "timed"):
                    originals.append((m, "timed", m.timed))
                    m.timed = charged
            for module, cls, name in _GL_CALLS:
                owner = getattr(importlib.import_module(module), cls)
                originals.append((owner, name, getattr(owner, name)))
                setattr(owner, name, gl_charged(getattr(owner, name)))
            try:
                outcomes = [pipe.process(i) for i in idents[1:]]
            finally:
                for owner, name, value in reversed(originals):
                    setattr(owner, name, value)
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


def stage_table(stages: dict[str, float], codec: float) -> None:
    """The stages, the GL passes and the CPU side, per set and against the codec."""
    gl = {k[3:]: v for k, v in stages.items() if k.startswith("gl ")}
    plain = {k: v for k, v in stages.items() if not k.startswith("gl ")}
    print(f"{'stage':<10}{'CPU-s':>8}{'of it GL':>10}")
    for stage, v in plain.items():
        print(f"  {stage:<8}{v:>8.3f}{gl.get(stage, 0.0):>10.3f}")
    total, gl_all = sum(plain.values()), sum(gl.values())
    left = gl.get("render", 0.0) + gl.get("compose", 0.0)
    right = plain.get("right", 0.0)
    print(f"  {'sum':<8}{total:>8.3f}{gl_all:>10.3f}")
    print(f"RIGHT VIEW  stage 'right' {right:.3f} CPU-s per set (its GL {gl.get('right', 0.0):.3f}); the left view's "
          f"render + compose GL passes {left:.3f}: ratio {right / max(left, 1e-9):.2f} (target <= 1)")
    print(f"CPU SIDE    everything but the GL passes {total - gl_all:.3f} CPU-s per set = "
          f"{(total - gl_all) / codec:.2f} x the codec (target <= 1.5)")


def stages_of(data: Path, count: int, code: Path | None, **view) -> tuple[dict[str, float], int]:
    """:func:`stage_cpu` here, or with ``code`` in a child that runs that checkout's package."""
    if code is None:
        return stage_cpu(data, count, **view)
    args = json.dumps({"data": str(data), "count": count, "view": view})
    out = subprocess.run([python_of(code), str(Path(__file__).resolve()), "--stages-json", args], check=True,
                         capture_output=True, text=True, cwd=code, env=code_env(code)).stdout
    stages, n = json.loads(out.strip().splitlines()[-1])
    return stages, n


def report(name: str, data: Path, count: int, workers: list[int], scale: list[int], right: bool,
           objects: dict | None = None, baseline: Path | None = None, baseline_scale: list[int] = ()) -> None:
    """The headline, the workers, the stages and the scales for one dataset; ``objects``:
    manifest_for's arguments for other objects than one car per set (--street); ``baseline``:
    another checkout measured the same way, each of its batches run right after this one's (of
    the ``scale`` batches, those in ``baseline_scale``)."""
    cores = os.cpu_count() or 1
    codec = codec_cpu(data, count, right)
    view = {"render": {"right_view": right}} | (objects or {})
    codes = {"this": None} | ({"baseline": baseline} if baseline else {})
    what = "the street cast, 2 objects" if objects else "one car"
    print(f"\n== {name}: {count} image sets, {what} each, right view {'on' if right else 'off'}, {data}")
    print(f"codec (decode the inputs, encode the outputs, one thread, level 1): {codec:.3f} CPU-s per set")
    ones = {label: run_batch(data, 1, 1, code=code, **view) for label, code in codes.items()}  # start-up, one set
    rows: dict[str, list] = {label: [] for label in codes}
    for w in workers:
        for label, code in codes.items():
            r = run_batch(data, w, count, code=code, **view)
            per_cpu, per_wall = r["cpu_s"] / r["sets"], r["wall_s"] / r["sets"]
            rows[label].append((w, per_cpu, per_wall, per_wall / (per_cpu / cores), r["peak_mb"], r))
    for label, code in codes.items():
        one, first = ones[label], rows[label][0][5]
        net = (first["cpu_s"] - one["cpu_s"]) / max(first["sets"] - one["sets"], 1)
        print(f"[{label}{' ' + str(code) if code else ''}]")
        print(f"HEADLINE  batch CPU-s per set {net:.3f} = {net / codec:.2f} x the codec (start-up removed by a 1-set "
              f"batch: {one['cpu_s']:.2f} CPU-s, peak RSS {one['peak_mb']:.0f} MB; target <= 3); with it "
              f"{rows[label][0][1]:.3f} = {rows[label][0][1] / codec:.2f} x")
        print(f"{'workers':>8}{'CPU-s/set':>11}{'x codec':>9}{'wall s/set':>12}{'wall/(CPU/cores)':>18}"
              f"{'peak RSS MB':>13}")
        for w, c, wall, busy, peak, _ in rows[label]:
            print(f"{w:>8}{c:>11.3f}{c / codec:>9.2f}{wall:>12.3f}{busy:>18.2f}{peak:>13.0f}")
    for label, code in codes.items():
        stages, n = stages_of(data, count, code, **view)
        print(f"[{label}] CPU-s per image set by stage (one after the other, {n} sets, after one to warm up):")
        stage_table(stages, codec)
    for size in scale:
        for label, code in codes.items():
            if code is not None and size not in baseline_scale:
                continue
            r = run_batch(data, 1, size, code=code, **view)
            print(f"[{label}] scale {r['sets']:>4} sets: CPU {r['cpu_s'] / r['sets']:.3f} s/set "
                  f"({(r['cpu_s'] - ones[label]['cpu_s']) / max(r['sets'] - 1, 1):.3f} without the start-up), "
                  f"wall {r['wall_s'] / r['sets']:.3f} s/set, peak RSS {r['peak_mb']:.0f} MB (target <= 600)",
                  flush=True)


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
        listed = [round(v, 2) for v in runs[car["name"]]]
        print(f"  {car['name']:>12}: {med:6.2f} CPU-s per set  x{med / first:.3f}  runs {listed}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--workers", default="1")
    ap.add_argument("--scale", default="", help="batch sizes for the memory and linearity check, e.g. 12,100")
    ap.add_argument("--no-right", dest="right", action="store_false", help="the left view alone")
    ap.add_argument("--street", action="store_true",
                    help='the demo\'s objects ("cast": "street", 2 a set), not one car')
    ap.add_argument("--real", type=Path, action="append", default=[],
                    help="a Cityscapes root (real frames) to measure too; may be given more than once")
    ap.add_argument("--baseline", type=Path, help="another checkout (e.g. a worktree of main) measured in the same run")
    ap.add_argument("--baseline-scale", help="--scale's batch sizes for the baseline too (default: all of them)")
    ap.add_argument("--stages-json", help=argparse.SUPPRESS)  # --baseline's child: stage_cpu's figures as JSON
    ap.add_argument("--cast", action="store_true",
                    help="only the cast's cost: the demo's old objects against the street cast (docs/cast.md)")
    ap.add_argument("--cars", default="", help="NAME=PATH@LENGTH[:UP:FORWARD],...: compare what each costs")
    ap.add_argument("--repeat", type=int, default=3, help="--cars: runs of each car, in turn")
    args = ap.parse_args()
    if args.stages_json:
        job = json.loads(args.stages_json)
        print(json.dumps(stage_cpu(Path(job["data"]), job["count"], **job["view"])))
        return 0
    width, height = (int(v) for v in args.size.split("x"))
    if args.cars:
        cars = [car_object(spec) for spec in args.cars.split(",")]
        compare_cars("generated", dataset(args.count, width, height), args.count, cars, args.repeat)
        for real in args.real:
            compare_cars(f"real {real}", real, min(args.count, len(find_image_sets(real))), cars, args.repeat)
        return 0
    scale = [int(v) for v in args.scale.split(",") if v]
    workers = [int(v) for v in args.workers.split(",")]
    print(f"{platform.node()}: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{datetime.date.today()}; llvmpipe unless a GPU is named by EGL")
    if args.cast:
        for real in args.real:
            compare_cast(f"real {real}", real, min(args.count, len(find_image_sets(real))))
        compare_cast("generated", dataset(args.count, width, height), args.count)
        return 0
    objects = {"objects": 2, "specs": [], "cast": "street"} if args.street else {}
    baseline = args.baseline.resolve() if args.baseline else None
    for real in args.real:  # real frames first
        report("real", real, min(args.count, len(find_image_sets(real))), workers, [], args.right, objects, baseline)
    baseline_scale = scale if args.baseline_scale is None else [int(v) for v in args.baseline_scale.split(",") if v]
    report("generated", dataset(max([args.count] + scale), width, height, right=True), args.count, workers, scale,
           args.right, objects, baseline, baseline_scale)
    return 0


if __name__ == "__main__":
    sys.exit(main())
