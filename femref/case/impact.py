"""The ``kind: impact`` case (DESIGN.md §3): cars in a line joined by couplers.

Layout of an impact case file::

    cars:        >= 2 rods in line order (rear to front): cars[i]'s +l end faces cars[i+1]'s −l end
    couplers:    >= 1, each between two neighbours [cars[i].name, cars[i+1].name], with a law
                 (registry :data:`COUPLER_LAW_SPECS`), contact and slack
    time, integrator, fem:   as in transient cases (fem.elements is per car)
    models:      model runs: a model name (uniform run) or {name, fidelity, cars} (mixed run)
    modal:       {modes}: elastic modes per modal car
    measurement: optional accelerometer model (rate, lowpass, noise, seed)
    estimators:  estimators run on the fem sensor records: an inverse estimator's name, or a
                 network {name: ann_<name>, network: file.npz} (a saved ann.storage network)
    tolerance:   optional {value, output} (or a number): choose the cheapest model expected within
                 it instead of running ``models`` (femref.choice)

Validation follows :mod:`femref.case.schema`: each key on its own first (every failure
reported), then the rules that relate keys — sensors against the car length, couplers
against the car names and line order, car overrides of mixed runs against the car names,
estimators against the runs, sensors, couplers, time and measurement — once the keys they
relate are valid. A network file is read when the case is loaded (like a CSV load), so a
missing or broken file is a case error too.

:func:`femref.impact.build.impact_scene_from_case` turns a validated case into the
frozen :class:`femref.impact.scene.ImpactScene`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import AfterValidator, BeforeValidator, Discriminator, Field, PrivateAttr, Tag, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from femref.case.capabilities import MODELS, refusal
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case import schema
from femref.case.schema import (
    CaseModel,
    FemSettings,
    IntegratorSettings,
    NonNegativeReal,
    PositiveReal,
    ProbeName,
    Real,
    RodBody,
    SceneCase,
    TaggedSpec,
    TimeSettings,
    _fem_field,
    _reject_bool,
    _tagged_union,
    resolve_case_path,
)
from femref.impact.ann_estimator import NetworkContract, NetworkFileError, read_network
from femref.impact.scene import ESTIMATOR_NAMES, FIDELITIES
from reduced.couplers import CONTACT_KINDS, KelvinVoigt, StandardLinearDraftGear

__all__ = [
    "COUPLER_LAW_SPECS",
    "AnnEstimatorSpec",
    "CarSpec",
    "CouplerLawSpec",
    "CouplerSpec",
    "DraftGearLaw",
    "ImpactCase",
    "KelvinVoigtLaw",
    "MeasurementSpec",
    "ModalSettings",
    "ModelRunSpec",
    "TableLaw",
    "ToleranceSpec",
]

#: Models run when a case gives no ``models`` list.
DEFAULT_MODELS: tuple[str, ...] = ("fem", "quasi_rigid", "rigid")
#: Result-group names a mixed run may not take (DESIGN.md §4: model names, ``ann_<name>``, scores).
RESERVED_RUN_NAMES: tuple[str, ...] = (*MODELS, *ESTIMATOR_NAMES, "scores")
#: Default of the table law's rate threshold between loading and unloading (m/s).
DEFAULT_SWITCH_VELOCITY = 0.01


# ---------------------------------------------------------------------------------------------
# Names


def _name_rule(what: str) -> Callable[[str], str]:
    """A validator: ``what`` names use letters, digits, '_', '-', '.' (they become HDF5 path parts)."""

    def check(name: str) -> str:
        if not name or not all(c.isalnum() or c in "_-." for c in name):
            raise PydanticCustomError("name_chars", "{what} names use letters, digits, '_', '-' and '.' only", {"what": what})
        return name

    return check


CarName = Annotated[str, AfterValidator(_name_rule("car"))]
CouplerName = Annotated[str, AfterValidator(_name_rule("coupler"))]
RunName = Annotated[str, AfterValidator(_name_rule("run"))]


def _fidelity(name: str) -> str:
    """A per-car fidelity, with a hint for misspellings."""
    if name not in FIDELITIES:
        raise PydanticCustomError(
            "fidelity", "unknown fidelity{hint}; a car is one of {known}", {"hint": did_you_mean(name, FIDELITIES), "known": ", ".join(FIDELITIES)}
        )
    return name


#: How one car is modelled within a run: one of ``femref.impact.scene.FIDELITIES``.
Fidelity = Annotated[str, AfterValidator(_fidelity)]


def _duplicates(names: list[str], what: str, path_of: Callable[[int], tuple[str | int, ...]]) -> list[Problem]:
    """A problem at each repeat of a name, pointing back at its first use."""
    first: dict[str, int] = {}
    problems = []
    for i, name in enumerate(names):
        if name in first:
            problems.append(Problem(path_of(i), f"duplicate {what} name; {name!r} is already used at index {first[name]}", name))
        first.setdefault(name, i)
    return problems


# ---------------------------------------------------------------------------------------------
# Cars


class CarSpec(CaseModel):
    """One car: a rod body (longitudinal impact), its initial velocity and its accelerometers."""

    name: CarName = Field(description="Car name, unique; letters, digits, '_', '-', '.'. Probes are named <car>/<sensor>. Required.")
    body: RodBody = Field(description="The car body: a rod (type: rod) exactly as in transient cases, any profiles. Required.")
    velocity: Real = Field(description="Initial velocity (m/s), finite, positive toward the front of the line (+x). Required.")
    sensors: dict[ProbeName, Real] = Field(
        default_factory=lambda: {"center": 0.0},
        description="Accelerometers: name → position x (m) within [−l, l]; at least one. Default {center: 0}.",
    )

    @field_validator("body", mode="wrap")
    @classmethod
    def _a_rod(cls, value: Any, handler: Callable[[Any], Any]) -> Any:
        """Refuse beams before checking their keys: an impact car is loaded along its axis."""
        if isinstance(value, Mapping):
            if "type" not in value:
                raise problems_error([Problem(("type",), "required key is missing; impact cars are rods (type: rod)")])
            if value["type"] == "beam":
                raise problems_error([Problem(("type",), "impact cars are rods (longitudinal impact)", "beam")])
        return handler(value)

    @field_validator("sensors", mode="after")
    @classmethod
    def _sensors_on_the_car(cls, value: dict[str, float], info: ValidationInfo) -> dict[str, float]:
        if not value:
            raise PydanticCustomError("sensors_empty", "must name at least one sensor (or be left out for {default})", {"default": "{center: 0}"})
        body = info.data.get("body")
        if body is None:
            return value
        l = body.half_length  # noqa: E741
        rule = f"must lie on the car, |x| <= l = {l} m (within [{-l}, {l}])"
        problems = [Problem((name,), rule, x) for name, x in value.items() if abs(x) > l]
        if problems:
            raise problems_error(problems)
        return value


def _cars_rule(cars: tuple[CarSpec, ...]) -> tuple[CarSpec, ...]:
    """At least two cars, unique names."""
    if len(cars) < 2:
        raise problems_error([Problem((), f"an impact needs at least 2 cars, in line order (rear to front); got {len(cars)}")])
    problems = _duplicates([car.name for car in cars], "car", lambda i: (i, "name"))
    if problems:
        raise problems_error(problems)
    return cars


# ---------------------------------------------------------------------------------------------
# Coupler laws (registry COUPLER_LAW_SPECS)


class CouplerLawSpec(TaggedSpec):
    """A coupler force law ``P(δ, δ̇, state)`` (N, compression positive), built into a ``reduced.couplers`` law."""

    def build(self) -> Any:
        """The ``reduced.couplers`` law object."""
        raise NotImplementedError


class KelvinVoigtLaw(CouplerLawSpec):
    """Linear spring and dashpot in parallel, ``P = c δ + μ δ̇`` (reduced.couplers.KelvinVoigt)."""

    tag: ClassVar[str] = "kelvin_voigt"
    stiffness: PositiveReal = Field(description="Spring stiffness c (N/m), > 0. Required.")
    damping: NonNegativeReal = Field(default=0.0, description="Dashpot μ (N·s/m), >= 0. Default 0.")

    def build(self) -> KelvinVoigt:
        return KelvinVoigt(stiffness=self.stiffness, damping=self.damping)


class DraftGearLaw(CouplerLawSpec):
    """Standard-linear draft gear with a stroke (reduced.couplers.StandardLinearDraftGear):
    two series springs carry the force to a gear spring with a dashpot, stiffening to
    ``solid_stiffness`` beyond the stroke."""

    tag: ClassVar[str] = "draft_gear"
    gear_stiffness: PositiveReal = Field(description="Gear spring c (N/m) while the gear is open, > 0. Required.")
    gear_damping: PositiveReal = Field(description="Gear dashpot μ (N·s/m), > 0. Required.")
    stroke: PositiveReal = Field(description="Gear travel before it closes solid (m), > 0. Required.")
    solid_stiffness: PositiveReal = Field(description="Gear stiffness c* beyond the stroke (N/m), > 0. Required.")
    series_stiffness_1: PositiveReal = Field(default=4.0e8, description="First series spring c1, car body (N/m), > 0. Default 4e8.")
    series_stiffness_2: PositiveReal = Field(default=4.0e8, description="Second series spring c2, coupler (N/m), > 0. Default 4e8.")

    def build(self) -> StandardLinearDraftGear:
        return StandardLinearDraftGear(
            series_stiffness_1=self.series_stiffness_1,
            series_stiffness_2=self.series_stiffness_2,
            gear_stiffness=self.gear_stiffness,
            gear_damping=self.gear_damping,
            stroke=self.stroke,
            solid_stiffness=self.solid_stiffness,
        )


class TableLaw(CouplerLawSpec):
    """Tabulated loading and unloading curves with hysteresis (reduced.couplers.HystereticTable):
    the force follows ``loading`` while the closure grows and ``unloading`` while it shrinks
    (the closure rate past ``switch_velocity`` picks the curve), plus ``damping · δ̇``."""

    tag: ClassVar[str] = "table"
    closure: tuple[Real, ...] = Field(min_length=2, description="Closures δ (m), strictly increasing from 0; two or more. Required.")
    loading: tuple[Real, ...] = Field(min_length=2, description="Force on the loading curve (N) at each closure: starts at 0, never decreases. Required.")
    unloading: tuple[Real, ...] = Field(
        min_length=2, description="Force on the unloading curve (N) at each closure: starts at 0, 0 <= unloading <= loading. Required."
    )
    damping: NonNegativeReal = Field(default=0.0, description="Viscous term added to either curve (N·s/m), >= 0. Default 0.")
    switch_velocity: PositiveReal = Field(
        default=DEFAULT_SWITCH_VELOCITY,
        description=f"Closure rate (m/s) over which the force blends between the curves, > 0. Default {DEFAULT_SWITCH_VELOCITY}.",
    )

    @model_validator(mode="after")
    def _curves(self) -> "TableLaw":
        problems = self._closure_problems() + self._curve_problems()
        if problems:
            raise problems_error(problems)
        return self

    def _closure_problems(self) -> list[Problem]:
        problems = []
        if self.closure[0] != 0.0:
            problems.append(Problem(("closure", 0), "must be 0: the table starts at zero closure", self.closure[0]))
        if any(a >= b for a, b in zip(self.closure, self.closure[1:])):
            problems.append(Problem(("closure",), "must increase strictly", list(self.closure)))
        return problems

    def _curve_problems(self) -> list[Problem]:
        n = len(self.closure)
        problems = [
            Problem((key,), f"must have one force per closure point: {n} entries, not {len(curve)}", list(curve))
            for key, curve in (("loading", self.loading), ("unloading", self.unloading))
            if len(curve) != n
        ]
        if problems:
            return problems
        for key, curve in (("loading", self.loading), ("unloading", self.unloading)):
            if curve[0] != 0.0:
                problems.append(Problem((key, 0), "must be 0: no force at zero closure", curve[0]))
        if any(a > b for a, b in zip(self.loading, self.loading[1:])):
            problems.append(Problem(("loading",), "must not decrease", list(self.loading)))
        if self.loading[-1] <= 0.0:
            problems.append(Problem(("loading",), "must rise above 0 (a coupler that carries no force)", list(self.loading)))
        for i, (down, up) in enumerate(zip(self.unloading, self.loading)):
            if down < 0.0:
                problems.append(Problem(("unloading", i), "must be >= 0", down))
            elif down > up:
                problems.append(Problem(("unloading", i), f"must not exceed loading[{i}] = {up}: unloading lies below loading", down))
        return problems or self._extension_problems()

    def _extension_problems(self) -> list[Problem]:
        """Beyond the last point the curves go on with their last slopes; they must stay ordered there."""
        h = self.closure[-1] - self.closure[-2]
        slope_up, slope_down = (self.loading[-1] - self.loading[-2]) / h, (self.unloading[-1] - self.unloading[-2]) / h
        if 0.0 <= slope_down <= slope_up:
            return []
        rule = (
            "beyond the last closure the curves continue with their last slopes, so the last unloading slope must lie "
            f"in [0, last loading slope = {slope_up:.6g} N/m]; it is {slope_down:.6g} N/m"
        )
        return [Problem(("unloading",), rule, list(self.unloading))]

    def build(self) -> Any:
        """The table law of :mod:`reduced.couplers`, looked up when needed (it is the newest law there)."""
        from reduced import couplers

        law = couplers.COUPLER_LAWS.get(self.tag) or getattr(couplers, "HystereticTable", None)
        if law is None:
            raise LookupError("reduced.couplers has no table law (HystereticTable) in this installation")
        return law(
            closure=self.closure,
            loading=self.loading,
            unloading=self.unloading,
            damping=self.damping,
            switch_velocity=self.switch_velocity,
        )


#: Coupler laws by case-file name.
COUPLER_LAW_SPECS: Mapping[str, type[CouplerLawSpec]] = {"kelvin_voigt": KelvinVoigtLaw, "draft_gear": DraftGearLaw, "table": TableLaw}

AnyCouplerLaw = _tagged_union(COUPLER_LAW_SPECS, "coupler law")


# ---------------------------------------------------------------------------------------------
# Couplers


def _two_names(value: Any) -> Any:
    """``between`` is exactly two names; whether they are cars in line order is checked on the case."""
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise PydanticCustomError("between_shape", "must be a list of two car names in line order, [rear, front]")


Between = Annotated[tuple[str, str], BeforeValidator(_two_names)]


class CouplerSpec(CaseModel):
    """A coupler joining the front (+l) of a car to the back (−l) of the next car in line."""

    name: CouplerName | None = Field(
        default=None, description="Coupler name, unique; letters, digits, '_', '-', '.'. Default c<k> for the k-th coupler (1-based)."
    )
    between: Between = Field(description="The two cars it joins, neighbours in line order: [cars[i].name, cars[i+1].name]. Required.")
    law: AnyCouplerLaw = Field(description="Force law: exactly one of kelvin_voigt, draft_gear, table. Required.")
    contact: Literal[CONTACT_KINDS] = Field(  # type: ignore[valid-type]
        default="compression_only",
        description="compression_only (free to roll: the cars may separate) or bilateral (coupled: tension too). Default compression_only.",
    )
    slack: NonNegativeReal = Field(default=0.0, description="Initial gap (m), >= 0, closed before the coupler carries compression. Default 0.")
    tension_slack: NonNegativeReal = Field(
        default=0.0, description="Free play in tension (m), >= 0, bilateral contact only. Default 0."
    )

    @model_validator(mode="after")
    def _tension_slack_bilateral(self) -> "CouplerSpec":
        if self.contact == "compression_only" and self.tension_slack != 0.0:
            rule = "applies to bilateral contact only; compression_only never transmits tension"
            raise problems_error([Problem(("tension_slack",), rule, self.tension_slack)])
        return self


def _line_order_rule(rear: int, front: int, names: list[str]) -> str:
    """Why ``[names[rear], names[front]]`` is not a pair of neighbours in line order."""
    if rear == front:
        return "names the same car twice; a coupler joins two neighbouring cars"
    if front == rear - 1:
        return f"lists the cars in reverse order; the rear car comes first, in line order: [{names[front]}, {names[rear]}]"
    pairs = ", ".join(f"[{a}, {b}]" for a, b in zip(names, names[1:]))
    return f"{names[rear]} (cars[{rear}]) and {names[front]} (cars[{front}]) are not neighbours; a coupler joins [cars[i], cars[i+1]]: one of {pairs}"


def _coupler_pair_problems(couplers: tuple[CouplerSpec, ...], names: list[str]) -> list[Problem]:
    """Couplers name known cars, join neighbours in line order, one coupler per pair."""
    index = {name: i for i, name in enumerate(names)}
    problems: list[Problem] = []
    taken: dict[int, int] = {}
    for k, coupler in enumerate(couplers):
        unknown = [(i, name) for i, name in enumerate(coupler.between) if name not in index]
        for i, name in unknown:
            problems.append(Problem((k, "between", i), f"unknown car{did_you_mean(name, names)}; cars: {', '.join(names)}", name))
        if unknown:
            continue
        rear, front = (index[name] for name in coupler.between)
        if front != rear + 1:
            problems.append(Problem((k, "between"), _line_order_rule(rear, front, names), list(coupler.between)))
        elif rear in taken:
            rule = f"cars {names[rear]} and {names[front]} already have a coupler (couplers[{taken[rear]}]); one coupler per pair"
            problems.append(Problem((k, "between"), rule, list(coupler.between)))
        else:
            taken[rear] = k
    return problems


# ---------------------------------------------------------------------------------------------
# Model runs


class ModelRunSpec(CaseModel):
    """A mixed-fidelity model run: each car modelled at ``fidelity`` unless overridden in ``cars``."""

    name: RunName = Field(description="Result-group name, unique among the runs; not a model or estimator name (unless this is that model's uniform run). Required.")
    fidelity: Fidelity = Field(description=f"Fidelity of every car not in cars: one of {', '.join(FIDELITIES)}. Required.")
    cars: dict[str, Fidelity] = Field(default_factory=dict, description="Per-car overrides: car name → fidelity. Default {} (no overrides).")

    @model_validator(mode="after")
    def _not_a_reserved_name(self) -> "ModelRunSpec":
        if self.name in RESERVED_RUN_NAMES and not self._is_uniform_run_of(self.name):
            if self.name in FIDELITIES:
                rule = f"{self.name!r} names the uniform {self.name} run; give a mixed run another name (e.g. {self.fidelity}_with_...)"
            else:
                rule = f"{self.name!r} is a reserved result-group name ({', '.join(RESERVED_RUN_NAMES)}); choose another"
            raise problems_error([Problem(("name",), rule, self.name)])
        if self.name.startswith("ann_"):
            raise problems_error([Problem(("name",), "names starting with 'ann_' are reserved for network estimators (ann_<name>)", self.name)])
        return self

    def _is_uniform_run_of(self, fidelity: str) -> bool:
        return self.fidelity == fidelity and all(f == fidelity for f in self.cars.values())

    def fidelities(self, car_names: list[str]) -> tuple[str, ...]:
        """The fidelity of each car, in line order."""
        return tuple(self.cars.get(name, self.fidelity) for name in car_names)


def _known_model(name: str) -> str:
    """A plain ``models`` entry names a registered model (whether it can serve is checked on the whole case)."""
    if name not in MODELS:
        raise PydanticCustomError(
            "model_name", "unknown model{hint}; known models: {known}", {"hint": did_you_mean(name, MODELS), "known": ", ".join(MODELS)}
        )
    return name


def _run_kind(value: Any) -> str | None:
    """The union tag of a ``models`` entry: a plain model name or a mixed-run mapping."""
    if isinstance(value, str):
        return "plain"
    if isinstance(value, (Mapping, ModelRunSpec)):
        return "mixed"
    return None


def _run_shape(value: Any) -> Any:
    """Refuse an entry that is neither (pydantic would report a missing tag instead)."""
    if _run_kind(value) is None:
        raise PydanticCustomError("run_shape", "must be a model name or a mapping {shape}", {"shape": "{name, fidelity, cars}"})
    return value


#: One entry of ``models``: a model name (a uniform run) or a :class:`ModelRunSpec`.
ModelRunEntry = Annotated[
    Union[Annotated[Annotated[str, AfterValidator(_known_model)], Tag("plain")], Annotated[ModelRunSpec, Tag("mixed")]],  # noqa: UP007
    Discriminator(_run_kind),
    BeforeValidator(_run_shape),
]


def _run_name(entry: str | ModelRunSpec) -> str:
    """The result-group name of a run: the model name of a uniform run, the given name of a mixed one."""
    return entry if isinstance(entry, str) else entry.name


def _runs_rule(runs: tuple[str | ModelRunSpec, ...]) -> tuple[str | ModelRunSpec, ...]:
    """At least one run; run names unique."""
    if not runs:
        raise PydanticCustomError("models_empty", "must list at least one model run ({known})", {"known": ", ".join(FIDELITIES)})
    problems = _duplicates([_run_name(run) for run in runs], "run", lambda i: (i,))
    if problems:
        raise problems_error(problems)
    return runs


# ---------------------------------------------------------------------------------------------
# Modal settings, measurement, estimators


class ModalSettings(CaseModel):
    """The modal car model: rigid mode, ``modes`` free-free elastic modes and a static correction."""

    modes: Annotated[int, BeforeValidator(_reject_bool), Field(ge=1)] = Field(
        default=4, description="Elastic modes kept per modal car, an integer >= 1. Default 4."
    )


class MeasurementSpec(CaseModel):
    """How accelerometer records are made from the model's sensor accelerations:
    anti-alias low-pass, resampling at ``rate``, then white noise."""

    rate: PositiveReal | None = Field(default=None, description="Sampling rate of the records (Hz), > 0. Default null: the model's time grid.")
    lowpass: PositiveReal | None = Field(
        default=None, description="Low-pass corner frequency (Hz), > 0 and below rate/2 (Nyquist) when rate is given. Default null: no filter."
    )
    noise: NonNegativeReal = Field(default=0.0, description="Standard deviation of added white noise (m/s²), >= 0. Default 0.")
    seed: Annotated[int, BeforeValidator(_reject_bool), Field(ge=0)] = Field(
        default=0, description="Seed of the noise generator, an integer >= 0. Default 0."
    )

    @model_validator(mode="after")
    def _below_nyquist(self) -> "MeasurementSpec":
        if self.rate is not None and self.lowpass is not None and self.lowpass >= 0.5 * self.rate:
            rule = f"must be below the Nyquist frequency rate/2 = {0.5 * self.rate:g} Hz"
            raise problems_error([Problem(("lowpass",), rule, self.lowpass)])
        return self


#: Outputs a tolerance may be set on (femref.choice.estimates.OUTPUTS; kept here so the case needs no solver import).
TOLERANCE_OUTPUTS: tuple[str, ...] = ("peak_coupler_force", "coupler_force")


class ToleranceSpec(CaseModel):
    """The accuracy the run must reach: ``femref run`` then chooses the cheapest model expected
    to meet it (femref.choice). A bare number is ``{value: number}``."""

    value: Annotated[float, BeforeValidator(_reject_bool), Field(gt=0.0, lt=1.0, allow_inf_nan=False)] = Field(
        description="Largest acceptable relative error of the output, 0 < value < 1 (0.01 is 1 %). Required."
    )
    output: Literal[TOLERANCE_OUTPUTS] = Field(  # type: ignore[valid-type]
        default="peak_coupler_force",
        description="What the tolerance is on: peak_coupler_force (peak compression, worst coupler) or coupler_force (force history, rms). Default peak_coupler_force.",
    )

    @model_validator(mode="before")
    @classmethod
    def _bare_number(cls, data: Any) -> Any:
        return {"value": data} if isinstance(data, (int, float)) and not isinstance(data, bool) else data


def _known_estimator(name: str) -> str:
    """A plain ``estimators`` entry names a registered inverse estimator (``ESTIMATOR_NAMES``)."""
    if name not in ESTIMATOR_NAMES:
        hint = did_you_mean(name, ESTIMATOR_NAMES)
        if not hint and _is_network_name(name):
            hint = f" (a network estimator is a mapping {{name: {name}, network: file.npz}})"
        raise PydanticCustomError(
            "estimator_name",
            "unknown estimator{hint}; known estimators: {known}, or a network {network}",
            {"hint": hint, "known": ", ".join(ESTIMATOR_NAMES), "network": "{name: ann_<name>, network: file.npz}"},
        )
    return name


def _is_network_name(name: str) -> bool:
    return name == "ann" or name.startswith("ann_")


def _network_name(name: str) -> str:
    """A network estimator's result-group name: ``ann`` or ``ann_<name>`` (DESIGN.md §4)."""
    _name_rule("estimator")(name)
    if not _is_network_name(name) or name == "ann_":
        raise PydanticCustomError("network_name", "network estimators are named ann or ann_<name> (DESIGN.md §4)")
    return name


