"""``synthcompose preview``: a window for debugging placement, over a headless session.

- :mod:`.session`: :class:`PreviewSession` runs the batch's stages on one image set and keeps a
  :class:`View`; the passes' images, the placement rules' :class:`Verdict`, saved placements.
- :mod:`.overlay`: :class:`Overlay`, the text drawn over the view (an RGBA picture), and the colours.
- :mod:`.export`: the objects' boxes and ground planes, and :func:`export_ply`.
- :mod:`.window`: :class:`PreviewWindow` (GLFW, imported only when a window opens) and :func:`run_preview`.

Only :mod:`.window` touches a windowing toolkit; everything else runs headless.
"""
from __future__ import annotations

from .export import BOX_EDGES, box_mesh, export_ply, plane_quad
from .orbit import Orbit
from .overlay import (
           ACCEPTED_COLOUR,
           BOX_COLOUR,
           FAIL_COLOUR,
           NOTE_COLOUR,
           OK_COLOUR,
           PLANE_COLOUR,
           SELECTED_BOX_COLOUR,
           TEXT_COLOUR,
           Overlay,
           view_legend,
)
from .session import (
           ID_COLOURS,
           PASS_TITLES,
           PASSES,
           REASON_COLOURS,
           STEP_M,
           STEP_YAW_DEG,
           PlacementRefused,
           PreviewObject,
           PreviewSession,
           Verdict,
           View,
)
from .window import HELP, KEYS, PreviewWindow, run_preview

__all__ = ["ACCEPTED_COLOUR", "BOX_COLOUR", "BOX_EDGES", "FAIL_COLOUR", "HELP", "ID_COLOURS", "KEYS", "NOTE_COLOUR",
           "OK_COLOUR", "Orbit", "Overlay", "PASSES", "PASS_TITLES", "PLANE_COLOUR", "PreviewObject", "PlacementRefused",
           "PreviewSession", "PreviewWindow", "REASON_COLOURS", "SELECTED_BOX_COLOUR", "STEP_M", "STEP_YAW_DEG",
           "TEXT_COLOUR", "Verdict", "View", "box_mesh", "export_ply", "plane_quad", "run_preview", "view_legend"]
