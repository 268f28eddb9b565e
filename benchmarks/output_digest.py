"""sha256 of every output file of the main job, to show that a change leaves the outputs the same:
a PNG by its pixels (its shape, sample type and decoded samples: the same image whatever encoder
wrote it), every other file by its bytes.

    python benchmarks/output_digest.py WORK --demo --generated 6 --root REAL_ROOT ... > sums.txt
    (change the code)
    python benchmarks/output_digest.py WORK --demo --generated 6 --root REAL_ROOT ... > sums-after.txt
    diff sums.txt sums-after.txt

Each input (the bundled demo sample, ``--generated N`` generated 2048x1024 image sets: half overcast
plain streets, half sunny traffic streets, and every ``--root``) goes through the bundled demo
manifest (its cast, 2 objects, seed 7) by the command line, into ``WORK/out/<input>``. Inputs the
script generates are kept under ``WORK/in`` and reused, so that a second run reads the same files.
Printed: one line per output file, ``sha256  input/relative path``; ``summary.json`` (wall times) is
left out. WORK must lie outside the repository when a root holds real frames (Cityscapes' licence).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
SKIPPED = {"summary.json"}


def synthcompose(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "synthcompose", *args], check=True, cwd=REPO,
                   stdout=subprocess.DEVNULL)


def generated_inputs(work: Path, count: int) -> list[tuple[str, Path]]:
    """``count`` generated image sets (kept and reused under ``work/in``)."""
    kinds = [("generated-overcast", ["--seed", "31"]), ("generated-sunny", ["--seed", "32", "--light", "sunny",
                                                                            "--streets", "traffic"])]
    inputs = []
    for i, (name, options) in enumerate(kinds):
        n = count // 2 + (count % 2 if i == 0 else 0)
        root = work / "in" / name
        if n and not (root / ".complete").is_file():
            shutil.rmtree(root, ignore_errors=True)
            synthcompose("make-sample", str(root), "--count", str(n), *options)
            (root / ".complete").touch()
        if n:
            inputs.append((name, root))
    return inputs


def run(name: str, root: Path, work: Path) -> Path:
    manifest = json.loads((REPO / "assets" / "demo" / "manifest.json").read_text())
    out = work / "out" / name
    shutil.rmtree(out, ignore_errors=True)
    splits = sorted({p.parent.parent.name for p in (root / "leftImg8bit").glob("*/*/*_leftImg8bit.png")})
    manifest.update(dataset=str(root.resolve()), output=str(out), splits=splits)
    path = work / f"{name}.manifest.json"
    path.write_text(json.dumps(manifest, indent=2))
    synthcompose("batch", str(path), "--no-progress", "--workers", "1")
    return out


def file_digest(path: Path) -> str:
    """sha256 of a PNG's pixels (shape, dtype and samples as decoded), of any other file's bytes."""
    data = path.read_bytes()
    if path.suffix == ".png":
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        data = f"png {img.shape} {img.dtype}\n".encode() + np.ascontiguousarray(img).tobytes()
    return hashlib.sha256(data).hexdigest()


def digest(out: Path):
    for path in sorted(p for p in out.rglob("*") if p.is_file()):
        if path.name not in SKIPPED:
            yield file_digest(path), path.relative_to(out).as_posix()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("work", type=Path, help="folder for generated inputs and the outputs")
    ap.add_argument("--demo", action="store_true", help="the bundled demo sample (make-sample's default, 3 sets)")
    ap.add_argument("--generated", type=int, default=0, help="generated 2048x1024 image sets")
    ap.add_argument("--root", type=Path, action="append", default=[], help="a Cityscapes root (repeatable)")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    inputs = []
    if args.demo:
        demo = args.work / "in" / "demo"
        if not (demo / ".complete").is_file():
            shutil.rmtree(demo, ignore_errors=True)
            synthcompose("make-sample", str(demo), "--count", "3")
            (demo / ".complete").touch()
        inputs.append(("demo", demo))
    inputs += generated_inputs(args.work, args.generated)
    inputs += [(f"root{i}-{r.name}", r) for i, r in enumerate(args.root)]
    for name, root in inputs:
        out = run(name, root, args.work)
        for sha, rel in digest(out):
            print(f"{sha}  {name}/{rel}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
