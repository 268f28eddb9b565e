"""The vehicle build's materials (one per role: docs/vehicles.md) and its GLB writer: one glTF
mesh per material, positions in glTF's frame (x forward, y up, z right), normals, UVs where a
material has a texture, embedded images."""
from __future__ import annotations

import io
import json
import struct

import numpy as np
from PIL import Image
from vehicle_mesh import Mesh

#: role -> (linear base colour factor RGBA, metallic, roughness): what each material reads as
#: under the renderer's light (albedos of the real things: tyre rubber ~0.03, black plastic trim
#: ~0.035, car paint recoloured per object, clear-coated so glossy). Glass: alpha = 1 - what the
#: pane lets through (tinted windscreen ~0.75, rear privacy glass less); every factor distinct,
#: so that the paint's key (appearance.py) matches no other material.
MATERIALS = {
    "paint": ((0.42, 0.43, 0.45, 1.0), 0.0, 0.25),
    "glass": ((0.04, 0.05, 0.05, 0.28), 0.0, 0.05),
    "glass_privacy": ((0.03, 0.035, 0.035, 0.45), 0.0, 0.05),
    "tyre": ((0.028, 0.028, 0.03, 1.0), 0.0, 0.9),
    "rim": ((0.55, 0.56, 0.58, 1.0), 1.0, 0.35),
    "rim_steel": ((0.05, 0.05, 0.055, 1.0), 0.3, 0.6),
    "chrome": ((0.72, 0.73, 0.75, 1.0), 1.0, 0.08),
    "plastic": ((0.033, 0.034, 0.037, 1.0), 0.0, 0.55),
    "rubber": ((0.02, 0.02, 0.021, 1.0), 0.0, 0.8),
    "light_red": ((0.32, 0.012, 0.01, 1.0), 0.0, 0.08),
    "light_amber": ((0.55, 0.2, 0.012, 1.0), 0.0, 0.08),
    "light_white": ((0.62, 0.63, 0.64, 1.0), 1.0, 0.12),
    "plate": ((0.8, 0.8, 0.78, 1.0), 0.0, 0.4),
    "interior": ((0.036, 0.035, 0.034, 1.0), 0.0, 0.85),
    "underbody": ((0.025, 0.025, 0.025, 1.0), 0.0, 0.9),
    "mirror": ((0.6, 0.6, 0.6, 1.0), 1.0, 0.04),
    "textured": ((0.999, 0.999, 0.999, 1.0), 0.0, 0.5),
    # fixed colours: a second paint (a two-tone roof), a bus's or lorry's livery (named "livery":
    # appearance.py leaves a vehicle with one in its colours)
    "white": ((0.68, 0.68, 0.66, 1.0), 0.0, 0.3),
    "livery": ((0.62, 0.6, 0.52, 1.0), 0.0, 0.3),
    "livery_band": ((0.03, 0.032, 0.036, 1.0), 0.0, 0.3),
    "canvas": ((0.16, 0.17, 0.165, 1.0), 0.0, 0.85),  # a lorry's tarpaulin  # the source's own texture kept (trim, grilles)
}
#: the number plate's own image (blank white, the EU size 520 x 110 mm): the renderer draws each
#: object's plate over its UVs at this aspect (synthcompose/look/plates.py)
PLATE_SIZE = (520, 110)


def _png(image: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def _jpeg(image: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="JPEG", quality=88)
    return buf.getvalue()


def write_glb(path, parts: dict[str, Mesh], textures: dict[str, np.ndarray] | None = None,
              factors: dict[str, tuple] | None = None) -> None:
    """Write ``parts`` (material name -> mesh in the source frame: x forward, y left, z up) as a
    GLB. ``textures``: material name -> (H, W, 3) uint8 sRGB base colour image (its UVs are used,
    OBJ convention); the plate gets a blank one. ``factors``: material name -> its
    (rgba, metallic, roughness) when not :data:`MATERIALS`' own (a debug colouring)."""
    textures = dict(textures or {})
    factors = factors or {}
    bin_chunks: list[bytes] = []
    offset = 0
    doc = {"asset": {"version": "2.0", "generator": "synthcompose scripts/build_vehicles.py"},
           "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "materials": [],
           "accessors": [], "bufferViews": [], "buffers": []}
    to_gltf = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # (x, y, z) -> (x, z, -y)

    def view(data: bytes, target: int | None = None) -> int:
        nonlocal offset
        pad = (-len(data)) % 4
        bin_chunks.append(data + b"\0" * pad)
        entry = {"buffer": 0, "byteOffset": offset, "byteLength": len(data)}
        if target:
            entry["target"] = target
        doc["bufferViews"].append(entry)
        offset += len(data) + pad
        return len(doc["bufferViews"]) - 1

    def accessor(array: np.ndarray, kind: str, component: int, target: int, minmax: bool = False) -> int:
        entry = {"bufferView": view(array.tobytes(), target), "componentType": component,
                 "count": int(len(array)), "type": kind}
        if minmax:
            entry["min"] = array.min(axis=0).tolist()
            entry["max"] = array.max(axis=0).tolist()
        doc["accessors"].append(entry)
        return len(doc["accessors"]) - 1

    images = []
    for name in sorted(parts):
        mesh = parts[name]
        if not len(mesh.faces):
            continue
        rgba, metallic, roughness = factors.get(name, MATERIALS[name.split(".")[0]])
        material = {"name": name.split(".")[0],
                    "pbrMetallicRoughness": {"baseColorFactor": [float(c) for c in rgba],
                                             "metallicFactor": float(metallic), "roughnessFactor": float(roughness)},
                    "doubleSided": True}
        if rgba[3] < 1.0:
            material["alphaMode"] = "BLEND"
        image = textures.get(name)
        if name == "plate" and image is None:
            image = np.full((PLATE_SIZE[1], PLATE_SIZE[0], 3), 255, np.uint8)
        attributes = {}
        pos = (mesh.vertices @ to_gltf.T).astype(np.float32)
        nrm = mesh.normals @ to_gltf.T
        nrm = (nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)).astype(np.float32)
        attributes["POSITION"] = accessor(pos, "VEC3", 5126, 34962, minmax=True)
        attributes["NORMAL"] = accessor(nrm, "VEC3", 5126, 34962)
        if image is not None:
            uv = np.stack([mesh.uvs[:, 0], 1.0 - mesh.uvs[:, 1]], axis=1).astype(np.float32)  # glTF: v down
            attributes["TEXCOORD_0"] = accessor(uv, "VEC2", 5126, 34962)
            data = _png(image) if name == "plate" else _jpeg(image)
            doc.setdefault("images", []).append({"bufferView": view(data), "mimeType":
                                                 "image/png" if name == "plate" else "image/jpeg"})
            doc.setdefault("textures", []).append({"source": len(doc["images"]) - 1})
            material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": len(doc["textures"]) - 1}
            images.append(name)
        indices = accessor(mesh.faces.astype(np.uint32).ravel(), "SCALAR", 5125, 34963)
        doc["materials"].append(material)
        doc["meshes"].append({"name": name, "primitives": [{"attributes": attributes, "indices": indices,
                                                             "material": len(doc["materials"]) - 1}]})
        doc["nodes"].append({"name": name, "mesh": len(doc["meshes"]) - 1})
        doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
    blob = b"".join(bin_chunks)
    doc["buffers"].append({"byteLength": len(blob)})
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * ((-len(text)) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    out = struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
    out += struct.pack("<II", len(blob), 0x004E4942) + blob
    with open(path, "wb") as f:
        f.write(out)
