"""Number plates: a registration drawn per vehicle (seeded) and the image of its plate.

A model's plate material (a textured material named like ``licence``/``license``/``plate``,
:mod:`.models.mesh`) is drawn with the plate of the object that wears it, so that no two cars
of a dataset carry the model's own text (a detector would learn it), and a plate shows what a
real one shows: dark characters on a light ground, with the blue EU band on the left. A real
plate's text is also what makes a stereo matcher find it: a blank one is a flat panel.

The registrations follow the German pattern (Cityscapes' cities): a district of one to three
letters, one or two letters, and one to four digits, at most eight characters in all. They are
random draws, not real registrations of anybody's car.
"""
from __future__ import annotations

import string

import cv2
import numpy as np

#: district codes of the Cityscapes cities and some of their neighbours (one to three letters)
DISTRICTS = ("A", "AC", "B", "BN", "BO", "D", "DA", "DO", "DU", "E", "EF", "EN", "F", "GE", "H", "HB",
             "HH", "HRO", "J", "K", "KA", "KR", "LEV", "M", "MG", "MS", "NE", "OF", "S", "SU", "UL",
             "W", "WI")
#: letters of the middle group (I, O and Q, which read like digits, are not given out)
LETTERS = "".join(c for c in string.ascii_uppercase if c not in "IOQ")
#: how often a number has 1, 2, 3, 4 digits (most have three or four)
DIGITS = np.array([0.05, 0.15, 0.35, 0.45])
#: plate image (width, height) px when the model's own texture gives none: 520 x 110 mm
SIZE = (520, 110)
#: a plate is drawn this many pixels high, as wide as the model's texture's aspect asks (within
#: 1 to 10 heights): the texture's own resolution does not matter, its UVs span it
HEIGHT_PX = 110


def draw_registration(rng: np.random.Generator) -> str:
    """A random German-style registration, e.g. ``"K AB 1234"`` (at most 8 characters)."""
    district = DISTRICTS[int(rng.integers(len(DISTRICTS)))]
    letters = "".join(LETTERS[int(i)] for i in rng.integers(len(LETTERS), size=int(rng.integers(1, 3))))
    room = min(8 - len(district) - len(letters), 4)
    digits = 1 + int(rng.choice(room, p=DIGITS[:room] / DIGITS[:room].sum()))
    number = str(int(rng.integers(10 ** (digits - 1), 10 ** digits)))
    return f"{district} {letters} {number}"


def plate_image(text: str, size: tuple[int, int] = SIZE) -> np.ndarray:
    """(H, W, 4) uint8 sRGB image of a plate reading ``text`` with the aspect of ``size`` = (W, H)
    (:data:`HEIGHT_PX` high): white ground (the plate material's own colour multiplies it), a
    dark rim, the blue EU band with a "D", black characters filling the height."""
    h = HEIGHT_PX
    w = int(round(h * min(max(size[0] / max(size[1], 1), 1.0), 10.0)))
    img = np.full((h, w, 3), 255, np.uint8)
    rim = max(1, round(h * 0.04))
    cv2.rectangle(img, (rim // 2, rim // 2), (w - 1 - rim // 2, h - 1 - rim // 2), (25, 25, 25), rim)
    band = round(w * 0.08)
    cv2.rectangle(img, (rim, rim), (rim + band, h - 1 - rim), (20, 70, 170), -1)
    font = cv2.FONT_HERSHEY_DUPLEX
    scale = cv2.getFontScaleFromHeight(font, max(int(h * 0.22), 1), 1)
    (dw, _), _ = cv2.getTextSize("D", font, scale, 1)
    cv2.putText(img, "D", (rim + (band - dw) // 2, h - rim - int(h * 0.12)), font, scale, (235, 235, 235),
                max(1, round(h * 0.02)), cv2.LINE_AA)
    centre, radius = np.array([rim + band / 2, h * 0.33]), band * 0.3
    for k in range(12):  # the ring of stars
        x, y = centre + radius * np.array([np.cos(k * np.pi / 6), np.sin(k * np.pi / 6)])
        cv2.circle(img, (int(round(x)), int(round(y))), max(1, round(h * 0.015)), (240, 200, 30), -1, cv2.LINE_AA)
    # the characters: as tall as the plate allows, narrowed to the room right of the band
    thick = max(1, round(h * 0.04))
    scale = cv2.getFontScaleFromHeight(font, int(h * 0.6), thick)
    (tw, th), _ = cv2.getTextSize(text, font, scale, thick)
    room = w - band - 2 * rim - int(h * 0.25)
    glyphs = np.full((th + 2 * thick, tw + 2 * thick, 3), 255, np.uint8)
    cv2.putText(glyphs, text, (thick, th + thick), font, scale, (15, 15, 15), thick, cv2.LINE_AA)
    gw = min(room, glyphs.shape[1])
    glyphs = cv2.resize(glyphs, (gw, glyphs.shape[0]), interpolation=cv2.INTER_AREA)
    y0 = (h - glyphs.shape[0]) // 2
    x0 = rim + band + (w - rim - band - gw) // 2
    img[y0:y0 + glyphs.shape[0], x0:x0 + gw] = np.minimum(img[y0:y0 + glyphs.shape[0], x0:x0 + gw], glyphs)
    return np.concatenate([img, np.full((h, w, 1), 255, np.uint8)], axis=2)
