"""Exact solutions for free-free Kelvin-Voigt rods and Euler-Bernoulli beams (issue 2 §3).

Harmonic responses (time factor ``e^{−iωt}``: closed form for one segment, transfer matrices
for several, each also on its own), the transient response of rods from rest
(:func:`rod_transient`, numerical inverse Laplace transform) and the Laplace-domain unit-load
responses behind them, all of a piecewise-constant body :class:`Segments`.

Conventions are those of docs/design.md §2: end loads are the internal force (moment,
shear) at the ends, tension positive; ``M a = F2 − F1`` for rods,
``M a_v = N1 − N2`` and ``J Ω = G2 − G1 − l(N1 + N2)`` for beams.
"""

from femref.exact.beam import (
    BeamFields,
    BeamHarmonic,
    BeamUnitResponse,
    beam_harmonic,
    beam_harmonic_closed_form,
    beam_harmonic_transfer,
    beam_unit_response_closed_form,
    beam_unit_response_transfer,
)
from femref.exact.laplace import invert_laplace
from femref.exact.rod import (
    RodHarmonic,
    RodUnitResponse,
    rod_harmonic,
    rod_harmonic_closed_form,
    rod_harmonic_transfer,
    rod_unit_response,
    rod_unit_response_closed_form,
    rod_unit_response_transfer,
)
from femref.exact.segments import Segments
from femref.exact.transient import RodTransient, rod_transient

__all__ = [
    "BeamFields",
    "BeamHarmonic",
    "BeamUnitResponse",
    "RodHarmonic",
    "RodTransient",
    "RodUnitResponse",
    "Segments",
    "beam_harmonic",
    "beam_harmonic_closed_form",
    "beam_harmonic_transfer",
    "beam_unit_response_closed_form",
    "beam_unit_response_transfer",
    "invert_laplace",
    "rod_harmonic",
    "rod_harmonic_closed_form",
    "rod_harmonic_transfer",
    "rod_transient",
    "rod_unit_response",
    "rod_unit_response_closed_form",
    "rod_unit_response_transfer",
]
