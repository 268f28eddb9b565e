"""Stage 1 - read: find Cityscapes image sets under a root and read them, checked.

Layout (cityscapesScripts ``csHelpers``: file names are ``city_seq_frame_type.ext``)::

    leftImg8bit/<split>/<city>/<city>_<seq>_<frame>_leftImg8bit.png     8-bit RGB
    rightImg8bit/<split>/<city>/<city>_<seq>_<frame>_rightImg8bit.png   8-bit RGB (optional)
    gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_labelIds.png      8-bit label ids
    gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_instanceIds.png   16-bit instance ids
    gtFine/<split>/<city>/<city>_<seq>_<frame>_gtFine_color.png         RGBA colours
    disparity/<split>/<city>/<city>_<seq>_<frame>_disparity.png         16-bit, d = (p-1)/256
    camera/<split>/<city>/<city>_<seq>_<frame>_camera.json              calibration
    vehicle/<split>/<city>/<city>_<seq>_<frame>_vehicle.json            GPS heading (optional)
"""
from __future__ import annotations

import os
import re
import stat
import unicodedata
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from cityscapesscripts.helpers.labels import name2label

from synthcompose.camera import Camera
from synthcompose.errors import InputError
from synthcompose.labels import KNOWN_IDS, byte_counts

from .files import decode_disparity, map_threads, read_json, read_png
from .vehicle import Vehicle, read_vehicle

#: ``city_seq_frame_leftImg8bit.png``: a city is any name without "_" (spaces and letters of any
#: script too: "bad homburg", "münchen"), the sequence and frame numbers are ASCII digits
_NAME = re.compile(r"^(?P<city>[^_/]+)_(?P<seq>[0-9]+)_(?P<frame>[0-9]+)_leftImg8bit\.png$")


@dataclass(frozen=True, order=True)
class ImageSetId:
    """Names one image set: ``split/city/city_seq_frame``."""

    split: str
    city: str
    seq: str
    frame: str

    @property
    def name(self) -> str:
        """``city_seq_frame``, the prefix of every file of the set."""
        return f"{self.city}_{self.seq}_{self.frame}"

    @property
    def key(self) -> str:
        return f"{self.split}/{self.city}/{self.name}"

    def path(self, root: Path, kind: str) -> Path:
        """Path of one file of the set under a Cityscapes root; ``kind`` is a file type."""
        folder, suffix = _KINDS[kind]
        return Path(root) / folder / self.split / self.city / f"{self.name}_{suffix}"


#: file type -> (top folder, file-name suffix)
_KINDS = {
    "rgb": ("leftImg8bit", "leftImg8bit.png"),
    "right": ("rightImg8bit", "rightImg8bit.png"),
    "labelIds": ("gtFine", "gtFine_labelIds.png"),
    "instanceIds": ("gtFine", "gtFine_instanceIds.png"),
    "color": ("gtFine", "gtFine_color.png"),
    "polygons": ("gtFine", "gtFine_polygons.json"),
    "disparity": ("disparity", "disparity.png"),
    "camera": ("camera", "camera.json"),
    "vehicle": ("vehicle", "vehicle.json"),
    "record": ("synthcompose", "synthcompose.json"),
}


def parse_name(split: str, filename: str) -> ImageSetId | None:
    m = _NAME.match(filename)
    if not m:
        return None
    return ImageSetId(split, m["city"], m["seq"], m["frame"])


def nfc(name: str) -> str:
    """A folder or frame name in Unicode's composed form (NFC): names are compared so, and a
    manifest's "münchen" selects a folder a Mac wrote as "mu" + combining diaeresis + "nchen"."""
    return unicodedata.normalize("NFC", name)


def list_folder(folder: Path) -> list[os.DirEntry]:
    """The entries of a dataset folder, sorted by name, or an :class:`InputError` naming it when
    it cannot be listed (no permission, a link loop, not a folder)."""
    try:
        with os.scandir(folder) as it:
            return sorted(it, key=lambda e: e.name)
    except OSError as exc:
        raise InputError(folder, f"folder cannot be listed ({exc.strerror or exc})") from None


def subfolders(folder: Path, wanted=None, skip_broken: bool = False) -> list[Path]:
    """The folders in ``folder`` (links to folders too) whose NFC names are in ``wanted`` (all
    when None). A wanted entry that is a link that cannot be followed (a loop, a link to
    nothing) is an :class:`InputError` naming it, not a folder silently left out (``skip_broken``:
    left out, for listings that only explain)."""
    out = []
    for entry in list_folder(folder):
        if wanted is not None and nfc(entry.name) not in wanted:
            continue
        try:
            os.stat(entry.path)  # follows links
        except OSError as exc:
            if skip_broken:
                continue
            raise InputError(entry.path, f"cannot be followed ({exc.strerror or exc})") from None
        if entry.is_dir():
            out.append(Path(entry.path))
    return out


