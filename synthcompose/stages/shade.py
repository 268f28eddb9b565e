"""Stages 4-5 - light, render and compose the placed objects into the photo -> :class:`Shaded`.

The light (the photo's estimate, or the manifest's fixed light) shades the objects; the
renderer draws them with their ground planes and real shadows; the compose pass puts them into
the photo by differential rendering with the camera's look, hidden where the real scene is in
front. Runs on the thread that owns the GL context.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Mapping

import cv2
import numpy as np

from synthcompose.camera import Camera
from synthcompose.colour import srgb_to_linear
from synthcompose.compose import Composed, Composer, SceneLayers
from synthcompose.geometry.depth import Frame, occluder_fill
from synthcompose.io.files import DISPARITY_SCALE
from synthcompose.labels import byte_counts, label_id, labels_in
from synthcompose.lighting.camera_match import object_tones
from synthcompose.look.appearance import Appearance, appearance_rng, draw_appearance
from synthcompose.placement import GROUND_LEVEL, Placement
from synthcompose.placement.noise import K_SIGMA
from synthcompose.record import ImageSetRecord
from synthcompose.render import Renderer, RenderObject, amodal_boxes, roi_for

from .options import ShadeOptions
from .place import Placed
from .prepare import PhotoLight, Prepared
from .right import LeftShading, shade_right
from .timing import Timings, timed


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


#: the matcher's specks on the ground the compose leaves out: at most this many pixels across
GROUND_SPECK = 11


def occluders_in_rows(depth: np.ndarray, bands: list[slice], ground: np.ndarray,
                      unlabelled: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~synthcompose.geometry.depth.occluder_fill` of ``depth`` and ``ground`` in the rows
    from the first of ``bands`` to the last (holes are filled along rows: the same values there
    as over the whole frame), a hole counted as ground only where no label names it
    (``unlabelled``: found surfaces leave the matcher's holes unnamed), the ground's specks
    closed (:data:`GROUND_SPECK`); elsewhere depth inf and ``ground`` as given (the compose does
    not read them)."""
    out, given = np.full(depth.shape, np.inf, np.float32), ground
    ground = ground.copy()
    if bands:
        r0, r1 = min(b.start for b in bands), max(b.stop for b in bands)
        for a in range(r0, r1, OCCLUDER_ROWS):  # (each row's values are the same as at once)
            b = min(a + OCCLUDER_ROWS, r1)
            out[a:b], ground[a:b] = _occluder_rows(depth, given, unlabelled, a, b)
    return out, ground


#: rows of :func:`occluders_in_rows` worked out at once (with :data:`GROUND_SPECK` rows either
#: side): its temporaries take about 40 bytes a pixel of them (a near car's rows: 30 MB at once)
OCCLUDER_ROWS = 256


