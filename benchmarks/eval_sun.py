"""The sun and the ground contact on any Cityscapes root (real frames first): one batch per seed
with the bundled manifest's objects (cars weighed up), estimated light and camera match, then

* per frame: sunny or not (the estimate) against a labels file (``sunny`` / ``overcast`` by
  eye; frames not listed are ambiguous), the metres of shadow edge the ground plan shows (the
  estimate's own margin: 2 m decide), and on frames called sunny the angle between the inserted
  shadows and the real ones: the real shadows' orientation is the strongest direction of the
  shadow edges on the input's ground plan (lighting.plansun); an inserted object's cast shadow
  is what the sun darkens: the frames called sunny are rendered a second time, the same objects
  and light but the sun's share given to the sky (its occlusion shadow alone); the ground darker
  than that render is the cast shadow, whose direction (and length) is the box shadow that
  matches it best (shadowlook.cast_shadow_fit); the angle is taken mod 180 (0-90 degrees). The earlier
  measure, from the footprint to the centre of all the ground the object darkens (occlusion
  included: the ground between it and the camera, whatever the sun; shadowlook.shadow_orientation),
  is counted beside it; and the whole cast shadow's angle (``| whole``): a third batch of those
  frames with the sun over all the real ground (no sun mask), over the sunless twin, so that
  the fit sees the shadow also where the output leaves it out on ground already in a real shadow;
* per inserted car at least 150 px wide: ``under`` (shadowlook.under on the car as annotated,
  the ground 2-8 px under its lowest pixel over 20-40 px under), ``outline`` (straight lines of
  the ratio output / input near it, over its width; every inserted pixel left out, a sign's
  post too) and roughness (look.shadow_blotchiness);
  the same ``under`` for the frame's real cars where labels (or --truth) give them; and the
  outline and roughness of the sky's shadow alone (``sky outline``, ``sky rough``: on frames
  called sunny, measured on the sunless twin, so that the sun shadow's own edges, the caster's
  shape, are left out; elsewhere the same as outline and rough);
* totals last.

    python benchmarks/eval_sun.py ROOT [ROOT ...] [--labels sun-labels.txt] [--seeds 1 2] [--truth LABELLED]
    python benchmarks/eval_sun.py --generated 4 --seeds 1 2       # generated scenes, sunny and overcast

Never commit outputs made from real frames (Cityscapes' licence forbids redistribution).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from eval_look import GROUND, write_manifest  # noqa: E402
from eval_real import done_outputs  # noqa: E402

from evaluation import shadowlook  # noqa: E402
from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.io.dataset import find_image_sets, labelled_twin, read_image_set  # noqa: E402
from synthcompose.io.files import decode_rle  # noqa: E402
from synthcompose.labels import label_id  # noqa: E402
from synthcompose.lighting import plansun  # noqa: E402
from synthcompose.lighting.light import LightEstimate  # noqa: E402
from synthcompose.lighting.plan import completed_labels  # noqa: E402
from synthcompose.look import measures as look  # noqa: E402
from synthcompose.manifest import load_manifest  # noqa: E402
from synthcompose.placement.rules import box_corners  # noqa: E402
from synthcompose.placement.surfaces import frame_for  # noqa: E402
from synthcompose.run.batch import run_batch  # noqa: E402

CAR = label_id("car")
MIN_WIDTH = 150  # pixels: the cars the under and outline figures are taken on
ANGLE_OK = 15.0  # degrees
#: a cast-shadow fit whose box shadow explains the dark ground at least this well (IoU)
BOX_FIT_OK = 0.5


def _frame_key(name: str) -> str:
    return "_".join(name.split("_")[:2])


def _called_sunny(record: Path) -> bool:
    """A done image set's record says its photo was called sunny."""
    if not record.is_file():
        return False
    rec = json.loads(record.read_text())
    return rec.get("status") == "done" and bool(rec.get("lighting", {}).get("sunny"))


