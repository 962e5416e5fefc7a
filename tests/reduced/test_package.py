"""The layout of ``reduced``: the couplers, signal tools and kalman packages re-export what
their modules define, the rigid closed forms and the ODE driver return one two-mass history
type, and nothing in ``reduced`` imports femref or ann."""

from __future__ import annotations

import ast
import importlib
from dataclasses import fields

import numpy as np
import pytest
from support.paths import REPO

from reduced.couplers import Coupling, KelvinVoigt
from reduced.history import TwoMassHistory
from reduced.nonlinear import ImpactSimulation, simulate_impact
from reduced.rigid import ImpactPair, kelvin_voigt_impact, kelvin_voigt_perturbation

HOMES = {
    "reduced.couplers": {
        "base": ["OPERATIONS", "Branch", "CouplerLaw", "CouplerTangent", "PackedLaw"],
        "kelvin_voigt": ["KelvinVoigt"],
        "power_law": ["PowerLawGear"],
        "draft_gear": ["StandardLinearDraftGear"],
        "table": ["HystereticTable"],
        "friction_gear": ["TABULATION_TOLERANCE", "CubicLoading", "ExponentialLoading", "LoadingCurve", "friction_gear", "rated_closure_force", "tabulation_nodes"],
        "coupling": ["CONTACT_KINDS", "CouplerResponse", "Coupling"],
        "registry": ["COUPLER_LAWS", "compiled_form_rule", "coupling_from_name", "law_module"],
    },
    "reduced.signal_tools": {
        "smoothing": [
            "SMOOTHERS",
            "AdaptiveBandwidth",
            "AdaptiveFit",
            "GaussianKernel",
            "SavitzkyGolay",
            "Smoother",
            "SpectralLowPass",
            "integrate_twice",
            "robust_noise_std",
        ],
        "classification": ["CLOSING_SIGMAS", "IMPACT_KINDS", "MAX_THRESHOLD", "NOISE_ENERGY_FACTOR", "NOT_AN_IMPACT", "ImpactClassification",
                           "MomentumEvidence", "classify_impact", "momentum_evidence", "zero_frequency_ratio"],
        "closure_force": ["ClosureForceEstimate", "detect_closure_force"],
        "records": ["SCALER_KINDS", "FeatureScaler", "peak_normalise", "resample_record"],
    },
    "reduced.kalman": {
        "cars": ["CarDynamics", "ConsistCars", "CoupledCars", "SensorFilter"],
        "augmented": ["AugmentedModel", "augmented_model", "forced_response", "undetectable_couplers"],
        "linear_gaussian": ["GaussianSmoothing", "kalman_smoother", "van_loan_discretisation"],
        "steady": [],
        "estimate": ["DEFAULT_FORCE_RATE_RANGE", "NOISE_SCALES", "KalmanForce", "estimate_force", "estimate_forces", "smoothed_responses"],
        "variants": ["VariantForceEstimate", "car_mass_models", "corner_models", "estimate_force_with_variants", "estimate_forces_with_variants"],
    },
}


@pytest.mark.parametrize("package", sorted(HOMES))
def test_package_reexports_every_public_name_of_its_modules(package: str) -> None:
    """``from <package> import X`` is the object its module defines, for exactly the names in ``__all__``."""
    top = importlib.import_module(package)
    names = [n for members in HOMES[package].values() for n in members]
    assert sorted(top.__all__) == sorted(names)
    for module, members in HOMES[package].items():
        sub = importlib.import_module(f"{package}.{module}")
        assert sorted(sub.__all__) == sorted(members), module
        for name in members:
            assert getattr(top, name) is getattr(sub, name), f"{package}.{name}"


def test_reduced_never_imports_femref_or_ann() -> None:
    """numpy and scipy only: no module of ``reduced`` imports the FE package or the networks."""
    offenders = []
    for path in sorted((REPO / "reduced").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                roots = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                roots = [node.module.split(".")[0]]
            else:
                continue
            offenders += [f"{path.relative_to(REPO)}:{node.lineno} {r}" for r in roots if r in ("femref", "ann")]
    assert offenders == []


def test_closed_forms_and_ode_driver_return_one_two_mass_history() -> None:
    """The closed forms return a TwoMassHistory; the ODE driver its subclass, whose
    separation time is the first separation event."""
    pair = ImpactPair.source_study()
    t = np.linspace(0.0, 0.2, 201)
    closed = kelvin_voigt_impact(pair, 4.0e7, 3.0e5, t, contact="compression_only")
    series = kelvin_voigt_perturbation(pair, 4.0e7, 3.0e5, t)
    ode = simulate_impact(pair, Coupling(KelvinVoigt(4.0e7, 3.0e5)), t)
    assert type(closed) is TwoMassHistory and type(series) is TwoMassHistory
    assert isinstance(ode, ImpactSimulation) and isinstance(ode, TwoMassHistory)
    shared = [f.name for f in fields(TwoMassHistory)]
    assert [f.name for f in fields(ImpactSimulation)][: len(shared)] == shared
    assert ode.status == "ok", ode.message
    assert ode.separation_time == ode.event_times("separation")[0]
    assert ode.separation_time == pytest.approx(closed.separation_time, abs=1e-9)
    assert series.separation_time is None
    assert closed.model == "kelvin_voigt_closed_form[compression_only]"
    assert ode.model == "nonlinear_ode[KelvinVoigt, compression_only]"
