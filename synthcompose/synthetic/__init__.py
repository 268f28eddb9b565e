"""Synthetic Cityscapes image sets of a straight street, with exactly known geometry.

Each frame is a procedurally drawn street scene ray-cast analytically, one ray per pixel
centre, in vectorised NumPy, and written in the exact Cityscapes layout (see
:mod:`synthcompose.io.dataset`), so the demo and the tests can run on data whose depth, labels
and instances are known exactly. The disparity written is, by default, what a semi-global
matcher would measure of that geometry (noise, fattening, holes, calibrated on real
Cityscapes frames); ``stereo="exact"`` writes the exact one. The photo is, by default, what
Cityscapes' camera records (dark, greenish, a wide range, little noise); ``photo="clean"``
keeps the shading as it is. The modules are the steps, in order:

scene     :class:`StreetScene`, :class:`Box`, :class:`Pole`: the street frame, ground plan and
          objects (the frames and the cross-section are described there)
layout    :func:`random_scene`: draws a street (camera, buildings, poles, cars, pedestrians)
streets   :class:`StreetKind`: streets laid out as traffic uses them (``street=`` option: two-way,
          one-way, parking bays, a zebra crossing)
raycast   the z-buffer of one ray per pixel centre: depth, primitive, face
shading   albedos, sky, the default light, haze, the bonnet
light     :class:`SceneLight`: an optional known light (linear light, cast shadows)
frame     :func:`render_scene`: the arrays of one frame (photo, labels, depth, disparity)
camera    :func:`camera_look`: the photo as Cityscapes' camera records it (default)
stereo    :func:`sgm_disparity`: the disparity as semi-global matching measures it (default)
writing   :func:`write_image_set`, :func:`make_sample`: the Cityscapes files

Everything random comes from the ``rng`` handed to :func:`random_scene` (and the scene's
``noise_seed``), so a seed gives byte-identical files.
"""
from .frame import HOLE_FRACTION, render_scene, render_scene_sunlit
from .layout import MAX_CAMBER, MAX_HEADING_DEG, MAX_SLOPE, random_camera, random_scene
from .light import SceneLight
from .photo import PHOTO_MODES, camera_look
from .scene import TEXTURES, Box, Pole, StreetScene
from .stereo import STEREO_MODES, sgm_disparity
from .streets import STREET_KINDS, StreetKind
from .writing import make_sample, write_image_set

__all__ = [
    "HOLE_FRACTION", "MAX_CAMBER", "MAX_HEADING_DEG", "MAX_SLOPE", "PHOTO_MODES", "TEXTURES", "Box", "Pole",
    "SceneLight", "STEREO_MODES", "STREET_KINDS", "StreetKind", "StreetScene", "camera_look", "make_sample", "random_camera",
    "random_scene",
    "render_scene", "render_scene_sunlit", "sgm_disparity", "write_image_set",
]
