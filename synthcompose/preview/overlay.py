"""The text the preview window draws over its view, as an RGBA picture (no window needed).

:class:`Overlay` holds the lines at the top left, the 3D view's legend (:func:`view_legend`) at the
bottom left and the key help, and renders them with OpenCV's Hershey font on translucent dark
panels (:func:`_panel`, text wrapped by :func:`_wrap`). The colours of the text and of the 3D
view (the legend's swatches, the window's boxes, planes and accepted positions) are here too.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

if TYPE_CHECKING:
    from .session import View

ACCEPTED_COLOUR = (0, 255, 0)
SELECTED_BOX_COLOUR, BOX_COLOUR, PLANE_COLOUR = (255, 255, 0), (255, 60, 60), (0, 220, 0)  # 3D view
OK_COLOUR, FAIL_COLOUR, NOTE_COLOUR, TEXT_COLOUR = (90, 230, 90), (255, 80, 80), (255, 210, 90), (235, 235, 235)

Rgb = tuple[int, int, int]
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_PANEL = (18, 18, 22, 175)  # RGBA of the panels behind the text


def _wrap(text: str, scale: float, width: int) -> list[str]:
    """``text`` cut at spaces (or anywhere, for one long word) into lines at most ``width`` px wide."""
    def fits(t: str) -> bool:
        return cv2.getTextSize(t, _FONT, scale, 1)[0][0] <= width

    lines, line = [], ""
    for word in text.split(" "):
        trial = f"{line} {word}" if line else word
        if fits(trial):
            line = trial
            continue
        if line:
            lines.append(line)
        while not fits(word) and len(word) > 1:
            cut = max(k for k in range(1, len(word) + 1) if fits(word[:k]) or k == 1)
            lines.append(word[:cut])
            word = word[cut:]
        line = word
    return lines + [line] if line else lines


def _panel(out: np.ndarray, x: int, y: int, rows: list[tuple[Rgb | None, str, Rgb]], scale: float,
           max_width: int, max_height: int, from_bottom: bool = False) -> tuple[int, int, int, int]:
    """Draw rows (swatch colour or None, text, text colour) on a dark panel with its top left
    corner at (x, y) (bottom left when ``from_bottom``), text wrapped to ``max_width`` px; a tab
    in a text starts a second column, aligned over the rows. Returns the panel's (x0, y0, x1, y1);
    rows beyond ``max_height`` px are left out."""
    H, W = out.shape[:2]
    (_, th), base = cv2.getTextSize("Ag", _FONT, scale, 1)
    line_h, pad = th + base + 3, 4
    sw = th + 4 if any(c is not None for c, _, _ in rows) else 0  # swatch column
    split = [(c, *(t.split("\t", 1) if "\t" in t else ("", t)), colour) for c, t, colour in rows]
    col = max((cv2.getTextSize(k, _FONT, scale, 1)[0][0] + 2 * th for _, k, _, _ in split if k), default=0)
    lines: list[tuple[Rgb | None, str, str, Rgb]] = []
    for swatch, key, text, colour in split:
        for k, part in enumerate(_wrap(text, scale, max(max_width - sw - col - 2 * pad, 10))):
            lines.append((swatch, key, part, colour) if k == 0 else (None, "", part, colour))
    lines = lines[:max((min(max_height, H) - 2 * pad + 3) // line_h, 0)]
    if not lines:
        return x, y, x, y
    width = sw + col + max(cv2.getTextSize(t, _FONT, scale, 1)[0][0] for _, _, t, _ in lines) + 2 * pad
    height = len(lines) * line_h + 2 * pad - 3
    y0 = y - height if from_bottom else y
    x1, y1 = min(x + width, W), min(y0 + height, H)
    out[max(y0, 0):y1, max(x, 0):x1] = _PANEL
    for k, (swatch, key, text, colour) in enumerate(lines):
        top = y0 + pad + k * line_h
        if swatch is not None:
            cv2.rectangle(out, (x + pad, top + 1), (x + pad + th, top + th), (*swatch, 255), -1)
        for dx, t in ((0, key), (col, text)):
            if t:
                cv2.putText(out, t, (x + pad + sw + dx, top + th), _FONT, scale, (*colour, 255), 1, cv2.LINE_AA)
    return x, y0, x1, y1


@dataclass(frozen=True)
class Overlay:
    """The text the window draws over its view: ``lines`` at the top left ((text, RGB)), the
    3D view's ``legend`` at the bottom left ((swatch RGB, text)), ``help`` below the first line
    (the other lines and the legend make room for it)."""

    lines: tuple[tuple[str, Rgb], ...]
    legend: tuple[tuple[Rgb, str], ...] = ()
    help: tuple[str, ...] = ()

    def render(self, width: int, height: int) -> np.ndarray:
        """(height, width, 4) uint8 RGBA picture (straight alpha, top row first): the text on
        translucent dark panels, transparent elsewhere."""
        out = np.zeros((height, width, 4), np.uint8)
        scale = float(np.clip(0.55 * min(width / 1280, height / 720), 0.4, 0.65))
        margin = 6
        room = width - 2 * margin
        lines = self.lines[:1] if self.help else self.lines  # help: only the first line stays
        _, _, _, bottom = _panel(out, margin, margin, [(None, t, c) for t, c in lines], scale, room,
                                 height - 2 * margin)
        below = height - bottom - 2 * margin  # room left under the lines
        if self.legend and not self.help:  # help takes the legend's place
            _panel(out, margin, height - margin, [(c, t, TEXT_COLOUR) for c, t in self.legend], scale,
                   min(room, max(width // 2, 320)), below, from_bottom=True)
        if self.help:
            _panel(out, margin, bottom + margin, [(None, t, TEXT_COLOUR) for t in self.help], scale, room, below)
        return out


def view_legend(view: View) -> tuple[tuple[Rgb, str], ...]:
    """The 3D view's colours: rejected candidates by reason (commonest first), then the rest."""
    cols = view.reason_colour()
    rows = [(cols[why], f"x{n} {why}") for why, n in sorted(view.reasons.items(), key=lambda kv: -kv[1])]
    return tuple(rows) + ((ACCEPTED_COLOUR, "accepted position"), (SELECTED_BOX_COLOUR, "selected object's box"),
                          (BOX_COLOUR, "other objects' boxes"), (PLANE_COLOUR, "fitted ground plane"))

