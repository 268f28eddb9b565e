"""The ambient light's colour on generated overcast scenes that measure like real frames (SGM-like
disparity, the camera's look), against the light's colour as that camera records it:

    python benchmarks/eval_ambient.py [--count 20] [--size 2048x1024] [--seed 5]

Prints the chromaticity error per scene (largest relative error of a channel, both colours at
luminance 1), how many were called sunny and how many estimates rest on evidence.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from synthcompose.geometry.depth import disparity_to_depth  # noqa: E402
from synthcompose.lighting import LUM, estimate_lighting  # noqa: E402
from synthcompose.synthetic import SceneLight, random_scene, render_scene  # noqa: E402
from synthcompose.synthetic.photo import recorded_colour  # noqa: E402


def chroma_error(estimated, true) -> float:
    a, b = np.asarray(estimated, float), np.asarray(true, float)
    return float(np.abs((a / (a @ LUM)) / (b / (b @ LUM)) - 1.0).max())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--size", default="2048x1024")
    ap.add_argument("--seed", type=int, default=5)
    a = ap.parse_args(argv)
    w, h = (int(v) for v in a.size.split("x"))
    rng = np.random.default_rng(a.seed)
    errors, sunny, evidence = [], 0, 0
    for k in range(a.count):
        tint = tuple(rng.uniform(0.8, 1.25, 3))
        light = SceneLight(sun_fraction=0.0, sky_tint=tint)
        scene = random_scene(np.random.default_rng(a.seed * 1000 + k), w, h, light=light)
        arrays = render_scene(scene)  # realistic stereo and photo
        est = estimate_lighting(arrays["rgb"], arrays["label_ids"], disparity_to_depth(arrays["disparity"], scene.camera),
                                scene.camera)
        errors.append(chroma_error(est.sky_rgb, recorded_colour(tint, scene.noise_seed)))
        sunny += est.sunny
        evidence += bool(est.evidence)
        print(f"scene {k:3d}: ambient colour error {errors[-1]:.3f}, sunny {est.sunny}, evidence {','.join(est.evidence)}")
    print(f"{a.count} overcast scenes {w}x{h}: ambient colour error median {np.median(errors):.3f}, max "
          f"{np.max(errors):.3f}; called sunny {sunny}; with evidence {evidence}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
