"""The preview's session: what ``synthcompose preview`` shows, without any window (headless, testable).

A :class:`PreviewSession` runs the batch's own stages (:mod:`synthcompose.stages`: prepare,
place, shade, with the GL context of a :class:`~synthcompose.run.pipeline.Pipeline`) on one image
set, up to the compose (nothing is written), keeps the results as a :class:`View`, and turns them into the
images of each pass (:meth:`PreviewSession.pass_image`, depth as turbo colours), a PLY file
(:mod:`.export`), and saved placements. Every shown pose is checked against the batch's placement
rules (:func:`~synthcompose.placement.check_pose`): a :class:`Verdict`, and :meth:`PreviewSession.save`
refuses a pose that breaks one unless forced (:class:`PlacementRefused`). The text drawn over the
view is :mod:`.overlay`; :mod:`.window` puts it all in a window. This module never imports a
windowing toolkit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Mapping

import cv2
import numpy as np

from synthcompose.colour import linear_to_srgb
from synthcompose.errors import SynthComposeError
from synthcompose.geometry.depth import Frame
from synthcompose.io.dataset import ImageSetId
from synthcompose.labels import COLOR_LUT
from synthcompose.manifest import Manifest
from synthcompose.placement import Placement, Rejection, check_pose
from synthcompose.placement.saved_poses import (
    IGNORE_SAVED,
    SavedObject,
    SavedPlacement,
    ground_pose,
    placement_path,
    read_saved,
    write_saved,
)
from synthcompose.stages import NotPlaced, StageOptions, measure_light, place, prepare, shade
from synthcompose.stages.timing import Timings

from .export import export_ply

#: the passes the preview shows, in key order (1..9)
PASSES = ("composed", "irpv", "ir", "alpha", "id", "odepth", "scene_depth", "occlusion", "semantic")
PASS_TITLES = {"composed": "composed", "irpv": "Irpv (objects + planes)", "ir": "Ir (planes)",
               "alpha": "alpha", "id": "object ID", "odepth": "object depth", "scene_depth": "scene depth",
               "occlusion": "occlusion mask", "semantic": "semantic overlay"}
#: RGB of the ID pass per object index (0 = none)
ID_COLOURS = np.array([[0, 0, 0], [230, 25, 75], [60, 180, 75], [255, 225, 25], [0, 130, 200], [245, 130, 48],
                       [145, 30, 180], [70, 240, 240], [240, 50, 230], [210, 245, 60], [250, 190, 212],
                       [0, 128, 128], [220, 190, 255], [170, 110, 40], [255, 250, 200], [128, 0, 0]], np.uint8)
#: colours of rejected candidates, by reason in order of first appearance
REASON_COLOURS = np.array([[255, 0, 0], [255, 128, 0], [255, 0, 255], [0, 255, 255], [255, 255, 0], [128, 0, 255],
                           [0, 128, 255], [255, 128, 128], [128, 255, 0], [255, 0, 128], [128, 128, 255],
                           [200, 200, 200]], np.uint8)
STEP_M = 0.25  # arrow keys move the object this far
STEP_YAW_DEG = 5.0  # Q/E turn it this much


class PlacementRefused(SynthComposeError):
    """save() of a pose that breaks the placement rules, without ``force``."""

    def __init__(self, verdict: "Verdict") -> None:
        self.verdict = verdict
        super().__init__(f"not saved: {verdict}; move it where the rules hold, or save it anyway (Shift+S)")

    @property
    def short(self) -> str:
        i, name, why = self.verdict.failures[0]
        return f"not saved: {name} #{i + 1} breaks the {why.rule} rule; Shift+S saves it anyway"


@dataclass(frozen=True)
class Verdict:
    """The batch's placement rules on the shown poses: per object (name, the rule it breaks or
    None), each checked against the objects before it, as the batch places them."""

    checks: tuple[tuple[str, Rejection | None], ...] = ()

    @property
    def failures(self) -> list[tuple[int, str, Rejection]]:
        return [(i, name, why) for i, (name, why) in enumerate(self.checks) if why is not None]

    @property
    def ok(self) -> bool:
        return not self.failures

    def __str__(self) -> str:
        if not self.checks:
            return "no object placed"
        bad = self.failures
        if not bad:
            return "placement OK"
        i, name, why = bad[0]
        more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
        return f"FAILS {name} #{i + 1} - {why}{more}"


@dataclass
class PreviewObject:
    name: str  # manifest object name
    class_name: str
    placement: Placement
    extents: tuple[float, float, float]
    allowed: tuple[str, ...]


@dataclass
class View:
    """Everything the preview shows for one image set (full-frame arrays, ROI passes)."""

    ident: ImageSetId
    rgb: np.ndarray  # (H, W, 3) uint8, the input photo
    frame: Frame
    objects: list[PreviewObject]
    failures: list[NotPlaced]
    trace: list  # (candidate point in V, rejection reason)
    source: str  # "random", "saved" or "moved"
    passes: Mapping[str, np.ndarray] = field(default_factory=dict)  # ROI-sized, as RenderPasses.read gives
    roi: tuple[int, int, int, int] | None = None  # x0, y0, width, height
    composed_rgb: np.ndarray | None = None
    composed_labels: np.ndarray | None = None
    visible: np.ndarray | None = None
    verdict: Verdict = Verdict()

    @property
    def reasons(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for _, why in self.trace:
            out[why] = out.get(why, 0) + 1
        return out

    def reason_colour(self) -> dict[str, tuple[int, int, int]]:
        return {why: tuple(int(c) for c in REASON_COLOURS[i % len(REASON_COLOURS)])
                for i, why in enumerate(self.reasons)}


def _to_srgb8(lin: np.ndarray) -> np.ndarray:
    return np.rint(linear_to_srgb(lin) * 255).astype(np.uint8)


def _colormap(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(H, W) float -> (H, W, 3) uint8 RGB turbo colours, min..max of the valid ones; black elsewhere."""
    out = np.zeros(values.shape + (3,), np.uint8)
    if valid.any():
        v = values[valid]
        lo, hi = float(v.min()), float(v.max())
        norm = np.zeros(values.shape, np.uint8)
        norm[valid] = np.rint(255 * (v - lo) / max(hi - lo, 1e-6)).astype(np.uint8)
        col = cv2.applyColorMap(norm, cv2.COLORMAP_TURBO)[..., ::-1]
        out[valid] = col[valid]
    return out