class AnnEstimatorSpec(CaseModel):
    """A trained network (an ``ann.storage`` file) that estimates one coupler's peak force from the fem
    sensor records (:mod:`femref.impact.ann_estimator`).

    The file is read and its metadata contract checked when the case is loaded; the
    case then checks the contract against the scene (coupler, probes, time.end,
    measurement). A relative ``network`` path is relative to the case file's directory
    and is stored resolved (absolute), so the resolved case reads the same file from anywhere.
    """

    name: Annotated[str, AfterValidator(_network_name)] = Field(description="Result-group name: ann or ann_<name>, unique. Required.")
    network: Path = Field(description="Network file (ann.storage .npz), relative to the case file's directory. Required.")
    _contract: NetworkContract | None = PrivateAttr(default=None)

    @field_validator("network", mode="after")
    @classmethod
    def _resolve(cls, path: Path, info: ValidationInfo) -> Path:
        return resolve_case_path(path, info)

    @model_validator(mode="after")
    def _readable(self) -> "AnnEstimatorSpec":
        try:
            _, self._contract = read_network(self.network)
        except NetworkFileError as error:
            raise problems_error([Problem(("network",), str(error))]) from None
        return self

    @property
    def contract(self) -> NetworkContract:
        """The network file's contract, as read at validation."""
        assert self._contract is not None  # set by the validator
        return self._contract


