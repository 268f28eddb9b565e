"""Build the German traffic signs of the cast: one folder per sign under assets/cast/signs/.

    python scripts/build_signs.py GIT_DIR [--commit COMMIT] [--out assets/cast/signs] [--px 256]

GIT_DIR is a clone (bare is fine) of github.com/osmberlin/osm-traffic-sign-tool. Only its
sign images are taken: the SVGs under ``packages/internal_svgs/src/data-svgs/DE/svgs/``
(``DE_<code>.svg``). The repository's code is AGPL and is neither run nor copied; its data
entries (``packages/traffic-sign-converter/src/data-definitions/DE/``) are only searched for
each sign's ``licence:`` line, and a sign whose entry does not say "Public Domain" is refused.
(The images are the official StVO sign designs, drawn after the Verkehrszeichenkatalog;
official works are free of copyright in Germany, UrhG section 5.)

Each sign gets ``face.png`` (the SVG rasterised with resvg, through the PyPI package
``resvg-py``, a build-time tool only: ``pip install resvg-py``; ``--px`` pixels along the long
side, RGBA; the colour of the fully transparent pixels is bled outward from the shape so that
a texture filter does not pull black into the plate's edge), ``entry.json`` (the catalogue entry:
class "traffic sign", kind its code, the plate's real size, its share of the street's signs,
the supplementary signs that may hang under it), ``SOURCE.txt`` and ``LICENSE.txt``.

Sizes are those of the VwV-StVO for size 2 ("Groesse 2", the rule for 20-80 km/h, the
town streets Cityscapes shows): triangles 900 mm a side (the SVG's rounded corners make the
plate 847 mm wide), round signs 600 mm, the stop octagon 900 mm, squares 600 mm, the
priority-road diamond 600 mm a side (849 mm across), supplementary signs 600 mm wide; the
heights follow the SVG's aspect.
"""
from __future__ import annotations

import argparse
import io
import json
import re
import subprocess
from pathlib import Path

import numpy as np
from PIL import Image

SVG_DIR = "packages/internal_svgs/src/data-svgs/DE/svgs"
DATA_DIR = "packages/traffic-sign-converter/src/data-definitions/DE"
REPO = "github:osmberlin/osm-traffic-sign-tool"

#: code (the StVO number as the data entries write it) -> (width mm, weight in the street's
#: signs, lower-edge heights m (None: the footway's 2.0-2.2 m), supplementary signs that may
#: hang under it ((code, probability), ...), what it is). Weights: how often a sign of that
#: kind stands at a town street's footway (speed limits and zones, priority, parking, no
#: stopping and the cycle/foot path signs most; warning signs and bans on vehicles fewer).
MAIN: dict[str, tuple[float, float, tuple[float, ...] | None, tuple[tuple[str, float], ...], str]] = {
    "205": (847, 1.2, None, (), "give way"),
    "206": (900, 0.4, None, (), "stop"),
    "267": (600, 0.8, None, (("1022-10", 0.5),), "no entry"),
    "274-30": (600, 0.8, None, (), "speed limit 30"),
    "274-50": (600, 0.4, None, (), "speed limit 50"),
    "274.1": (600, 0.8, None, (), "30 zone begins"),
    "283": (600, 0.9, None, (("1042-30", 0.2), ("1000-30", 0.15)), "no stopping"),
    "283-10": (600, 0.5, None, (), "no stopping, ends here"),
    "286": (600, 0.8, None, (("1042-30", 0.3), ("1000-30", 0.15)), "restricted stopping"),
    "301": (847, 0.5, None, (), "priority at the next junction"),
    "306": (849, 1.2, None, (), "priority road"),
    "350-10": (600, 0.5, None, (), "pedestrian crossing (right)"),
    "350-20": (600, 0.3, None, (), "pedestrian crossing (left)"),
    "314": (600, 0.9, None, (("1042-30", 0.15),), "parking"),
    "325.1": (900, 0.3, None, (), "traffic-calmed area begins"),
    "224": (450, 0.4, None, (), "bus or tram stop"),
    "237": (600, 0.6, (2.25, 2.3), (), "cycle path"),
    "239": (600, 0.5, None, (("1022-10", 0.5),), "footpath"),
    "240": (600, 0.7, (2.25, 2.3), (), "shared foot and cycle path"),
    "241-30": (600, 0.5, (2.25, 2.3), (), "segregated foot and cycle path"),
    "250": (600, 0.3, None, (("1020-30", 0.4), ("1022-10", 0.3), ("1024-10", 0.1)), "no vehicles"),
    "260": (600, 0.3, None, (("1020-30", 0.4), ("1020-12", 0.2)), "no motor vehicles"),
    "220-20": (800, 0.5, None, (), "one-way street (right)"),
    "357": (600, 0.3, None, (), "dead end"),
    "136-10": (847, 0.3, None, (), "children"),
    "138-10": (847, 0.2, None, (), "cyclists crossing"),
    "101": (847, 0.1, None, (), "danger"),
}
#: supplementary signs ("Zusatzzeichen"): only under a main sign (weight 0)
SUPPLEMENTARY: dict[str, tuple[float, str]] = {
    "1020-30": (600, "residents' access only (Anlieger frei)"),
    "1022-10": (600, "cyclists allowed (Radverkehr frei)"),
    "1042-30": (600, "working days (werktags)"),
    "1000-30": (600, "both directions (arrows)"),
    "1020-12": (600, "cyclists and residents allowed"),
    "1024-10": (600, "cars allowed"),
}