class PreviewSession:
    """One manifest's image sets through the batch's pipeline, one at a time, for viewing."""

    def __init__(self, manifest: Manifest, frame: str | None = None, gl=None, gl_backend: str | None = None) -> None:
        from synthcompose.run.batch import select
        from synthcompose.run.pipeline import Pipeline

        self.base = manifest
        self.ids, weights, _ = select(manifest)
        if not self.ids:
            raise SynthComposeError(f"{manifest.path}: the manifest selects no image set")
        self.index = 0
        if frame is not None:
            names = [i.name for i in self.ids]
            if frame not in names:
                from synthcompose.run.selection import near

                raise SynthComposeError(f"frame {frame!r} is not among the manifest's image sets "
                                        f"({', '.join(names[:5])}{', ...' if len(names) > 5 else ''})"
                                        f"{near(frame, names)}")
            self.index = names.index(frame)
        self.pipeline = Pipeline(manifest, weights, gl_backend=gl_backend, gl=gl)
        self.seed_offset = 0
        self.selected = 0  # the object the keys move
        self.view: View | None = None

    def close(self) -> None:
        self.pipeline.close()

    @property
    def ident(self) -> ImageSetId:
        return self.ids[self.index]

    # ----------------------------------------------------------------- running the pipeline
    def load(self, override=None) -> View:
        """Run the batch's stages on the current image set, up to the compose (nothing is
        written). ``override``: None (the image set's saved placement, if any), IGNORE_SAVED (a
        random placement), or a SavedPlacement (these poses)."""
        p = self.pipeline
        m = replace(self.base, seed=self.base.seed + self.seed_offset, right_view=False)  # the left view is shown
        saved = read_saved(m.output, self.ident) if override is None else \
            (None if override is IGNORE_SAVED else override)
        o = StageOptions.of(m)
        prep = prepare(o.read, self.ident, Timings())
        trace: list = []
        placed = place(o.place, p.weights, prep, Timings(), saved=saved, trace=trace)
        shaded = shade(p.renderer, p.composer, o.shade, prep, measure_light(o.read, prep, Timings()), placed, Timings(),
                       keep=("irpv", "ir", "alpha", "odepth", "id")) if placed.objects else None
        source = "random" if saved is None else ("saved" if saved.path is not None else "moved")
        objects = [PreviewObject(o.spec.name, o.spec.class_name, o.placement, tuple(o.placement.extents),
                                tuple(o.spec.allowed_surfaces)) for o in placed.objects]
        composed = None if shaded is None else shaded.composed
        self.view = View(self.ident, prep.image_set.rgb, prep.frame, objects, list(placed.failures), trace, source,
                         {} if shaded is None else shaded.passes, None if shaded is None else shaded.roi,
                         None if composed is None else composed.rgb,
                         None if composed is None else composed.label_ids,
                         None if composed is None else composed.visible,
                         self._verdict(prep.frame, objects))
        self.selected = min(self.selected, max(len(objects) - 1, 0))
        return self.view

    def _verdict(self, frame: Frame, objects: list[PreviewObject]) -> Verdict:
        """Each object against the rules, the objects before it standing (the batch's order)."""
        rules = self.base.rules
        return Verdict(tuple((o.name, check_pose(frame, o.class_name, o.extents, o.placement.matrix, rules, o.allowed,
                                                 [p.placement for p in objects[:i]]))
                             for i, o in enumerate(objects)))

    def step_set(self, step: int) -> View:
        self.index = (self.index + step) % len(self.ids)
        self.seed_offset, self.selected = 0, 0
        return self.load()

    def reroll(self) -> View:
        """Next seed offset: a new random placement (a saved one is ignored)."""
        self.seed_offset += 1
        return self.load(IGNORE_SAVED)

    def _override(self, matrices: list[np.ndarray]) -> SavedPlacement:
        return SavedPlacement(self.ident.key, tuple(SavedObject(o.name, tuple(tuple(float(v) for v in r) for r in m))
                                                    for o, m in zip(self.view.objects, matrices)))

    def move(self, dx: float = 0.0, dy: float = 0.0, dyaw_deg: float = 0.0) -> View:
        """Move the selected object on the ground (metres in the vehicle frame: x forward,
        y left) and turn it; it stands on the ground fitted where it lands."""
        v = self.view
        if v is None or not v.objects:
            return v
        mats = [o.placement.matrix for o in v.objects]
        m = mats[self.selected]
        yaw = math.atan2(m[1, 0], m[0, 0]) + math.radians(dyaw_deg)
        mats[self.selected] = ground_pose(v.frame, m[0, 3] + dx, m[1, 3] + dy, yaw, v.objects[self.selected].extents,
                                          fallback_z=float(m[2, 3]), fallback_normal=m[:3, 2])
        new = self.load(self._override(mats))
        new.trace = v.trace  # the candidates the random placement rejected stay on show
        return new

    def select_next(self) -> int:
        if self.view and self.view.objects:
            self.selected = (self.selected + 1) % len(self.view.objects)
        return self.selected

    def save(self, force: bool = False) -> Path | None:
        """Write the shown poses as the image set's placement file; a later batch uses them.
        A pose that breaks a placement rule raises :class:`PlacementRefused` unless ``force``
        (the window's Shift+S: save anyway)."""
        v = self.view
        if v is None or not v.objects:
            return None
        if not force and not v.verdict.ok:
            raise PlacementRefused(v.verdict)
        return write_saved(self.base.output, v.ident, [(o.name, o.placement.matrix) for o in v.objects])

    @property
    def placement_file(self) -> Path:
        return placement_path(self.base.output, self.ident)

    # --------------------------------------------------------------------------- images
    def pass_image(self, name: str) -> np.ndarray:
        """(H, W, 3) uint8 RGB picture of one pass over the full frame."""
        v = self.view
        H, W = v.rgb.shape[:2]
        out = np.zeros((H, W, 3), np.uint8)
        if name == "composed":
            return (v.composed_rgb if v.composed_rgb is not None else v.rgb).copy()
        if name == "scene_depth":
            d = v.frame.depth
            ok = np.isfinite(d) & (d > 0)
            return _colormap(np.where(ok, 1.0 / np.where(ok, d, 1.0), 0.0), ok)
        if name == "semantic":
            labels = v.composed_labels if v.composed_labels is not None else v.frame.label_ids
            base = v.composed_rgb if v.composed_rgb is not None else v.rgb
            return ((base.astype(np.uint16) + COLOR_LUT[labels]) // 2).astype(np.uint8)
        if name not in PASSES:
            raise KeyError(f"unknown pass {name!r}; one of {', '.join(PASSES)}")
        if v.roi is None:
            return out
        x0, y0, w, h = v.roi
        rows, cols = slice(y0, y0 + h), slice(x0, x0 + w)
        p = v.passes
        if name in ("irpv", "ir"):
            out[rows, cols] = _to_srgb8(p[name][..., :3])
        elif name == "alpha":
            out[rows, cols] = np.rint(np.clip(p["alpha"], 0, 1) * 255).astype(np.uint8)[..., None]
        elif name == "id":
            out[rows, cols] = ID_COLOURS[np.minimum(p["id"], len(ID_COLOURS) - 1)]
        elif name == "odepth":
            a = p["alpha"]
            ok = a > 1e-3
            out[rows, cols] = _colormap(np.where(ok, p["odepth"] / np.maximum(a, 1e-3), 0.0), ok)
        elif name == "occlusion":
            out[:] = (v.rgb.astype(np.uint16) * 2 // 5).astype(np.uint8)
            rendered = np.zeros((H, W), bool)
            rendered[rows, cols] = p["id"] > 0
            seen = v.visible > 0 if v.visible is not None else np.zeros((H, W), bool)
            out[rendered & ~seen] = (255, 40, 40)
            out[rendered & seen] = (40, 220, 40)
        return out

    def objects_line(self) -> str:
        """Where the placement comes from, and each object (* selected) with distance and yaw."""
        v = self.view
        objs = ", ".join(f"{o.name}{'*' if i == self.selected else ''} {o.placement.distance:.1f}m "
                         f"yaw {math.degrees(o.placement.yaw):.0f}" for i, o in enumerate(v.objects)) or "no object placed"
        return f"[{v.source}, seed+{self.seed_offset}] {objs}"

    def status_line(self) -> str:
        v = self.view
        return f"{v.ident.key} {self.objects_line()} - {v.verdict}"

    def legend(self) -> list[str]:
        v = self.view
        cols = v.reason_colour()
        lines = [f"rejected candidates of {v.ident.key} (seed+{self.seed_offset}):"]
        for why, n in sorted(v.reasons.items(), key=lambda kv: -kv[1]):
            lines.append(f"  rgb{cols[why]}  x{n}  {why}")
        for f in v.failures:
            lines.append(f"  not placed: {f.name} ({f.reason}, {f.attempts} attempts)")
        return lines

    # ------------------------------------------------------------------------------ PLY
    def cloud_colours(self, by: str = "rgb") -> np.ndarray:
        """(N, 3) uint8 colour of each cloud point: the photo's, or its label's Cityscapes colour."""
        v = self.view
        px = v.frame.cloud.pixels
        if by == "label":
            return COLOR_LUT[v.frame.cloud.labels]
        return v.rgb[px[:, 0], px[:, 1]]

    def export_ply(self, path: str | Path, colour: str = "rgb") -> dict[str, int]:
        return export_ply(path, self.view, self.cloud_colours(colour))

