"""Stage 3 - placement: where an object stands in the real scene, and why.

The package reads as its steps: ``rules`` (the rules and the values handed on), ``noise`` (the
frame's stereo error and the tolerances that follow it), ``ground`` (robust local ground
planes over a metric neighbourhood), ``road`` (kerb lines and the road's direction), ``boxes``
(boxes, footprints, collisions, visibility), ``poses`` (the rules of one pose, and
:func:`check_pose` for a pose given outright) and ``search`` (drawing candidates:
:func:`place_object`). Traffic sense (docs/placement.md): ``markings`` (lane lines and zebra
stripes in the photo), ``street_lines`` and ``street`` (the street's axis, lines, carriageways,
centre line, crossings), ``parked`` (the frame's own parked rows), ``lanes`` (lanes and their
directions), ``traffic`` (a candidate's place in traffic), ``claim`` (what placement says of it:
:class:`Traffic`) and ``verdict``
(the traffic rules of a finished pose, part of :func:`check_pose`).
"""
from .boxes import (
    FOOTPRINT_SAMPLES,
    footprint_corners,
    footprint_grid,
    footprints_overlap,
    penetration,
    pose_matrix,
    prefilter,
    rays_hit_box,
    strict_inside,
    visibility_of,
)
from .claim import Traffic
from .ground import GroundFit, fit_ground, ground_points, local_ground
from .noise import StereoNoise, stereo_noise
from .poses import PoseTests, check_pose, footprint_support, frame_noise, scene_clearance
from .road import RoadLine, fit_road_line, road_line, surface_edges
from .rules import (
    ALLOWED_SURFACES,
    GROUND_LEVEL,
    INLIER_BAND,
    KERB_CLEARANCE,
    MAX_PENETRATION,
    ORIENTATION,
    ORIENTATIONS,
    POSE_GROUND_SEARCH,
    RULE_OF,
    Placement,
    PlacementResult,
    PlacementRules,
    Rejection,
    box_corners,
    label_mask,
)
from .search import no_ground, place_object
from .street import Street, find_street

__all__ = [
    "ALLOWED_SURFACES", "FOOTPRINT_SAMPLES", "GROUND_LEVEL", "INLIER_BAND", "KERB_CLEARANCE", "MAX_PENETRATION",
    "ORIENTATION", "ORIENTATIONS", "POSE_GROUND_SEARCH", "RULE_OF", "GroundFit", "Placement", "PlacementResult",
    "PlacementRules", "PoseTests", "Rejection", "RoadLine", "StereoNoise", "visibility_of", "box_corners", "check_pose",
    "fit_ground", "fit_road_line", "footprint_corners", "footprint_grid", "footprint_support", "footprints_overlap",
    "frame_noise", "ground_points", "label_mask", "local_ground", "no_ground", "penetration", "place_object", "pose_matrix",
    "prefilter", "rays_hit_box", "road_line", "scene_clearance", "stereo_noise", "strict_inside", "surface_edges",
    "Street", "Traffic", "find_street",
]
