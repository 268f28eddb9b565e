"""A static HTML page about a finished batch: ``synthcompose report OUT``.

Writes ``OUT/report/index.html`` with, from the records and ``summary.json``:

* a grid of before/after thumbnails per image set (input photo | output photo with the
  semantic labels of the inserted objects overlaid), linked to the full-size outputs;
* counts of inserted objects per class, and objects that found no place;
* every rejection reason of the placement, summed over the batch;
* time per stage (mean) and total time per image set, as inline SVG bar charts.

Thumbnails are JPEG files under ``OUT/report/thumbs/``; the page needs nothing else.
"""
from __future__ import annotations

import html
from collections import Counter
from pathlib import Path

import cv2
import numpy as np

from synthcompose.errors import InputError
from synthcompose.io.files import read_json, read_png, write_bytes_atomic
from synthcompose.labels import COLOR_LUT
from synthcompose.record import read_record

THUMB_WIDTH = 480
MAX_THUMBS = 300


def _thumb(rgb: np.ndarray) -> bytes:
    h, w = rgb.shape[:2]
    small = cv2.resize(rgb, (THUMB_WIDTH, max(1, round(h * THUMB_WIDTH / w))), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", small[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 85])
    return buf.tobytes()


def _overlay(rgb: np.ndarray, labels: np.ndarray, changed: np.ndarray) -> np.ndarray:
    """The output photo with the inserted objects' label colours blended in and outlined."""
    out = rgb.astype(np.float32)
    colour = COLOR_LUT[labels].astype(np.float32)
    out[changed] = 0.45 * out[changed] + 0.55 * colour[changed]
    edges = cv2.morphologyEx(changed.astype(np.uint8), cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    out[edges] = (255, 255, 255)
    return out.astype(np.uint8)


def _bars(title: str, items: list[tuple[str, float]], unit: str, width: int = 640) -> str:
    """A horizontal SVG bar chart."""
    if not items:
        return f"<h3>{html.escape(title)}</h3><p>no data</p>"
    top = max(v for _, v in items) or 1.0
    row = 18
    label_w = 230
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{row * len(items) + 10}" '
             f'role="img" aria-label="{html.escape(title)}">']
    for i, (name, v) in enumerate(items):
        y = 5 + i * row
        bw = (width - label_w - 90) * v / top
        parts.append(f'<text x="0" y="{y + 13}" font-size="12">{html.escape(name[:36])}</text>'
                     f'<rect x="{label_w}" y="{y + 2}" width="{bw:.1f}" height="{row - 5}" fill="#4a7fb5"/>'
                     f'<text x="{label_w + bw + 5:.1f}" y="{y + 13}" font-size="12">{v:.1f} {unit}</text>')
    parts.append("</svg>")
    return f"<h3>{html.escape(title)}</h3>" + "".join(parts)


def write_report(out_root: Path) -> Path:
    """Build the page for the batch under ``out_root``; returns the path of index.html."""
    out_root = Path(out_root)
    records = []
    for path in sorted((out_root / "synthcompose").rglob("*_synthcompose.json")):
        try:
            records.append(read_record(path))
        except InputError:  # damaged, or not a record
            continue
    summary = read_json(out_root / "summary.json") if (out_root / "summary.json").is_file() else {}
    rep = out_root / "report"
    classes: Counter[str] = Counter()
    not_placed: Counter[str] = Counter()
    reasons: Counter[str] = Counter()
    cards: list[str] = []
    for record in records:
        for obj in record.objects:
            classes[obj.class_name] += 1
            reasons.update(obj.placement.get("rejections", {}))
        for miss in record.not_placed:
            not_placed[miss.get("class", "?")] += 1
            reasons.update(miss.get("rejections", {}))
        if record.done and len(cards) < MAX_THUMBS and (card := _card(record, out_root, rep)) is not None:
            cards.append(card)
    index = rep / "index.html"
    write_bytes_atomic(index, _page(out_root, summary, classes, not_placed, reasons, cards).encode("utf-8"))
    return index


def _card(record, out_root: Path, rep: Path) -> str | None:
    """One image set's before/after thumbnails (written under ``rep``) and its figure, or None
    when its images cannot be read."""
    key = record.image_set
    split, city, name = key.split("/")
    try:
        before = read_png(record.source["rgb"], "rgb8")
        after = read_png(out_root / "leftImg8bit" / split / city / f"{name}_leftImg8bit.png", "rgb8")
        labels = read_png(out_root / "gtFine" / split / city / f"{name}_gtFine_labelIds.png", "gray8")
        src_labels = read_png(record.source["labelIds"], "gray8") if Path(record.source["labelIds"]).is_file() \
            else np.zeros_like(labels)
    except InputError:
        return None
    stem = key.replace("/", "__")
    write_bytes_atomic(rep / "thumbs" / f"{stem}_before.jpg", _thumb(before))
    write_bytes_atomic(rep / "thumbs" / f"{stem}_after.jpg", _thumb(_overlay(after, labels, labels != src_labels)))
    objs = ", ".join(f"{o.name} {o.distance_m:.0f} m" for o in record.objects)
    full = f"../leftImg8bit/{split}/{city}/{name}_leftImg8bit.png"
    return (
        f'<figure><a href="{html.escape(full)}"><img src="thumbs/{stem}_before.jpg" alt="before {html.escape(key)}">'
        f'<img src="thumbs/{stem}_after.jpg" alt="after {html.escape(key)}"></a>'
        f"<figcaption>{html.escape(key)}<br>{html.escape(objs)}</figcaption></figure>")


def _page(out_root: Path, summary: dict, classes: Counter, not_placed: Counter, reasons: Counter,
          cards: list[str]) -> str:
    """The report's HTML."""
    stage = [(k, v * 1000) for k, v in summary.get("mean_stage_s", {}).items()]
    per_set = [(s["image_set"].split("/")[-1], sum(s["stage_s"].values()) * 1000)
               for s in summary.get("image_sets", []) if s.get("stage_s")][:60]
    counts = "".join(f"<tr><td>{html.escape(c)}</td><td>{n}</td><td>{not_placed.get(c, 0)}</td></tr>"
                     for c, n in sorted((classes + not_placed).items())) or "<tr><td colspan=3>none</td></tr>"
    problems = "".join(f"<li>{html.escape(p['status'])}: {html.escape(p['image_set'])}: {html.escape(str(p['reason']))}</li>"
                       for p in summary.get("problems", []))
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>synthcompose report: {html.escape(str(out_root))}</title>
<style>
body{{font-family:sans-serif;margin:1.5em;color:#222}} figure{{display:inline-block;margin:0 1em 1em 0;vertical-align:top}}
figure img{{display:block;width:{THUMB_WIDTH}px;margin-bottom:2px}} figcaption{{font-size:12px;max-width:{THUMB_WIDTH}px}}
table{{border-collapse:collapse}} td,th{{border:1px solid #bbb;padding:2px 8px;text-align:left}}
</style></head><body>
<h1>synthcompose batch report</h1>
<p id="totals">{summary.get("done", len(cards))} done, {summary.get("skipped", 0)} skipped,
{summary.get("failed", 0)} failed, {summary.get("resumed", 0)} from an earlier run;
wall time {summary.get("wall_s", 0):.1f} s with {summary.get("workers", 1)}
{html.escape(str(summary.get("engine", "")))} worker(s).</p>
<h2>Inserted objects per class</h2>
<table id="classes"><tr><th>class</th><th>inserted</th><th>no valid placement</th></tr>{counts}</table>
<h2>Placement rejections</h2>
{_bars("candidates rejected, by reason", reasons.most_common(), "")}
<h2>Time</h2>
{_bars("mean time per stage", stage, "ms")}
{_bars("time per image set", per_set, "ms")}
<h2>Problems</h2><ul id="problems">{problems or "<li>none</li>"}</ul>
<h2>Before / after</h2>
<p>Each pair: the input photo, then the output with the inserted objects' labels overlaid (outlined in white).</p>
<div id="grid">{"".join(cards)}</div>
<script>
// how many thumbnails the browser could decode (read by the tests through a headless browser)
window.addEventListener("load", () => {{
  const imgs = [...document.images];
  document.body.dataset.images = imgs.length;
  document.body.dataset.imagesLoaded = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
}});
</script>
</body></html>
"""
    return page
