"""From a validated impact case (:class:`femref.case.ImpactCase`) to the resolved :class:`ImpactScene`.

The case has already checked every rule (names, line order, sensors, laws, runs); this
module only converts: rod specs to :class:`femref.scene.Body` (the same way single-body
scenes are built), coupler specs to :class:`reduced.couplers.Coupling`, runs to
per-car fidelity tuples in line order, network estimator specs to loaded
:class:`femref.impact.ann_estimator.AnnEstimator` networks.
"""

from __future__ import annotations

from pathlib import Path

from femref.case import CaseError, ImpactCase
from femref.case.impact import AnnEstimatorSpec, CarSpec, CouplerSpec, MeasurementSpec
from femref.impact.ann_estimator import AnnEstimator, NetworkFileError
from femref.impact.scene import Car, Coupler, ImpactScene, Measurement, ModelRun
from femref.scene_builder import body_from_spec, fem_settings_of
from reduced.couplers import Coupling

__all__ = ["impact_scene_from_case"]


def impact_scene_from_case(case: ImpactCase, base_dir: Path | None = None) -> ImpactScene:
    """Resolve the cars, couplers, model runs and settings of an impact case.

    ``base_dir`` is accepted for symmetry with :func:`femref.scene_builder.scene_from_case`:
    the network files of ``estimators`` were resolved (absolute) when the case was loaded.
    Raises :class:`CaseError` when :mod:`reduced.couplers` lacks a law the case names or
    refuses its parameters by a rule the schema does not check, or when a network file
    can no longer be read as it was at validation.
    """
    index = {name: i for i, name in enumerate(case.car_names)}
    integrator = case.integrator
    return ImpactScene(
        cars=tuple(_car_of(spec) for spec in case.cars),
        couplers=tuple(_coupler_of(k, spec, index) for k, spec in enumerate(case.couplers)),
        runs=tuple(ModelRun(name, fidelity) for name, fidelity in case.run_fidelities().items()),
        end=case.time.end,
        dt=case.time.dt,
        output_stride=case.time.output_stride,
        integrator=integrator.scheme,
        rho_inf=integrator.rho_inf if integrator.rho_inf is not None else 1.0,
        fem=fem_settings_of(case.fem),
        modal_modes=case.modal.modes,
        measurement=_measurement_of(case.measurement),
        estimators=tuple(entry for entry in case.estimators if isinstance(entry, str)),
        networks=tuple(_network_of(i, spec) for i, spec in enumerate(case.estimators) if isinstance(spec, AnnEstimatorSpec)),
    )


def _car_of(spec: CarSpec) -> Car:
    return Car(name=spec.name, body=body_from_spec(spec.body), velocity=spec.velocity, sensors=dict(spec.sensors))


def _coupler_of(k: int, spec: CouplerSpec, index: dict[str, int]) -> Coupler:
    """Coupler ``k``: its rear car is the first of ``between`` (the case checked the line order)."""
    where = f"couplers[{k}].law.{spec.law.tag}"
    try:
        law = spec.law.build()
    except LookupError as error:
        raise CaseError.at(where, f"this coupler law is not available: {error}") from None
    except ValueError as error:  # a rule of reduced.couplers the schema does not know (yet)
        raise CaseError.at(where, str(error)) from None
    coupling = Coupling(law, contact=spec.contact, slack=spec.slack, tension_slack=spec.tension_slack)
    assert spec.name is not None  # the case fills in default names
    return Coupler(name=spec.name, rear=index[spec.between[0]], coupling=coupling)


def _network_of(i: int, spec: AnnEstimatorSpec) -> AnnEstimator:
    """Load network estimator ``estimators[i]``; the file must still hold what the case validated."""
    where = f"estimators[{i}].network"
    try:
        network = AnnEstimator.load(spec.name, spec.network)
    except NetworkFileError as error:
        raise CaseError.at(where, str(error)) from None
    if network.contract != spec.contract:
        raise CaseError.at(where, f"network file {spec.network} changed since the case was validated; load the case again")
    return network


def _measurement_of(spec: MeasurementSpec | None) -> Measurement | None:
    if spec is None:
        return None
    return Measurement(rate=spec.rate, lowpass=spec.lowpass, noise=spec.noise, seed=spec.seed)