def twin_batch(manifest: Path, out: Path, frames: list[str], owner, name: str, make) -> None:
    """The batch of ``manifest`` on ``frames`` again into ``out``, in this process, with
    ``owner.name`` replaced by ``make(original)`` while it runs (put back after)."""
    original = getattr(owner, name)
    m = replace(load_manifest(manifest), output=out, frames=tuple(frames))
    setattr(owner, name, make(original))
    try:
        run_batch(m, workers=1, progress=False, resume=False)
    finally:
        setattr(owner, name, original)


def sunless_batch(manifest: Path, out: Path, frames: list[str]) -> None:
    """:func:`twin_batch` with each photo's light estimated as before but the sun's share given
    to the sky: the same objects, poses and camera match, their occlusion shadow without the
    sun's cast shadow."""
    import importlib

    prepare = importlib.import_module("synthcompose.stages.prepare")  # the module (the package exports a function)

    def sunless(estimate):
        return lambda *args, **kwargs: replace(estimate(*args, **kwargs), sunny=False, sun_fraction=0.0)

    twin_batch(manifest, out, frames, prepare, "estimate_lighting", sunless)


def open_sun_batch(manifest: Path, out: Path, frames: list[str]) -> None:
    """:func:`twin_batch` with the sun reaching all the real ground (no sun mask): each object's
    whole cast shadow, also where the output leaves it out because the ground there lies in a
    real shadow already (a tree's, a house's). Over the sunless twin it gives the direction the
    object throws its shadow in, seen on as much ground as the photo shows, not only on the
    sunlit patches of a dappled road."""

    def everywhere(sun_mask):
        def mask_everywhere(self, rgb, label_ids):
            mask = sun_mask(self, rgb, label_ids)
            return None if mask is None else np.ones_like(mask)
        return mask_everywhere

    twin_batch(manifest, out, frames, LightEstimate, "sun_mask", everywhere)