def _estimator_kind(value: Any) -> str | None:
    """The union tag of an ``estimators`` entry: an inverse estimator's name or a network mapping."""
    if isinstance(value, str):
        return "inverse"
    if isinstance(value, (Mapping, AnnEstimatorSpec)):
        return "ann"  # a tag no mapping has as a key: error key paths drop union tags absent from the input
    return None


def _estimator_shape(value: Any) -> Any:
    if _estimator_kind(value) is None:
        raise PydanticCustomError("estimator_shape", "must be an estimator name or a network {shape}", {"shape": "{name: ann_<name>, network: file.npz}"})
    return value


#: One entry of ``estimators``: an inverse estimator's name or an :class:`AnnEstimatorSpec`.
EstimatorEntry = Annotated[
    Union[Annotated[Annotated[str, AfterValidator(_known_estimator)], Tag("inverse")], Annotated[AnnEstimatorSpec, Tag("ann")]],  # noqa: UP007
    Discriminator(_estimator_kind),
    BeforeValidator(_estimator_shape),
]


def _estimator_name(entry: str | AnnEstimatorSpec) -> str:
    """The result-group name of an estimator."""
    return entry if isinstance(entry, str) else entry.name


def _estimators_rule(entries: tuple[str | AnnEstimatorSpec, ...]) -> tuple[str | AnnEstimatorSpec, ...]:
    """Each estimator once: names unique (a name listed twice, or two networks of one name)."""
    problems = []
    names = [_estimator_name(entry) for entry in entries]
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