def _occluder_rows(depth: np.ndarray, ground: np.ndarray, unlabelled: np.ndarray, r0: int, r1: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`occluders_in_rows`' depth and ground in the rows [r0, r1)."""
    # the rows around them too, so that the closing below reads past the rows' edges (holes are
    # filled along rows)
    p0, p1 = max(r0 - GROUND_SPECK, 0), min(r1 + GROUND_SPECK, depth.shape[0])
    rows, filled = occluder_fill(depth[p0:p1], ground[p0:p1])
    near = ground[p0:p1] | (filled & unlabelled[p0:p1])
    # the ground's depth without the matcher's specks: a few pixels half a pixel of
    # disparity nearer than the road around them hid the inserted shadow there (bright dots
    # in the shadow under a car); a closing (the farther of the nearest) over GROUND_SPECK
    # pixels lifts such pits to the road's depth and keeps its slope; it never brings the
    # ground nearer, so the real ground hides no more of an inserted object than before
    kernel = np.ones((GROUND_SPECK, GROUND_SPECK), np.uint8)
    closed = cv2.morphologyEx(np.minimum(rows, np.float32(1e4)), cv2.MORPH_CLOSE, kernel)
    rows = np.where(near & np.isfinite(rows), closed, rows)
    return rows[r0 - p0:r1 - p0], near[r0 - p0:r1 - p0]


def ground_occluders(depth: np.ndarray, bands: list[slice], labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`occluders_in_rows` with the real ground of ``labels``: the ground whose stereo noise
    must not hide what lies on it (the compose's band over ground). The shade stage gives the
    labels the light was measured on: on a frame without labels the found surfaces completed
    from the depth (``lighting.plan.completed_labels``), so that level ground the finder left
    unnamed, a leafy footway, is ground too (a far person's sun shadow across such a footway came
    out in dashes, where the stereo brought the ground nearer than the shadow's plane)."""
    return occluders_in_rows(depth, bands, labels_in(labels, [label_id(n) for n in GROUND_LEVEL]), labels == 0)


@dataclass(frozen=True, eq=False)
class ObjectLook:
    """How one placed object was shaded."""

    plane_albedo: tuple  # the real ground's linear colour under it
    sun_visibility: float  # 0: it stands in a real cast shadow
    appearance: Appearance  # its paint or clothes
    camera_look: Mapping[str, Any] | None  # the camera's tone on it (gain, saturation, reference, targets)


@dataclass(frozen=True, eq=False)
class Shaded:
    """Everything the write stage needs (no GL object), and the passes asked for."""

    placed: Placed
    looks: tuple[ObjectLook, ...]
    record: ImageSetRecord  # the placement's, with the lighting and camera match
    composed: Composed
    amodal: tuple  # amodal 2D box of each object, or None (annotations)
    rendered: np.ndarray  # rendered pixels of each object index (0: none)
    camera: Camera
    camera_json: bytes
    passes: Mapping[str, np.ndarray]  # name -> copy of the render pass (ROI-sized), for the passes asked for
    roi: tuple | None  # (x0, y0, width, height) of the render's ROI
    right_rgb: np.ndarray | None = None  # (H, W, 3) uint8: the right photo with the objects (stages.right)
    vehicle_json: bytes | None = None  # the input's vehicle file, kept beside the camera's


def shade(renderer: Renderer, composer: Composer, o: ShadeOptions, prep: Prepared, light: PhotoLight, placed: Placed,
          timings: Timings, keep: tuple[str, ...] = ()) -> Shaded:
    """Light, render and compose ``placed`` (at least one object) into the prepared photo, in
    the photo's ``light``; and into the right photo of the pair, when it was read (the
    manifest's ``render.right_view``, :func:`stages.prepare`). ``keep``: render passes to copy out before they are released (the
    preview's)."""
    image_set, frame, cam = prep.image_set, prep.frame, prep.image_set.camera
    record = placed.record
    lighting, estimate, match = o.lighting, light.estimate, light.match
    if estimate is not None:
        lighting = estimate.to_lighting(estimate.exposure if o.match_exposure else 1.0)
        record = record.with_(lighting=estimate.to_dict() | {"renderer": lighting.to_dict()})
    if match is not None:
        record = record.with_(camera_match=match.to_dict())
    looks = []
    # where the sun reaches the real ground: on the labels the light was measured on
    ground_labels = light.labels if light.labels is not None else frame.label_ids
    with timed(timings, "render"):
        objects = []
        for obj in placed.objects:
            spec, pl = obj.spec, obj.placement
            albedo = ground_albedo(image_set.rgb, frame, pl, [label_id(s) for s in spec.allowed_surfaces])
            # an object standing in a real cast shadow gets no sun
            sun = 1.0 if estimate is None else estimate.sun_visibility(int(ground_labels[pl.pixel]), albedo)
            # this object's paint or clothes and its plates, drawn apart from the placement's draws
            look = draw_appearance(obj.model, spec.class_name, appearance_rng(o.seed, prep.ident.key, len(objects))) \
                if spec.appearance == "varied" else Appearance()
            objects.append(RenderObject(obj.model, pl.matrix, albedo, sun_visibility=sun, recolour=look.recolour,
                                        plate=look.plate))
            looks.append((albedo, sun, look))
        sun_mask = None if estimate is None else estimate.sun_mask(image_set.rgb, ground_labels)
        passes = renderer.render(cam, objects, lighting, photo=image_set.rgb,  # real shadows on the objects
                                 sun_mask=sun_mask, scene_depth=prep.depth)
    with timed(timings, "compose"):
        noise = placed.noise
        # the rows the compose passes read: the left region of interest's and the right one's
        rois = [passes.roi if passes is not None else None,
                roi_for(cam.right_camera(), objects, lighting) if image_set.right_rgb is not None else None]
        occluders, ground = ground_occluders(prep.depth, [r.slices[0] for r in rois if r is not None], ground_labels)
        scene = SceneLayers(image_set.rgb, image_set.label_ids, image_set.instance_ids, image_set.disparity,
                            occluders, cam.baseline * cam.fx * DISPARITY_SCALE, ground=ground,
                            ground_band=K_SIGMA * noise.sigma_d / noise.focal_baseline)
        classes = [label_id(o.spec.class_name) for o in placed.objects]
        tones, camera_looks = None, [None] * len(placed.objects)
        # object index per pixel (at most MAX_OBJECTS: a byte, held through the compose)
        ids = passes.read("id").astype(np.uint8) if passes is not None else None
        if ids is not None and any(p.label for o in placed.objects for p in o.model.parts):
            ids[passes.read("part") > 0] = 0  # each object's own class: not a sign's pole
        if passes is not None and light.reference is not None:  # the camera's look on the objects
            fallback = estimate.exposure if estimate is not None and not o.match_exposure else 1.0
            camera_looks = object_tones(passes.read("objc", widen=False), ids, classes, [look.rank for _, _, look in looks],
                                        light.reference, fallback, match)
            tones = [(t["gain"], t["saturation"]) for t in camera_looks]
        instances = [o.instance_id for o in placed.objects]
        composed = composer.compose(passes, scene, classes, instances, match, tones)
        n = len(placed.objects)
        rendered = np.zeros(n + 1, np.int64)
        amodal = [None] * n  # amodal 2D box of each object
        kept, roi = {}, None
        if passes is not None:
            rendered = byte_counts(ids)[:n + 1]  # (object indices 1..n)
            amodal = amodal_boxes(ids, passes.roi, n)
            kept = {k: passes.read(k).copy() for k in keep if k in passes.textures}
            roi = (passes.roi.x0, passes.roi.y0, passes.roi.width, passes.roi.height)
            renderer.release(passes)
    right_rgb = None
    if image_set.right_rgb is not None:
        with timed(timings, "right"):
            right_rgb = shade_right(renderer, composer, prep, LeftShading(objects, lighting, sun_mask, scene, classes,
                                                                          instances, match, tones))
    return Shaded(placed, tuple(ObjectLook(a, s, lk, None if c is None else MappingProxyType(c))
                                  for (a, s, lk), c in zip(looks, camera_looks)), record,
                  composed, tuple(amodal), rendered, cam, prep.camera_json, MappingProxyType(kept), roi, right_rgb,
                  prep.vehicle_json)
