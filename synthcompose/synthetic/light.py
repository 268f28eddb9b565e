"""Optional light control of synthetic frames: :class:`SceneLight`.

Used only when a scene carries a :class:`SceneLight` (``random_scene(..., light=...)``); scenes
without one are shaded by the default model of :mod:`.shading`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synthcompose.colour import LUM
from synthcompose.lighting.solar import elevations_at

from .scene import StreetScene, Vec3


@dataclass(frozen=True)
class SceneLight:
    """A known light for a synthetic frame, in the renderer's model (shaders/lit.glsl).

    Shading is in linear light: ``albedo * (ambient(n) + sun * max(0, n.l) * visible)`` with
    ``ambient(n) = mix(ground, sky, 0.5 + 0.5 n_z)``, sun visibility ray-cast against every box
    and pole (cast shadows) when ``shadows``. :meth:`lighting` gives the same light as a
    :class:`synthcompose.render.Lighting`, the ground truth an estimate is compared with.

    sun_azimuth_deg, sun_elevation_deg : towards the sun, vehicle frame V (azimuth from x to y)
    sun_fraction : share of an up-facing surface's irradiance coming from the sun (0: overcast)
    intensity    : irradiance of an up-facing unshadowed surface (1: the Lighting convention)
    sky_tint     : colour of the ambient light (scaled to luminance 1)
    sun_tint     : colour of the sunlight (scaled to luminance 1)
    ground_ratio : ambient from below (ground bounce) over ambient from above
    shadows      : cast shadows of boxes and poles
    sun_radius_deg : the sun's angular radius: its shadows' penumbra (a real sun's is 0.27
                   degrees; 0 draws them sharp); sampled over :data:`SUN_DISC` directions
    """

    sun_azimuth_deg: float = 135.0
    sun_elevation_deg: float = 45.0
    sun_fraction: float = 0.6
    intensity: float = 1.0
    sky_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    sun_tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    ground_ratio: float = 0.3
    shadows: bool = True
    sun_radius_deg: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.sun_fraction < 1.0:
            raise ValueError("sun_fraction must be in [0, 1)")
        if not 2.0 <= self.sun_elevation_deg <= 90.0:
            raise ValueError("sun_elevation_deg must be in [2, 90]")
        if self.intensity <= 0 or min(self.sky_tint) <= 0 or min(self.sun_tint) <= 0:
            raise ValueError("intensity and tints must be positive")

    @property
    def direction(self) -> Vec3:
        """Unit vector towards the sun in V."""
        el, az = math.radians(self.sun_elevation_deg), math.radians(self.sun_azimuth_deg)
        return (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))

    @staticmethod
    def _unit_luminance(rgb: tuple[float, float, float]) -> np.ndarray:
        c = np.asarray(rgb, np.float64)
        return c / float(c @ LUM)

    def rgb(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(sky, ground, sun) linear RGB irradiances: sky + sun * sin(elevation) = intensity
        (in luminance) on an up-facing surface; sun is the irradiance facing the sun."""
        k = 1.0 - self.sun_fraction
        sky = self.intensity * k * self._unit_luminance(self.sky_tint)
        sun = self.intensity * self.sun_fraction / math.sin(math.radians(self.sun_elevation_deg)) \
            * self._unit_luminance(self.sun_tint)
        return sky, self.ground_ratio * sky, sun

    def lighting(self):
        """The same light as a :class:`synthcompose.render.Lighting`."""
        from synthcompose.lighting.light import Lighting

        sky, ground, sun = self.rgb()
        t = lambda c: tuple(float(v) for v in c)  # noqa: E731
        return Lighting(t(self.direction), t(sun), t(sky), t(ground))


