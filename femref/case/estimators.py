"""The sensor records of an impact case and what reads them: ``measurement`` and ``estimators``.

An ``estimators`` entry is an inverse estimator's name (``femref.core.catalog.ESTIMATORS``) or a saved
network (:class:`AnnEstimatorSpec`, read when the case is loaded). The checks of the estimators against
the scene are here too; the case runs them once the keys they relate are valid.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Field, PrivateAttr, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from femref.case.cars import CarSpec
from femref.case.couplers import CouplerSpec
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, NonNegativeReal, PositiveReal, entry_name, name_or_model, name_rule, reject_bool, resolve_case_path
from femref.core.catalog import ESTIMATORS as ESTIMATOR_NAMES
from femref.sensing.network import NetworkContract, NetworkFileError, read_network

__all__ = ["ANY_IMPACT", "QUASI_RIGID_INVERSE_SENSORS", "AnnEstimatorSpec", "EstimatorEntry", "MeasurementSpec", "NetworksByImpactType"]

#: Minimum sensors on the front car of every coupler that ``inverse_quasi_rigid`` needs.
QUASI_RIGID_INVERSE_SENSORS = 2


class MeasurementSpec(CaseModel):
    """How accelerometer records are made from the model's sensor accelerations:
    anti-alias low-pass, resampling at ``rate``, then white noise."""

    rate: PositiveReal | None = Field(default=None, description="Sampling rate of the records (Hz), > 0. Default null: the model's time grid.")
    lowpass: PositiveReal | None = Field(
        default=None, description="Low-pass corner frequency (Hz), > 0 and below rate/2 (Nyquist) when rate is given. Default null: no filter."
    )
    noise: NonNegativeReal = Field(default=0.0, description="Standard deviation of added white noise (m/s²), >= 0. Default 0.")
    seed: Annotated[int, BeforeValidator(reject_bool), Field(ge=0)] = Field(
        default=0, description="Seed of the noise generator, an integer >= 0. Default 0."
    )
    pitch_rate_noise: NonNegativeReal = Field(
        default=0.0, description="Standard deviation of white noise on the pitch-rate records of cars that bend (rad/s), >= 0. Default 0."
    )

    @model_validator(mode="after")
    def _below_nyquist(self) -> "MeasurementSpec":
        if self.rate is not None and self.lowpass is not None and self.lowpass >= 0.5 * self.rate:
            rule = f"must be below the Nyquist frequency rate/2 = {0.5 * self.rate:g} Hz"
            raise problems_error([Problem(("lowpass",), rule, self.lowpass)])
        return self


def _is_network_name(name: str) -> bool:
    return name == "ann" or name.startswith("ann_")


def _network_name(name: str) -> str:
    """A network estimator's result-group name: ``ann`` or ``ann_<name>`` (docs/design.md §4)."""
    name_rule("estimator")(name)
    if not _is_network_name(name) or name == "ann_":
        raise PydanticCustomError("network_name", "network estimators are named ann or ann_<name> (docs/design.md §4)")
    return name


class NetworksByImpactType(CaseModel):
    """One network file per impact type (``reduced.signal_tools.IMPACT_KINDS``): each record set is
    classified by the zero harmonic of its relative acceleration and read by its type's network."""

    free_to_roll: Path | None = Field(default=None, description="Network file for free-to-roll impacts, relative to the case file's directory.")
    coupled: Path | None = Field(default=None, description="Network file for coupled impacts, relative to the case file's directory.")

    @field_validator("free_to_roll", "coupled", mode="after")
    @classmethod
    def _resolve(cls, path: Path | None, info: ValidationInfo) -> Path | None:
        return None if path is None else resolve_case_path(path, info)

    @model_validator(mode="after")
    def _at_least_one(self) -> "NetworksByImpactType":
        if self.free_to_roll is None and self.coupled is None:
            raise problems_error([Problem((), "give a network file for free_to_roll, coupled or both")])
        return self


NetworkFiles = name_or_model(Path, NetworksByImpactType, ("file", "by_type"), ("network_shape", "must be a network file or {shape}",
                             {"shape": "{free_to_roll: file.npz, coupled: file.npz}"}), names=(str, Path))

#: The key of :attr:`AnnEstimatorSpec.files` of an estimator with one network for every impact type.
ANY_IMPACT = "any"


