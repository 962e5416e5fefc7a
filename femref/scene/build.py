"""From a validated case (:mod:`femref.case`) to the resolved scene: the one case → scene builder.

The case has already checked every rule; this module only converts (body specs to
:class:`femref.core.body.Body` alike for a single body and for a car, coupler specs to
:class:`reduced.couplers.Coupling`, network specs to loaded networks).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from femref.case import Case, CaseError, ImpactCase
from femref.case.measured import MeasuredCase
from femref.case.bodies import BodySchema
from femref.case.cars import CarSpec
from femref.case.couplers import CouplerSpec
from femref.case.estimators import ANY_IMPACT, AnnEstimatorSpec, MeasurementSpec
from femref.case.settings import FemSpec
from femref.core.body import Body
from femref.fem.build import FemSettings
from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from femref.scene.measured import Checks, KalmanModel, MeasuredCar, MeasuredCoupler, MeasuredScene
from femref.scene.single import Scene
from femref.sensing.calibration import read_calibration
from femref.sensing.measurement import Measurement
from femref.sensing.network import AnnEstimator, ImpactTypeNetworks, NetworkEstimator, NetworkFileError
from reduced.couplers import Coupling

__all__ = ["body_from_spec", "scene_from_case"]


def scene_from_case(case: Case, base_dir: Path | None = None) -> Scene | ImpactScene | MeasuredScene:
    """Resolve a case: profiles, signals, the frequency axis and settings (CSV paths relative to ``base_dir``)."""
    if case.kind == "impact":
        return impact_scene_from_case(case)
    if case.kind == "measured":
        return measured_scene_from_case(case)
    common = dict(body=body_from_spec(case.body), probes=dict(case.probes), models=tuple(case.models), fem=fem_settings_of(case.fem))
    if case.kind == "harmonic":
        loads = {name: complex(value) for name, value in case.load_amplitudes().items() if value != 0}
        return Scene(kind="harmonic", loads=loads, omega=np.asarray(case.omega(), dtype=float), **common)
    return Scene(kind="transient", loads=case.load_signals(base_dir), **_time_of(case), **common)


def _time_of(case: Case) -> dict[str, Any]:
    """The time settings of a transient or impact case (``rho_inf`` 1 for newmark, which has no numerical damping)."""
    time, integrator = case.time, case.integrator  # type: ignore[union-attr]
    rho_inf = integrator.rho_inf if integrator.rho_inf is not None else 1.0
    return dict(end=time.end, dt=time.dt, output_stride=time.output_stride, integrator=integrator.scheme, rho_inf=rho_inf)


def body_from_spec(spec: BodySchema) -> Body:
    """The resolved body of a body spec: built profiles and the wave travel time."""
    built = spec.profiles()
    return Body(
        kind=spec.type,
        half_length=spec.half_length,
        mass_per_length=built["mass_per_length"],
        stiffness=built["stiffness"],
        viscosity=built["viscosity"],
        wave_travel_time=spec.wave_time(),
    )


def fem_settings_of(fem: FemSpec) -> FemSettings:
    """The resolved finite-element settings (the case has filled in the element order)."""
    return FemSettings(elements=fem.elements, order=fem.order, grading=fem.grading, fields=fem.fields, field_stride=fem.field_stride)


def impact_scene_from_case(case: ImpactCase) -> ImpactScene:
    """Resolve the cars, couplers, model runs and settings of an impact case; :class:`CaseError` when
    :mod:`reduced.couplers` refuses a law by a rule the schema does not check, or a network file changed."""
    index = {name: i for i, name in enumerate(case.car_names)}
    bodies: dict[tuple, Body] = {}
    return ImpactScene(
        cars=tuple(_car_of(spec, _coupler_slopes(case, i), bodies) for i, spec in enumerate(case.cars)),
        couplers=tuple(_coupler_of(k, spec, index) for k, spec in enumerate(case.couplers)),
        runs=tuple(ModelRun(name, fidelity) for name, fidelity in case.run_fidelities().items()),
        **_time_of(case),
        fem=fem_settings_of(case.fem),
        modal_modes=case.modal.modes,
        measurement=_measurement_of(case.measurement),
        estimators=tuple(entry for entry in case.estimators if isinstance(entry, str)),
        networks=tuple(_network_of(i, spec) for i, spec in enumerate(case.estimators) if isinstance(spec, AnnEstimatorSpec)),
    )


def measured_scene_from_case(case: MeasuredCase) -> MeasuredScene:
    """Resolve the record files, cars (a body, or only mass and length), couplers, events, estimators and checks."""
    index = {car.name: i for i, car in enumerate(case.cars)}
    cars = []
    for spec in case.cars:
        body = body_from_spec(spec.body) if spec.body is not None else None
        mass = body.total_mass if body is not None else float(spec.mass)  # type: ignore[arg-type]
        cars.append(MeasuredCar(spec.name, body, mass, 2.0 * spec.half_length, dict(spec.sensors)))
    checks = case.checks
    return MeasuredScene(
        records=case.record_sources(),
        cars=tuple(cars),
        couplers=tuple(MeasuredCoupler(spec.name, index[spec.between[0]]) for spec in case.couplers),  # type: ignore[arg-type]
        trigger=case.events.trigger,
        pre=case.events.pre,
        post=case.events.post,
        rearm=case.events.rearm,
        quiet=case.events.quiet,
        max_window=case.events.max_window,
        estimators=tuple(entry for entry in case.estimators if isinstance(entry, str)),
        kalman=KalmanModel(case.kalman.modes, case.kalman.mass_tolerance, case.kalman.frequency_tolerance, tuple(case.kalman.damping_factors),
                           tuple(spec.mass_tolerance for spec in case.cars)),
        networks=tuple(_network_of(i, spec) for i, spec in enumerate(case.estimators) if isinstance(spec, AnnEstimatorSpec)),
        checks=Checks(checks.alarm, checks.rated_closure_force, checks.wear_tolerance),
        calibration=read_calibration(case.calibration) if case.calibration is not None else None,
        closing_speeds=case.events.stated_speeds(),
    )


def _shared_body(spec: BodySchema, bodies: dict[tuple, Body]) -> Body:
    """The body of ``spec``, one object per geometry in ``bodies`` (a scene's): cars alike share it, and with it
    what it computes once (:attr:`Body.total_mass`)."""
    body = body_from_spec(spec)
    return bodies.setdefault((body.geometry, body.wave_travel_time), body)


def _car_of(spec: CarSpec, slopes: tuple[float, float], bodies: dict[tuple, Body]) -> Car:
    bending = _shared_body(spec.body.beam(), bodies) if spec.body.bends else None
    return Car(name=spec.name, body=_shared_body(spec.body, bodies), velocity=spec.velocity, sensors=dict(spec.sensors),
               bending=bending, coupler_offset=(float(spec.coupler_offset[0]), float(spec.coupler_offset[1])), coupler_slope=slopes)


def _coupler_slopes(case: ImpactCase, car: int) -> tuple[float, float]:
    """The inclination of the couplers at car ``car``'s rear and front end (0 where none is attached)."""
    names = case.car_names
    rear = next((c.slope for c in case.couplers if c.between[1] == names[car]), 0.0)
    front = next((c.slope for c in case.couplers if c.between[0] == names[car]), 0.0)
    return (float(rear), float(front))


def _coupler_of(k: int, spec: CouplerSpec, index: dict[str, int]) -> Coupler:
    """Coupler ``k``: its rear car is the first of ``between`` (the case checked the line order)."""
    where = f"couplers[{k}].law.{spec.law.tag}"
    try:
        law = spec.law.build()
    except ValueError as error:  # a rule of reduced.couplers the schema does not know (yet)
        raise CaseError.at(where, str(error)) from None
    coupling = Coupling(law, contact=spec.contact, slack=spec.slack, tension_slack=spec.tension_slack)
    assert spec.name is not None  # the case fills in default names
    return Coupler(name=spec.name, rear=index[spec.between[0]], coupling=coupling)


def _network_of(i: int, spec: AnnEstimatorSpec) -> NetworkEstimator:
    """Load network estimator ``estimators[i]``; each file must still hold what the case validated."""
    networks = {}
    for kind, path in spec.files.items():
        where = ".".join([f"estimators[{i}]", *spec.where(kind)])
        try:
            networks[kind] = AnnEstimator.load(spec.name, path)
        except NetworkFileError as error:
            raise CaseError.at(where, str(error)) from None
        if networks[kind].contract != spec.contracts[kind]:
            raise CaseError.at(where, f"network file {path} changed since the case was validated; load the case again")
    return networks[ANY_IMPACT] if ANY_IMPACT in networks else ImpactTypeNetworks(spec.name, networks)


def _measurement_of(spec: MeasurementSpec | None) -> Measurement | None:
    if spec is None:
        return None
    return Measurement(rate=spec.rate, lowpass=spec.lowpass, noise=spec.noise, seed=spec.seed, pitch_rate_noise=spec.pitch_rate_noise)
