"""Build the vehicles of the default cast (assets/cast/vehicles/<id>/) from their public sources.

    python scripts/build_vehicles.py --chrono <git dir of projectchrono/chrono> \
        --openmaterial <git dir of LudwigFriedmann/OpenMATERIAL> \
        [--only chrono-audi ...] [--out assets/cast/vehicles] [--debug]

Every source file is read out of a bare git directory at the commit named in
``vehicle_recipes.SOURCES`` (get one with ``git clone --bare``); nothing else is read, so the
same commits give the same GLBs. Each recipe (``vehicle_recipes.RECIPES``) reads its meshes and
textures, sorts every face into a material role (paint, glass, tyre, rim, chrome, plastic,
lights, plate, interior: docs/vehicles.md), deletes brand badges, adds what the source lacks
(wheels at the axle positions its Chrono JSON gives, number plates, a dark interior), and the
result is written as one GLB with ``entry.json``, the licence text and ``SOURCE.txt``.
``--debug`` colours each role flatly instead (to check the sorting by eye).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from vehicle_glb import MATERIALS, write_glb  # noqa: E402
from vehicle_recipes import RECIPES, SOURCES, Build  # noqa: E402
from vehicle_recipes_jme import JME_RECIPES  # noqa: E402

RECIPES.update(JME_RECIPES)

#: flat colours of --debug, per role
DEBUG = {"paint": (0.5, 0.5, 0.5), "glass": (0.0, 0.2, 0.9), "glass_privacy": (0.0, 0.05, 0.4),
         "tyre": (0.02, 0.02, 0.02), "rim": (0.9, 0.9, 0.0), "rim_steel": (0.5, 0.5, 0.0),
         "chrome": (0.0, 0.9, 0.9), "plastic": (0.3, 0.0, 0.3), "rubber": (0.1, 0.0, 0.1),
         "light_red": (1.0, 0.0, 0.0), "light_amber": (1.0, 0.4, 0.0), "light_white": (1.0, 1.0, 1.0),
         "plate": (0.0, 1.0, 0.0), "interior": (0.5, 0.25, 0.0), "underbody": (0.2, 0.2, 0.2),
         "mirror": (0.0, 0.5, 0.5), "textured": (1.0, 0.0, 1.0), "white": (0.9, 0.9, 0.7),
         "livery": (0.9, 0.8, 0.5), "livery_band": (0.3, 0.3, 0.5), "canvas": (0.4, 0.6, 0.4)}


def build(recipe_id: str, gits: dict[str, Path], out_root: Path, debug: bool = False) -> dict:
    recipe = RECIPES[recipe_id]
    build = Build(gits)
    made = recipe.make(build)
    parts, textures = made[0], made[1]
    factors = made[2] if len(made) > 2 else {}
    out = out_root / recipe_id
    out.mkdir(parents=True, exist_ok=True)
    model = out / f"{recipe_id.split('-', 1)[1]}.glb"
    if debug:
        factors = {name: ((*DEBUG[name.split('.')[0]], 1.0), 0.0, 0.8) for name in parts}
        textures = {k: v for k, v in textures.items() if k == "plate"}
    write_glb(model, parts, textures, factors)
    source = SOURCES[recipe.source]
    lines = [recipe.title, "", f"Source: github:{source.repo} at commit {source.commit}",
             "Files read (paths in that repository):"] + [f"  {p}" for p in build.read] + [""]
    lines += ["What was changed (scripts/build_vehicles.py, recipe " + recipe_id + "):"]
    lines += [f"  - {c}" for c in recipe.changes + tuple(build.notes)] + [""]
    lines += [f"Licence: {source.spdx} ({source.licence_note})."]
    (out / "SOURCE.txt").write_text("\n".join(lines) + "\n")
    (out / "LICENSE").write_bytes(build.licence_text(recipe.source))
    tris = int(sum(len(m.faces) for m in parts.values()))
    entry = {"id": recipe_id, "class": recipe.cls, "kind": recipe.kind, "model": model.name,
             "up": "+y", "forward": "+x", "size": {"length": recipe.length}, "weight": recipe.weight,
             "licence": source.spdx, "source": f"github:{source.repo}@{source.commit} {recipe.folder}"}
    (out / "entry.json").write_text(json.dumps(entry, indent=2) + "\n")
    lo = np.min([m.vertices.min(0) for m in parts.values() if len(m.faces)], axis=0)
    hi = np.max([m.vertices.max(0) for m in parts.values() if len(m.faces)], axis=0)
    return {"id": recipe_id, "triangles": tris, "bytes": model.stat().st_size,
            "extent": [round(float(v), 3) for v in hi - lo], "materials": sorted(parts)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for name in SOURCES:
        ap.add_argument(f"--{name}", type=Path, help=f"bare git directory of github:{SOURCES[name].repo}")
    ap.add_argument("--only", nargs="*", default=None, help="recipe ids (default: all)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "assets/cast/vehicles")
    ap.add_argument("--debug", action="store_true", help="flat colours per material role")
    args = ap.parse_args(argv)
    gits = {name: getattr(args, name) for name in SOURCES if getattr(args, name) is not None}
    for recipe_id in args.only or list(RECIPES):
        needed = RECIPES[recipe_id].source
        if needed not in gits:
            ap.error(f"{recipe_id} needs --{needed}")
        print(json.dumps(build(recipe_id, gits, args.out, args.debug)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

assert set(DEBUG) >= set(MATERIALS)
