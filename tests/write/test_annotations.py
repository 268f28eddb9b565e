"""Ground truth of the inserted objects: Cityscapes polygons, 2D boxes, Cityscapes 3D boxes
(checked with cityscapesScripts' own loader and projection) and the batch's COCO file
(checked with pycocotools)."""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from cityscapesscripts.helpers.annotation import Annotation, CsBbox3d, CsObjectType, CsPoly
from cityscapesscripts.helpers.box3dImageTransform import CRS_S, CRS_V, Box3dImageTransform
from cityscapesscripts.helpers.box3dImageTransform import Camera as CsCamera
from cityscapesscripts.preparation.json2instanceImg import createInstanceImage
from cityscapesscripts.preparation.json2labelImg import createLabelImage
from pycocotools.coco import COCO

from synthcompose.camera import Camera
from synthcompose.cli import main
from synthcompose.io.dataset import ImageSetId, read_image_set
from synthcompose.io.files import decode_rle, encode_rle
from synthcompose.labels import HAS_INSTANCES
from synthcompose.render import mask_box
from synthcompose.write.annotations import COCO_NAME, bbox3d_path, box3d_corners
from synthcompose.write.polygons import draw_polygons, frame_polygons, mask_polygon

from ..helpers import drawn_back, write_manifest

# the tolerances, from the one table; imported from here too (test_ecosystem, test_real_polygons)
from ..tolerances import CORNER_M, CORNER_PX, INSTANCES_DRAWN_BACK, LABELS_DRAWN_BACK, POLYGON_MIN_IOU, SILHOUETTE_PX

W, H = 640, 320


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


# ------------------------------------------------------------------ polygons, no GL needed
def _filled(poly, shape) -> np.ndarray:
    return draw_polygons([(poly, 1)], shape).astype(bool)


def test_one_polygon_per_mask_keeps_its_holes_and_joins_its_parts():
    mask = np.zeros((40, 50), bool)
    mask[5:35, 5:45] = True
    mask[15:25, 15:25] = False  # a large hole: stays open
    mask[30, 40] = False  # a one-pixel hole: stays open too
    mask[8:10, 30:32] = False  # a hole just under the top edge
    filled = _filled(mask_polygon(mask), mask.shape)
    assert (filled == mask).all()  # one part: exactly its pixels (Pillow's even-odd fill)
    mask[2, 2] = True  # a one-pixel part: a speck, left out
    mask[37, 10:20] = True  # a one-pixel-thick part: joined by a bridge down the gap
    filled = _filled(mask_polygon(mask), mask.shape)
    extra = filled & ~mask
    assert not filled[2, 2] and filled[37, 10:20].all() and (filled | ~mask)[:, 3:].all()
    assert extra.sum() == 2  # the bridge: rows 35 and 36 of one column
    assert mask_polygon(np.zeros((4, 4), bool)) is None


def test_polygons_of_random_masks_draw_back_to_the_mask_and_their_bridges():
    rng = np.random.default_rng(3)
    for _ in range(50):
        mask = np.zeros((60, 80), np.uint8)
        for _ in range(int(rng.integers(1, 5))):
            cv2.ellipse(mask, (int(rng.integers(0, 80)), int(rng.integers(0, 60))),
                        (int(rng.integers(1, 25)), int(rng.integers(1, 20))), float(rng.uniform(0, 180)), 0, 360, 1, -1)
        for _ in range(int(rng.integers(0, 6))):
            cv2.circle(mask, (int(rng.integers(0, 80)), int(rng.integers(0, 60))), int(rng.integers(0, 5)), 0, -1)
        mask = mask.astype(bool)
        filled = _filled(mask_polygon(mask, min_part_pixels=1), mask.shape)
        assert filled[mask].all()  # every pixel, holes left open
        parts = cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)[0] - 1
        if parts == 1:
            assert (filled == mask).all()
        else:  # the rest: the bridges between parts, each no longer than the gap it crosses
            assert (filled & ~mask).sum() <= (parts - 1) * 80


