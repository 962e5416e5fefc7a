"""Finite elements for Kelvin-Voigt rods and Euler-Bernoulli beams."""

from femref.fem.harmonic import HarmonicResponse, harmonic_response
from femref.fem.mesh import body_nodes, graded_nodes
from femref.fem.operators import Operators, assemble_beam, assemble_rod
from femref.fem.transient import INTEGRATORS, Integrator, Stepper, TransientResponse

__all__ = [
    "HarmonicResponse",
    "INTEGRATORS",
    "Integrator",
    "Operators",
    "Stepper",
    "TransientResponse",
    "assemble_beam",
    "assemble_rod",
    "body_nodes",
    "graded_nodes",
    "harmonic_response",
]
