"""The photo as Cityscapes' camera gives it, made from a generated frame's shading.

Measured on the four real development frames (``benchmarks/stereo_stats.py ROOT``, photo
figures; README "Generated stereo"): Cityscapes photos are dark (median brightness V 49-102 of
255), of a wide range between the shaded street and the sky (the road's median V 48-116, the
sky's 195-236: 9-15 times the road's linear light, against about 4 in the generator's clean
shading), greenish (the road's median sRGB about (52, 62, 52): red and blue 70-90 % of green
in linear light), and clean at the pixel level (Immerkaer's noise estimate 0.4-0.5 levels,
2.1 in the clean generated photo). The realistic photo reproduces that with a per-frame
camera drawn from the scene's ``noise_seed``:

* a tone curve in linear light, ``e * L ** gamma`` (gamma 1.3-1.6 spreads the street and the
  sky apart; the exposure e puts the street at the real range of brightness);
* a floor of veiling glare (the real frames' darkest 5 % are at V 25-39, not black);
* colours muted towards grey, and the real frames' greenish cast (red and blue gains below
  green's);
* the sensor noise at the real level (the clean photo's noise fields, scaled).
"""
from __future__ import annotations

import numpy as np

from synthcompose.colour import LUM, linear_to_srgb, srgb_to_linear

PHOTO_MODES = ("realistic", "clean")
#: tone curve: gamma (in linear light) and exposure ranges, drawn per frame (log-uniform exposure)
GAMMA = (1.4, 1.8)
EXPOSURE = (1.2, 2.4)
#: white balance: red and blue gains relative to green, linear light
RED_GAIN, BLUE_GAIN = (0.65, 0.88), (0.65, 0.88)
#: veiling glare: a floor of linear light over the whole frame (real shadows never go black)
FLARE = (0.005, 0.009)
#: colourfulness kept (the rest goes to grey, in linear light): real photos are muted
SATURATION = (0.6, 0.85)
#: the realistic photo's sensor noise, as a share of the clean photo's (1.6 and 1.4 levels)
NOISE_SHARE = 0.15


def camera_look(rgb: np.ndarray, seed: int) -> np.ndarray:
    """(H, W, 3) float32 0-255 sRGB of the clean shading -> the same as the frame's camera
    would record it (module doc), before blur and noise. Deterministic in ``seed``."""
    rng = np.random.default_rng([int(seed), 0x43414D])
    gamma = rng.uniform(*GAMMA)
    exposure = float(np.exp(rng.uniform(np.log(EXPOSURE[0]), np.log(EXPOSURE[1]))))
    gains = np.array([rng.uniform(*RED_GAIN), 1.0, rng.uniform(*BLUE_GAIN)], np.float32)
    keep = np.float32(rng.uniform(*SATURATION))
    lin = srgb_to_linear(np.clip(rgb, 0.0, 255.0) / np.float32(255.0)).astype(np.float32)
    grey = lin @ LUM.astype(np.float32)
    lin = grey[..., None] + keep * (lin - grey[..., None])
    flare = np.float32(rng.uniform(*FLARE))
    lin = (np.float32(exposure) * np.power(lin, np.float32(gamma)) + flare) * gains
    return (linear_to_srgb(np.clip(lin, 0.0, 1.0)) * np.float32(255.0)).astype(np.float32)


def recorded_colour(rgb_linear, seed: int) -> np.ndarray:
    """(3,) linear colour that a light of colour ``rgb_linear`` has once the camera of photo seed
    ``seed`` records it (:func:`camera_look`: white balance, muting, tone curve), measured on a
    mid-grey patch: what an estimate of the light from that photo can find."""
    c = np.asarray(rgb_linear, np.float32)
    patch = np.full((8, 8, 3), 0.12, np.float32) * c / float(c @ LUM)
    srgb = np.rint(np.clip(linear_to_srgb(patch), 0, 1) * 255).astype(np.float32)
    return srgb_to_linear(camera_look(srgb, seed) / np.float32(255.0)).reshape(-1, 3).mean(axis=0)
