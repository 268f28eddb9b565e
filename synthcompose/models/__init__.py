"""3D models: load glTF/GLB/OBJ/STL/PLY (trimesh) and FBX (pyassimp) into one form
(:mod:`.mesh`: :class:`Model`, :class:`MeshPart`, object frame O: x forward, y left, z up,
metres, footprint centred, lowest point at z = 0); :mod:`.load` reads files, :mod:`.builtin`
builds the models named ``builtin:<name>``; :mod:`.skinning` poses skinned people (:mod:`.skin` reads and skins them,
:mod:`.rig`, :mod:`.poses`, :mod:`.gait`, :mod:`.arms` pose them)."""
from .builtin import BUILTINS, box_parts, traffic_sign_parts
from .load import MAX_TRIANGLES, load_model, model_digest
from .mesh import BUILTIN_PREFIX, GLASS_RGB, NEUTRAL_PLATE, MeshPart, Model, vertex_tangents
from .skinning import posable, pose_rng, posed_model

__all__ = ["BUILTINS", "BUILTIN_PREFIX", "GLASS_RGB", "MAX_TRIANGLES", "NEUTRAL_PLATE", "MeshPart", "Model",
           "box_parts", "load_model", "model_digest", "posable", "pose_rng", "posed_model", "traffic_sign_parts",
           "vertex_tangents"]