def _folder(path: Path, what: str) -> None:
    """An :class:`InputError` naming ``path`` unless it is a folder (links followed)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(path, f"{what} is missing") from None
    except OSError as exc:
        raise InputError(path, f"{what} cannot be followed ({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(path, f"{what} is not a folder")


def find_image_sets(root: Path, splits=None, cities=None, frames=None, skip_broken: bool = False
                    ) -> list[ImageSetId]:
    """Every image set under ``root/leftImg8bit/<split>/<city>/``, sorted.

    ``splits`` defaults to every split folder present; ``cities`` and ``frames``
    (``city_seq_frame`` names) narrow the selection when given (names compared in NFC). A
    folder that cannot be listed is an :class:`InputError` naming it (never silently empty),
    unless ``skip_broken`` (then it is left out: a listing that only explains a selection).
    """
    root = Path(root)
    _folder(root, "dataset root")
    _folder(root / "leftImg8bit", "the dataset root's leftImg8bit folder (its photos)")
    if splits is None:
        splits = [p.name for p in subfolders(root / "leftImg8bit", skip_broken=skip_broken)]
    city_set = None if cities is None else {nfc(c) for c in cities}
    frame_set = None if frames is None else {nfc(f) for f in frames}
    found: list[ImageSetId] = []
    for split in splits:
        split_dir = root / "leftImg8bit" / split
        _folder(split_dir, f"split folder (split {split!r})")
        for city_dir in subfolders(split_dir, city_set, skip_broken):
            try:
                entries = list_folder(city_dir)
            except InputError:
                if skip_broken:
                    continue
                raise
            for entry in entries:
                ident = parse_name(split, entry.name) if entry.name.endswith("_leftImg8bit.png") else None
                if ident is None or ident.city != city_dir.name:
                    continue
                if frame_set is not None and nfc(ident.name) not in frame_set:
                    continue
                found.append(ident)
    return sorted(found)


def labelled_twin(root: Path, ident: ImageSetId) -> ImageSetId | None:
    """The image set of the same city, sequence and frame under ``root`` that has gtFine labels,
    in any of the train, val and test splits (a labelled copy of an unlabelled set, as in the
    development set), or None."""
    for split in ("train", "val", "test"):
        twin = ImageSetId(split, ident.city, ident.seq, ident.frame)
        if twin.path(root, "labelIds").exists():
            return twin
    return None


@dataclass(frozen=True, eq=False)
class ImageSet:
    """One frame's data, checked for shape and type.

    rgb          : (H, W, 3) uint8, sRGB
    label_ids    : (H, W) uint8, Cityscapes label ids
    instance_ids : (H, W) uint16 (the file's), id*1000+k for instance classes, plain label id elsewhere
    disparity    : (H, W) uint16, Cityscapes encoding (p=0 invalid, d=(p-1)/256 px)
    camera       : the frame's own calibration
    vehicle      : its GPS heading and position (Cityscapes' vehicle file), None without one
    """

    ident: ImageSetId
    rgb: np.ndarray
    label_ids: np.ndarray
    instance_ids: np.ndarray
    disparity: np.ndarray
    camera: Camera
    labelled: bool = True  # False: no gtFine files, or labels that mark nothing (test split)
    right_rgb: np.ndarray | None = None  # (H, W, 3) uint8 sRGB, the right view, when read and there
    vehicle: Vehicle | None = None

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return self.rgb.shape[1], self.rgb.shape[0]


#: a disparity above this share of the image width means an object nearer than ~0.5 m to a
#: 2 m-baseline-ratio camera: no street scene has it
MAX_DISPARITY_WIDTH_SHARE = 0.5


#: the input files whose change makes a completed image set stale
INPUT_KINDS = ("rgb", "right", "labelIds", "instanceIds", "disparity", "camera", "vehicle")


def input_fingerprint(root: Path, ident: ImageSetId) -> dict[str, list[int] | None]:
    """(size, modification time in ns) of each input file of an image set (None when absent):
    recorded with its outputs, so that a resumed batch redoes a set whose inputs changed."""
    out: dict[str, list[int] | None] = {}
    for kind in INPUT_KINDS:
        try:
            st = ident.path(root, kind).stat()
            out[kind] = [int(st.st_size), int(st.st_mtime_ns)]
        except OSError:
            out[kind] = None
    return out


def check_disparity(path: Path, disparity: np.ndarray, width: int) -> None:
    """Refuse disparity maps that cannot be real: no valid pixel, or impossible values."""
    valid = disparity > 1
    if not valid.any():
        raise InputError(path, "disparity has no valid pixel (all zero): no depth to place objects by")
    d = decode_disparity(disparity[valid])
    share = float((d > MAX_DISPARITY_WIDTH_SHARE * width).mean())
    if share > 0.01:
        raise InputError(path, f"{share:.0%} of the disparities exceed half the image width "
                               f"(up to {d.max():.0f} px): not a Cityscapes disparity map")


def read_image_set(root: Path, ident: ImageSetId, right: bool = False) -> ImageSet:
    """Read and check all files of one image set; raises :class:`InputError` naming the file.
    ``right``: read the right view too, when the set has one (``ImageSet.right_rgb``)."""
    rgb_path = ident.path(root, "rgb")
    label_path = ident.path(root, "labelIds")
    inst_path = ident.path(root, "instanceIds")
    disp_path = ident.path(root, "disparity")
    right_path = ident.path(root, "right")
    right = right and right_path.exists()
    labelled = label_path.exists() or inst_path.exists()
    # both gtFine files must be there; a set without any is unlabelled. Decoded side by side.
    files = [(rgb_path, "rgb8")] + ([(label_path, "gray8"), (inst_path, "gray16")] if labelled else [])
    files += [(right_path, "rgb8")] if right else []
    rgb, *gt, disparity = map_threads(lambda f: read_png(*f), files + [(disp_path, "gray16")])
    right_rgb = gt.pop() if right else None
    h, w = rgb.shape[:2]
    labels, instances = gt if labelled else (np.zeros((h, w), np.uint8), np.zeros((h, w), np.uint16))
    checked = [(label_path, labels), (inst_path, instances), (disp_path, disparity)]
    for path, img in checked + ([(right_path, right_rgb)] if right else []):
        if img.shape[:2] != (h, w):
            raise InputError(path, f"image is {img.shape[1]}x{img.shape[0]} but {rgb_path.name} is {w}x{h}")
    camera = Camera.read(ident.path(root, "camera"), w, h)
    vehicle = read_vehicle(ident.path(root, "vehicle"))
    # Cityscapes' test split ships placeholder labels: nothing but ids 0-3 (unlabeled, ego
    # vehicle, rectification border, out of roi)
    labelled = labelled and bool((labels > 3).any())
    unknown = np.flatnonzero(byte_counts(labels)[~KNOWN_IDS])
    if len(unknown):
        bad = np.arange(256)[~KNOWN_IDS][unknown]
        raise InputError(label_path, f"holds label ids Cityscapes does not define: {', '.join(map(str, bad[:10]))}")
    check_disparity(disp_path, disparity, w)
    return ImageSet(ident, rgb, labels, instances, disparity, camera, labelled, right_rgb, vehicle)


# ------------------------------------------------------------ input polygons (gtFine)
def polygon_instance_counts(source: Path) -> dict[int, int]:
    """Per class id with instances: how many entries the input's polygons file numbers
    (cityscapesScripts counts every entry of the class but its groups and deleted ones), so
    that an inserted instance appended after them gets the id its position gives it."""
    counts: dict[int, int] = {}
    for obj in read_polygons(source)[1]:
        label = name2label.get(obj["label"])
        if label is not None and label.hasInstances and not obj.get("deleted"):
            counts[label.id] = counts.get(label.id, 0) + 1
    return counts


def _polygon_entries(source: Path, data: Any) -> list[dict[str, Any]]:
    """The entries of an input polygons file, each checked to be what cityscapesScripts draws:
    an object with a string ``label`` and a ``polygon`` of [x, y] number pairs."""
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list):
        raise InputError(source, "polygons JSON must be an object with an 'objects' list")
    for i, obj in enumerate(data["objects"]):
        if not isinstance(obj, dict) or not isinstance(obj.get("label"), str):
            raise InputError(source, f"polygons JSON entry {i} has no 'label' string")
        poly = obj.get("polygon")
        if not isinstance(poly, list) or not all(
                isinstance(p, list) and len(p) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                          for v in p) for p in poly):
            raise InputError(source, f"polygons JSON entry {i} ({obj['label']!r}) has no 'polygon' list of [x, y]")
    return data["objects"]


def read_polygons(source: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """An input ``gtFine_polygons.json``: the document and its checked entries
    (:class:`InputError` naming the file and the entry otherwise)."""
    data = read_json(source)
    return data, _polygon_entries(source, data)
