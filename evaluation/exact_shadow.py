"""Exact shadows of a box car on a flat road, for judging the shadow measures (issue 29's
outline): what a physically right shadow reads, with nothing rendered.

For each point of the road, the share of the sky's light that reaches it past the car (a CIE
overcast sky, radiance 1 + 2 cos(zenith), over equal-solid-angle directions) and, with a sun,
the share of the sun's disc (0.53 degrees) it sees; the car is boxes (body, overhangs, cabin,
wheels) and every ray is traced against them. :func:`picture` sees it from a Cityscapes camera
as 8-bit sRGB, the form :mod:`evaluation.shadowlook` measures. No light bounces: the ground under
the car comes out darker than in a photo; the shadow's edges are where the boxes put them.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from synthcompose.colour import SRGB8_TO_LINEAR, linear_to_srgb

W, H, F, CX, CY, CAM_H = 2048, 1024, 2262.0, 1024.0, 513.0, 1.22
#: the car's parts: (x0, x1) across, (y0, y1) along, (z0, z1) up, metres in its own frame
CAR = (
    ((-0.90, 0.90), (-1.40, 1.40), (0.18, 0.90)),   # body between the axles, over the sills
    ((-0.85, 0.85), (1.40, 2.30), (0.32, 0.90)),    # front overhang, over the bumper's lip
    ((-0.85, 0.85), (-2.30, -1.40), (0.36, 0.90)),  # rear overhang
    ((-0.78, 0.78), (-1.10, 1.30), (0.90, 1.45)),   # cabin
    *(((sx * 0.78 - 0.11, sx * 0.78 + 0.11), (sy * 1.35 - 0.32, sy * 1.35 + 0.32), (0.0, 0.64))
      for sx in (-1, 1) for sy in (-1, 1)),         # wheels
)
#: the road's grey (8-bit sRGB) and the car's
ROAD, BODY = 110, 60
#: the ground grid around the car: half size and step (metres); beyond it the sky is whole
REACH, STEP = 9.0, 0.1
#: the sun's light on the road over the sky's: the sunlit road 1 + 2 = 3 times as bright as the shade
SUN_TO_SKY = 2.0


def _hits(points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """(len(points), len(dirs)) bool: the ray from each point along each direction meets a part
    of the car (points and directions in the car's frame)."""
    hit = np.zeros((len(points), len(dirs)), bool)
    inv = 1.0 / np.where(np.abs(dirs) < 1e-9, 1e-9, dirs)
    for part in CAR:
        lo = np.array([p[0] for p in part])
        hi = np.array([p[1] for p in part])
        t1 = (lo[None, None, :] - points[:, None, :]) * inv[None, :, :]
        t2 = (hi[None, None, :] - points[:, None, :]) * inv[None, :, :]
        near = np.minimum(t1, t2).max(axis=2)
        far = np.maximum(t1, t2).min(axis=2)
        hit |= far >= np.maximum(near, 0.0)
    return hit


def _sky_dirs(n_theta: int = 32, n_phi: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Directions over the upper hemisphere (equal solid angle) and their weights: CIE overcast
    radiance times the cosine, summing to 1."""
    u = (np.arange(n_theta) + 0.5) / n_theta  # cos(zenith), uniform: equal solid angle
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * math.pi
    uu, pp = np.meshgrid(u, phi, indexing="ij")
    s = np.sqrt(1 - uu ** 2)
    dirs = np.stack([s * np.cos(pp), s * np.sin(pp), uu], -1).reshape(-1, 3)
    w = ((1 + 2 * uu) * uu).ravel()
    return dirs, w / w.sum()


def _sun_dirs(azimuth: float, elevation: float, n: int = 64) -> np.ndarray:
    """Directions over the sun's disc (0.265 degrees radius), camera frame (x right, y forward)."""
    rng = np.random.default_rng(0)
    r = math.radians(0.265) * np.sqrt(rng.random(n))
    a = rng.random(n) * 2 * math.pi
    az = math.radians(azimuth) + r * np.cos(a) / max(math.cos(math.radians(elevation)), 1e-3)
    el = math.radians(elevation) + r * np.sin(a)
    return np.stack([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)], -1)


def _rot(yaw: float) -> np.ndarray:
    """The car's frame to the camera's ground frame: its length along the view at yaw 0."""
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    return np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])