#: Minimum sensors on the front car of every coupler that ``inverse_quasi_rigid`` needs.
QUASI_RIGID_INVERSE_SENSORS = 2


# ---------------------------------------------------------------------------------------------
# The case


class ImpactCase(SceneCase):
    """Cars in a line joined by couplers, moving at given velocities from ``t = 0`` (DESIGN.md §3)."""

    kind: Literal["impact"] = Field(default="impact", description="impact. Required in the case file.")
    cars: Annotated[tuple[CarSpec, ...], AfterValidator(_cars_rule)] = Field(
        description="Two or more cars in line order (rear to front): cars[i]'s +l end faces cars[i+1]'s −l end. Required."
    )
    couplers: tuple[CouplerSpec, ...] = Field(description="One or more couplers between neighbouring cars. Required.")
    time: TimeSettings = Field(description="Simulated interval and step. Required (time.end at least).")
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings, description="Time integrator. Default generalized_alpha with rho_inf 0.8.")
    models: Annotated[tuple[ModelRunEntry, ...], AfterValidator(_runs_rule)] = Field(
        default=DEFAULT_MODELS,
        description=(
            f"Model runs: a model name ({', '.join(MODELS)}; a uniform run of that fidelity) or a mapping "
            "{name, fidelity, cars: {car: fidelity}} (a mixed-fidelity run); unique names. "
            f"Default [{', '.join(DEFAULT_MODELS)}]."
        ),
    )
    fem: FemSettings = _fem_field()
    modal: ModalSettings = Field(default_factory=ModalSettings, description="Modal car model. Default: see ModalSettings (4 modes).")
    measurement: MeasurementSpec | None = Field(default=None, description="Accelerometer model. Default null: records on the model's time grid, no filter, no noise.")
    estimators: Annotated[tuple[EstimatorEntry, ...], AfterValidator(_estimators_rule)] = Field(
        default=(),
        description=(
            f"Estimators run on the fem sensor records: an inverse estimator ({', '.join(ESTIMATOR_NAMES)}) or a network "
            "{name: ann_<name>, network: file.npz} (peak force of one coupler); unique names; they need a uniform fem run. Default []."
        ),
    )
    tolerance: ToleranceSpec | None = Field(
        default=None,
        description=(
            "Choose the model: the run climbs a ladder of models and resolutions and keeps the cheapest expected within this "
            "relative error (a number, or {value, output}); it replaces the models list and skips the estimators. Default null: run the models list."
        ),
    )

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        """Point single-body keys (body, loads, probes, frequency) at what an impact has instead."""
        if any(key in other.model_fields for other in schema.CASE_KINDS.values() if other is not cls):
            return f"{key!r} is a key of single-body cases, not of impact cases (an impact has cars and couplers){did_you_mean(key, known)}"
        return super()._unknown_key_rule(key, known)

    @field_validator("couplers", mode="after")
    @classmethod
    def _couplers_join_neighbours(cls, couplers: tuple[CouplerSpec, ...], info: ValidationInfo) -> tuple[CouplerSpec, ...]:
        if not couplers:
            raise PydanticCustomError("couplers_empty", "an impact needs at least one coupler between neighbouring cars")
        named = tuple(c if c.name is not None else c.model_copy(update={"name": f"c{k + 1}"}) for k, c in enumerate(couplers))
        problems = _duplicates([c.name for c in named], "coupler", lambda k: (k, "name"))  # type: ignore[misc]
        cars = info.data.get("cars")
        if cars is not None:
            problems += _coupler_pair_problems(named, [car.name for car in cars])
        if problems:
            raise problems_error(problems)
        return named

    @field_validator("models", mode="after")
    @classmethod
    def _overrides_name_cars(cls, runs: tuple[str | ModelRunSpec, ...], info: ValidationInfo) -> tuple[str | ModelRunSpec, ...]:
        cars = info.data.get("cars")
        if cars is None:
            return runs
        names = [car.name for car in cars]
        problems = [
            Problem((i, "cars", car), f"unknown car{did_you_mean(car, names)}; cars: {', '.join(names)}")
            for i, run in enumerate(runs)
            if isinstance(run, ModelRunSpec)
            for car in run.cars
            if car not in names
        ]
        if problems:
            raise problems_error(problems)
        return runs

    @field_validator("fem", mode="after")
    @classmethod
    def _rod_order(cls, fem: FemSettings) -> FemSettings:
        if fem.order is None:
            return fem.model_copy(update={"order": RodBody.default_order})
        if fem.order not in RodBody.element_orders:
            raise problems_error([Problem(("order",), "impact cars are rods: order 1 (P1) or 2 (P2)", fem.order)])
        return fem

    @field_validator("estimators", mode="after")
    @classmethod
    def _estimators_have_records(cls, entries: tuple[str | AnnEstimatorSpec, ...], info: ValidationInfo) -> tuple[str | AnnEstimatorSpec, ...]:
        cars, couplers, runs = (info.data.get(key) for key in ("cars", "couplers", "models"))
        if not entries or cars is None or runs is None:
            return entries
        names = [_estimator_name(entry) for entry in entries]
        car_names = [car.name for car in cars]
        if not any(set(_fidelities(run, car_names)) == {"fem"} for run in runs):
            rule = "the estimators run on the fem sensor records; add fem (a uniform fem run) to models"
            raise problems_error([Problem((), rule, names)])
        problems = []
        if "inverse_quasi_rigid" in names and couplers is not None:
            problems += _quasi_rigid_sensor_problems(names.index("inverse_quasi_rigid"), cars, couplers)
        for i, entry in enumerate(entries):
            if isinstance(entry, AnnEstimatorSpec):
                problems += [p.under((i, "network")) for p in _network_problems(entry.contract, cars, couplers, info.data)]
        if problems:
            raise problems_error(problems)
        return entries

    @model_validator(mode="after")
    def _models_serve_the_scene(self) -> "ImpactCase":
        """Refuse model names (and mixed-run fidelities) that cannot serve an impact, with the reason."""
        problems = []
        for i, run in enumerate(self.models):
            for model in dict.fromkeys((run,) if isinstance(run, str) else self.run_fidelities()[run.name]):
                reason = refusal(model, self)  # type: ignore[arg-type]
                if reason is not None:
                    problems.append(Problem((i,) if isinstance(run, str) else (i, "fidelity"), f"{model} cannot serve this case: {reason}", model))
        if problems:
            raise problems_error([p.under(("models",)) for p in problems])
        return self

    @property
    def car_names(self) -> list[str]:
        """Car names in line order."""
        return [car.name for car in self.cars]

    def run_fidelities(self) -> dict[str, tuple[str, ...]]:
        """Run name → the fidelity of each car in line order, in the order of ``models``."""
        return {_run_name(run): _fidelities(run, self.car_names) for run in self.models}


