"""Reflections of the photo (shaders/lit.glsl, environment()): where a reflected ray leaves the
frame - behind the camera, above the image, to the sides - paint and glass still reflect a street
like the one in the photo (the point folded back into the frame's angles), not one flat colour.
Real cars' panels carry that texture; without it a near car's rear is one plain panel, and a
stereo matcher cannot find its depth (issue 20)."""
from __future__ import annotations

import numpy as np

from synthcompose.models import MeshPart, Model
from synthcompose.render import Lighting, Renderer, RenderObject

from ..helpers import make_camera

LIGHT = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.5)


def _mirror_facing_the_camera() -> Model:
    """A 2 m x 1.2 m mirror (metallic, roughness 0.05) facing the camera (object -x), 0.4 m up."""
    corners = np.array([[0, 1.0, 0.4], [0, -1.0, 0.4], [0, -1.0, 1.6], [0, 1.0, 1.6]], np.float32)
    part = MeshPart(positions=corners, normals=np.tile([-1.0, 0.0, 0.0], (4, 1)).astype(np.float32),
                    uvs=np.zeros((4, 2), np.float32), colors=np.tile([0.9, 0.9, 0.9, 1.0], (4, 1)).astype(np.float32),
                    material=np.tile([1.0, 0.05], (4, 1)).astype(np.float32),
                    indices=np.array([[0, 1, 2], [0, 2, 3]], np.uint32), texture=None)
    return Model("test-mirror", (part,), (0.05, 2.0, 1.6))


def _mirror_render(gl, photo: np.ndarray, mirror: Model | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(lit colour, coverage) of ``mirror`` (default: the flat one) 8 m ahead, reflecting
    ``photo``, full-frame arrays."""
    cam = make_camera()
    pose = np.eye(4)
    pose[:3, 3] = (8.0, 0.0, 0.0)
    renderer = Renderer(gl)
    mirror = mirror if mirror is not None else _mirror_facing_the_camera()
    passes = renderer.render(cam, [RenderObject(mirror, pose, (0.2, 0.2, 0.2))], LIGHT, photo=photo)
    colour = np.zeros((cam.height, cam.width, 3), np.float32)
    alpha = np.zeros((cam.height, cam.width), np.float32)
    colour[passes.roi.slices] = passes.read("objc")[..., :3]
    alpha[passes.roi.slices] = passes.read("alpha")
    renderer.release(passes)
    return colour, alpha


def test_a_mirror_facing_the_camera_reflects_a_street_not_a_flat_colour(gl_clean):
    cam = make_camera()
    # the photo: vertical stripes 24 px wide, dark and bright
    cols = np.arange(cam.width)
    photo = np.where(((cols // 24) % 2 == 0)[None, :, None], 40, 220).astype(np.uint8)
    photo = np.ascontiguousarray(np.broadcast_to(photo, (cam.height, cam.width, 3)))
    colour, alpha = _mirror_render(gl_clean, photo)
    inner = alpha > 0.999
    rows, cols_ = np.nonzero(inner)
    assert len(rows) > 2000
    lum = colour[..., 1]
    # the rays go back past the camera: the mirror shows the stripes (strong changes along its rows)
    band = lum[rows.min() + 3:rows.max() - 2, cols_.min() + 3:cols_.max() - 2]
    profile = band.mean(axis=0)
    assert profile.max() > 2.0 * profile.min(), profile
    flips = np.count_nonzero(np.diff(np.sign(profile - np.median(profile))))
    assert flips >= 4, profile


def test_the_street_behind_keeps_its_sides(gl_clean):
    cam = make_camera()
    # the photo: its left half dark, its right half bright
    photo = np.full((cam.height, cam.width, 3), 220, np.uint8)
    photo[:, : cam.width // 2] = 40
    colour, alpha = _mirror_render(gl_clean, photo)
    inner = alpha > 0.999
    rows, cols = np.nonzero(inner)
    mid = (cols.min() + cols.max()) // 2
    lum = colour[..., 1]
    left = lum[inner & (np.arange(cam.width)[None, :] < mid - 20)].mean()
    right = lum[inner & (np.arange(cam.width)[None, :] > mid + 20)].mean()
    # a mirror shows what is behind the camera on the same side: the dark left on its left
    assert right > 1.5 * left, (left, right)


def _bent_mirror(columns: int = 40) -> Model:
    """A flat 2 m x 1.2 m mirror facing the camera whose normals turn from -60 to +60 degrees
    across it, as a coarsely modelled curved panel's smoothed normals do."""
    ys = np.linspace(1.0, -1.0, columns)
    angles = np.radians(np.linspace(-60.0, 60.0, columns))
    positions, normals = [], []
    for y, a in zip(ys, angles):
        for z in (0.4, 1.6):
            positions.append([0.0, y, z])
            normals.append([-np.cos(a), np.sin(a), 0.0])
    quads = [[2 * k, 2 * k + 2, 2 * k + 3, 2 * k, 2 * k + 3, 2 * k + 1] for k in range(columns - 1)]
    n = len(positions)
    part = MeshPart(positions=np.array(positions, np.float32), normals=np.array(normals, np.float32),
                    uvs=np.zeros((n, 2), np.float32), colors=np.tile([0.9, 0.9, 0.9, 1.0], (n, 1)).astype(np.float32),
                    material=np.tile([1.0, 0.05], (n, 1)).astype(np.float32),
                    indices=np.array(quads, np.uint32).reshape(-1, 3), texture=None)
    return Model("test-bent-mirror", (part,), (0.05, 2.0, 1.6))


def test_a_curved_panel_reflects_the_photo_filtered_over_its_footprint(gl_clean):
    """Where the next pixel's reflected ray lands many photo pixels away, the pixel reflects the
    photo averaged over that footprint (the mip level that covers it), not one sharp point of it:
    fine detail in the photo does not break into shards and jagged lines over a curved panel."""
    cam = make_camera()
    cols = np.arange(cam.width)
    photo = np.where(((cols // 3) % 2 == 0)[None, :, None], 40, 220).astype(np.uint8)  # 3 px stripes
    photo = np.ascontiguousarray(np.broadcast_to(photo, (cam.height, cam.width, 3)))
    colour, alpha = _mirror_render(gl_clean, photo, _bent_mirror())
    lum = colour[..., 1]
    inner = alpha > 0.999
    rows, cols_ = np.nonzero(inner)
    band = lum[rows.min() + 3:rows.max() - 2, cols_.min() + 3:cols_.max() - 2]
    # next to each other, pixels differ little against the stripes' own contrast (the mean of
    # the stripes stands between them); the plain textureLod read them at the panel's roughness
    # alone and jumped between dark and bright from pixel to pixel
    steps = np.abs(np.diff(band, axis=1)).mean()
    assert steps < 0.3 * band.mean(), (steps, band.mean())  # 0.18 (0.52 before)
