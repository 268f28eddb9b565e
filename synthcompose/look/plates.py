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
    thin dark rim, the blue EU band with a "D", then the characters in the proportions of the
    German standard plate (DIN 74069, 520 x 110 mm): 75 mm high, condensed (letters 47.5 mm,
    digits 44.5 mm wide, strokes about 9 mm), the groups apart, with the round seal between the
    district and the letters; narrowed together if they do not fit."""
    h = HEIGHT_PX
    w = int(round(h * min(max(size[0] / max(size[1], 1), 1.0), 10.0)))
    mm = h / 110.0  # pixels per millimetre of the real plate
    img = np.full((h, w, 3), 255, np.uint8)
    rim = max(1, round(1.5 * mm))
    cv2.rectangle(img, (rim // 2, rim // 2), (w - 1 - rim // 2, h - 1 - rim // 2), (35, 35, 35), rim)
    band = round(min(w * 0.08, 44 * mm))
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
    # the characters: each drawn in a cell of its own and condensed to the standard's width
    glyphs = _characters(text, mm)
    room = w - band - 2 * rim - round(16 * mm)
    gw = min(room, glyphs.shape[1])
    glyphs = cv2.resize(glyphs, (gw, glyphs.shape[0]), interpolation=cv2.INTER_AREA)
    y0 = (h - glyphs.shape[0]) // 2
    x0 = rim + band + (w - rim - band - gw) // 2
    img[y0:y0 + glyphs.shape[0], x0:x0 + gw] = np.minimum(img[y0:y0 + glyphs.shape[0], x0:x0 + gw], glyphs)
    return np.concatenate([img, np.full((h, w, 1), 255, np.uint8)], axis=2)


#: the standard plate's character (mm): height, letter and digit width (ink; 47.5 and 44.5 with the
#: spacing), stroke, the gap between
#: characters, between the letters and the digits, and the seal's room after the district
_CHAR_H, _LETTER_W, _DIGIT_W, _STROKE, _GAP, _GROUP_GAP, _SEAL_GAP = 75, 40, 38, 9, 7, 22, 46
#: the inspection sticker's colours (the year's: blue, orange, green, brown, pink, yellow)
_STICKER = ((40, 90, 190), (235, 120, 30), (60, 150, 60), (120, 80, 50), (230, 130, 170), (230, 200, 40))


def _characters(text: str, mm: float) -> np.ndarray:
    """The registration's characters as one white image with dark glyphs, ``_CHAR_H`` high."""
    font, thick = cv2.FONT_HERSHEY_SIMPLEX, max(1, round(_STROKE * mm * 0.7))
    ch = round(_CHAR_H * mm)
    groups = text.split()
    cells: list[np.ndarray] = []
    for g, group in enumerate(groups):
        for c in group:
            glyph = "O" if c == "0" else c  # the standard's zero is an oval, unslashed (the font's is slashed)
            (cw, chh), _ = cv2.getTextSize(glyph, font, 1.0, thick)
            scale = (ch - 2 * thick) / max(chh, 1)
            cell = np.full((2 * ch, round(cw * scale) + 4 * thick, 3), 255, np.uint8)
            cv2.putText(cell, glyph, (2 * thick, ch + ch // 2), font, scale, (22, 22, 22), thick, cv2.LINE_AA)
            ink_c, ink_r = (np.flatnonzero(cell.min(axis=(a, 2)) < 200) for a in (0, 1))
            cell = cell[ink_r[0]:ink_r[-1] + 1, ink_c[0]:ink_c[-1] + 1]
            width = round((_DIGIT_W if c.isdigit() else _LETTER_W) * mm)
            if cell.shape[1] < 0.6 * width:  # a narrow character (1, I) keeps its width, centred
                pad = width - cell.shape[1]
                cell = np.pad(cell, ((0, 0), (pad // 2, pad - pad // 2), (0, 0)), constant_values=255)
            cells += [cv2.resize(cell, (width, ch), interpolation=cv2.INTER_AREA),
                      np.full((ch, round(_GAP * mm), 3), 255, np.uint8)]
        if g == 0 and len(groups) > 1:  # the seals between the district and the letters
            cells.append(_seals(text, ch, round(_SEAL_GAP * mm)))
        elif g < len(groups) - 1:
            cells.append(np.full((ch, round(_GROUP_GAP * mm), 3), 255, np.uint8))
    return np.concatenate(cells[:-1], axis=1)


def _seals(text: str, height: int, width: int) -> np.ndarray:
    """The room between district and letters: the inspection sticker above the state's seal
    (round, about 35 mm), the sticker's colour from the registration (it is per year)."""
    img = np.full((height, width, 3), 255, np.uint8)
    r = max(1, round(min(width, height / 2) * 0.38))
    cx = width // 2
    colour = _STICKER[sum(map(ord, text)) % len(_STICKER)]
    cv2.circle(img, (cx, height // 4), r, colour, -1, cv2.LINE_AA)
    cv2.circle(img, (cx, 3 * height // 4), r, (200, 200, 195), -1, cv2.LINE_AA)
    cv2.circle(img, (cx, 3 * height // 4), max(1, r // 2), (150, 60, 50), -1, cv2.LINE_AA)
    return img
