"""The ``compare-lighting`` command: the same placements under a fixed light and under each
photo's estimated light, side by side, with the crops of every inserted object next to the
nearest real object of its class (:func:`synthcompose.look.measures.side_by_side`)."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from synthcompose.io.files import decode_rle, read_png, write_png
from synthcompose.look.measures import side_by_side
from synthcompose.record import ImageSetRecord, Status, read_record
from synthcompose.run.batch import select
from synthcompose.run.pipeline import Pipeline


def _label(img: np.ndarray, text: str) -> np.ndarray:
    """The image with a caption bar on top."""
    h, w = img.shape[:2]
    scale = max(w / 1400.0, 0.45)
    bar = np.full((int(34 * scale) + 8, w, 3), 24, np.uint8)
    cv2.putText(bar, text, (8, bar.shape[0] - int(10 * scale) - 2), cv2.FONT_HERSHEY_SIMPLEX, 0.8 * scale,
                (235, 235, 235), max(1, int(round(1.6 * scale))), cv2.LINE_AA)
    return np.concatenate([bar, img], axis=0)


def _describe(record: ImageSetRecord) -> str:
    lt = record.lighting
    if lt.get("mode") == "estimate":
        if lt.get("sunny"):
            return (f"estimated: sun az {lt['sun_azimuth_deg']:.0f} el {lt['sun_elevation_deg']:.0f} deg, "
                    f"{100 * lt['sun_fraction']:.0f}% sun{', the ground in shadow' if lt.get('ground_shadowed') else ''}, "
                    f"confidence {lt['confidence']:.2f}")
        return f"estimated: no sun (ambient only), confidence {lt['confidence']:.2f}"
    d = lt.get("sun_direction", [0, 0, 1])
    el = math.degrees(math.asin(max(-1.0, min(1.0, d[2]))))
    return f"fixed: sun az {math.degrees(math.atan2(d[1], d[0])):.0f} el {el:.0f} deg"


def compare_lighting(manifest, out_dir, limit: int | None = None) -> list[dict]:
    """For each image set the manifest selects (at most ``limit``): run the pipeline with the
    fixed light (the manifest's, or the default daylight) and with the estimated light - same
    placement, same seed - and write under ``out_dir``:

    * ``<frame>_fixed_vs_estimated.png`` : output with the fixed light | with the estimated light
    * ``<frame>_before_after.png``       : input | output with the estimated light
    * ``<frame>_zoom.png``               : input | fixed | estimated, cropped around the objects
    * ``<frame>_object<k>_side_by_side.png`` : per object, input | output | the nearest real object
      of its class in the frame (:func:`synthcompose.look.measures.side_by_side`; labelled frames)

    The two full outputs go to ``out_dir/fixed`` and ``out_dir/estimated``. Returns one entry
    per image set (its status and the PNGs written).
    """
    out_dir = Path(out_dir).resolve()
    ids, weights, _ = select(manifest)
    ids = ids[:limit] if limit else ids
    sun_keys = ("sun_elevation_deg", "sun_azimuth_deg", "sun_fraction")
    given = manifest.raw.get("lighting", {})
    fixed_raw = {"mode": "fixed", **{k: given[k] for k in sun_keys if k in given}}
    keep = {k: given[k] for k in ("camera_match",) if k in given}
    variants = {
        "fixed": replace(manifest, output=out_dir / "fixed", lighting_mode="fixed",
                         raw={**manifest.raw, "lighting": {**fixed_raw, **keep}}),
        "estimated": replace(manifest, output=out_dir / "estimated", lighting_mode="estimate",
                             raw={**manifest.raw, "lighting": {"mode": "estimate", **keep}}),
    }
    for name, m in variants.items():
        with Pipeline(m, weights) as pipe:
            for ident in ids:
                pipe.process(ident)
    results = []
    for ident in ids:
        entry: dict = {"image_set": ident.key, "written": []}
        records = {name: ident.path(m.output, "record") for name, m in variants.items()}
        if not all(p.is_file() for p in records.values()):
            entry["status"] = Status.FAILED
            results.append(entry)
            continue
        rec = {name: read_record(p) for name, p in records.items()}
        entry["status"] = rec["estimated"].status
        if entry["status"] != Status.DONE:
            results.append(entry)
            continue
        src = read_png(ident.path(manifest.dataset, "rgb"), "rgb8")
        out = {name: read_png(ident.path(m.output, "rgb"), "rgb8") for name, m in variants.items()}
        name = ident.key.replace("/", "_")
        pairs = {
            "fixed_vs_estimated": (_label(out["fixed"], "fixed light - " + _describe(rec["fixed"])),
                                   _label(out["estimated"], _describe(rec["estimated"]))),
            "before_after": (_label(src, "input"), _label(out["estimated"], "output, " + _describe(rec["estimated"]))),
        }
        changed = np.any(out["estimated"] != src, axis=2) | np.any(out["fixed"] != src, axis=2)
        ys, xs = np.nonzero(changed)
        if len(xs):
            h, w = src.shape[:2]
            pad = 40
            x0, x1 = max(int(xs.min()) - pad, 0), min(int(xs.max()) + pad + 1, w)
            y0, y1 = max(int(ys.min()) - pad, 0), min(int(ys.max()) + pad + 1, h)
            zoom = 2 if (x1 - x0) < w / 3 else 1
            crop = [cv2.resize(a[y0:y1, x0:x1], None, fx=zoom, fy=zoom, interpolation=cv2.INTER_NEAREST)
                    for a in (src, out["fixed"], out["estimated"])]
            pairs["zoom"] = tuple(_label(c, t) for c, t in zip(crop, ("input", "fixed", "estimated")))
        for kind, imgs in pairs.items():
            path = out_dir / f"{name}_{kind}.png"
            gap = np.full((imgs[0].shape[0], 6, 3), 255, np.uint8)
            row = [imgs[0]]
            for img in imgs[1:]:
                row += [gap, img]
            write_png(path, np.concatenate(row, axis=1))
            entry["written"].append(str(path))
        # per object: input | output | the nearest real object of its class (labelled frames)
        real_ids = read_png(ident.path(manifest.dataset, "instanceIds"), "gray16").astype(np.int32) \
            if ident.path(manifest.dataset, "instanceIds").is_file() else None
        for obj in rec["estimated"].objects:
            rle = obj.mask_rle
            if not rle:
                continue
            mask = decode_rle(rle)
            if not mask.any():
                continue
            path = out_dir / f"{name}_object{obj.index}_side_by_side.png"
            write_png(path, side_by_side(src, out["estimated"], mask, real_ids, obj.label_id))
            entry["written"].append(str(path))
        entry["lighting"] = dict(rec["estimated"].lighting)
        results.append(entry)
    return results
