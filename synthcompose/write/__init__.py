"""Stage 6 - write: the augmented image set's files (outputs), its annotations (COCO, 3D boxes) and polygons."""