def sign_id(code: str) -> str:
    """The catalogue id of a sign code: "274.1" -> "de-274-1"."""
    return "de-" + re.sub(r"[^0-9a-z]+", "-", code.lower()).strip("-")


def svg_name(code: str) -> str:
    return "DE_" + re.sub(r"[.-]", "_", code) + ".svg"


def git(git_dir: str, *args: str) -> bytes:
    return subprocess.run(["git", f"--git-dir={git_dir}", *args], check=True, capture_output=True).stdout


def licences(git_dir: str, commit: str) -> dict[str, tuple[str, str]]:
    """signId -> (licence, source URL) of every DE data entry (read as text, never run)."""
    files = git(git_dir, "ls-tree", "-r", "--name-only", commit, DATA_DIR).decode().split()
    out: dict[str, tuple[str, str]] = {}
    for name in files:
        if not name.endswith(".ts"):
            continue
        text = git(git_dir, "show", f"{commit}:{name}").decode("utf-8")
        # each entry: signId: '...' ... sourceUrl: '...' ... licence: '...' before the next signId
        for block in re.split(r"(?=\bsignId:\s*')", text)[1:]:
            sid = re.match(r"signId:\s*'([^']*)'", block).group(1)
            lic = re.search(r"licence:\s*'([^']*)'", block)
            url = re.search(r"sourceUrl:\s*'([^']*)'", block)
            if lic and sid not in out:
                out[sid] = (lic.group(1), url.group(1) if url else "")
    return out


