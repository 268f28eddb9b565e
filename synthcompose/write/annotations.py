"""Ground truth of the inserted objects in the formats detectors and segmenters train on.

Per image set (written next to the other outputs, before the record):

* ``gtFine/<split>/<city>/<name>_gtFine_polygons.json`` - Cityscapes polygons that draw back
  (cityscapesScripts' ``json2labelImg`` / ``json2instanceImg``) to the written labelIds and
  instanceIds (:mod:`synthcompose.write.polygons`). The input's polygons (when it has a polygons
  file) are copied, then one entry per inserted object is appended (its visible pixels):
  Cityscapes draws polygons in file order, later ones on top. Without an input polygons file
  the whole frame is described.
* ``gtBbox3d/<split>/<city>/<name>_gtBbox3d.json`` - Cityscapes 3D boxes, the layout
  cityscapesScripts' ``CsBbox3d`` / ``Box3dImageTransform`` and ``evalObjectDetection3d``
  read (the input's own ``gtBbox3d`` objects are copied first when it has that file).

Per batch: ``coco_instances.json`` in the output root, COCO instances of the inserted
objects of every complete image set under the root, rebuilt from the records alone (each
object record carries its visible mask as COCO RLE), so a resumed batch gets a complete
file too.

Conventions
-----------
* 2D boxes in records: ``[x0, y0, x1, y1]`` in pixels, pixel edges, x1/y1 exclusive (the
  box of pixel columns x0..x1-1). In Cityscapes/COCO files: ``[x0, y0, w, h]`` with
  w = x1 - x0, h = y1 - y0 of the same box.
* Masks are (H, W) bool arrays of full-frame pixels; the *visible* (modal) mask is where
  the object is seen after occlusion by the real scene and the other inserted objects
  (:attr:`Composed.visible`), the *amodal* mask its whole rendered silhouette
  (``RenderPasses.read("id")``), both sampled at pixel centres.
* Polygons: vertices at pixel centres (integer (x, y) = column, row), the way cityscapesScripts
  rasterises them (Pillow ``ImageDraw.polygon``: even-odd, boundary included).
* 3D: vehicle frame V (ISO 8855, metres, see :mod:`synthcompose.camera`); the box centre is
  the centre of the object's box (its footprint centre raised by half its height), the
  rotation the quaternion [w, x, y, z] of V <- object, dimensions [length, width, height].
"""
from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from cityscapesscripts.helpers.labels import name2label
from scipy.spatial.transform import Rotation

from synthcompose.camera import Camera
from synthcompose.errors import InputError
from synthcompose.io.dataset import ImageSetId, read_polygons
from synthcompose.io.files import read_json, write_json
from synthcompose.labels import label_name
from synthcompose.placement import box_corners
from synthcompose.record import ImageSetRecord, ObjectRecord, read_record

from .polygons import frame_polygons, mask_polygon

log = logging.getLogger("synthcompose")

Box = list[int]  # [x0, y0, x1, y1], pixel edges, x1/y1 exclusive

COCO_NAME = "coco_instances.json"


# ------------------------------------------------------------------------------- 2D boxes
def xywh(box: Box) -> list[int]:
    """[x0, y0, x1, y1] -> [x0, y0, w, h]."""
    return [box[0], box[1], box[2] - box[0], box[3] - box[1]]


# ------------------------------------------------------------------------------- polygons
def polygons_document(source: Path | None, objects: Sequence[ObjectRecord], visible: np.ndarray,
                      label_ids: np.ndarray, instance_ids: np.ndarray) -> dict[str, Any]:
    """The gtFine polygons JSON of an augmented image set: it draws back (cityscapesScripts)
    to the written ``label_ids`` and ``instance_ids``.

    ``source``: the input set's ``gtFine_polygons.json`` or None. With it, its entries are
    copied (any extra top-level keys kept) and each inserted object (``objects``: their
    records) is appended as one entry, its visible pixels
    (``visible`` (H, W) uint8: index of the object seen at each pixel), in instance-id order.
    Without it, the whole frame is described from ``label_ids`` / ``instance_ids``
    (:func:`polygons.frame_polygons`).
    """
    h, w = visible.shape
    doc: dict[str, Any] = {"imgHeight": h, "imgWidth": w, "objects": []}
    if source is None:
        doc["objects"] = frame_polygons(label_ids, instance_ids)
        return doc
    data, entries = read_polygons(source)
    if (data.get("imgWidth"), data.get("imgHeight")) != (w, h):
        raise InputError(source, f"polygons JSON is for {data.get('imgWidth')}x{data.get('imgHeight')} "
                                 f"but the image is {w}x{h}")
    doc = dict(data) | {"objects": list(entries)}
    for obj in sorted(objects, key=lambda o: (o.instance_id, o.index)):
        seen = visible == obj.index
        # the parts labelled apart from the object (a sign's pole) first, then the object
        parts = sorted(set(np.unique(label_ids[seen]).tolist()) - {obj.label_id})
        for lid, mask in [(p, seen & (label_ids == p)) for p in parts] + [(obj.label_id, seen & (label_ids == obj.label_id))]:
            poly = mask_polygon(mask)
            if poly is not None:
                doc["objects"].append({"label": label_name(int(lid)), "polygon": poly})
    return doc


