"""Helpers shared by the test modules (import them from here, not from another test module)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from synthcompose.camera import Camera

ASSETS = Path(__file__).resolve().parent.parent / "assets" / "models"
#: the files every complete output image set has
OUT_KINDS = ("rgb", "labelIds", "instanceIds", "color", "disparity", "camera", "record")


def write_manifest(path: Path, dataset: Path, output: Path, seed: int = 5, **extra) -> Path:
    """A batch manifest at ``path``: a car model and the built-in sign, two objects per image set;
    ``extra`` replaces or adds top-level fields."""
    manifest = {
        "dataset": str(dataset), "output": str(output), "seed": seed, "objects_per_image": 2,
        "objects": [
            {"name": "car", "model": str(ASSETS / "openmaterial_car" / "vehicle_example.gltf"), "class": "car",
             "size": {"length": 4.4}, "weight": 2},
            {"name": "sign", "model": "builtin:traffic-sign", "class": "traffic sign", "size": {"height": 2.5}},
        ],
    }
    manifest.update(extra)
    path.write_text(json.dumps(manifest))
    return path


def box_manifest(path: Path, dataset: Path, output: Path, **extra) -> Path:
    """A manifest with one built-in box as a car per image set (a 1.8 m cube: as wide as a car, so
    that a lane holds it), placed 5-30 m away (small frames)."""
    return write_manifest(path, dataset, output, **{
        "objects_per_image": 1, "objects": [{"name": "box", "model": "builtin:box", "class": "car",
                                             "size": {"length": 1.8}}],
        "placement": {"distance": [5, 30]}, **extra})


def with_reference_run(tmp_path: Path, manifest=write_manifest, count: int = 6, seed: int = 9, size=(320, 160)):
    """``count`` generated image sets under ``tmp_path/cs``, a complete batch of them in ``ref``
    and a manifest writing to ``out`` for a run to interrupt: (image set ids, manifest, out, ref)."""
    from synthcompose.cli import main
    from synthcompose.synthetic import make_sample

    root = tmp_path / "cs"
    ids = make_sample(root, count=count, width=size[0], height=size[1], seed=seed)
    ref = tmp_path / "ref"
    assert main(["batch", str(manifest(tmp_path / "r.json", root, ref)), "--no-progress"]) == 0
    out = tmp_path / "out"
    return ids, manifest(tmp_path / "m.json", root, out), out, ref


def assert_resume_matches(ids, manifest: Path, out: Path, ref: Path) -> None:
    """A rerun of an interrupted batch completes it, every file byte-identical to the reference."""
    from synthcompose.cli import main

    assert main(["batch", str(manifest), "--no-progress"]) == 0
    for ident in ids:
        for kind in OUT_KINDS:
            assert ident.path(out, kind).read_bytes() == ident.path(ref, kind).read_bytes(), (ident, kind)


def crashing_worker(crash_key: str, *args) -> None:
    """A worker process (``engines.worker_entry``) that dies like a driver crash (SIGSEGV)
    once it has begun the image set ``crash_key``; module-level, so a spawned worker imports it."""
    import os
    import signal

    from synthcompose.run import engines, pipeline

    stream = pipeline.Pipeline.stream

    def crashing_stream(self, items, on_begin=None):
        def begin(ident):
            if on_begin is not None:
                on_begin(ident)
            if ident.key == crash_key:
                os.kill(os.getpid(), signal.SIGSEGV)
        return stream(self, items, on_begin=begin)

    pipeline.Pipeline.stream = crashing_stream
    engines.run_worker(*args)


#: the small frames of the end-to-end tests (pixels)
W, H = 640, 320
#: the sizes the placement tests give a car, a person and a sign (length, width, height, metres)
SIZES = {"car": (4.4, 1.85, 1.48), "person": (0.5, 0.6, 1.75), "traffic sign": (0.2, 0.8, 2.5)}


def make_camera(w=640, h=320, **kw) -> Camera:
    base = dict(fx=700.0, fy=702.0, u0=w / 2 + 11.3, v0=h / 2 - 4.2, baseline=0.21, x=1.7, y=0.1, z=1.22,
                yaw=0.02, pitch=0.04, roll=-0.005, width=w, height=h)
    base.update(kw)
    return Camera(**base)


def drawn_back(objects, shape) -> tuple[np.ndarray, np.ndarray]:
    """labelIds and instanceIds as cityscapesScripts draws them from polygon entries."""
    from cityscapesscripts.helpers.annotation import Annotation
    from cityscapesscripts.preparation.json2instanceImg import createInstanceImage
    from cityscapesscripts.preparation.json2labelImg import createLabelImage

    ann = Annotation()
    ann.fromJsonText(json.dumps({"imgHeight": shape[0], "imgWidth": shape[1], "objects": objects}))
    return np.array(createLabelImage(ann, "ids")), np.array(createInstanceImage(ann, "ids")).astype(np.int64)


def pose_behind_a_pole(scene) -> np.ndarray:
    """(4, 4) pose on the road 3 m behind a pole, across the line of sight (skips without one)."""
    from synthcompose.placement import pose_matrix

    cam = scene.camera
    for pole in scene.poles:
        ray = np.array([pole.x - cam.x, pole.y - cam.y])
        dist = np.hypot(*ray)
        behind = np.array([cam.x, cam.y]) + ray / dist * (dist + 3.0)
        if bool(scene.is_road(behind[0], behind[1])):
            z = float(scene.ground_height(behind[0], behind[1]))
            return pose_matrix(np.array([behind[0], behind[1], z]), np.array([0.0, 0.0, 1.0]),
                               math.atan2(ray[1], ray[0]) + math.pi / 2)
    pytest.skip("no pole in front of the road in this scene")


def street_offset(scene, frame, b: float, a: float = 15.0) -> float:
    """The road-frame offset s (placement/street.py) of a generated scene's street line at b
    (metres across its street), seen ``a`` metres along it."""
    from synthcompose.placement.street import find_street

    x, y = scene.to_vehicle(a, b)
    return float(find_street(frame).to_road(np.array([[float(x), float(y)]]))[1][0])
