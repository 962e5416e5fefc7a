"""From a resolved body to its finite-element operators: the mesh settings and the one assembly entry point.

A rod gets Lagrange elements of ``order`` 1 or 2 (:func:`femref.fem.operators.assemble_rod`),
a beam Hermite cubics (:func:`femref.fem.operators.assemble_beam`); the mesh has nodes
on every profile jump and kink (:func:`femref.fem.mesh.body_nodes`), optionally graded
toward the ends.
"""

from __future__ import annotations

from dataclasses import dataclass

from femref.core.body import Body
from femref.fem.mesh import body_nodes
from femref.fem.operators import Operators, assemble_beam, assemble_rod


@dataclass(frozen=True)
class FemSettings:
    """Mesh of a body (``elements`` per body; ``order`` of rod elements; ``grading`` toward the ends)
    and whether the displacement field is kept (every ``field_stride``-th output)."""

    elements: int = 64
    order: int = 2
    grading: float = 1.0
    fields: bool = False
    field_stride: int = 1


def build_operators(body: Body, settings: FemSettings) -> Operators:
    """Mesh the body (nodes on every profile jump and kink) and assemble its operators."""
    nodes = body_nodes(body.half_length, settings.elements, body.jumps, settings.grading)
    if body.kind == "rod":
        return assemble_rod(nodes, settings.order, body.mass_per_length, body.stiffness, body.viscosity)
    return assemble_beam(nodes, body.mass_per_length, body.stiffness, body.viscosity)