def measure(root: Path, out: Path, labels: dict[str, str], truth: Path | None,
            sunless: Path | None = None, open_sun: Path | None = None) -> tuple[list, list, list]:
    """(frames, inserted cars, real cars) of one batch's outputs under ``out``; ``sunless``: the
    output root of :func:`sunless_batch` for its frames called sunny; ``open_sun``: that of
    :func:`open_sun_batch`."""
    frames, cars, real = [], [], []
    for ident, rec, src, res in done_outputs(root, out):
        depth = disparity_to_depth(src.disparity, src.camera)
        frame, _ = frame_for(src, depth)
        lab = frame.label_ids if frame.labelled else completed_labels(frame.label_ids, depth, src.camera)
        ground = np.isin(lab, GROUND)
        light = rec.get("lighting", {})
        sunny = bool(light.get("sunny"))
        plan_cue = light.get("cues", {}).get("plan", {})
        ps, plan, _ = plansun.measure(src.rgb, lab, depth, src.camera, frame.labelled)
        real_dir = ps.azimuths[0][0] if ps.azimuths else None
        masks = [shadowlook.annotated(decode_rle(o["mask_rle"])) for o in rec["objects"]]
        objects = np.zeros(ground.shape, bool)
        for m in masks:
            objects |= m
        # every inserted pixel, a sign's post too (labelled pole, apart from its plate's instance):
        # where the output's labels differ from the input's (nothing but inserted objects where the
        # input has none)
        inserted = objects | (res.label_ids != (src.label_ids if src.labelled else 0))
        objects = inserted.copy()
        twin = labelled_twin(truth, ident) if truth is not None and not src.labelled else None
        ref = read_image_set(truth, twin) if twin is not None else (src if src.labelled else None)
        if ref is not None:
            objects |= ref.instance_ids >= 1000
        outlines = shadowlook.outline(src.rgb, res.rgb, masks, inserted)
        twin = None
        if sunny and real_dir is not None and sunless is not None and ident.path(sunless, "record").is_file():
            twin = read_image_set(sunless, ident)
        # each footprint where the plan sees it (a footway's objects stand over the road plane)
        # (the box's base corners: every other one of box_corners)
        feet = [shadowlook.on_plan(box_corners(np.array(o["pose"]["vehicle"]["matrix"]), o["extents_m"])[0::2],
                                   plan, src.camera) for o in rec["objects"]]
        fits = shadowlook.cast_shadow_fit(twin.rgb, res.rgb, masks, feet, plan) if twin is not None else None
        # the whole cast shadow: the sun over all the real ground, over the sunless twin
        whole = None
        if twin is not None and open_sun is not None and ident.path(open_sun, "record").is_file():
            whole = shadowlook.cast_shadow_fit(twin.rgb, read_image_set(open_sun, ident).rgb, masks, feet, plan)
        # the sky's shadow alone (the sunless twin where the frame is sunny): the receiver's own
        # outline and blotches, without the sun shadow's edges (the caster's shape)
        sky_out = res.rgb if twin is None else twin.rgb
        sky_outlines = outlines if twin is None else shadowlook.outline(src.rgb, twin.rgb, masks, inserted)
        angles, angles_all, angles_whole, whole_fits = [], [], [], []
        for k, (obj, m, line, sky_line) in enumerate(zip(rec["objects"], masks, outlines, sky_outlines)):
            angle = None
            if sunny and real_dir is not None:
                foot = shadowlook.on_plan(np.array([obj["pose"]["vehicle"]["position_m"]]), plan, src.camera)[0]
                d = shadowlook.shadow_orientation(src.rgb, res.rgb, m, foot, (plan.u, plan.v), plan.xy)
                if d is not None:
                    angles_all.append(shadowlook.axis_angle(d, real_dir))
            if fits is not None:
                angle = None if fits[k] is None else shadowlook.axis_angle(fits[k][0], real_dir)
                if angle is not None:
                    angles.append(angle)
            if whole is not None and whole[k] is not None:
                angles_whole.append(shadowlook.axis_angle(whole[k][0], real_dir))
                whole_fits.append({"class": obj.get("class"), "angle": angles_whole[-1], "iou": whole[k][2]})
            ys, xs = np.nonzero(m)
            width = int(xs.max() - xs.min() + 1) if len(xs) else 0
            if obj["label_id"] != CAR or width < MIN_WIDTH:
                continue
            vis = decode_rle(obj["mask_rle"])
            cars.append({"frame": ident.name, "distance": obj["distance_m"], "width": width,
                         "under": shadowlook.under(res.rgb, m, ground & ~(objects & ~m), objects),
                         "edge": shadowlook.under_edge(res.rgb, m, ground & ~(objects & ~m), objects),
                         "outline": line, "rough": look.shadow_blotchiness(src.rgb, res.rgb, vis, objects),
                         "angle": angle, "sunny": sunny, "sky_outline": sky_line,
                         "sky_rough": look.shadow_blotchiness(src.rgb, sky_out, vis, objects)})
        if ref is not None:
            for inst in np.unique(ref.instance_ids[ref.instance_ids // 1000 == CAR]):
                m = ref.instance_ids == inst
                xs = np.nonzero(m.any(axis=0))[0]
                if xs.max() - xs.min() + 1 >= MIN_WIDTH:
                    z = depth[m & np.isfinite(depth)]
                    real.append({"frame": ident.name, "under": shadowlook.under(src.rgb, m, ground, objects),
                                 "edge": shadowlook.under_edge(src.rgb, m, ground, objects),
                                 "distance": float(np.median(z)) if len(z) else None})
        frames.append({"frame": ident.name, "label": labels.get(_frame_key(ident.name), "?"), "sunny": sunny,
                       "edge_m": plan_cue.get("edge_length_m"), "azimuth": light.get("sun_azimuth_deg"),
                       "elevation": light.get("sun_elevation_deg"), "real_dir": real_dir,
                       "angles": angles, "angles_all": angles_all, "angles_whole": angles_whole,
                       "whole_fits": whole_fits})
    return frames, cars, real


def _sun_off(f: dict) -> float | None:
    """Degrees (0-90) between the estimated sun's azimuth, the axis along which every inserted
    object's shadow is thrown on level ground, and the real shadows' axis on the input's ground
    plan, on a frame called sunny that shows real shadows; None elsewhere."""
    if not f["sunny"] or f["real_dir"] is None or f["azimuth"] is None:
        return None
    return shadowlook.axis_angle(f["azimuth"], f["real_dir"])


def report(title: str, frames: list, cars: list, real: list) -> dict:
    print(f"\n== {title}")
    print(f"{'frame':<28} {'label':<9} {'called':<7} {'edges m':>7} {'sun az/el':>11} {'real dir':>8} {'sun off':>7}"
          "  angles | whole")
    seen = {}
    for f in frames:  # one line per frame (the first seed's light: the estimate is the photo's)
        seen.setdefault(f["frame"], f)
    for f in sorted(seen.values(), key=lambda f: f["frame"]):
        ang = [a for g in frames if g["frame"] == f["frame"] for a in g["angles"]]
        whole = [a for g in frames if g["frame"] == f["frame"] for a in g.get("angles_whole", [])]
        mark = "" if f["label"] == "?" else ("ok" if (f["label"] == "sunny") == f["sunny"] else "MISS")
        print(f"{f['frame']:<28} {f['label']:<9} {('sunny' if f['sunny'] else 'no'):<7} {f['edge_m'] or 0:7.2f} "
              f"{f['azimuth']:5.0f}/{f['elevation']:<5.0f} "
              f"{f['real_dir'] if f['real_dir'] is not None else float('nan'):8.0f} "
              f"{off if (off := _sun_off(f)) is not None else float('nan'):7.0f}  "
              f"{' '.join(f'{a:.0f}' for a in ang)}{' | whole ' if whole else ''}{' '.join(f'{a:.0f}' for a in whole)} {mark}")
    print(f"\n{'car (>= 150 px)':<28} {'dist':>5} {'width':>5} {'under':>6} {'edge':>6} {'outline':>7} {'rough':>6}"
          f" {'angle':>6} {'sky outline':>11} {'sky rough':>9}")
    fmt = lambda v, p=2: "   -" if v is None else f"{v:.{p}f}"  # noqa: E731
    for c in cars:
        print(f"{c['frame']:<28} {c['distance']:5.1f} {c['width']:5d} {fmt(c['under']):>6} {fmt(c.get('edge'), 3):>6} "
              f"{fmt(c['outline']):>7} "
              f"{fmt(c['rough']):>6} {fmt(c['angle'], 0):>6} {fmt(c.get('sky_outline')):>11} {fmt(c.get('sky_rough')):>9}")
    if real:
        print(f"\n{'real car (>= 150 px)':<28} {'dist':>5} {'under':>6} {'edge':>6}")
        for r in real:
            print(f"{r['frame']:<28} {fmt(r.get('distance'), 1):>5} {fmt(r['under']):>6} {fmt(r.get('edge'), 3):>6}")
    sunny_l = [f for f in seen.values() if f["label"] == "sunny"]
    over_l = [f for f in seen.values() if f["label"] == "overcast"]
    angles = [a for f in frames if f["sunny"] for a in f["angles"]]
    angles_all = [a for f in frames if f["sunny"] for a in f.get("angles_all", [])]
    whole = [a for f in frames if f["sunny"] for a in f.get("angles_whole", [])]
    whole_l = [a for f in frames if f["sunny"] and f["label"] == "sunny" for a in f.get("angles_whole", [])]
    outl_dull = [c["outline"] for c in cars if c["outline"] is not None and not c["sunny"]]
    unders = [c["under"] for c in cars if c["under"] is not None]
    real_u = [r["under"] for r in real if r["under"] is not None]
    outl = [c["outline"] for c in cars if c["outline"] is not None]
    rough = [c["rough"] for c in cars if c["rough"] is not None]
    sky_outl = [c["sky_outline"] for c in cars if c.get("sky_outline") is not None]
    sky_rough = [c["sky_rough"] for c in cars if c.get("sky_rough") is not None]
    # the axis every inserted shadow is thrown along on level ground (the estimated sun's
    # azimuth) against the real shadows' axis, on the frames called sunny that show one
    offs = [(_sun_off(f), f["label"]) for f in seen.values() if _sun_off(f) is not None]
    out = {
        "sun_axis_within_15_of_real_shadows": f"{sum(a <= ANGLE_OK for a, _ in offs)}/{len(offs)}",
        "sun_axis_within_15_on_frames_labelled_sunny":
            f"{sum(a <= ANGLE_OK for a, lab in offs if lab == 'sunny')}/{sum(lab == 'sunny' for _, lab in offs)}",
        "sun_axis_off_max": max((a for a, _ in offs), default=None),
        "sunny_called_sunny": f"{sum(f['sunny'] for f in sunny_l)}/{len(sunny_l)}",
        "overcast_called_sunny": f"{sum(f['sunny'] for f in over_l)}/{len(over_l)}",
        "angles_within_15": f"{sum(a <= ANGLE_OK for a in angles)}/{len(angles)}",
        "angle_median": float(np.median(angles)) if angles else None,
        "angles_within_15_all_darkening": f"{sum(a <= ANGLE_OK for a in angles_all)}/{len(angles_all)}",
        "angles_within_15_whole_cast_shadow": f"{sum(a <= ANGLE_OK for a in whole)}/{len(whole)}",
        "whole_cast_shadow_median": float(np.median(whole)) if whole else None,
        "angles_within_15_whole_on_frames_labelled_sunny": f"{sum(a <= ANGLE_OK for a in whole_l)}/{len(whole_l)}",
        **_whole_by_kind(frames),
        "under_inserted": _summary(unders), "under_real": _summary(real_u),
        "edge_inserted": _summary([c["edge"] for c in cars if c.get("edge") is not None]),
        "edge_real": _summary([r["edge"] for r in real if r.get("edge") is not None]),
        "outline_over_0.2": f"{sum(v > 0.2 for v in outl)}/{len(outl)}",
        "outline_over_0.2_frames_not_called_sunny": f"{sum(v > 0.2 for v in outl_dull)}/{len(outl_dull)}",
        "rough_le_0.3": f"{sum(v <= 0.3 for v in rough)}/{len(rough)}",
        "sky_shadow_outline_over_0.2": f"{sum(v > 0.2 for v in sky_outl)}/{len(sky_outl)}",
        "sky_shadow_rough_le_0.3": f"{sum(v <= 0.3 for v in sky_rough)}/{len(sky_rough)}",
    }
    print("\ntotals:")
    for k, v in out.items():
        print(f"  {k}: {v}")
    return out


def _whole_by_kind(frames: list) -> dict:
    """The whole cast shadow's angles within ANGLE_OK per kind of object, and for the fits whose
    box shadow explains the dark ground (IoU at least BOX_FIT_OK). A person's or a sign's shadow
    is a thin streak the box of its footprint moved along the sun explains poorly (IoU
    0.04-0.4 on the street frames), often cut by the image's border within a metre of its foot
    or mixed with a neighbour's (the ground is shared out by the nearest footprint): its fitted
    direction says little, where a car's (IoU 0.5-0.9) is sure."""
    fits = [w for f in frames if f["sunny"] for w in f.get("whole_fits", [])]
    kinds = {"cars": ("car", "truck", "bus"), "people": ("person", "rider"),
             "signs": ("traffic sign", "traffic light", "pole")}
    out = {}
    for name, classes in kinds.items():
        a = [w["angle"] for w in fits if w["class"] in classes]
        out[f"angles_within_15_whole_{name}"] = f"{sum(v <= ANGLE_OK for v in a)}/{len(a)}"
    a = [w["angle"] for w in fits if w["iou"] >= BOX_FIT_OK]
    out[f"angles_within_15_whole_box_fit_iou_ge_{BOX_FIT_OK}"] = f"{sum(v <= ANGLE_OK for v in a)}/{len(a)}"
    return out


def _summary(v: list) -> dict | None:
    if not v:
        return None
    return {"n": len(v), "min": round(float(np.min(v)), 3), "median": round(float(np.median(v)), 3),
            "max": round(float(np.max(v)), 3)}


def run(root: Path, base: Path, seeds, objects: int, labels: dict, truth: Path | None, measure_only: bool):
    frames, cars, real = [], [], []
    for seed in seeds:
        out = base / f"out_{seed}"
        if not measure_only:
            base.mkdir(parents=True, exist_ok=True)
            manifest = load_manifest(write_manifest(root, out, objects, seed, 6.0, base))
            run_batch(manifest, workers=1, progress=False, resume=False)
        sunny = [ident.name for ident in find_image_sets(out) if _called_sunny(ident.path(out, "record"))]
        sunless = base / f"out_{seed}_sunless"
        open_sun = base / f"out_{seed}_open_sun"
        if sunny and not measure_only:
            sunless_batch(base / f"look_manifest_{seed}.json", sunless, sunny)
            open_sun_batch(base / f"look_manifest_{seed}.json", open_sun, sunny)
        f, c, r = measure(root, out, labels, truth, sunless if sunless.is_dir() else None,
                          open_sun if open_sun.is_dir() else None)
        frames += f
        cars += c
        real += r if seed == seeds[0] else []
    return frames, cars, real


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("roots", nargs="*", type=Path, help="Cityscapes roots (real frames)")
    ap.add_argument("--labels", type=Path, help="sunny / overcast labels by eye (lines: 'sunny name ...')")
    ap.add_argument("--truth", type=Path, help="labelled root with the same frames (real cars of an unlabelled ROOT)")
    ap.add_argument("--generated", type=int, default=0, help="also N generated scenes, 2048x1024, same run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--objects", type=int, default=4, help="objects asked per image set")
    ap.add_argument("--out", type=Path, help="keep the outputs here (default: temporary)")
    ap.add_argument("--json", type=Path, help="write the totals here")
    ap.add_argument("--measure-only", action="store_true", help="measure the outputs already under --out")
    a = ap.parse_args(argv)
    if not a.roots and not a.generated:
        ap.error("give a ROOT, --generated N, or both")
    labels = shadowlook.read_sun_labels(a.labels) if a.labels else {}
    results = {}
    with tempfile.TemporaryDirectory(prefix="synthcompose-sun-") as tmp:
        base = a.out or Path(tmp)
        frames, cars, real = [], [], []
        for i, root in enumerate(a.roots):
            f, c, r = run(root.resolve(), base / f"real{i}", a.seeds, a.objects, labels, a.truth, a.measure_only)
            frames, cars, real = frames + f, cars + c, real + r
        if a.roots:
            results["real"] = report(f"real: {' '.join(map(str, a.roots))} (seeds {a.seeds})", frames, cars, real)
        if a.generated:
            from synthcompose.synthetic import make_sample

            gen = base / "generated"
            if not a.measure_only:
                make_sample(gen / "cityscapes", count=a.generated, width=2048, height=1024, seed=11)
            gen_labels = {}
            for scene in sorted((gen / "cityscapes").glob("**/*_scene.json")):
                meta = json.loads(scene.read_text())
                if "sunny" in meta:
                    gen_labels[_frame_key(scene.name)] = "sunny" if meta["sunny"] else "overcast"
            f, c, r = run(gen / "cityscapes", gen, a.seeds, a.objects, gen_labels, None, a.measure_only)
            results["generated"] = report(f"generated ({a.generated} scenes, seeds {a.seeds})", f, c, r)
    if a.json:
        a.json.write_text(json.dumps(results, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
