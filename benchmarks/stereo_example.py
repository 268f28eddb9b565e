"""A left / right / disparity picture of one augmented image set, for the README.

    python benchmarks/stereo_example.py OUTPUT_ROOT OUT.png [--frame city_seq_frame] [--width 1024]

Stacks, cropped to the rows the inserted objects cover: the augmented left photo, the augmented
right photo, and the written disparity (colour map, black where invalid), each with a vertical
line through the first object's leftmost column in the left photo, so the shift between the
views is seen. Only for generated image sets: never commit pictures made from real frames.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from synthcompose.io.dataset import find_image_sets  # noqa: E402
from synthcompose.io.files import decode_disparity, read_png, write_png  # noqa: E402
from synthcompose.record import read_record  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("output", type=Path)
    ap.add_argument("png", type=Path)
    ap.add_argument("--frame", help="city_seq_frame (default: the first with a right view)")
    ap.add_argument("--width", type=int, default=1024)
    args = ap.parse_args()
    idents = [i for i in find_image_sets(args.output) if i.path(args.output, "right").is_file()
              and (args.frame is None or i.name == args.frame)]
    if not idents:
        sys.exit(f"{args.output}: no augmented image set with a right view")
    ident = idents[0]
    left = read_png(ident.path(args.output, "rgb"), "rgb8")
    right = read_png(ident.path(args.output, "right"), "rgb8")
    raw = read_png(ident.path(args.output, "disparity"), "gray16")
    record = read_record(ident.path(args.output, "record"))
    boxes = [o.bbox_2d for o in record.objects if o.bbox_2d is not None]
    y0 = max(min(b[1] for b in boxes) - 40, 0)
    y1 = min(max(b[3] for b in boxes) + 40, left.shape[0])
    d = np.where(raw > 0, decode_disparity(raw), 0.0)
    scaled = np.clip(d / max(float(np.percentile(d[raw > 0], 99.5)), 1.0) * 255, 0, 255).astype(np.uint8)
    disp = cv2.cvtColor(cv2.applyColorMap(scaled, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB)
    disp[raw == 0] = 0
    x = boxes[0][0]
    panels = []
    for img in (left, right, disp):
        crop = img[y0:y1].copy()
        crop[:, max(x - 1, 0):x + 1] = (255, 255, 255)
        panels.append(crop)
    out = np.concatenate(panels, axis=0)
    h = round(out.shape[0] * args.width / out.shape[1])
    write_png(args.png, cv2.resize(out, (args.width, h), interpolation=cv2.INTER_AREA))
    print(f"{ident.key}: rows {y0}-{y1}, line at column {x}; wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
