"""One image set through every stage: dataset -> geometry -> placement -> render -> compose -> write.

A :class:`Pipeline` holds one GL context, renderer and composer and processes image sets
one after the other; :mod:`synthcompose.batch` decides which, in which process. A bad image
set is reported (a ``failed`` outcome), never raised. Each image set goes through three
steps, each with its own typed value: ``_prepare`` (read, geometry, the photo's light and
camera -> :class:`_Prepared`), ``_compute`` (placement, render, compose -> :class:`_Computed`)
and ``_write``; :meth:`Pipeline.stream` runs the three on three image sets at once.
"""
from __future__ import annotations

import logging
import math
import time
import zlib
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, Iterator

import numpy as np
from threadpoolctl import threadpool_limits

from . import __version__
from .appearance import Appearance, appearance_rng, draw_appearance
from .annotations import amodal_boxes, annotate_objects, polygon_instance_counts, write_frame_annotations  # annotations
from .colour import srgb_to_linear
from .camera import Camera
from .compose import Composed, Composer, SceneLayers
from .dataset import ImageSet, ImageSetId, input_fingerprint, read_image_set
from .errors import InputError, SynthComposeError
from .fileio import read_input_bytes
from .frequency import object_weights
from .geometry import Frame, disparity_to_depth, occluder_depth
from .gl import GLContext
from .labels import HAS_INSTANCES, INSTANCE_FACTOR, label_id
from .lighting import CameraMatch, LightEstimate, camera_noise_seed, estimate_lighting, fixed_record
from .lighting.camera import ToneReference, object_tones
from .manifest import Manifest, ObjectSpec
from .models import load_model
from .placement import (ALLOWED_SURFACES, GROUND_LEVEL, ORIENTATION, Placement, check_pose, frame_noise,
                        place_object)
from .placement.noise import K_SIGMA
from .surfaces import Surfaces, frame_for
from .render import RenderObject, Renderer
from .writer import write_outputs, write_record
from .placements import IGNORE_SAVED, read_saved, saved_result  # saved placements (preview)

log = logging.getLogger("synthcompose")

STAGES = ("read", "geometry", "placement", "lighting", "render", "compose", "write")


@dataclass(frozen=True)
class Outcome:
    """What happened to one image set: ``done``, ``skipped`` (no valid placement) or ``failed``."""

    key: str
    status: str
    reason: str | None = None
    objects: int = 0
    timings: dict[str, float] = field(default_factory=dict)
    resumed: bool = False  # complete from an earlier run with the same configuration


def image_set_rng(seed: int, ident: ImageSetId) -> np.random.Generator:
    """Randomness of one image set: a function of (seed, image-set id) only, never of order."""
    return np.random.default_rng([seed, zlib.crc32(ident.key.encode())])


