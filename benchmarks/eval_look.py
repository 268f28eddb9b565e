"""The look of inserted objects on any Cityscapes root (real frames first): one batch per seed with
the bundled manifest's objects (cars weighed up), estimated light and camera match, then

* per frame: the light estimate (sun or not, its confidence, the evidence it used);
* per inserted car: median brightness and saturation (HSV 0-255) against the 10th-90th
  percentile range of the real cars' per-car medians in the same frame (labelled roots);
* per object: the shadow's blotchiness in a ring around it (look.shadow_blotchiness: <= 0.3
  reads as a soft shadow) and the contact error at its lowest points (look.contact_error);
* with --out: per object, input | output | nearest real object of its class (look.side_by_side).

    python benchmarks/eval_look.py ROOT [--seeds 1 2 3 4] [--objects 3] [--out DIR]
    python benchmarks/eval_look.py ROOT --generated 4      # generated scenes too, same run

Never commit outputs made from real frames (Cityscapes' licence forbids redistribution).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.io.dataset import labelled_twin, read_image_set  # noqa: E402
from synthcompose.io.files import decode_rle, write_png  # noqa: E402
from synthcompose.labels import label_id  # noqa: E402
from synthcompose.look import measures as look  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.run.batch import run_batch  # noqa: E402

sys.path.insert(0, str(REPO / "benchmarks"))
from eval_real import done_outputs  # noqa: E402
from eval_real import write_manifest as demo_manifest  # noqa: E402

CAR = label_id("car")
GROUND = [label_id(n) for n in ("road", "sidewalk", "parking", "ground", "terrain", "rail track")]


def write_manifest(root: Path, out: Path, objects: int, seed: int, car_weight: float, folder: Path) -> Path:
    """eval_real's manifest (the demo's objects on ``root``), cars weighed up, light estimated."""
    m = json.loads(demo_manifest(root, out, objects, seed, folder).read_text())
    for obj in m["objects"]:
        if obj["class"] == "car":
            obj["weight"] = obj.get("weight", 1.0) * car_weight
    m["lighting"] = {"mode": "estimate", "camera_match": True}
    path = folder / f"look_manifest_{seed}.json"
    path.write_text(json.dumps(m, indent=2))
    return path


def measure(root: Path, out: Path, truth: Path | None, views: Path | None, tag: str) -> dict:
    """Figures of one batch's outputs under ``out`` (inputs under ``root``)."""
    cars, shadows, contacts, lights = [], [], [], []
    for ident, rec, src, res in done_outputs(root, out):
        twin = labelled_twin(truth, ident) if truth is not None and not src.labelled else None
        ref = read_image_set(truth, twin) if twin is not None else (src if src.labelled else None)
        lights.append((ident.key, rec.get("lighting", {})))
        fb = src.camera.fx * src.camera.baseline
        src_depth = disparity_to_depth(src.disparity, src.camera)
        out_depth = look.decode_depth(res.disparity, fb)
        objects = np.zeros(src.label_ids.shape, bool)
        masks = []
        for obj in rec["objects"]:
            rle = obj["mask_rle"]  # the visible mask as annotated (a class without instances
            m = decode_rle(rle)  # shares ids)
            masks.append((obj, m))
            objects |= m
        ground = np.isin((ref.label_ids if ref is not None else src.label_ids), GROUND)
        real = look.real_tones(src.rgb, ref.instance_ids, CAR) if ref is not None else {}
        for k, (obj, m) in enumerate(masks):
            if m.sum() < 50:
                continue
            blot = look.shadow_blotchiness(src.rgb, res.rgb, m, objects)
            contact = look.contact_error(src_depth, out_depth, m, ground & ~objects,
                                         labels=ref.label_ids if ref is not None else None)
            shadows.append((ident.key, obj["name"], blot, obj["distance_m"]))
            contacts.append((ident.key, obj["name"], contact))
            if obj["label_id"] == CAR and m.sum() >= look.MIN_REAL_PIXELS and len(real) >= 3:
                t = look.tone(res.rgb, m)
                v = np.array([r.brightness for r in real.values()])
                s = np.array([r.saturation for r in real.values()])
                vr, sr = np.quantile(v, [0.1, 0.9]), np.quantile(s, [0.1, 0.9])
                cars.append({"image_set": ident.key, "paint": obj.get("appearance", {}).get("paint"),
                             "V": t.brightness, "S": t.saturation, "V_range": vr.tolist(), "S_range": sr.tolist(),
                             "inside": bool(vr[0] <= t.brightness <= vr[1] and sr[0] <= t.saturation <= sr[1])})
            if views is not None:
                views.mkdir(parents=True, exist_ok=True)
                panel = look.side_by_side(src.rgb, res.rgb, m, ref.instance_ids if ref is not None else None,
                                          obj["label_id"])
                write_png(views / f"{tag}_{ident.name}_{k}_{obj['name'].replace(' ', '-')}.png", panel)
    return {"cars": cars, "shadows": shadows, "contacts": contacts, "lights": lights}