class AnnEstimatorSpec(CaseModel):
    """A trained network (an ``ann.storage`` file) that estimates one coupler's peak force from the fem sensor
    records (:mod:`femref.sensing.network`), or one network per impact type. Each file is read and its contract
    checked when the case is loaded; its path is stored resolved, so the resolved case reads it from anywhere."""

    name: Annotated[str, AfterValidator(_network_name)] = Field(description="Result-group name: ann or ann_<name>, unique. Required.")
    network: NetworkFiles = Field(
        description="Network file (ann.storage .npz), or {free_to_roll: file, coupled: file} for one per impact type; "
        "relative to the case file's directory. Required."
    )
    _contracts: dict[str, NetworkContract] = PrivateAttr(default_factory=dict)

    @field_validator("network", mode="after")
    @classmethod
    def _resolve(cls, network: Path | NetworksByImpactType, info: ValidationInfo) -> Path | NetworksByImpactType:
        return resolve_case_path(network, info) if isinstance(network, Path) else network

    @model_validator(mode="after")
    def _readable(self) -> "AnnEstimatorSpec":
        problems, contracts = [], {}
        for kind, path in self.files.items():
            try:
                _, contracts[kind] = read_network(path)
            except NetworkFileError as error:
                problems.append(Problem(self.where(kind), str(error)))
        couplers = {kind: contract.coupler for kind, contract in contracts.items()}
        if not problems and len(set(couplers.values())) > 1:
            listed = ", ".join(f"{kind} estimates {coupler}" for kind, coupler in couplers.items())
            problems.append(Problem(("network",), f"the networks of one estimator must estimate one coupler; {listed}"))
        if problems:
            raise problems_error(problems)
        self._contracts = contracts
        return self

    @property
    def files(self) -> dict[str, Path]:
        """Impact type → network file; one file for every type is under :data:`ANY_IMPACT`."""
        if isinstance(self.network, Path):
            return {ANY_IMPACT: self.network}
        return {kind: path for kind, path in (("free_to_roll", self.network.free_to_roll), ("coupled", self.network.coupled)) if path is not None}

    @property
    def contracts(self) -> dict[str, NetworkContract]:
        """Impact type → the network file's contract, as read at validation (keys of :attr:`files`)."""
        return self._contracts

    def where(self, kind: str) -> tuple[str, ...]:
        """The key path, under this entry, of the file of ``kind``."""
        return ("network",) if kind == ANY_IMPACT else ("network", kind)


def estimator_entry(names: tuple[str, ...]) -> Any:
    """The type of one entry of ``estimators``: one of the estimator ``names`` (an unknown name is refused with the
    known ones, or how a network is given) or an :class:`AnnEstimatorSpec`."""

    def known(name: str) -> str:
        if name not in names:
            hint = did_you_mean(name, list(names))
            if not hint and _is_network_name(name):
                hint = f" (a network estimator is a mapping {{name: {name}, network: file.npz}})"
            raise PydanticCustomError("estimator_name", "unknown estimator{hint}; known estimators: {known}, or a network {network}",
                                      {"hint": hint, "known": ", ".join(names), "network": "{name: ann_<name>, network: file.npz}"})
        return name

    return name_or_model(Annotated[str, AfterValidator(known)], AnnEstimatorSpec, ("inverse", "ann"),
                         ("estimator_shape", "must be an estimator name or a network {shape}", {"shape": "{name: ann_<name>, network: file.npz}"}))


#: One entry of an impact case's ``estimators``: an inverse estimator's name or an :class:`AnnEstimatorSpec`.
EstimatorEntry = estimator_entry(ESTIMATOR_NAMES)


def estimators_rule(entries: tuple[str | AnnEstimatorSpec, ...]) -> tuple[str | AnnEstimatorSpec, ...]:
    """Each estimator once: names unique (a name listed twice, or two networks of one name)."""
    problems = []
    names = [entry_name(entry) for entry in entries]
    for i, (entry, name) in enumerate(zip(entries, names)):
        if name not in names[:i]:
            continue
        if isinstance(entry, str):
            problems.append(Problem((i,), "is listed twice", name))
        else:
            problems.append(Problem((i, "name"), f"duplicate estimator name; {name!r} is already used at index {names.index(name)}", name))
    if problems:
        raise problems_error(problems)
    return entries