def new_instance_id(instance_ids: np.ndarray, class_id: int, taken: set[int]) -> int:
    """class_id * 1000 + k with k above every instance of that class in the frame (and in
    ``taken``); classes without instances keep their plain id (cityscapesScripts rule)."""
    if not HAS_INSTANCES[class_id]:
        return class_id
    ids = np.unique(instance_ids[instance_ids >= INSTANCE_FACTOR])
    existing = [int(i) % INSTANCE_FACTOR for i in ids if int(i) // INSTANCE_FACTOR == class_id]
    existing += [i % INSTANCE_FACTOR for i in taken if i // INSTANCE_FACTOR == class_id]
    k = max(existing, default=-1) + 1
    if k >= INSTANCE_FACTOR:
        raise SynthComposeError(f"no free instance id left for class {class_id}")
    return class_id * INSTANCE_FACTOR + k


def ground_albedo(rgb: np.ndarray, frame: Frame, placement: Placement, allowed: list[int]) -> tuple:
    """Median linear colour of the real ground seen under and around the object's footprint."""
    cam, depth = frame.camera, frame.depth
    l, w, _ = placement.extents
    gx, gy = np.meshgrid(np.linspace(-1.0, 1.0, 15), np.linspace(-1.0, 1.0, 9))
    local = np.column_stack([gx.ravel() * l, gy.ravel() * w, np.zeros(gx.size)])
    m = cam.optical_from_vehicle @ placement.matrix
    pts = local @ m[:3, :3].T + m[:3, 3]
    uv = np.rint(cam.project(pts)).astype(int)
    H, W = depth.shape
    ok = (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
    u, v, z = uv[ok, 0], uv[ok, 1], pts[ok, 2]
    ok2 = np.isin(frame.label_ids[v, u], allowed) & (depth[v, u] >= z * 0.97 - 0.1)
    if ok2.sum() == 0:
        return (0.15, 0.15, 0.15)
    lin = srgb_to_linear(rgb[v[ok2], u[ok2]].astype(np.float64) / 255.0)
    return tuple(float(c) for c in np.median(lin, axis=0))


def _saved_spec(m: Manifest, saved, k: int) -> ObjectSpec:
    """The manifest object a saved placement names (placements.py)."""
    name = saved.objects[k].name
    for spec in m.objects:
        if spec.name == name:
            return spec
    raise InputError(saved.path, f"saved placement names object {name!r}, which the manifest does not have "
                                 f"({', '.join(repr(s.name) for s in m.objects)})")


@dataclass(frozen=True, eq=False)
class _Prepared:
    """What depends on the photo alone (read, geometry, lighting): made ahead on a thread."""

    image_set: ImageSet
    camera_json: bytes
    depth: np.ndarray  # (H, W) float32 metres, inf where unknown
    frame: Frame
    surfaces: Surfaces | None  # unlabelled image sets: the road and sidewalk found (surfaces.py)
    rng: np.random.Generator  # the image set's randomness, after the geometry's draws
    estimate: LightEstimate | None  # lighting "estimate" mode
    match: CameraMatch | None  # lighting "camera_match"
    reference: ToneReference | None  # with camera_match: the tones of the frame's own objects


@dataclass(frozen=True, eq=False)
class _Computed:
    """Geometry-to-compose's output: everything the write stage needs (no GL object)."""

    ident: ImageSetId
    record: dict  # the record so far; the write stage adds the objects and the status
    records: list  # per placed object: result, spec, instance_id, model, check, plane_albedo, sun_visibility
    saved: bool  # the poses came from a saved placement
    composed: Composed
    amodal: list  # amodal 2D box of each object (annotations)
    rendered: np.ndarray  # rendered pixels of each object index (0: none)
    camera: Camera
    camera_json: bytes


#: glibc's mallopt parameter: allocations of at least this many bytes are mapped afresh and
#: given back to the system when freed
_M_MMAP_THRESHOLD = -3
_malloc_fixed = False


def _steady_malloc(threshold: int = 4 << 20) -> None:
    """Fix glibc's mmap threshold (once per process) so that freed image-size arrays go back to
    the system. By default the threshold grows with the largest block freed (up to 32 MB), after
    which 2048x1024 arrays come from the heaps of the threads that made them and stay there:
    streaming 40 image sets, resident memory grew from 600 to 880 MB (peak 1021 MB). With the
    threshold fixed at 4 MB it stayed at 370-480 MB (peak 858 MB), for about 5 % more CPU
    (fresh pages); at 1 MB the same, for 10 %; at 16 MB it grew again (490 -> 640 MB). Limiting
    glibc to one arena did not help. Does nothing without glibc."""
    global _malloc_fixed
    if _malloc_fixed:
        return
    _malloc_fixed = True
    try:
        import ctypes
        import ctypes.util

        name = ctypes.util.find_library("c")
        if name:
            ctypes.CDLL(name).mallopt(_M_MMAP_THRESHOLD, threshold)
    except (OSError, AttributeError):  # not glibc: its own allocator
        pass


def _guarded(ident: ImageSetId, timings: dict[str, float], step: Callable):
    """``step()``, or a ``failed`` outcome when it raises: bad input is reported, never raised."""
    try:
        return step()
    except SynthComposeError as exc:
        return Outcome(ident.key, "failed", str(exc), timings=timings)
    except Exception as exc:  # a bug must not take the rest of the batch down
        log.debug("internal error on %s", ident.key, exc_info=True)
        return Outcome(ident.key, "failed", f"internal error: {type(exc).__name__}: {exc}", timings=timings)


@contextmanager
def _timed(timings: dict[str, float], stage: str) -> Iterator[None]:
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[stage] = timings.get(stage, 0.0) + time.perf_counter() - t0


def _matrix(m: np.ndarray) -> list[list[float]]:
    return [[round(float(v), 6) for v in row] for row in m]


class Pipeline:
    """Processes image sets of one manifest with one GL context."""

    def __init__(self, manifest: Manifest, weights: np.ndarray | None = None, gl_backend: str | None = None,
                 gl_device: int | None = None, gl: GLContext | None = None) -> None:
        """``weights``: probability of choosing each manifest object (default: their weights);
        ``gl_device``: EGL device index (a GPU) for this pipeline's context; ``gl``: work in this
        context instead of making one (the preview window's, :meth:`GLContext.wrap`)."""
        self.manifest = manifest
        self.gl = gl if gl is not None else GLContext(gl_backend, device=gl_device)
        self._own_gl = gl is None  # a context given is its owner's to release
        # --- preview hooks (preview_state.py): see _capture and saved_placement
        self.capture = None  # callable(stage, values): sees the intermediate results, may raise to stop
        self.trace: list | None = None  # a list: gets (candidate point, rejection reason) of every candidate
        self.placement_override = None  # None: the saved file if any; IGNORE_SAVED; or a SavedPlacement
        # --- end preview hooks
        self.renderer = Renderer(self.gl, shading=manifest.shading)
        self.composer = Composer(self.gl)
        if weights is None:
            weights = object_weights([o.weight for o in manifest.objects], [], "weights")
        self._weights = np.asarray(weights, float)

    def close(self) -> None:
        if self._own_gl:
            self.gl.release()

    # --- preview hooks / saved placements (placements.py)
    def _capture(self, stage: str, **values) -> None:
        if self.capture is not None:
            self.capture(stage, values)

    def saved_placement(self, ident: ImageSetId):
        """The poses to use instead of a random placement (placements.py), or None."""
        if self.placement_override is IGNORE_SAVED:
            return None
        if self.placement_override is not None:
            return self.placement_override
        return read_saved(self.manifest.output, ident)
    # --- end preview hooks

    def __enter__(self) -> "Pipeline":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def process(self, ident: ImageSetId) -> Outcome:
        """Run every stage for one image set; never raises for bad input (returns ``failed``)."""
        timings: dict[str, float] = {}
        return _guarded(ident, timings, lambda: self._process(ident, timings))

    def stream(self, idents: Iterable[ImageSetId], on_begin: Callable[[ImageSetId], None] | None = None
               ) -> Iterator[Outcome]:
        """Outcomes of ``idents``, in order, with three image sets in the works at once.

        While one image set is placed, rendered and composed (on this thread: it owns the GL
        context), the next one is prepared (read, its geometry, light and camera measured:
        what depends on the photo alone) and the previous one written, each on a thread of its
        own. OpenCV's codecs and NumPy's array operations release the GIL, so where a core is
        spare the batch is bound by the slowest of the three instead of their sum. The outcome
        of an image set comes after its files are all written. ``idents`` is pulled one ahead
        (by the preparing thread: it may block, e.g. on a worker's pipe); ``on_begin`` is
        called on this thread before an image set's placement starts.
        """
        _steady_malloc()
        source = iter(idents)

        def prepare_next() -> tuple[ImageSetId, dict, "_Prepared | Outcome"] | None:
            ident = next(source, None)
            if ident is None:
                return None
            timings: dict[str, float] = {}
            return ident, timings, _guarded(ident, timings, lambda: self._prepare(ident, timings))

        # BLAS thread pools on top of these threads only contend: our matrices are skinny
        # ((N, 3) by (3, 3)), and OpenBLAS threads spin while waiting - with a pool per process
        # an (N, 3) product took 196 ms instead of 11 on this machine's two busy cores
        with threadpool_limits(limits=1, user_api="blas"), \
                ThreadPoolExecutor(1, "synthcompose-prepare") as preparer, \
                ThreadPoolExecutor(1, "synthcompose-write") as writer:
            preparing = preparer.submit(prepare_next)
            writing = None
            while (item := preparing.result()) is not None:
                preparing = preparer.submit(prepare_next)
                ident, timings, prepared = item
                if on_begin is not None:
                    on_begin(ident)
                result = prepared if isinstance(prepared, Outcome) else \
                    _guarded(ident, timings, lambda: self._compute(ident, prepared, timings))
                if writing is not None:
                    yield writing.result()
                    writing = None
                if isinstance(result, Outcome):
                    yield result
                else:
                    writing = writer.submit(lambda r=result, t=timings, i=ident: _guarded(i, t, lambda: self._write(r, t)))
            if writing is not None:
                yield writing.result()

    def _process(self, ident: ImageSetId, timings: dict[str, float]) -> Outcome:
        """Every stage of one image set on this thread (the preview's hooks stop it early)."""
        result = self._compute(ident, self._prepare(ident, timings), timings)
        return result if isinstance(result, Outcome) else self._write(result, timings)

    def _prepare(self, ident: ImageSetId, timings: dict[str, float]) -> "_Prepared":
        """Everything that depends on the photo alone: read, geometry, its light and camera."""
        m = self.manifest
        with _timed(timings, "read"):
            image_set = read_image_set(m.dataset, ident)
            camera_json = read_input_bytes(ident.path(m.dataset, "camera"), 1 << 20)
        with _timed(timings, "geometry"):
            cam = image_set.camera
            depth = disparity_to_depth(image_set.disparity, cam)
            rng = image_set_rng(m.seed, ident)
            # no labels (test split): road and sidewalk found from the disparity and the photo
            frame, surfaces = frame_for(image_set, depth)
        # --- lighting (lighting.py): the photo's own light, and its camera's blur and noise
        with _timed(timings, "lighting"):
            estimate = match = None
            if m.lighting_mode == "estimate":
                estimate = estimate_lighting(image_set.rgb, frame.label_ids, depth, cam)
            reference = None
            if m.camera_match:
                match = CameraMatch.measure(image_set.rgb, camera_noise_seed(m.seed, ident.key))
                reference = ToneReference.measure(image_set.rgb, image_set.instance_ids if image_set.labelled else None,
                                                  frame.label_ids)
        # --- end lighting
        return _Prepared(image_set, camera_json, depth, frame, surfaces, rng, estimate, match, reference)

    def _compute(self, ident: ImageSetId, prep: "_Prepared", timings: dict[str, float]) -> "_Computed | Outcome":
        """Placement, render and compose: what the writer needs, or the outcome when nothing is placed."""
        m = self.manifest
        image_set, depth, frame, rng, cam = prep.image_set, prep.depth, prep.frame, prep.rng, prep.image_set.camera
        placed: list[tuple[ObjectSpec, Placement, int]] = []
        records, failures = [], []
        taken: set[int] = set()  # instance ids given; with an input polygons file, its numbering too
        src_poly = ident.path(m.dataset, "polygons")
        if src_poly.is_file():
            taken = {cid * INSTANCE_FACTOR + n - 1 for cid, n in polygon_instance_counts(src_poly).items() if n}
        with _timed(timings, "placement"):
            saved = self.saved_placement(ident)  # saved placements: these objects and poses, no draw
            for k in range(m.objects_per_image if saved is None else len(saved.objects)):
                spec = m.objects[int(rng.choice(len(m.objects), p=self._weights))] if saved is None else \
                    _saved_spec(m, saved, k)
                model = load_model(spec.model, spec.size, spec.up, spec.forward)
                result = place_object(frame, spec.class_name, model.extents, rng, m.rules, spec.allowed_surfaces,
                                      spec.orientation, [p for _, p, _ in placed], trace=self.trace) \
                    if saved is None else saved_result(frame, spec.class_name, model.extents, saved.objects[k])
                if result.placement is None:
                    failures.append({"name": spec.name, "class": spec.class_name, "reason": "no valid placement",
                                     "attempts": result.attempts, "rejections": result.rejections})
                    continue
                check = None
                if saved is not None:  # a saved pose is used as it is; the record says whether the
                    # batch's rules accept it (Shift+S in the preview saves a pose that breaks them)
                    why = check_pose(frame, spec.class_name, model.extents, result.placement.matrix, m.rules,
                                     spec.allowed_surfaces, [p for _, p, _ in placed])
                    check = {"ok": True}
                    if why is not None:
                        check = {"ok": False, "rule": why.rule, "reason": why.reason, "detail": why.detail}
                        log.warning("%s: saved pose of %s breaks a placement rule: %s", ident.key, spec.name, why)
                cid = label_id(spec.class_name)
                inst = new_instance_id(image_set.instance_ids, cid, taken)
                taken.add(inst)
                placed.append((spec, result.placement, inst))
                records.append({"result": result, "spec": spec, "instance_id": inst, "model": model, "check": check})
        noise = frame_noise(frame)  # the stereo error: in the record, and the compose's ground band
        record = {
            "synthcompose_version": __version__,
            "image_set": ident.key,
            "config_sha256": m.config_hash,
            "seed": m.seed,
            "source": {k: str(ident.path(m.dataset, k)) for k in ("rgb", "labelIds", "instanceIds", "disparity",
                                                                   "camera")},
            "source_fingerprint": input_fingerprint(m.dataset, ident),  # resume: a changed input is redone
            "labels": "gtFine" if image_set.labelled else prep.surfaces.to_dict(),
            "stereo_noise": noise.to_dict(),
            "lighting": fixed_record(m.lighting, **m.raw.get("lighting", {})) if m.lighting_mode == "fixed"
            else {"mode": "estimate"},  # lighting.py; the estimate replaces it below
            "objects": [],
            "not_placed": failures,
        }
        if saved is not None:  # saved placements
            record["placement_file"] = {"path": str(saved.path) if saved.path else None, "sha256": saved.sha256}
        self._capture("placement", image_set=image_set, frame=frame, depth=depth, records=records,
                      failures=failures, placed=placed, saved=saved)  # preview hook
        if not placed:
            record["status"] = "no valid placement"
            with _timed(timings, "write"):
                write_record(m.output, ident, record)
            reasons = Counter()
            for f in failures:
                reasons.update(f["rejections"])
            why = ", ".join(f"{k} x{v}" for k, v in reasons.most_common(3)) or "no candidates"
            return Outcome(ident.key, "skipped", f"no valid placement ({why})", timings=timings)

        # --- lighting (lighting.py): measured in _prepare
        lighting, estimate, match = m.lighting, prep.estimate, prep.match
        if estimate is not None:
            lighting = estimate.to_lighting(estimate.exposure if m.match_exposure else 1.0)
            record["lighting"] = estimate.to_dict() | {"renderer": lighting.to_dict()}
        if match is not None:
            record["camera_match"] = match.to_dict()
        # --- end lighting
        with _timed(timings, "render"):
            objects = []
            for rec in records:
                spec, pl = rec["spec"], rec["result"].placement
                allowed = [label_id(s) for s in (spec.allowed_surfaces or ALLOWED_SURFACES.get(spec.class_name, ("road",)))]
                albedo = ground_albedo(image_set.rgb, frame, pl, allowed)
                # lighting: an object standing in a real cast shadow gets no sun
                sun = 1.0 if estimate is None else estimate.sun_visibility(int(frame.label_ids[pl.pixel]), albedo)
                # appearance: this object's paint or clothes, drawn apart from the placement's draws
                look = draw_appearance(rec["model"], spec.class_name, appearance_rng(m.seed, ident.key, len(objects))) \
                    if spec.appearance == "varied" else Appearance()
                objects.append(RenderObject(rec["model"], pl.matrix, albedo, sun_visibility=sun,
                                            recolour=look.recolour))
                rec["plane_albedo"], rec["sun_visibility"], rec["appearance"] = albedo, sun, look
            passes = self.renderer.render(cam, objects, lighting, photo=image_set.rgb,  # lighting: real shadows
                                          sun_mask=None if estimate is None else estimate.sun_mask(image_set.rgb, frame.label_ids))
        with _timed(timings, "compose"):
            scene = SceneLayers(image_set.rgb, image_set.label_ids, image_set.instance_ids, image_set.disparity,
                                occluder_depth(depth), cam.baseline * cam.fx * 256.0,
                                ground=np.isin(frame.label_ids, [label_id(n) for n in GROUND_LEVEL]),
                                ground_band=K_SIGMA * noise.sigma_d / noise.focal_baseline)
            classes = [label_id(spec.class_name) for spec, _, _ in placed]
            tones = None
            ids = passes.read("id") if passes is not None else None  # object index per pixel
            if passes is not None and prep.reference is not None:  # lighting: the camera's look on the objects
                fallback = estimate.exposure if estimate is not None and not m.match_exposure else 1.0
                looks = object_tones(passes.read("objc"), ids, classes,
                                     [rec["appearance"].rank for rec in records], prep.reference, fallback, match)
                tones = [(t["gain"], t["saturation"]) for t in looks]
                for rec, t in zip(records, looks):
                    rec["camera_look"] = t
            composed = self.composer.compose(passes, scene, classes, [inst for _, _, inst in placed], match, tones)
            self._capture("compose", passes=passes, composed=composed, scene=scene)  # preview hook
            rendered = np.zeros(len(placed) + 1, np.int64)
            amodal = [None] * len(placed)  # annotations: amodal 2D box of each object
            if passes is not None:
                rendered = np.bincount(ids.ravel(), minlength=len(placed) + 1)
                amodal = amodal_boxes(ids, passes.roi, len(placed))  # annotations
                self.renderer.release(passes)
        return _Computed(ident, record, records, saved is not None, composed, amodal, rendered, cam,
                         prep.camera_json)

    def _write(self, c: "_Computed", timings: dict[str, float]) -> Outcome:
        """The image set's files, the record last (thread-safe: touches no GL and no state of self)."""
        m, ident, record, composed, cam = self.manifest, c.ident, c.record, c.composed, c.camera
        with _timed(timings, "write"):
            write_outputs(m.output, ident, composed, c.camera_json)
            opt_from_v = cam.optical_from_vehicle
            for k, rec in enumerate(c.records, start=1):
                pl, spec = rec["result"].placement, rec["spec"]
                mask = composed.visible == k
                ys, xs = np.nonzero(mask)
                bbox = [int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1] if len(xs) else None
                record["objects"].append({
                    "index": k, "name": spec.name, "model": spec.model, "class": spec.class_name,
                    "allowed_surfaces": list(spec.allowed_surfaces or ALLOWED_SURFACES.get(spec.class_name, ("road",))),
                    "orientation": spec.orientation or ORIENTATION.get(spec.class_name, "along-road"),
                    "label_id": label_id(spec.class_name), "instance_id": rec["instance_id"],
                    "extents_m": list(pl.extents),
                    "pose": {
                        "vehicle": {"matrix": _matrix(pl.matrix), "position_m": [round(float(v), 4) for v in pl.position],
                                    "yaw_deg": round(math.degrees(pl.yaw), 3)},
                        "camera_optical": {"matrix": _matrix(opt_from_v @ pl.matrix),
                                           "position_m": [round(float(v), 4) for v in
                                                          (opt_from_v @ np.append(pl.position, 1.0))[:3]]},
                    },
                    "ground": {"normal": [round(v, 5) for v in pl.ground_normal], "rms_m": round(pl.ground_rms, 4),
                               "albedo_linear": [round(v, 4) for v in rec["plane_albedo"]],
                               "sun_visibility": round(rec["sun_visibility"], 3)},  # lighting
                    "distance_m": round(pl.distance, 3),
                    "road_yaw_deg": None if pl.road_yaw is None else round(math.degrees(pl.road_yaw), 3),
                    "pixel": list(pl.pixel),
                    "bbox_2d": bbox,
                    "visible_pixels": int(mask.sum()),
                    "rendered_pixels": int(c.rendered[k]),
                    "occluded_fraction": round(1.0 - int(mask.sum()) / max(int(c.rendered[k]), 1), 4),
                    "truncated": pl.truncated,
                    "placement": {"attempts": rec["result"].attempts, "rejections": rec["result"].rejections},
                    "appearance": rec["appearance"].to_dict(),
                    **({"camera_look": {k: (round(v, 4) if isinstance(v, float) else v)
                                        for k, v in rec["camera_look"].items()}} if "camera_look" in rec else {}),
                    "placement_source": "saved" if c.saved else "random",  # saved placements
                    **({} if rec["check"] is None else {"placement_check": rec["check"]}),
                })
            # --- annotations (annotations.py): amodal boxes and visible-mask RLE in the record,
            # gtFine polygons and gtBbox3d files; before the record, which is written last
            annotate_objects(record, composed.visible, c.amodal, ident)
            write_frame_annotations(m.output, m.dataset, ident, record, composed.visible, composed.label_ids,
                                    composed.instance_ids, cam)
            # --- end annotations
            record["status"] = "done"
            write_record(m.output, ident, record)
        return Outcome(ident.key, "done", None, len(c.records), timings)
