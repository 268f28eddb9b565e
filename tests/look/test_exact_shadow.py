"""Issue 29's outline measure on an exactly worked-out shadow (:mod:`evaluation.exact_shadow`): a
car's overcast shadow traced against its boxes, nothing rendered, reads as an outline, with an
under-car edge as sharp as the real cars' (docs/realism.md, "The outline of an exact shadow")."""
from __future__ import annotations

from evaluation import shadowlook
from evaluation.exact_shadow import light_grid, picture


def test_an_exact_overcast_shadow_of_a_car_reads_as_an_outline():
    sky, _ = light_grid(90, None, step=0.15, sky_dirs=16)
    src, out, _, car = picture(15, 90, sky, None)
    # the straight lines are the car's own: its sills' and bumpers' edges cast on the road
    assert shadowlook.outline(src, out, [car])[0] > 0.2
    # and the dark band's edge under it is as sharp as the real cars' (0.11-0.24 on the labelled
    # development frames; the inserted ones 0.03-0.12)
    assert shadowlook.under_edge(out, car, ~car) > 0.1