def quasi_rigid_sensor_problems(at: int, cars: tuple[CarSpec, ...], couplers: tuple[CouplerSpec, ...]) -> list[Problem]:
    """``inverse_quasi_rigid`` differentiates the acceleration along the front car of each coupler."""
    by_name = {car.name: car for car in cars}
    problems = []
    for coupler in couplers:
        front = by_name[coupler.between[1]]
        if len(front.sensors) < QUASI_RIGID_INVERSE_SENSORS:
            rule = (
                f"inverse_quasi_rigid needs >= {QUASI_RIGID_INVERSE_SENSORS} sensors on the front car of every coupler; "
                f"car {front.name!r} (front of coupler {coupler.name}) has {len(front.sensors)}: {', '.join(front.sensors)}"
            )
            problems.append(Problem((at,), rule, "inverse_quasi_rigid"))
    return problems


def network_problems(contract: NetworkContract, cars: tuple[CarSpec, ...], couplers: tuple[CouplerSpec, ...] | None, data: Mapping[str, Any]) -> list[Problem]:
    """A network's contract against the scene (``data``: the case keys validated so far): its coupler, probes and
    cars exist, its records fit in ``time.end``, and the case measures them as the training records were
    (same rate and low-pass; noise and seed may differ — testing on noisier records is legitimate)."""
    probes = [f"{car.name}/{sensor}" for car in cars for sensor in car.sensors]
    coupler_names = None if couplers is None else [c.name for c in couplers]
    problems = contract_scene_problems(contract, coupler_names, probes, "are not sensors of this case; probes", [car.name for car in cars])
    time = data.get("time")
    if time is not None and contract.record_end > time.end:
        problems.append(Problem((), f"the network reads records over [0, {contract.record_end:g}] s, beyond time.end = {time.end:g} s"))
    if "measurement" in data:
        problem = _chain_problem(contract, data["measurement"])
        if problem is not None:
            problems.append(Problem((), problem))
    return problems


def contract_scene_problems(contract: NetworkContract, couplers: list[str] | None, probes: list[str], absent: str, cars: list[str]) -> list[Problem]:
    """The network's coupler, probes and mass inputs against the case's ``couplers`` (None: not compared), ``probes``
    (those it lacks "``absent``: <probes>") and ``cars``."""
    rules = []
    if couplers is not None and contract.coupler not in couplers:
        rules.append(f"the network estimates coupler {contract.coupler!r}, which this case does not have; couplers: {', '.join(couplers)}")
    if missing := [probe for probe in contract.probes if probe not in probes]:
        rules.append(f"the network reads probe(s) {', '.join(missing)}, which {absent}: {', '.join(probes)}")
    if unknown := [car for car in contract.mass_inputs if car not in cars]:
        rules.append(f"the network takes the mass of car(s) {', '.join(unknown)}, which this case does not have; cars: {', '.join(cars)}")
    return [Problem((), rule) for rule in rules]


def _chain_problem(contract: NetworkContract, measurement: MeasurementSpec | None) -> str | None:
    """Why the case's records are not measured like the network's training records, or None."""
    trained = contract.measurement
    if trained is None:
        if measurement is not None:
            return "the network was trained on the model's own sensor accelerations (record_source model); this case measures them (measurement:) — remove measurement or use a network trained on measured records"
        return None
    chain = f"rate {_hz(trained.rate)}, lowpass {_hz(trained.lowpass)}"
    if measurement is None:
        return f"the network was trained on measured records ({chain}); add that measurement: to the case"
    if not (_same(measurement.rate, trained.rate) and _same(measurement.lowpass, trained.lowpass)):
        return (
            f"the network was trained on records measured at {chain}; this case measures at rate {_hz(measurement.rate)}, "
            f"lowpass {_hz(measurement.lowpass)} (rate and lowpass must match; noise and seed may differ)"
        )
    return None


def _same(a: float | None, b: float | None) -> bool:
    return a is None and b is None or (a is not None and b is not None and math.isclose(a, b, rel_tol=1e-9))


def _hz(value: float | None) -> str:
    return "null" if value is None else f"{value:g} Hz"