def _frame(with_gap: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A small labelled frame: road with a sidewalk, a building with a window of sky, cars
    (one split by a pole, one around a hole, one skipped id), a person group, a traffic sign."""
    lab = np.zeros((60, 100), np.uint8)
    lab[30:, :] = 7  # road
    lab[25:30, :] = 8  # sidewalk
    lab[:25, :] = 11  # building
    lab[5:10, 40:50] = 23  # a window of sky in the building (a hole, filled, sky drawn after)
    inst = lab.astype(np.int32).copy()
    lab[35:50, 10:40] = 26
    inst[35:50, 10:40] = 26000
    lab[35:50, 55:80] = 26
    inst[35:50, 55:80] = 26002 if with_gap else 26001  # id 26001 hidden: skipped
    lab[40:44, 62:70] = 20  # a sign in front of the car (a hole in it)
    inst[40:44, 62:70] = 20
    lab[20:58, 24:27] = 17  # a pole in front of the first car: splits it in two
    inst[20:58, 24:27] = 17
    lab[52:58, 85:95] = 24  # a group of people
    inst[52:58, 85:95] = 24
    lab[0:3, 0:3] = 0  # unlabeled corner
    inst[0:3, 0:3] = 0
    return lab, inst


@pytest.mark.parametrize("with_gap", [True, False])
def test_frame_polygons_draw_back_to_the_labels_with_cityscapesscripts(with_gap):
    lab, inst = _frame(with_gap)
    objects = frame_polygons(lab, inst)
    labels, instances = drawn_back(objects, lab.shape)
    assert (labels == lab).all() and (instances == inst).all()
    cars = [o for o in objects if o["label"] == "car"]
    assert len(cars) == (3 if with_gap else 2)  # one entry per instance, a one-pixel one for the gap
    assert {o["label"] for o in objects} == {"road", "sidewalk", "building", "sky", "car", "traffic sign", "pole",
                                             "persongroup"}


def test_frame_polygons_of_random_label_images_draw_back():
    rng = np.random.default_rng(5)
    for _ in range(10):
        lab = np.full((80, 120), 7, np.uint8)
        inst = lab.astype(np.int32).copy()
        for k in range(int(rng.integers(3, 12))):
            lid = int(rng.choice([11, 17, 20, 21, 24, 26]))
            c = (int(rng.integers(0, 120)), int(rng.integers(0, 80)))
            axes = (int(rng.integers(2, 30)), int(rng.integers(2, 20)))
            m = np.zeros(lab.shape, np.uint8)
            cv2.ellipse(m, c, axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
            lab[m > 0] = lid
            inst[m > 0] = lid * 1000 + k if lid in (24, 26) else lid
        labels, instances = drawn_back(frame_polygons(lab, inst), lab.shape)
        assert (labels == lab).mean() >= LABELS_DRAWN_BACK and (instances == inst).mean() >= INSTANCES_DRAWN_BACK


def test_mask_box_is_pixel_edges_exclusive():
    mask = np.zeros((10, 12), bool)
    mask[2:5, 3:9] = True
    assert mask_box(mask) == [3, 2, 9, 5]
    assert mask_box(mask, 100, 200) == [103, 202, 109, 205]
    assert mask_box(np.zeros((4, 4), bool)) is None


def test_sensor_matrix_matches_a_real_cityscapes_3d_file():
    """sensor_T_ISO_8855 = [R^T | -R^T t] from camera.json's extrinsics reproduces the matrix a
    Cityscapes 3D gtBbox3d file gives for that calibration (x 1.7, y 0.1, z 1.22, yaw -0.0195,
    pitch 0.038, roll 0), digit for digit."""
    from synthcompose.write.annotations import sensor_T_iso8855

    cam = Camera(fx=2262.52, fy=2265.3017905988554, u0=1096.98, v0=513.137, baseline=0.209313, x=1.7, y=0.1,
                 z=1.22, yaw=-0.0195, pitch=0.038, roll=0.0, width=2048, height=1024)
    published = [[0.9990881051503779, -0.01948468779721943, -0.03799085532693703, -1.6501524664770573],
                 [0.019498764210995674, 0.9998098810245096, 0.0, -0.1331288872611436],
                 [0.03798363254444427, -0.0007407747301939942, 0.9992780868764849, -1.2836173638418473]]
    assert np.abs(sensor_T_iso8855(cam) - np.array(published)).max() < 1e-12


# ------------------------------------------------------------------------- end to end
def _records(out: Path, ids: list[ImageSetId]) -> list[dict]:
    records = [json.loads(i.path(out, "record").read_text()) for i in ids]
    assert all(r["status"] == "done" and r["objects"] for r in records)
    return records


def _visible_masks(root: Path, out: Path, ident: ImageSetId, record: dict) -> dict[int, np.ndarray]:
    """Each object's visible mask from its record RLE, checked against the written ids."""
    src, res = read_image_set(root, ident), read_image_set(out, ident)
    masks = {}
    for obj in record["objects"]:
        mask = decode_rle(obj["mask_rle"])
        assert mask.shape == (H, W) and mask.sum() == obj["visible_pixels"]
        assert mask_box(mask) == obj["bbox_2d"]
        if HAS_INSTANCES[obj["label_id"]]:
            assert (mask == (res.instance_ids == obj["instance_id"])).all()
        else:  # plain class id: the object's pixels are among the new pixels of its class
            assert (res.label_ids[mask] == obj["label_id"]).all()
            assert (src.instance_ids[mask] != obj["instance_id"]).all()
        masks[obj["index"]] = mask
    return masks


def test_every_annotation_file_is_written(annotated_batch):
    _, out, ids = annotated_batch
    for ident in ids:
        assert ident.path(out, "polygons").is_file()
        assert bbox3d_path(out, ident).is_file()
    assert (out / COCO_NAME).is_file()


def test_amodal_box_holds_the_modal_box(annotated_batch):
    _, out, ids = annotated_batch
    for record in _records(out, ids):
        for obj in record["objects"]:
            m, a = obj["bbox_2d"], obj["bbox_2d_amodal"]
            assert a[0] <= m[0] and a[1] <= m[1] and m[2] <= a[2] and m[3] <= a[3]
            assert 0 <= a[0] < a[2] <= W and 0 <= a[1] < a[3] <= H
            if obj["occluded_fraction"] == 0:
                assert a == m


def test_polygons_draw_back_to_the_written_labels(annotated_batch):
    """cityscapesScripts' json2labelImg / json2instanceImg drawing of the polygons file gives
    the written labelIds and instanceIds: the whole frame, one entry per instance."""
    root, out, ids = annotated_batch
    for ident, record in zip(ids, _records(out, ids)):
        masks = _visible_masks(root, out, ident, record)
        res = read_image_set(out, ident)
        ann = Annotation()
        ann.fromJsonFile(str(ident.path(out, "polygons")))
        assert (ann.imgWidth, ann.imgHeight) == (W, H)
        assert ann.objects and all(isinstance(o, CsPoly) for o in ann.objects)
        labels = np.array(createLabelImage(ann, "ids"))
        instances = np.array(createInstanceImage(ann, "ids")).astype(np.int64)
        assert (labels == res.label_ids).mean() >= LABELS_DRAWN_BACK, ident
        assert (instances == res.instance_ids).mean() >= INSTANCES_DRAWN_BACK, ident
        for obj in record["objects"]:
            assert (labels[masks[obj["index"]]] == obj["label_id"]).mean() >= POLYGON_MIN_IOU
            if HAS_INSTANCES[obj["label_id"]]:
                assert (instances[masks[obj["index"]]] == obj["instance_id"]).mean() >= POLYGON_MIN_IOU
        doc = json.loads(ident.path(out, "polygons").read_text())
        source = ident.path(root, "polygons")
        if source.is_file():  # the input's objects first, unchanged, then one entry per object
            kept = json.loads(source.read_text())["objects"]
            assert doc["objects"][:len(kept)] == kept
            new = doc["objects"][len(kept):]
            assert len(new) == len(record["objects"]) and all(set(o) == {"label", "polygon"} for o in new)
            before = Annotation()
            before.fromJsonFile(str(source))
            changed = np.array(createLabelImage(before, "ids")) != labels
            union = np.any(list(masks.values()), axis=0)
            assert (changed & ~union).sum() <= 0.02 * union.sum()  # only the objects' pixels change


def _cs_corner_order(pose: np.ndarray, extents) -> np.ndarray:
    """Our box corners in V in cityscapesScripts' order BLB BRB FRB FLB BLT BRT FRT FLT
    (back = -x, left = +y, bottom = z 0)."""
    l, w, h = extents
    local = np.array([[-l / 2, w / 2, 0], [-l / 2, -w / 2, 0], [l / 2, -w / 2, 0], [l / 2, w / 2, 0],
                      [-l / 2, w / 2, h], [-l / 2, -w / 2, h], [l / 2, -w / 2, h], [l / 2, w / 2, h]])
    return local @ pose[:3, :3].T + pose[:3, 3]


def test_3d_boxes_load_and_project_with_cityscapesscripts(annotated_batch):
    root, out, ids = annotated_batch
    for ident, record in zip(ids, _records(out, ids)):
        path = bbox3d_path(out, ident)
        ann = Annotation(CsObjectType.BBOX3D)
        ann.fromJsonFile(str(path))
        boxes = [o for o in ann.objects if isinstance(o, CsBbox3d)]
        data = json.loads(path.read_text())
        assert (ann.imgWidth, ann.imgHeight) == (W, H) and "ignore" in data
        cam = Camera.read(ident.path(out, "camera"), W, H)
        sensor = data["sensor"]
        assert [sensor[k] for k in ("fx", "fy", "u0", "v0", "baseline")] == [cam.fx, cam.fy, cam.u0, cam.v0,
                                                                            cam.baseline]
        cs_cam = CsCamera(sensor["fx"], sensor["fy"], sensor["u0"], sensor["v0"], sensor["sensor_T_ISO_8855"],
                          imgWidth=W, imgHeight=H)
        kept = 1 if ident == ids[0] else 0  # the input's own box comes first
        if kept:
            assert boxes[0].instanceId == 26000 and data["ignore"][0]["2d"] == [0, 0, 10, 10]
        ours = boxes[kept:]
        assert len(ours) == len(record["objects"])
        for box, obj in zip(ours, record["objects"]):
            pose = np.array(obj["pose"]["vehicle"]["matrix"])
            assert box.label == obj["class"] and box.instanceId == obj["instance_id"] and box.score == 1.0
            assert box.bbox_2d.bbox_modal == obj["bbox_2d"] and box.bbox_2d.bbox_amodal == obj["bbox_2d_amodal"]
            assert box.dims == pytest.approx(obj["extents_m"], abs=1e-4)
            t = Box3dImageTransform(cs_cam)
            t.initialize_box_from_annotation(box, coordinate_system=CRS_V)
            corners_v = _cs_corner_order(pose, obj["extents_m"])
            # centre and rotation: the same box in the vehicle frame
            got_v = np.array(list(t.get_vertices(CRS_V).values()))
            assert np.abs(got_v - corners_v).max() < CORNER_M
            # sensor_T_ISO_8855: V -> C; cityscapesScripts' S frame is our optical frame
            opt = corners_v @ cam.optical_from_vehicle[:3, :3].T + cam.optical_from_vehicle[:3, 3]
            assert np.abs(np.array(list(t.get_vertices(CRS_S).values())) - opt).max() < CORNER_M
            # its projection = ours (pixel-centre coordinates)
            uv_cs = np.array(list(t.get_vertices_2d().values()))
            assert np.abs(uv_cs - cam.project(opt)).max() < CORNER_PX
            # the rendered silhouette (pixel centres x0..x1-1) lies inside the projected box
            u0, v0 = uv_cs.min(0)
            u1, v1 = uv_cs.max(0)
            a = obj["bbox_2d_amodal"]
            assert a[0] >= u0 - SILHOUETTE_PX and a[2] - 1 <= u1 + SILHOUETTE_PX
            assert a[1] >= v0 - SILHOUETTE_PX and a[3] - 1 <= v1 + SILHOUETTE_PX
            # and fills most of it (a car or a sign is nearly as wide and tall as its box)
            assert (a[2] - 1 - a[0]) >= 0.6 * (u1 - u0) and (a[3] - 1 - a[1]) >= 0.6 * (v1 - v0)
            # cityscapesScripts' own amodal box (clipped corners; x/y max inclusive)
            cs_box = t.get_amodal_box_2d()
            assert cs_box[0] <= a[0] + SILHOUETTE_PX and cs_box[2] >= a[2] - 1 - SILHOUETTE_PX
            assert np.allclose(box3d_corners(pose, obj["extents_m"]).mean(0), box.center, atol=1e-3)


def test_coco_file_loads_and_matches_the_instance_masks(annotated_batch):
    root, out, ids = annotated_batch
    coco = COCO(str(out / COCO_NAME))
    records = _records(out, ids)
    assert len(coco.getImgIds()) == len(ids)
    classes = {o["label_id"]: o["class"] for r in records for o in r["objects"]}
    assert {c["id"]: c["name"] for c in coco.loadCats(coco.getCatIds())} == classes
    for ident, record in zip(ids, records):
        (img,) = [i for i in coco.loadImgs(coco.getImgIds()) if i["image_set"] == ident.key]
        assert (out / img["file_name"]).resolve() == ident.path(out, "rgb").resolve()
        assert (img["width"], img["height"]) == (W, H)
        masks = _visible_masks(root, out, ident, record)
        anns = coco.loadAnns(coco.getAnnIds(imgIds=[img["id"]]))
        assert len(anns) == len(record["objects"])
        res = read_image_set(out, ident)
        for ann, obj in zip(anns, record["objects"]):
            mask = coco.annToMask(ann).astype(bool)
            assert ann["category_id"] == obj["label_id"] and ann["iscrowd"] == 0
            assert (mask == masks[obj["index"]]).all()
            if HAS_INSTANCES[obj["label_id"]]:
                assert (mask == (res.instance_ids == obj["instance_id"])).all()
            ys, xs = np.nonzero(mask)
            assert ann["bbox"] == [xs.min(), ys.min(), xs.max() + 1 - xs.min(), ys.max() + 1 - ys.min()]
            assert ann["area"] == mask.sum() == obj["visible_pixels"]


def test_coco_file_is_rebuilt_from_the_records_on_resume(annotated_batch, tmp_path):
    root, out, ids = annotated_batch
    first = (out / COCO_NAME).read_bytes()
    (out / COCO_NAME).unlink()
    manifest = write_manifest(tmp_path / "m.json", root, out)  # same configuration: every set is resumed
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed"] == len(ids)
    assert (out / COCO_NAME).read_bytes() == first


# ------------------------------------------------------------- an object behind a real pole
def test_object_behind_a_real_pole_boxes_and_polygons(gl_clean, tmp_path):
    from synthcompose.compose import Composer, SceneLayers
    from synthcompose.geometry.depth import disparity_to_depth, occluder_depth
    from synthcompose.labels import label_id
    from synthcompose.models import load_model
    from synthcompose.render import Lighting, Renderer, RenderObject, amodal_boxes
    from synthcompose.synthetic import random_scene, render_scene
    from synthcompose.write.annotations import bbox3d_document, polygons_document

    from ..helpers import pose_behind_a_pole

    scene = random_scene(np.random.default_rng([11, 0]), 1024, 512)
    arrays = render_scene(scene)
    cam = scene.camera
    pose = pose_behind_a_pole(scene)  # a car on the road just behind a pole
    model = load_model("builtin:box", (("length", 1.6),))
    renderer, composer = Renderer(gl_clean), Composer(gl_clean)
    passes = renderer.render(cam, [RenderObject(model, pose, (0.2, 0.2, 0.2))], Lighting.daylight(),
                             photo=arrays["rgb"])
    (amodal,) = amodal_boxes(passes.read("id"), passes.roi, 1)
    silhouette = np.zeros((cam.height, cam.width), bool)
    silhouette[passes.roi.slices] = passes.read("id") == 1
    car = label_id("car")
    scene_layers = SceneLayers(arrays["rgb"], arrays["label_ids"], arrays["instance_ids"].astype(np.int32),
                               arrays["disparity"], occluder_depth(disparity_to_depth(arrays["disparity"], cam)),
                               cam.baseline * cam.fx * 256)
    out = composer.compose(passes, scene_layers, [car], [car * 1000 + 99])
    renderer.release(passes)
    visible = out.visible == 1
    hidden = silhouette & ~visible
    assert (arrays["label_ids"][hidden] == label_id("pole")).sum() > 5, "the pole should hide part of the car"
    assert amodal == mask_box(silhouette) and mask_box(visible) is not None

    # the record entries the pipeline makes, then the annotation documents
    # the object's record as the write stage makes it, then the annotation documents
    from synthcompose.record import ObjectPose, ObjectRecord
    obj = ObjectRecord(
        index=1, name="box", model="builtin:box", class_name="car", allowed_surfaces=("road",),
        orientation="along-road", label_id=car, instance_id=car * 1000 + 99, extents_m=tuple(model.extents),
        pose=ObjectPose.of(pose, cam.optical_from_vehicle, pose[:3, 3], 0.0), ground={}, distance_m=0.0,
        road_yaw_deg=None, pixel=(0, 0), bbox_2d=tuple(mask_box(visible)), visible_pixels=int(visible.sum()),
        rendered_pixels=int(silhouette.sum()), occluded_fraction=round(float(hidden.sum() / silhouette.sum()), 4),
        truncated=False, placement={}, appearance={}, camera_look=None, placement_source="random",
        placement_check=None, bbox_2d_amodal=tuple(amodal), mask_rle=encode_rle(visible))
    assert (decode_rle(obj.to_json()["mask_rle"]) == visible).all()
    assert ObjectRecord.from_json(json.loads(json.dumps(obj.to_json()))) == obj  # the record round-trips
    record = {"objects": [obj]}

    # appended to the scene's own polygons: one entry, drawn on top, leaving the pole in front alone
    source = tmp_path / "polygons.json"
    source.write_text(json.dumps({"imgHeight": cam.height, "imgWidth": cam.width,
                                  "objects": frame_polygons(arrays["label_ids"], arrays["instance_ids"])}))
    doc = polygons_document(source, record["objects"], out.visible, out.label_ids, out.instance_ids)
    (entry,) = doc["objects"][len(json.loads(source.read_text())["objects"]):]
    assert entry["label"] == "car"
    filled = _filled(entry["polygon"], visible.shape)
    assert _iou(filled, visible) >= POLYGON_MIN_IOU
    assert (filled & hidden).sum() <= 0.02 * visible.sum()  # the bridges across the pole
    labels, instances = drawn_back(doc["objects"], visible.shape)
    assert (labels == out.label_ids).mean() >= LABELS_DRAWN_BACK
    assert (instances == out.instance_ids).mean() >= INSTANCES_DRAWN_BACK
    # without the scene's polygons: the whole frame, drawn back
    whole = polygons_document(None, record["objects"], out.visible, out.label_ids, out.instance_ids)
    labels, instances = drawn_back(whole["objects"], visible.shape)
    assert (labels == out.label_ids).mean() >= LABELS_DRAWN_BACK
    assert (instances == out.instance_ids).mean() >= INSTANCES_DRAWN_BACK

    boxes = bbox3d_document(cam, record["objects"], [pose])
    (entry,) = boxes["objects"]
    # (the pole hides a strip inside the box: the modal box may equal the amodal one)
    x, y, w, h = entry["2d"]["amodal"]
    m = entry["2d"]["modal"]
    assert x <= m[0] and y <= m[1] and m[0] + m[2] <= x + w and m[1] + m[3] <= y + h
    assert entry["occlusion"] == obj.occluded_fraction > 0 and entry["truncation"] == 0.0