def rasterise(svg: bytes, px: int) -> Image.Image:
    """RGBA, ``px`` along the long side, transparent pixels' colour bled from the shape."""
    import resvg_py

    text = svg.decode("utf-8")
    m = re.search(r'viewBox="\s*[-\d.]+[\s,]+[-\d.]+[\s,]+([\d.]+)[\s,]+([\d.]+)', text)
    w, h = float(m.group(1)), float(m.group(2))
    size = dict(width=px) if w >= h else dict(height=px)
    img = Image.open(io.BytesIO(bytes(resvg_py.svg_to_bytes(svg_string=text, **size)))).convert("RGBA")
    arr = np.asarray(img).astype(np.float32)
    rgb, alpha = arr[..., :3], arr[..., 3:] / 255.0
    known = alpha[..., 0] > 0.99
    # grow the shape's colours outward, one pixel ring at a time (mean of known neighbours)
    filled = np.where(known[..., None], rgb, 0.0)
    for _ in range(8):
        if known.all():
            break
        acc = np.zeros_like(filled)
        cnt = np.zeros(known.shape, np.float32)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                acc += np.roll(np.roll(filled * known[..., None], dy, 0), dx, 1)
                cnt += np.roll(np.roll(known.astype(np.float32), dy, 0), dx, 1)
        grow = ~known & (cnt > 0)
        filled[grow] = acc[grow] / cnt[grow][:, None]
        known = known | grow
    out = np.concatenate([np.where(alpha > 0.99, rgb, filled), alpha * 255.0], axis=-1)
    return Image.fromarray(np.clip(np.rint(out), 0, 255).astype(np.uint8), "RGBA")


def build(git_dir: str, commit: str, out: Path, px: int) -> None:
    commit = git(git_dir, "rev-parse", commit).decode().strip()
    lic = licences(git_dir, commit)
    codes = list(MAIN) + list(SUPPLEMENTARY)
    for code in codes:
        licence, url = lic.get(code, ("(no data entry)", ""))
        if licence != "Public Domain":
            raise SystemExit(f"sign {code}: its data entry says licence {licence!r}, not 'Public Domain'")
        path = f"{SVG_DIR}/{svg_name(code)}"
        face = rasterise(git(git_dir, "show", f"{commit}:{path}"), px)
        folder = out / sign_id(code)
        folder.mkdir(parents=True, exist_ok=True)
        face.save(folder / "face.png", optimize=True)
        if code in MAIN:
            width, weight, lower, below, what = MAIN[code]
        else:
            (width, what), weight, lower, below = SUPPLEMENTARY[code], 0.0, None, ()
        sign = {"face": "face.png", "width_mm": width,
                "height_mm": round(width * face.height / face.width)}
        if lower:
            sign["lower_edge_m"] = list(lower)
        if below:
            sign["below"] = [{"id": sign_id(c), "p": p} for c, p in below]
        entry = {"id": sign_id(code), "class": "traffic sign", "kind": sign_id(code), "model": "builtin:sign",
                 "weight": weight, "licence": "LicenseRef-PublicDomain",
                 "source": f"{REPO}@{commit} {path}", "description": f"Zeichen {code}: {what}", "sign": sign}
        (folder / "entry.json").write_text(json.dumps(entry, indent=2, ensure_ascii=False) + "\n")
        (folder / "SOURCE.txt").write_text(
            f"Zeichen {code} ({what}) of the German StVO.\n"
            f"Source repository: {REPO}, commit {commit}\n"
            f"Original file: {path} (only this SVG was taken; none of the repository's code)\n"
            f"The repository's data entry for sign {code} gives: licence 'Public Domain', image source {url}\n"
            f"Changed: rasterised to face.png ({face.width} x {face.height} px, RGBA) with resvg (resvg-py), "
            "the colour of the transparent pixels bled outward from the shape; see scripts/build_signs.py.\n")
        (folder / "LICENSE.txt").write_text(
            "Public domain.\n\n"
            "This image is a German official traffic sign (StVO, Anlage 1-3; Verkehrszeichenkatalog), an\n"
            "official work free of copyright in Germany (UrhG section 5). The SVG it was rasterised from is\n"
            f"marked 'Public Domain' in the data entry of {REPO} ({url}).\n")
        print(f"{sign_id(code):12s} {face.width:4d} x {face.height:<4d} {width} mm  {what}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("git_dir")
    ap.add_argument("--commit", default="HEAD")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "assets" / "cast" / "signs"))
    ap.add_argument("--px", type=int, default=256)
    args = ap.parse_args()
    build(args.git_dir, args.commit, Path(args.out), args.px)


if __name__ == "__main__":
    main()
