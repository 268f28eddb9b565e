"""Stage 3b - lighting: the light of each photo and its camera's look, for the inserted objects.

The package's files are its steps: ``light`` (the record of a light, :class:`LightEstimate`, and
the constants the cues share), ``grid`` (the photo reduced to cells with points and normals),
one file per cue (``shadows``, ``pairs``, ``casters``, ``lines``, ``ground_suns``; the ground plan's
``plan``, ``edges``, ``plansun``), ``estimate`` (the cues weighed into one estimate), ``colours`` (the
light's colours and the ground's levels) and ``camera_match`` (the camera's noise, blur and tone, given to the
inserted objects). The ``compare-lighting`` command lives in :mod:`synthcompose.tools.compare`.

The estimate:

No neural network: a low-order physical model fitted to the pixels, in linear light. The light
is the renderer's model (``shaders/lit.glsl``, :class:`synthcompose.render.Lighting`)::

    E(n) = ambient(n) + sun * max(0, n.l) * visible,   ambient(n) = mix(ground, sky, 0.5 + 0.5 n_z)

scaled so that an up-facing, unshadowed surface receives 1 (luminance). Cues, on a grid about
700 cells wide (cells of 3x3 pixels at 2048x1024; depth: the mean of a cell's known pixels;
normals: from the cells 1 and 2 apart, or, on the objects' faces (not the ground), where those
cross an edge - narrow faces, cells next to a corner - from the cell's centre pixel and the
photo's pixels 1 and 2 apart, so that a coarser grid does not lose the faces the shading needs):

* **cast shadows on the ground** (road, sidewalk, parking; up-facing cells only, none within
  half a metre of something standing, which is dark from ambient occlusion alone, no lane
  markings or kerbstones - bright and narrower than 1.75 m on the ground plan): the log
  luminance of each class is fitted by two levels, lit and a shared step down ``delta`` into
  shadow (EM, with an outlier component). A clear second level (gain >= 0.05 nats per sample,
  at least 30 % darker) means sunlight; ``exp(delta)`` is the sky's share of the light on
  up-facing ground, ``1 - exp(delta)`` the sun's. Without such shadows the light is ambient
  only (an overcast sky) - unless all the ground in view is lit: the
  shading pairs show a clear sun (:data:`LIT_GROUND_MIN_GAIN`) whose best direction (within
  :data:`LIT_GROUND_MARGIN`) the geometry says leaves the ground samples it can tell about lit
  (none predicted in shadow; at least :data:`LIT_GROUND_KNOWN` of them known), or, where the
  geometry cannot tell (the sun behind the camera), whose sunlit pairs reach down to the ground
  (:data:`LIT_PAIRS_LOW`: the sun reaches the feet of the walls and cars in view). Then the sun
  is that direction and the sky's share the pairs' fit. Failing that, where no ground lies a
  shadow step above its class's median (it is all lit, or all shadow), the casters' shadows
  may still show the sun (below). Failing that too, a clear shading sun whose sunlit pairs all
  stand above the ground (:data:`LIT_PAIRS_LOW`), and that the geometry does not see light
  the ground, lights the walls beyond the street's shadow: the sun is that direction, and all
  the ground in view is in shadow (``ground_shadowed``: an object standing on it gets the sky
  alone, as it would under an overcast sky, but a sunny day's sky).
* **shadows of the casters in view** (the sun ahead of the camera: the ground is nearly all
  lit, the shadows of cars, poles and people, falling towards the camera, too small a share for
  two levels, and no wall faces the sun for the shading): every point of what stands in view
  (below :data:`CASTER_MAX_HEIGHT` over its ground) throws its shadow, for a sun direction, onto
  a ground-plan map of the ground in view (log luminance against its class's median; ground
  under a car's body or at a caster's foot, dark from contact shadow alone, left out). A
  direction (elevation up to :data:`CASTER_MAX_ELEVATION`) whose shadows land on dark ground
  (:data:`CASTER_MIN_AGREEMENT`, :data:`CASTER_MIN_DARK`) is the sun; the step down where they
  land is the shadow's.
* **shading of surface pairs** (the sun's direction): pairs of nearby cells of one class on
  the two faces of a convex edge (car tops and sides, building corners, kerbs, poles), of one
  chromaticity (so a lamp or a window next to the edge does not count), whose normals (from the
  depth) differ. Their brightness ratio cancels the albedo and is fitted, with a robust loss,
  by the model over a grid of sun directions, sky shares and ground bounces; a pair may lie in a
  cast shadow instead (ambient only, at a small cost). Pairs are weighed so that no image region
  (one near car) outweighs the rest, and by class (:data:`PAIR_CLASS_WEIGHT`: building corners
  count most, cars, with lamps and trims, less, kerbs, too small for good normals, least).
* **straight shadow edges on the ground** (the sun's azimuth, where the ground has two levels):
  the shading of walls facing across the street tells little more than how far the sun stands
  to one side for its height, so a range of directions fits it about as well. The shadow of
  something vertical (a building's corner, a pole, a car's corner) has a straight edge along
  the sun's azimuth, whether or not the caster is in view. The edges between lit and shadowed
  ground are put on the ground plan (within 30 m), and the longest straight one that is at
  least :data:`LINE_MIN_LENGTH` long and off the street's axis and its normal (kerbs, roof
  lines and building ends throw edges along those) gives the azimuth, up to its half turn:
  the direction is then the best along it whose shading is within :data:`LINE_MARGIN` of the
  best.
* **shadows predicted from the geometry** (a weak tie-breaker): a height map of everything
  standing on the ground gives each ground sample's horizon towards each azimuth; a sun
  direction predicts which samples lie in shadow, where the visible scene can tell (paths that
  leave the view, or pass over occluders cut by the image top, are unknown). Agreement with the
  dark samples adds to the direction's score.
* **colour** (grey world on the ground): the ground's colour in shadow is the sky's, lit minus
  shadow the sun's; without shadows the ground's colour is the ambient colour.
* **real shadows**: the lit level of each ground class and the shadow step are kept, so that
  :meth:`LightEstimate.sun_visibility` / :meth:`LightEstimate.sun_mask` tell where the sun
  reaches the real ground (an inserted object standing in a real shadow gets no sun, and its
  own shadow darkens only sunlit ground).

``exposure`` is recorded as well: the lit road's luminance against a typical asphalt albedo
(:data:`ROAD_ALBEDO`; sidewalk against :data:`SIDEWALK_ALBEDO`), the irradiance the photo's
exposure implies. It is applied only where the manifest asks for it (``match_exposure``).
"""
from __future__ import annotations

from . import estimate, lines
from .camera_match import CameraMatch, estimate_blur, estimate_noise
from .estimate import estimate_lighting
from .light import GROUND_IDS, LUM, OCCLUDER_IDS, SHADING_IDS, LightEstimate, Lighting, camera_noise_seed, fixed_record

__all__ = ["CameraMatch", "GROUND_IDS", "LUM", "LightEstimate", "Lighting", "OCCLUDER_IDS", "SHADING_IDS", "camera_noise_seed",
           "estimate", "estimate_blur", "estimate_lighting", "estimate_noise", "fixed_record", "lines"]