def light_grid(yaw: float, sun: tuple[float, float] | None, step: float = STEP, sky_dirs: int = 32
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """The sky's share and the sun's share over the ground grid around the car (car-centred,
    camera-aligned axes; ``step`` metres, ``REACH`` either way); ``sky_dirs``: zenith rings (twice
    as many azimuths)."""
    n = int(round(2 * REACH / step)) + 1
    g = np.linspace(-REACH, REACH, n)
    gx, gy = np.meshgrid(g, g, indexing="xy")  # rows along y (forward), columns along x
    pts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 1e-4)], -1)
    rot = _rot(yaw)
    local = pts @ rot  # camera ground frame -> car frame (rot is orthonormal)
    dirs, w = _sky_dirs(sky_dirs, 2 * sky_dirs)
    sky = np.empty(len(pts))
    sun_share = np.empty(len(pts)) if sun is not None else None
    sdirs = _sun_dirs(*sun) @ rot if sun is not None else None
    for k in range(0, len(pts), 2048):
        chunk = local[k:k + 2048]
        sky[k:k + 2048] = 1.0 - _hits(chunk, dirs @ rot) @ w
        if sdirs is not None:
            sun_share[k:k + 2048] = 1.0 - _hits(chunk, sdirs).mean(axis=1)
    return sky.reshape(n, n), (None if sun_share is None else sun_share.reshape(n, n))


def picture(distance: float, yaw: float, sky: np.ndarray, sun: np.ndarray | None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """(input, output under the sky alone, output with the sun or None, car mask) of the car at
    ``distance`` straight ahead: the road and the car flat greys, each output the road's grey
    times the light that reaches it (``sky`` and ``sun`` from :func:`light_grid` for the same
    yaw); the car is traced once for both."""

    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    rays = np.stack([(u - CX) / F, np.ones_like(u), -(v - CY) / F], -1)
    centre = np.array([0.0, distance, 0.0])
    cam = np.array([0.0, 0.0, CAM_H])
    rot = _rot(yaw)
    top = max(0, int(CY - F * 1.6 / (distance - 3)))  # the car's top is under 1.6 m
    r = rays[top:].reshape(-1, 3)
    origin = ((cam - centre) @ rot)[None, :]
    hit = np.concatenate([_hits(origin, r[k:k + (1 << 16)] @ rot)[0] for k in range(0, len(r), 1 << 16)])
    car = np.zeros((H, W), bool)
    car[top:] = hit.reshape(H - top, W)
    # the ground each pixel sees, in the grid's cells
    down = np.maximum(-rays[..., 2], 1e-9)
    t = CAM_H / down
    gx = t * rays[..., 0] - centre[0]
    gy = t * rays[..., 1] - centre[1]
    ground = (rays[..., 2] < 0) & (np.abs(gx) < REACH) & (np.abs(gy) < REACH)
    step = 2 * REACH / (sky.shape[0] - 1)
    mx = ((gx + REACH) / step).astype(np.float32)
    my = ((gy + REACH) / step).astype(np.float32)

    def sample(grid):
        s = cv2.remap(grid.astype(np.float32), mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        return np.where(ground, s, 1.0)

    def written(light):  # the road's grey in that light, the car its own, as 8-bit sRGB
        out = np.round(255 * linear_to_srgb(SRGB8_TO_LINEAR[ROAD] * light))
        return np.repeat(np.where(car, BODY, out).astype(np.uint8)[..., None], 3, 2)

    sky_light = sample(sky)
    with_sun = None if sun is None else written((sky_light + SUN_TO_SKY * sample(sun)) / (1 + SUN_TO_SKY))
    src = np.where(car, BODY, ROAD).astype(np.uint8)
    return np.repeat(src[..., None], 3, 2), written(sky_light), with_sun, car
