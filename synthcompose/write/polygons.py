"""Cityscapes polygons: one polygon per mask, and the polygons of a whole labelled frame.

cityscapesScripts (``json2labelImg``, ``json2instanceImg``, ``csCreateTrainIdLabelImgs``) and
the converters built on them (mmsegmentation's) draw a ``gtFine_polygons.json`` entry by entry,
in file order, later entries on top, with Pillow's ``ImageDraw.polygon``: even-odd fill, the
boundary included, vertices at pixel centres. ``json2instanceImg`` numbers the instances of a
class by their order in the file (the k-th ``car`` entry is ``26000 + k``).

* :func:`mask_polygon` - one polygon that Pillow fills back to exactly a mask: its holes are
  joined to the outline by a zero-width cut through the mask's own pixels (even-odd leaves them
  open); its parts are joined by a zero-width bridge between their nearest boundary pixels (the
  only pixels drawn that are not the mask's: the bridge's). Parts under ``min_part_pixels``
  are left out (a bridge to a speck costs more pixels than the speck).
* :func:`frame_polygons` - the entries of a whole frame from its labelIds and instanceIds,
  drawn in an order that reproduces them: every region of a class without instances (and every
  ``<class>group`` region) as its outline with its holes filled, whatever lies in a hole drawn
  after it; every instance as one entry (:func:`mask_polygon`), the instances of a class in the
  order of their ids; an id the frame skips (an instance the annotators' later polygons hid
  entirely) gets a one-pixel entry that the next instance of its class draws over, so the
  numbering stays the frame's.

Polygons are lists of ``[x, y]`` integer pixel centres (column, row).
"""
from __future__ import annotations

import heapq
from collections import defaultdict
from typing import Any, Sequence

import cv2
import numpy as np
from cityscapesscripts.helpers.labels import id2label
from PIL import Image, ImageDraw
from scipy.ndimage import find_objects
from scipy.spatial import cKDTree

from synthcompose.labels import INSTANCE_FACTOR

Polygon = list[list[int]]

#: parts of fewer pixels are left out of an instance's polygon: specks where a real occluder
#: has no disparity and the object shows through, not parts an annotator would draw
MIN_PART_PIXELS = 4


