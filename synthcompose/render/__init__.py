"""Stage 4 - render: the passes differential rendering needs, for a region of interest.

For the objects placed in one frame, :class:`Renderer` draws (all in linear light, in the
frame's own camera, only inside the screen rectangle the objects and their planes cover):

* ``irpv``  : objects + their local ground planes, lit, with shadows (4x MSAA, resolved)
* ``ir``    : the planes alone, lit, no shadows
* ``alpha`` : object coverage in [0, 1] (antialiased)
* ``odepth``: coverage-weighted object depth (divide by alpha for the mean depth)
* ``plane`` : (coverage-weighted plane depth, plane coverage)
* ``id``    : uint object index 1..K at each pixel centre (0 = none), and ``id_depth``

The modules: :mod:`.values` what a render takes and gives (no GL), :mod:`.transforms` the 4x4
matrices, :mod:`.gpu_model` the models and the ground plane on the GPU, :mod:`.shadows` the
light's depth maps, :mod:`.lit` lit.glsl's uniforms and draws, :mod:`.shading` per-sample or
per-pixel shading of the lit pass, :mod:`.renderer` the :class:`Renderer` running them in order.
"""
from .renderer import Renderer
from .values import FAR, NEAR, Lighting, RenderObject, RenderPasses, Roi, amodal_boxes, crop_camera, mask_box, roi_for

__all__ = ["FAR", "NEAR", "Lighting", "RenderObject", "RenderPasses", "Renderer", "Roi", "amodal_boxes", "crop_camera",
           "mask_box", "roi_for"]