# ------------------------------------------------------------------------------- 3D boxes
def bbox3d_path(root: Path, ident: ImageSetId) -> Path:
    """``root/gtBbox3d/<split>/<city>/<name>_gtBbox3d.json`` (Cityscapes 3D layout)."""
    return Path(root) / "gtBbox3d" / ident.split / ident.city / f"{ident.name}_gtBbox3d.json"


def sensor_T_iso8855(camera: Camera) -> np.ndarray:
    """(3, 4) [R^T | -R^T t]: vehicle V (ISO 8855) -> camera C (origin at the optical centre,
    axes as V), the ``sensor_T_ISO_8855`` of Cityscapes 3D (p_C = T @ [p_V, 1])."""
    r = camera.rotation
    return np.hstack([r.T, (-r.T @ camera.position)[:, None]])


def sensor_block(camera: Camera) -> dict[str, Any]:
    """The ``sensor`` object of a gtBbox3d file for this camera."""
    return {"sensor_T_ISO_8855": [[float(v) for v in row] for row in sensor_T_iso8855(camera)],
            "fx": camera.fx, "fy": camera.fy, "u0": camera.u0, "v0": camera.v0, "baseline": camera.baseline}


def box3d(vehicle_from_object: np.ndarray, extents: Sequence[float]) -> dict[str, list[float]]:
    """Cityscapes 3D box of an object: centre (V, metres), dimensions [l, w, h] (metres) and
    rotation quaternion [w, x, y, z] (V <- object, w >= 0).

    ``vehicle_from_object`` (4, 4): object frame (x forward, y left, z up, origin at the
    footprint centre on the ground) -> V; ``extents`` (l, w, h) of the object's box.
    """
    m = np.asarray(vehicle_from_object, float)
    l, w, h = (float(e) for e in extents)
    centre = m[:3, :3] @ np.array([0.0, 0.0, h / 2]) + m[:3, 3]
    x, y, z, qw = Rotation.from_matrix(m[:3, :3]).as_quat()
    q = np.array([qw, x, y, z]) * (1.0 if qw >= 0 else -1.0)
    return {"center": [round(float(v), 4) for v in centre], "dimensions": [round(v, 4) for v in (l, w, h)],
            "rotation": [round(float(v), 8) + 0.0 for v in q]}  # + 0.0: no -0.0


def box3d_corners(vehicle_from_object: np.ndarray, extents: Sequence[float]) -> np.ndarray:
    """(8, 3) corners of the object's box in V, metres."""
    return box_corners(np.asarray(vehicle_from_object, float), extents)


def projected_extent(camera: Camera, vehicle_from_object: np.ndarray, extents: Sequence[float]) -> np.ndarray | None:
    """[u_min, v_min, u_max, v_max] of the box corners projected (pixel-centre coordinates,
    not clipped), or None when a corner is not in front of the camera."""
    pts = box3d_corners(vehicle_from_object, extents)
    m = camera.optical_from_vehicle
    opt = pts @ m[:3, :3].T + m[:3, 3]
    if (opt[:, 2] <= 0.1).any():
        return None
    uv = camera.project(opt)
    return np.array([uv[:, 0].min(), uv[:, 1].min(), uv[:, 0].max(), uv[:, 1].max()])


def truncation(camera: Camera, vehicle_from_object: np.ndarray, extents: Sequence[float]) -> float:
    """Share of the projected 3D box's 2D extent outside the image (0 = whole object inside).

    Pixel centres 0..W-1 cover [-0.5, W - 0.5). 1.0 when part of the box is behind the camera.
    """
    ext = projected_extent(camera, vehicle_from_object, extents)
    if ext is None:
        return 1.0
    full = max(ext[2] - ext[0], 1e-9) * max(ext[3] - ext[1], 1e-9)
    cw = max(min(ext[2], camera.width - 0.5) - max(ext[0], -0.5), 0.0)
    ch = max(min(ext[3], camera.height - 0.5) - max(ext[1], -0.5), 0.0)
    return round(float(np.clip(1.0 - cw * ch / full, 0.0, 1.0)), 4)