def report(label: str, figs: dict) -> dict:
    print(f"\n== {label}")
    seen = {}
    for key, lt in figs["lights"]:
        seen[key] = lt
    for key, lt in sorted(seen.items()):
        cues = lt.get("cues", {})
        print(f"light {key:<44} sunny {lt.get('sunny')!s:<5} confidence {lt.get('confidence', 0):.2f} evidence "
              f"{','.join(lt.get('evidence', [])) or 'NONE'} (ground samples {cues.get('ground_samples', 0)}, "
              f"pairs {cues.get('shading_pairs', 0)})")
    cars = figs["cars"]
    inside = sum(c["inside"] for c in cars)
    for c in cars:
        print(f"car {c['image_set']:<44} {c['paint'] or '-':<10} V {c['V']:5.0f} in [{c['V_range'][0]:.0f}, "
              f"{c['V_range'][1]:.0f}]  S {c['S']:5.0f} in [{c['S_range'][0]:.0f}, {c['S_range'][1]:.0f}]  "
              f"{'ok' if c['inside'] else 'OUT'}")
    blots = [b for _, _, b, _ in figs["shadows"] if b is not None]
    # a shadow thinner than the measure's smoothing (people, anything far: the ground 1 m deep
    # spans f h / z^2 rows, 2 px at 36 m) reads blotchy however smooth it is: also by kind
    near_vehicles = [b for _, n, b, d in figs["shadows"] if b is not None and d < 25 and n in ("car", "truck")]
    contacts = [abs(c) for _, _, c in figs["contacts"] if c is not None]
    result = {
        "cars": len(cars), "cars_inside": inside, "cars_inside_share": inside / len(cars) if cars else None,
        "shadow_blotchiness": {"n": len(blots), "median": float(np.median(blots)) if blots else None,
                               "max": float(np.max(blots)) if blots else None,
                               "le_0.3": int(sum(b <= 0.3 for b in blots))},
        "shadow_blotchiness_vehicles_within_25m": {
            "n": len(near_vehicles), "median": float(np.median(near_vehicles)) if near_vehicles else None,
            "max": float(np.max(near_vehicles)) if near_vehicles else None,
            "le_0.3": int(sum(b <= 0.3 for b in near_vehicles))},
        "contact_error": {"n": len(contacts), "median": float(np.median(contacts)) if contacts else None,
                          "max": float(np.max(contacts)) if contacts else None,
                          "le_0.05": int(sum(c <= 0.05 for c in contacts))},
        "light_evidence": f"{sum(bool(lt.get('evidence')) for lt in seen.values())}/{len(seen)}",
    }
    print(f"cars inside the real cars' 10-90 % range (V and S): {inside}/{len(cars)}")
    print("shadow blotchiness per object:", " ".join(f"{n}@{d:.0f}m:{b:.2f}" for _, n, b, d in figs["shadows"] if b is not None))
    print(f"shadow blotchiness: {result['shadow_blotchiness']}")
    print(f"  cars and trucks within 25 m: {result['shadow_blotchiness_vehicles_within_25m']}")
    print("contact error per object:", " ".join(f"{n}:{c:+.3f}" for _, n, c in figs["contacts"] if c is not None))
    print(f"contact error |real/object - 1|: {result['contact_error']}")
    print(f"light estimate with evidence: {result['light_evidence']}")
    return result


def run(root: Path, base: Path, seeds, objects: int, car_weight: float, truth: Path | None, views: bool,
        tag: str, measure_only: bool = False) -> dict:
    figs = {"cars": [], "shadows": [], "contacts": [], "lights": []}
    for seed in seeds:
        out = base / f"out_{seed}"
        if not measure_only:
            manifest = load_manifest(write_manifest(root, out, objects, seed, car_weight, base))
            run_batch(manifest, workers=1, progress=False, resume=False)
        f = measure(root, out, truth, base / "views" if views else None, f"{tag}_s{seed}")
        for k in figs:
            figs[k] += f[k]
    return report(f"{tag}: {root} (seeds {' '.join(map(str, seeds))})", figs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("root", nargs="?", type=Path, help="Cityscapes root (real frames)")
    ap.add_argument("--truth", type=Path, help="labelled root with the same frames (for an unlabelled ROOT)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated scenes, 2048x1024, same run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--objects", type=int, default=3, help="objects asked per image set")
    ap.add_argument("--car-weight", type=float, default=6.0, help="the car's weight (others 1)")
    ap.add_argument("--out", type=Path, help="keep outputs and side-by-side views here (default: temporary)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    ap.add_argument("--measure-only", action="store_true", help="measure the outputs already under --out")
    a = ap.parse_args(argv)
    if a.root is None and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    results = {}
    with tempfile.TemporaryDirectory(prefix="synthcompose-look-") as tmp:
        base = a.out or Path(tmp)
        if a.root is not None:
            (base / "real").mkdir(parents=True, exist_ok=True)
            results["real"] = run(a.root.resolve(), base / "real", a.seeds, a.objects, a.car_weight, a.truth,
                                  a.out is not None, "real", a.measure_only)
        if a.generated:
            from synthcompose.synthetic import make_sample

            gen = base / "generated"
            if not a.measure_only:
                make_sample(gen / "cityscapes", count=a.generated, width=2048, height=1024, seed=11)
            results["generated"] = run(gen / "cityscapes", gen, a.seeds, a.objects, a.car_weight, None,
                                       a.out is not None, "generated", a.measure_only)
    if a.json:
        a.json.write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