# ------------------------------------------------------------------------- one mask
def _contours(mask: np.ndarray, mode: int, chain: int = cv2.CHAIN_APPROX_NONE
               ) -> tuple[list[np.ndarray], np.ndarray | None]:
    """OpenCV contours ((N, 2) int x, y; every boundary pixel by default) of a 0/1 mask and their
    hierarchy."""
    padded = cv2.copyMakeBorder(mask.astype(np.uint8), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    contours, hierarchy = cv2.findContours(padded, mode, chain)
    return [c.reshape(-1, 2) - 1 for c in contours], (None if hierarchy is None else hierarchy[0])


def _splice(ring: list[tuple[int, int]], at: int, loop: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """``ring`` with the closed ``loop`` (starting at its joining vertex) visited from vertex ``at``:
    ring[at] -> loop[0] .. loop[-1] -> loop[0] -> ring[at] (a zero-width bridge both ways)."""
    return ring[:at + 1] + loop + [loop[0]] + ring[at:]


def _rotated(points: np.ndarray, start: int) -> list[tuple[int, int]]:
    return list(map(tuple, np.roll(points, -start, axis=0).tolist()))


def _cut_up(ring: list[tuple[int, int]], hole: np.ndarray, mask: np.ndarray) -> list[tuple[int, int]]:
    """Join a hole's boundary to ``ring`` by a vertical cut up through the mask's pixels.

    From the hole boundary's top-most pixel the cut climbs while the pixels are the mask's; the
    last one lies on a boundary already in ``ring`` (the outline, or a hole above, joined
    first). If it is not found there (a boundary OpenCV traced another way), the nearest
    vertex of ``ring`` is used: the bridge may then cross a few pixels that are not the mask's.
    """
    top = int(np.lexsort((hole[:, 0], hole[:, 1]))[0])
    x, y = (int(v) for v in hole[top])
    while y > 0 and mask[y - 1, x]:
        y -= 1
    index = {p: i for i, p in enumerate(ring)}
    at = index.get((x, y))
    if at is None:
        at = int(cKDTree(np.asarray(ring)).query(hole[top])[1])
    return _splice(ring, at, _rotated(hole, top))


def _simplified(ring: list[tuple[int, int]]) -> Polygon:
    """The vertices where the path turns (straight runs reduced to their ends), at least three."""
    pts = [p for i, p in enumerate(ring) if i == 0 or p != ring[i - 1]]
    if len(pts) > 1 and pts[-1] == pts[0]:
        pts.pop()
    n = len(pts)
    if n > 2:
        arr = np.asarray(pts)
        d_in = arr - np.roll(arr, 1, axis=0)
        d_out = np.roll(arr, -1, axis=0) - arr
        # same direction in and out (cross product 0, dot product > 0): a point inside a run
        straight = (d_in[:, 0] * d_out[:, 1] == d_in[:, 1] * d_out[:, 0]) & ((d_in * d_out).sum(axis=1) > 0)
        pts = [p for p, s in zip(pts, straight) if not s]
    pts = [list(p) for p in pts]
    while len(pts) < 3:
        pts.append(list(pts[-1]))
    return pts


def _part_ring(part: np.ndarray) -> list[tuple[int, int]]:
    """Closed boundary path of one 8-connected part (0/1 mask): its outline with every hole
    joined by a cut (even-odd fill leaves the holes open)."""
    contours, hierarchy = _contours(part, cv2.RETR_CCOMP)
    outer = [i for i in range(len(contours)) if hierarchy[i][3] < 0]
    ring = _rotated(contours[outer[0]], 0)
    holes = [c for i, c in enumerate(contours) if hierarchy[i][3] >= 0]
    holes.sort(key=lambda c: (int(c[:, 1].min()), int(c[c[:, 1] == c[:, 1].min(), 0].min())))
    for hole in holes:  # top-most first: a cut ends on the outline or on a hole joined before
        ring = _cut_up(ring, hole, part)
    return ring


def mask_polygon(mask: np.ndarray, min_part_pixels: int = MIN_PART_PIXELS) -> Polygon | None:
    """One polygon of an (H, W) mask (see the module notes), or None if it has no pixels.

    Parts under ``min_part_pixels`` pixels are left out unless every part is that small (then
    the largest is kept).
    """
    x0, y0, w, h = cv2.boundingRect(np.asarray(mask, np.uint8))
    if w == 0:
        return None
    crop = np.asarray(mask[y0:y0 + h, x0:x0 + w], np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(crop, connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = [int(i) + 1 for i in np.argsort(-areas, kind="stable")]
    keep = [i for i in order if stats[i, cv2.CC_STAT_AREA] >= min_part_pixels] or order[:1]
    ring: list[tuple[int, int]] = []
    for label in keep:
        part_ring = _part_ring((labels == label).astype(np.uint8))
        if not ring:
            ring = part_ring
            continue
        # the bridge: between the nearest boundary pixels of the part and of what is joined
        dist, nearest = cKDTree(np.asarray(ring)).query(np.asarray(part_ring))
        j = int(np.argmin(dist))
        ring = _splice(ring, int(nearest[j]), part_ring[j:] + part_ring[:j])
    return [[x + x0, y + y0] for x, y in _simplified(ring)]


def draw_polygons(entries: Sequence[tuple[Polygon, int]], shape: tuple[int, int], background: int = 0) -> np.ndarray:
    """(H, W) int32: the polygons drawn in order with their values, as cityscapesScripts draws
    them (Pillow, even-odd, boundary included)."""
    img = Image.new("I", (shape[1], shape[0]), background)
    draw = ImageDraw.Draw(img)
    for poly, value in entries:
        draw.polygon([tuple(p) for p in poly], fill=int(value))
    return np.asarray(img, np.int32)


# ------------------------------------------------------------------------ whole frame
def _name(label_id: int) -> str:
    return id2label[label_id].name


def frame_polygons(label_ids: np.ndarray, instance_ids: np.ndarray) -> list[dict[str, Any]]:
    """The ``objects`` of a gtFine polygons file describing the whole frame (module notes).

    ``label_ids`` (H, W) uint8 and ``instance_ids`` (H, W) int, Cityscapes encoded
    (``label * 1000 + k`` for instances, the label id elsewhere). A region of label 0
    (``unlabeled``, the background cityscapesScripts starts from) gets an entry only where
    another entry would draw over it (a hole in a region).
    """
    label_ids = np.asarray(label_ids)
    instance_ids = np.asarray(instance_ids)
    if instance_ids.dtype not in (np.int32, np.uint16):  # (Cityscapes' own 16 bits: no copy)
        instance_ids = instance_ids.astype(np.int64 if instance_ids.size and instance_ids.max() >= 2 ** 31 else np.int32)
    # each pixel's segment: its instance id, or its label id (a class without instances, a group)
    segment = np.where(instance_ids >= INSTANCE_FACTOR, instance_ids, label_ids)
    values = _present(segment)
    lookup = np.zeros(int(values[-1]) + 1, np.int32)
    lookup[values] = np.arange(1, values.size + 1)  # 1 + the segment's place in values: find_objects' labels
    index = lookup[segment]
    del segment
    owner = np.full(label_ids.shape, -1, np.int32)  # the entry each pixel belongs to
    entries: list[dict[str, Any]] = []  # label, polygon, box (x, y, w, h), drawn area in the box
    chains: dict[int, list[int]] = defaultdict(list)  # class -> its instances' entries, by id
    for k, box in enumerate(find_objects(index)):
        value = int(values[k])
        own_box = index[box] == k + 1
        y0, x0 = box[0].start, box[1].start
        if value >= INSTANCE_FACTOR:  # an instance: one entry
            poly = mask_polygon(own_box, min_part_pixels=1)  # a speck left out would show what lies under it
            poly = [[px + x0, py + y0] for px, py in poly]
            xs, ys = [p[0] for p in poly], [p[1] for p in poly]
            x, y = min(xs + [x0]), min(ys + [y0])
            x1, y1 = max(xs + [box[1].stop - 1]) + 1, max(ys + [box[0].stop - 1]) + 1
            drawn = draw_polygons([([[px - x, py - y] for px, py in poly], 1)], (y1 - y, x1 - x)).astype(bool)
            owner[box][own_box] = len(entries)
            chains[value // INSTANCE_FACTOR].append(len(entries))
            entries.append({"label": _name(value // INSTANCE_FACTOR), "polygon": poly, "id": value,
                            "box": (x, y, x1 - x, y1 - y), "drawn": drawn, "area": int(drawn.sum())})
            continue
        label = id2label.get(value)
        if label is None or label.id < 0:
            continue
        name = label.name + ("group" if label.hasInstances else "")
        # a region: each 8-connected part, its outline with the holes filled
        n, comp, stats, _ = cv2.connectedComponentsWithStats(own_box.view(np.uint8), connectivity=8)
        for c in range(1, n):
            x, y, w, h = (int(v) for v in stats[c, :4])
            own = comp[y:y + h, x:x + w] == c
            outline = _contours(own, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[0][0]  # runs to their ends
            filled = np.zeros((h, w), np.uint8)
            cv2.drawContours(filled, [outline.reshape(-1, 1, 2)], -1, 1, cv2.FILLED)
            x, y = x + x0, y + y0
            owner[y:y + h, x:x + w][own] = len(entries)
            polygon = (outline + (x, y)).tolist()
            polygon += [polygon[-1]] * (3 - len(polygon))
            entries.append({"label": name, "polygon": polygon,
                            "box": (x, y, w, h), "drawn": filled.astype(bool), "area": int(filled.sum()),
                            "background": label.id == 0})
    order = _drawing_order(entries, owner, [chains[c] for c in sorted(chains)])
    return _with_skipped_ids([entries[i] for i in order])


def _present(segment: np.ndarray) -> np.ndarray:
    """The values ``segment`` holds, ascending (``np.flatnonzero(np.bincount(segment.ravel()))``;
    16-bit segments by OpenCV's histogram, without bincount's int64 copy of the frame)."""
    if segment.dtype == np.uint16 and segment.ndim == 2 and segment.size:
        hist = cv2.calcHist([np.ascontiguousarray(segment)], [0], None, [1 << 16], [0, 1 << 16])
        return np.flatnonzero(hist.ravel())
    return np.flatnonzero(np.bincount(segment.ravel()))


def _with_skipped_ids(ordered: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The entries' ``{"label", "polygon"}``, with a one-pixel entry for every instance id the
    frame skips, just before the next instance of its class (which draws over it)."""
    seen: dict[int, int] = defaultdict(int)  # class -> instances numbered so far
    objects = []
    for e in ordered:
        if "id" in e:
            cid, k = divmod(e["id"], INSTANCE_FACTOR)
            first = list(e["polygon"][0])
            objects += [{"label": e["label"], "polygon": [first, first, first]}] * (k - seen[cid])
            seen[cid] = k + 1
        objects.append({"label": e["label"], "polygon": e["polygon"]})
    return objects


def _drawing_order(entries: list[dict[str, Any]], owner: np.ndarray, chains: list[list[int]]) -> list[int]:
    """An order in which no entry draws over a pixel of an entry drawn before it, as far as
    one exists.

    Entry A must come before entry B when A's drawn area covers pixels of B (a region's filled
    holes, an instance's bridge), weighted by that pixel count; the instances of a class keep
    the order of their ids (``chains``, never broken). Where the overlaps form a cycle (a
    bridge across the road the instance stands in), the entry whose remaining predecessors
    cover the fewest of its pixels goes first. Ties: the larger drawn area first.
    """
    n = len(entries)
    succ: list[dict[int, int]] = [dict() for _ in range(n)]  # a -> {b: pixels of b that a covers}
    soft = [0] * n  # pixels of each entry covered by entries not yet placed
    hard = [0] * n  # instances of its class with a lower id not yet placed
    for a, e in enumerate(entries):
        x, y, w, h = e["box"]
        counts = np.bincount(owner[y:y + h, x:x + w][e["drawn"]] + 1, minlength=n + 1)[1:]  # -1: no entry
        counts[a] = 0
        for b in np.flatnonzero(counts).tolist():
            succ[a][b] = c = int(counts[b])
            soft[b] += c
    after: dict[int, int] = {}
    for chain in chains:
        for a, b in zip(chain, chain[1:]):
            after[a] = b
            hard[b] += 1
    area = [int(e["area"]) for e in entries]
    # background regions nothing draws over need no entry: the drawing starts from it
    left = [not (e.get("background") and soft[i] == 0) for i, e in enumerate(entries)]
    # the first of: no lower id waiting, fewest pixels that a later entry would cover, larger
    # area, lower index; a heap of those keys, an entry pushed again whenever its key falls
    # (keys only fall) and a popped key that is no longer the entry's own passed over
    key = lambda i: (hard[i] > 0, soft[i], -area[i], i)  # noqa: E731
    heap = [key(i) for i in range(n) if left[i]]
    heapq.heapify(heap)
    order: list[int] = []
    while heap:
        top = heapq.heappop(heap)
        best = top[3]
        if not left[best] or top != key(best):
            continue
        order.append(best)
        left[best] = False
        for b, c in succ[best].items():
            soft[b] -= c
            if left[b]:
                heapq.heappush(heap, key(b))
        if best in after:
            hard[after[best]] -= 1
            if left[after[best]]:
                heapq.heappush(heap, key(after[best]))
    return order