def bbox3d_document(camera: Camera, objects: Sequence[ObjectRecord], poses: Sequence[np.ndarray],
                    source: Path | None = None) -> dict[str, Any]:
    """The gtBbox3d JSON of an augmented image set.

    ``objects``: the objects' records; ``poses``: each one's placement matrix (V <- object,
    4x4, as placed, not as rounded in the record); objects seen in no pixel are left out. ``source``: the input set's own
    gtBbox3d file or None; its ``objects`` and ``ignore`` entries are copied first,
    unchanged (their modal boxes do not account for the inserted objects).
    """
    doc: dict[str, Any] = {"imgWidth": camera.width, "imgHeight": camera.height, "sensor": sensor_block(camera),
                           "objects": [], "ignore": []}
    if source is not None:
        data = read_json(source)
        if not isinstance(data, dict) or not isinstance(data.get("objects", []), list) \
                or not isinstance(data.get("ignore", []), list):
            raise InputError(source, "gtBbox3d JSON must be an object with 'objects' and 'ignore' lists")
        doc["objects"] = list(data.get("objects", []))
        doc["ignore"] = list(data.get("ignore", []))
    for obj, pose in zip(objects, poses):
        if obj.bbox_2d is None or obj.bbox_2d_amodal is None:
            continue
        pose = np.asarray(pose, float)
        doc["objects"].append({
            "2d": {"modal": xywh(obj.bbox_2d), "amodal": xywh(obj.bbox_2d_amodal)},
            "3d": box3d(pose, obj.extents_m) | {"type": obj.name, "format": "CRS_ISO8855"},
            "occlusion": obj.occluded_fraction,
            "truncation": truncation(camera, pose, obj.extents_m),
            "instanceId": obj.instance_id,
            "label": obj.class_name,
            "score": 1.0,
        })
    return doc


# ------------------------------------------------------------------ per image set: files
def write_frame_annotations(out_root: Path, dataset_root: Path, ident: ImageSetId, objects: Sequence[ObjectRecord],
                            poses: Sequence[np.ndarray], visible: np.ndarray, label_ids: np.ndarray,
                            instance_ids: np.ndarray, camera: Camera) -> list[Path]:
    """Write the polygons and gtBbox3d files of one augmented image set; returns their paths.

    ``objects``: the objects' records, ``poses`` their placement matrices; the input set's
    polygons and gtBbox3d files under ``dataset_root`` are merged in when they exist;
    ``label_ids`` / ``instance_ids``: the written label images (the polygons describe them).
    """
    src_poly = ident.path(dataset_root, "polygons")
    src_3d = bbox3d_path(dataset_root, ident)
    polygons = polygons_document(src_poly if src_poly.is_file() else None, objects, visible, label_ids,
                                 instance_ids)
    boxes = bbox3d_document(camera, objects, poses, src_3d if src_3d.is_file() else None)
    paths = [ident.path(out_root, "polygons"), bbox3d_path(out_root, ident)]
    write_json(paths[0], polygons)
    write_json(paths[1], boxes)
    return paths


# ------------------------------------------------------------------------ per batch: COCO
def coco_document(out_root: Path) -> dict[str, Any]:
    """COCO instances of the inserted objects of every done record under ``out_root``.

    Images are numbered 1.. in the records' sorted order (``split/city/name``), annotations
    1.. in image then object order. Only the inserted objects are annotated, not the real
    scene's. Category ids are Cityscapes label ids, names Cityscapes class names.
    """
    images, annotations, classes = [], [], {}
    for path in sorted((Path(out_root) / "synthcompose").rglob("*_synthcompose.json")):
        try:
            record = read_record(path)
        except InputError as exc:  # a damaged or malformed record (hand-edited, another tool's)
            log.warning("%s; left out of %s", exc, COCO_NAME)
            continue
        if not record.done:
            continue
        if record.image is None or any(o.mask_rle is None for o in record.objects):
            log.warning("%s: record has no masks (written by an older version); left out of %s", path, COCO_NAME)
            continue
        try:
            image, objects = _coco_entries(record, len(images) + 1, len(annotations))
        except (KeyError, TypeError, ValueError) as exc:
            log.warning("%s: record is malformed (%s: %s); left out of %s", path, type(exc).__name__, exc, COCO_NAME)
            continue
        images.append(image)
        for ann, name in objects:
            classes[ann["category_id"]] = name
            annotations.append(ann)
    categories = [{"id": cid, "name": name, "supercategory": name2label[name].category}
                  for cid, name in sorted(classes.items())]
    return {"info": {"description": "synthcompose: the inserted objects only (not the real scene's)"},
            "licenses": [], "images": images, "annotations": annotations, "categories": categories}


def _coco_entries(record: ImageSetRecord, image_id: int, first: int) -> tuple[dict, list[tuple[dict, str]]]:
    """The COCO image of a done record and its annotations (with their class names), numbered
    from ``image_id`` and ``first`` + 1. Raises KeyError / TypeError / ValueError on a record
    whose values are not what it says."""
    im = record.image
    image = {"id": image_id, "file_name": str(im["file_name"]), "width": int(im["width"]),
             "height": int(im["height"]), "image_set": record.image_set}
    anns = []
    for obj in record.objects:
        if not obj.visible_pixels or obj.bbox_2d is None:
            continue
        if obj.class_name not in name2label:
            raise ValueError(f"unknown class {obj.class_name!r}")
        anns.append(({
            "id": first + len(anns) + 1, "image_id": image_id, "category_id": obj.label_id,
            "bbox": xywh(list(obj.bbox_2d)), "area": obj.visible_pixels,
            "segmentation": dict(obj.mask_rle), "iscrowd": 0, "instance_id": obj.instance_id,
        }, obj.class_name))
    return image, anns


def write_coco(out_root: Path) -> Path:
    """Write ``out_root/coco_instances.json`` (atomically) from the records; returns its path."""
    path = Path(out_root) / COCO_NAME
    write_json(path, coco_document(out_root))
    return path