def _fidelities(run: str | ModelRunSpec, car_names: list[str]) -> tuple[str, ...]:
    """Per-car fidelities of a run; a plain model name models every car alike."""
    return (run,) * len(car_names) if isinstance(run, str) else run.fidelities(car_names)


def _quasi_rigid_sensor_problems(at: int, cars: tuple[CarSpec, ...], couplers: tuple[CouplerSpec, ...]) -> list[Problem]:
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


def _network_problems(contract: NetworkContract, cars: tuple[CarSpec, ...], couplers: tuple[CouplerSpec, ...] | None, data: Mapping[str, Any]) -> list[Problem]:
    """A network's contract against the scene: its coupler and probes exist, its records fit in
    ``time.end``, and the case measures the records as the training records were measured
    (same chain rate and low-pass; noise and seed may differ — testing on noisier records is legitimate).

    ``data`` holds the case keys validated so far; a key that failed is not compared.
    """
    problems = []
    coupler_names = [c.name for c in couplers or ()]
    if couplers is not None and contract.coupler not in coupler_names:
        rule = f"the network estimates coupler {contract.coupler!r}, which this case does not have; couplers: {', '.join(coupler_names)}"
        problems.append(Problem((), rule))
    probes = [f"{car.name}/{sensor}" for car in cars for sensor in car.sensors]
    missing = [p for p in contract.probes if p not in probes]
    if missing:
        rule = f"the network reads probe(s) {', '.join(missing)}, which are not sensors of this case; probes: {', '.join(probes)}"
        problems.append(Problem((), rule))
    car_names = [car.name for car in cars]
    unknown_cars = [car for car in contract.mass_inputs if car not in car_names]
    if unknown_cars:
        rule = f"the network takes the mass of car(s) {', '.join(unknown_cars)}, which this case does not have; cars: {', '.join(car_names)}"
        problems.append(Problem((), rule))
    time = data.get("time")
    if time is not None and contract.record_end > time.end:
        problems.append(Problem((), f"the network reads records over [0, {contract.record_end:g}] s, beyond time.end = {time.end:g} s"))
    if "measurement" in data:
        problem = _chain_problem(contract, data["measurement"])
        if problem is not None:
            problems.append(Problem((), problem))
    return problems


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
