"""Quasi-rigid models (issue 3): low-frequency perturbation of the rigid-body motion of rods and beams.

``QuasiRigidRod`` and ``QuasiRigidBeam`` take arbitrary profiles (callables of x with
jump positions) and a creep kernel (Voigt by default) and give the two-term response
in the frequency domain (``harmonic``) and in the time domain (``transient``); their
``stepper`` is the displacement form for coupled simulation. numpy and scipy only.
"""

from .beam import QuasiRigidBeam
from .body import HarmonicResponse, LoadHistory, TransientResponse
from .coupled import QuasiRigidStepper, StepMatrices, StepPrediction, step_matrices
from .creep import VOIGT, CreepKernel, filter_piecewise_linear, harmonic_factor, harmonic_factor_at, update_coefficients
from .rod import QuasiRigidRod

__all__ = [
    "CreepKernel",
    "HarmonicResponse",
    "LoadHistory",
    "QuasiRigidBeam",
    "QuasiRigidRod",
    "QuasiRigidStepper",
    "StepMatrices",
    "StepPrediction",
    "TransientResponse",
    "VOIGT",
    "filter_piecewise_linear",
    "harmonic_factor",
    "harmonic_factor_at",
    "step_matrices",
    "update_coefficients",
]
