"""The look on real Cityscapes frames (root from SYNTHCOMPOSE_REAL_ROOT, a labelled root; skipped
without it): the light estimate rests on evidence on every frame, and the inserted cars take the
tone of the frame's own cars and stand on its ground (benchmarks/eval_look.py gives the figures)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from synthcompose.cli import main
from synthcompose.geometry.depth import disparity_to_depth
from synthcompose.io.dataset import find_image_sets, read_image_set
from synthcompose.io.files import decode_rle
from synthcompose.lighting import estimate_lighting
from synthcompose.look import measures as look
from synthcompose.placement.surfaces import frame_for

from ..real_root import REAL, needs_real
from ..tolerances import CONTACT_DEPTH_REL, REAL_TONE_IN_RANGE_MIN

pytestmark = needs_real
ASSETS = Path(__file__).resolve().parents[2] / "assets" / "models"
GROUND = (6, 7, 8, 9, 10, 22)


def test_the_light_estimate_has_evidence_on_every_real_frame():
    root = Path(REAL)
    for ident in find_image_sets(root)[:8]:
        s = read_image_set(root, ident)
        frame, _ = frame_for(s)
        est = estimate_lighting(s.rgb, frame.label_ids, disparity_to_depth(s.disparity, s.camera), s.camera)
        assert "ground" in est.evidence and not est.to_dict()["fallback"], ident.key
        assert 0.0 <= est.confidence <= 1.0


def test_inserted_cars_take_the_frames_tone_and_stand_on_its_ground(tmp_path):
    root = Path(REAL)
    idents = find_image_sets(root)[:4]
    manifest = {
        "dataset": str(root), "output": str(tmp_path / "out"), "seed": 3, "objects_per_image": 3,
        "splits": sorted({i.split for i in idents}), "frames": [i.name for i in idents],
        "objects": [{"name": "car", "model": str(ASSETS / "openmaterial_car" / "vehicle_example.gltf"),
                     "class": "car", "size": {"length": 4.4}}],
        "lighting": {"mode": "estimate"},
    }
    (tmp_path / "m.json").write_text(json.dumps(manifest))
    assert main(["batch", str(tmp_path / "m.json"), "--no-progress"]) == 0
    inside, cars, contacts = 0, 0, []
    out = tmp_path / "out"
    for ident in find_image_sets(out):
        rec = json.loads(ident.path(out, "record").read_text())
        if rec.get("status") != "done":
            continue
        src, res = read_image_set(root, ident), read_image_set(out, ident)
        real = look.real_tones(src.rgb, src.instance_ids, 26)
        v = np.quantile([t.brightness for t in real.values()], [0.1, 0.9])
        s = np.quantile([t.saturation for t in real.values()], [0.1, 0.9])
        depth = disparity_to_depth(src.disparity, src.camera)
        out_depth = look.decode_depth(res.disparity, src.camera.fx * src.camera.baseline)
        masks = [decode_rle(o["mask_rle"]) for o in rec["objects"]]
        objects = np.any(masks, axis=0)
        for m in masks:
            if m.sum() >= look.MIN_REAL_PIXELS and len(real) >= 3:
                t = look.tone(res.rgb, m)
                cars += 1
                inside += v[0] <= t.brightness <= v[1] and s[0] <= t.saturation <= s[1]
            c = look.contact_error(depth, out_depth, m, np.isin(src.label_ids, GROUND) & ~objects,
                                   labels=src.label_ids)
            if c is not None:
                contacts.append(abs(c))
    assert cars >= 5 and inside >= REAL_TONE_IN_RANGE_MIN * cars, (inside, cars)
    assert contacts and np.median(contacts) <= CONTACT_DEPTH_REL, contacts
