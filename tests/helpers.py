"""Helpers shared by the test modules (import them from here, not from another test module)."""
from __future__ import annotations

import json
from pathlib import Path

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
    """A manifest with one built-in box as a car per image set, placed 5-30 m away (small frames)."""
    return write_manifest(path, dataset, output, **{
        "objects_per_image": 1, "objects": [{"name": "box", "model": "builtin:box", "class": "car",
                                             "size": {"length": 4.0}}],
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
