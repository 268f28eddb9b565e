"""synthcompose: insert rendered 3D objects into Cityscapes image sets, with full ground truth.

Stages, one module each: dataset -> geometry -> placement -> render -> compose -> writer;
:mod:`synthcompose.run.pipeline` runs them for a batch.
"""
__version__ = "0.1.0"
