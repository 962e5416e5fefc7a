"""The resolutions a model may run at: the element and mode counts the bench and the model choice climb.

One list of each, so the bench's rows and the choice ladder's rungs are the same runs:

* fem: at least :data:`MIN_ELEMENTS` elements per car; :func:`with_elements` re-meshes a scene;
* modal: :data:`MODE_COUNTS` elastic modes per car, those the case's mesh holds
  (:func:`mode_counts`: at most ``ndof − 2`` of the smallest car's mesh).
"""

from __future__ import annotations

import dataclasses

from femref.fem.mesh import body_nodes
from femref.scene import ImpactScene

MIN_ELEMENTS = 4
"""Fewest fem elements per car a bench row or ladder rung uses."""
MODE_COUNTS: tuple[int, ...] = (1, 2, 4, 8, 16)
"""Elastic modes per modal car of the bench rows and ladder rungs (those the mesh holds)."""


def with_elements(scene: ImpactScene, elements: int) -> ImpactScene:
    """``scene`` with ``fem.elements`` per car replaced."""
    return dataclasses.replace(scene, fem=dataclasses.replace(scene.fem, elements=elements))


def mode_counts(scene: ImpactScene, candidates: tuple[int, ...] | None = None, ndof: int | None = None) -> list[int]:
    """The mode counts every car's fem mesh holds (``≤ ndof − 2``, ``ndof`` the smallest car's DOFs: given, or
    counted on the meshes) among ``candidates`` (default: :data:`MODE_COUNTS` and the case's ``modal_modes``),
    ascending."""
    if ndof is None:
        ndof = min(
            (body_nodes(car.body.half_length, scene.fem.elements, car.body.jumps, scene.fem.grading).size - 1) * scene.fem.order + 1
            for car in scene.cars
        )
    if candidates is None:
        candidates = (*MODE_COUNTS, scene.modal_modes)
    return sorted(k for k in set(candidates) if 1 <= k <= ndof - 2)


__all__ = ["MIN_ELEMENTS", "MODE_COUNTS", "mode_counts", "with_elements"]