def _lin(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def _sun_visibility(scene: StreetScene, p: np.ndarray, sun: np.ndarray) -> np.ndarray:
    """(N,) 1.0 where street-frame points p (N, 3) see the sun (direction ``sun``, T), 0.0
    where a box or pole is in the way."""
    vis = np.ones(len(p), np.float32)
    if sun[2] <= 1e-3 or not len(p):
        return vis
    p = p.astype(np.float64)
    for box in scene.boxes:
        m = box.matrix
        q, d = (p, sun) if m is None else ((p - m[:3, 3]) @ m[:3, :3], sun @ m[:3, :3])
        lo, hi = np.array(box.lo), np.array(box.hi)
        if d[2] <= 1e-6:
            continue
        # candidates: below the top, within the box's footprint swept away from the sun
        reach = np.maximum(hi[2] - q[:, 2], 0.0) / d[2]
        sel = q[:, 2] < hi[2]
        for ax in (0, 1):
            shift = -d[ax] * reach
            sel &= (q[:, ax] >= lo[ax] + np.minimum(shift, 0.0) - 1e-6) & (q[:, ax] <= hi[ax] + np.maximum(shift, 0.0) + 1e-6)
        idx = np.nonzero(sel)[0]
        if not len(idx):
            continue
        qq = q[idx]
        t0, t1 = np.full(len(idx), -np.inf), np.full(len(idx), np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            for ax in range(3):
                if abs(d[ax]) < 1e-12:
                    inside = (qq[:, ax] >= lo[ax]) & (qq[:, ax] <= hi[ax])
                    t0 = np.where(inside, t0, np.inf)
                    continue
                a, b = (lo[ax] - qq[:, ax]) / d[ax], (hi[ax] - qq[:, ax]) / d[ax]
                t0, t1 = np.maximum(t0, np.minimum(a, b)), np.minimum(t1, np.maximum(a, b))
        vis[idx[(t0 <= t1) & (t1 > 1e-3)]] = 0.0
    for pole in scene.poles:
        dxy = math.hypot(sun[0], sun[1])
        reach = np.maximum(pole.base_z + pole.height - p[:, 2], 0.0) / sun[2]
        fx, fy = p[:, 0] - pole.x, p[:, 1] - pole.y
        near = (np.hypot(fx, fy) <= reach * dxy + pole.radius) & (p[:, 2] < pole.base_z + pole.height)
        idx = np.nonzero(near)[0]
        if not len(idx) or dxy < 1e-9:
            continue
        fx, fy = fx[idx], fy[idx]
        a = dxy * dxy
        b = fx * sun[0] + fy * sun[1]
        c = fx * fx + fy * fy - pole.radius ** 2
        disc = b * b - a * c
        with np.errstate(invalid="ignore"):
            t = (-b - np.sqrt(disc)) / a
            t_far = (-b + np.sqrt(disc)) / a
        t = np.maximum(t, 0.0)
        z = p[idx, 2] + t * sun[2]
        hit = (disc >= 0) & (t_far > 1e-3) & (z >= pole.base_z) & (z <= pole.base_z + pole.height)
        vis[idx[hit]] = 0.0
    return vis


#: directions on the sun's disc (unit disc) its visibility is averaged over (a penumbra)
SUN_DISC = ((0.0, 0.0), (0.75, 0.0), (-0.375, 0.65), (-0.375, -0.65), (0.375, 0.65), (0.375, -0.65),
            (-0.75, 0.0))


def _disc_directions(sun: np.ndarray, radius_deg: float) -> list[np.ndarray]:
    """Unit directions to :data:`SUN_DISC`'s points on a sun of angular radius ``radius_deg``
    centred on ``sun``."""
    if radius_deg <= 0:
        return [sun]
    t = math.tan(math.radians(radius_deg))
    e1 = np.cross(sun, [0.0, 0.0, 1.0])
    e1 = e1 / max(np.linalg.norm(e1), 1e-12) if np.linalg.norm(e1) > 1e-9 else np.array([1.0, 0.0, 0.0])
    e2 = np.cross(sun, e1)
    return [(sun + t * (a * e1 + b * e2)) / np.linalg.norm(sun + t * (a * e1 + b * e2)) for a, b in SUN_DISC]


def light_shade(scene: StreetScene, albedo: np.ndarray, normal: np.ndarray, pts: np.ndarray,
                 sun: np.ndarray, sunlit: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(N, 3) sRGB 0-255 colour of surface points lit by ``scene.light`` (linear-light shading).
    ``sunlit`` (bool array, indices of the points in it), when given, receives where the sun
    reaches the points."""
    light = scene.light
    sky, ground, sun_rgb = (c.astype(np.float32) for c in light.rgb())
    n = normal.astype(np.float32)
    ndl = np.maximum(n @ sun.astype(np.float32), 0.0)
    if light.shadows:
        lit_idx = np.nonzero(ndl > 0)[0]
        vis = np.zeros(len(n), np.float32)
        q = pts[lit_idx] + 0.02 * n[lit_idx]
        dirs = _disc_directions(sun.astype(np.float64), light.sun_radius_deg)
        v = _sun_visibility(scene, q, dirs[0])
        if len(dirs) > 1:  # the disc's other points where its rim disagrees (a penumbra)
            rim = [_sun_visibility(scene, q, dirs[k]) for k in (1, 2, 3)]
            edge = np.nonzero((rim[0] != v) | (rim[1] != v) | (rim[2] != v))[0]
            total = v + rim[0] + rim[1] + rim[2]
            for d in dirs[4:]:
                total[edge] += _sun_visibility(scene, q[edge], d)
            v = np.where(np.isin(np.arange(len(v)), edge), total / len(dirs), v)
        vis[lit_idx] = v
        ndl = ndl * vis
    if sunlit is not None:
        sunlit[0][sunlit[1]] = ndl > 0.5 * np.maximum(n @ sun.astype(np.float32), 0.0)
    up = (0.5 + 0.5 * n[:, 2:3])
    irradiance = ground * (1 - up) + sky * up + sun_rgb * ndl[:, None]
    return (_srgb(_lin(albedo / 255.0) * irradiance) * 255.0).astype(np.float32)


def light_tint(scene: StreetScene, color: np.ndarray) -> np.ndarray:
    """Sky and haze colours (sRGB 0-255) under ``scene.light``: tinted by the ambient colour
    and scaled with its intensity."""
    tint = SceneLight._unit_luminance(scene.light.sky_tint) * scene.light.intensity
    return (_srgb(_lin(color / 255.0) * tint.astype(np.float32)) * 255.0).astype(np.float32)


#: the generator's sunny days: sun elevation (degrees), the sun's share of an up-facing lit
#: surface's light (lit / shadowed ground 2-2.9 times: the plan's edge steps of 8 generated sunny
#: streets 0.78-1.18 in log luminance, median 0.99; the 13 sunny street frames' 0.70-1.00), and
#: the colours: a bluish sky, a warm sun (the shadow's side bluer, as in the photos)
SUNNY_ELEVATION, SUNNY_FRACTION = (18.0, 55.0), (0.5, 0.66)
SUNNY_SKY_TINT, SUNNY_SUN_TINT = (0.86, 1.0, 1.22), (1.12, 1.0, 0.84)
#: a real sun's angular radius (degrees)
SUN_RADIUS_DEG = 0.267
#: the sun's azimuth this many degrees from the street's axis (either way, ahead or behind): a
#: sun from across the street. The generated streets are canyons (buildings 8-20 m high, 7-10 m
#: from the centre line) whose houses on the sun's side shade the road, and the sun comes in
#: through a gap in their row (:func:`~.sunlit.open_to_the_sun`) onto a patch of road whose
#: edges run along its azimuth, as the shadows of corners, poles and trunks do on the sunny
#: street frames. (A sun along the street lit a band of road whose only edge, the roofs'
#: shadow, runs along the street whatever the sun's azimuth, or, from behind, none.)
SUNNY_AZIMUTH_FROM_STREET = (50.0, 85.0)


def sunny_light(rng: np.random.Generator) -> SceneLight:
    """A sunny day's :class:`SceneLight`: the sun across the street (:data:`SUNNY_AZIMUTH_FROM_STREET`
    from its axis, the street along x), the ranges above, the penumbra of a real sun."""
    ahead = rng.random() < 0.5
    off = rng.uniform(*SUNNY_AZIMUTH_FROM_STREET) * (1.0 if rng.random() < 0.5 else -1.0)
    azimuth = (0.0 if ahead else 180.0) + (off if ahead else -off)
    return SceneLight(sun_azimuth_deg=float(azimuth % 360.0),
                      sun_elevation_deg=float(rng.uniform(*SUNNY_ELEVATION)),
                      sun_fraction=float(rng.uniform(*SUNNY_FRACTION)), sky_tint=SUNNY_SKY_TINT,
                      sun_tint=SUNNY_SUN_TINT, ground_ratio=0.3, shadows=True, sun_radius_deg=SUN_RADIUS_DEG)


#: the latitude (degrees north) of the generated sunny frames' vehicle files: Cityscapes' cities
#: lie at 47.4-54.3
SITE_LATITUDE = 50.5


def sunny_vehicle(light: SceneLight, rng: np.random.Generator) -> dict:
    """A vehicle file (Cityscapes' ``vehicle.json`` fields) for a frame lit by ``light``: at
    :data:`SITE_LATITUDE`, heading where the sun, at ``light``'s azimuth in the vehicle frame and
    its elevation, stands at a compass azimuth it has on some day of the year (drawn among
    them)."""
    el = light.sun_elevation_deg
    fits = []
    for compass in range(360):
        e = elevations_at(SITE_LATITUDE, float(compass))
        if len(e) and e.min() - 0.5 <= el <= e.max() + 0.5:
            fits.append(compass)
    compass = float(rng.choice(fits))
    return {"gpsHeading": round((compass + light.sun_azimuth_deg) % 360.0, 2), "gpsLatitude": SITE_LATITUDE,
            "gpsLongitude": 7.0, "outsideTemperature": 20.0, "speed": 8.0, "yawRate": 0.0}
