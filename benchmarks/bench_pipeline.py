"""Per-stage wall time of the pipeline at Cityscapes size, next to the PNG codec floor.

    python benchmarks/bench_pipeline.py [--count N] [--size 2048x1024] [--objects K]

Generates N synthetic image sets (cached under out/bench/), then in one run measures
(a) the codec floor: decoding the inputs and encoding the outputs of the same image sets
with the same settings and nothing else, and (b) the pipeline per image set, split by stage
(after one warm-up image set that compiles shaders and uploads the models).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from synthcompose.dataset import find_image_sets, read_image_set  # noqa: E402
from synthcompose.fileio import encode_png  # noqa: E402
from synthcompose.labels import colorize  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.pipeline import STAGES, Pipeline  # noqa: E402
from synthcompose.sample import make_sample  # noqa: E402


def codec_floor(root: Path, ids) -> float:
    """Mean seconds per image set to decode its 4 input PNGs and encode 5 output PNGs."""
    times = []
    for ident in ids:
        t0 = time.perf_counter()
        s = read_image_set(root, ident)
        for arr in (s.rgb, s.label_ids, s.instance_ids.astype("uint16"), colorize(s.label_ids), s.disparity):
            encode_png(arr)
        times.append(time.perf_counter() - t0)
    return statistics.mean(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=6)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--objects", type=int, default=1, help="objects per image set")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    data = ROOT / "out" / "bench" / f"cityscapes-{width}x{height}-{args.count}"
    if not (data / ".complete").exists():
        print(f"generating {args.count} image sets at {width}x{height} in {data} ...", flush=True)
        make_sample(data, count=args.count, width=width, height=height, seed=123)
        (data / ".complete").touch()
    ids = find_image_sets(data)
    with tempfile.TemporaryDirectory() as tmp:
        manifest_path = Path(tmp) / "bench.json"
        manifest_path.write_text(json.dumps({
            "dataset": str(data), "output": str(Path(tmp) / "out"), "seed": 1, "objects_per_image": args.objects,
            "objects": [{"name": "car", "model": str(ROOT / "assets/models/openmaterial_car/vehicle_example.gltf"),
                         "class": "car", "size": {"length": 4.4}}]}))
        manifest = load_manifest(manifest_path)
        floor = codec_floor(data, ids)
        with Pipeline(manifest) as pipe:
            print(f"GL: {pipe.gl.renderer_name}")
            pipe.process(ids[0])  # warm-up: shaders, model upload
            outcomes = []
            for ident in ids:
                t0 = time.perf_counter()
                o = pipe.process(ident)
                outcomes.append((o, time.perf_counter() - t0))
    done = [(o, t) for o, t in outcomes if o.status == "done"]
    if not done:
        print("no image set was done:", [o.reason for o, _ in outcomes])
        return 1
    print(f"\n{len(done)} image sets at {width}x{height}, {args.objects} object(s) each, one process:\n")
    print(f"{'stage':<12}{'mean ms':>10}{'median ms':>11}")
    for stage in STAGES:
        vals = [o.timings.get(stage, 0.0) * 1000 for o, _ in done]
        print(f"{stage:<12}{statistics.mean(vals):>10.0f}{statistics.median(vals):>11.0f}")
    total = [t * 1000 for _, t in done]
    print(f"{'total':<12}{statistics.mean(total):>10.0f}{statistics.median(total):>11.0f}")
    print(f"\nPNG codec floor (decode 4 inputs + encode 5 outputs): {floor * 1000:.0f} ms per image set")
    print(f"pipeline / codec floor: {statistics.mean(total) / (floor * 1000):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
