"""The ``kind: impact`` case (docs/design.md §3): cars in a line joined by couplers.

The keys are validated by :mod:`femref.case.cars`, :mod:`femref.case.couplers`, :mod:`femref.case.runs` and
:mod:`femref.case.estimators`; this module holds the case. As in the single-body cases, each key is validated on
its own first (every failure reported), then the rules that relate keys, once the keys they relate are valid. A
network file is read when the case is loaded (like a CSV load), so a missing or broken file is a case error too.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from femref.case.base import SceneCase, case_classes
from femref.case.bodies import RodBody
from femref.case.capabilities import MODELS, refusal
from femref.case.cars import CarSpec, cars_rule
from femref.case.couplers import CouplerSpec, named_couplers
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.estimators import (
    AnnEstimatorSpec,
    EstimatorEntry,
    MeasurementSpec,
    estimators_rule,
    network_problems,
    quasi_rigid_sensor_problems,
)
from femref.case.fields import entry_name
from femref.case.runs import DEFAULT_MODELS, ModalSettings, ModelRunEntry, ModelRunSpec, ToleranceSpec, car_fidelities, runs_rule
from femref.case.settings import FemSpec, IntegratorSettings, TimeSettings, fem_field
from femref.core.catalog import ESTIMATORS as ESTIMATOR_NAMES

__all__ = ["ImpactCase"]

#: Why an impact case refuses the field-file keys of ``fem`` (fem.fields, fem.field_stride).
FIELD_FILES_RULE = (
    "field files are written for single-body scenes only; impact results record sensors at the probes "
    "(cars[i].sensors), so an impact's fem cars store no displacement field"
)


def _field_output_problems(fem: FemSpec) -> list[Problem]:
    """``fem.fields: true`` (or a ``fem.field_stride`` other than 1) asks for field files, which impacts
    do not write (:data:`FIELD_FILES_RULE`): a problem at each such key, rather than a silent no-op."""
    problems = []
    if fem.fields:
        problems.append(Problem(("fields",), f"{FIELD_FILES_RULE}; remove it or set it to false", fem.fields))
    if fem.field_stride != 1:
        problems.append(Problem(("field_stride",), f"{FIELD_FILES_RULE}; remove it", fem.field_stride))
    return problems


class ImpactCase(SceneCase):
    """Cars in a line joined by couplers, moving at given velocities from ``t = 0`` (docs/design.md §3)."""

    kind: Literal["impact"] = Field(default="impact", description="impact. Required in the case file.")
    cars: Annotated[tuple[CarSpec, ...], AfterValidator(cars_rule("an impact"))] = Field(
        description="Two or more cars in line order (rear to front): cars[i]'s +l end faces cars[i+1]'s −l end. Required."
    )
    couplers: tuple[CouplerSpec, ...] = Field(description="One or more couplers between neighbouring cars. Required.")
    time: TimeSettings = Field(description="Simulated interval and step. Required (time.end at least).")
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings, description="Time integrator. Default generalized_alpha with rho_inf 0.8.")
    models: Annotated[tuple[ModelRunEntry, ...], AfterValidator(runs_rule)] = Field(
        default=DEFAULT_MODELS,
        description=(
            f"Model runs: a model name ({', '.join(MODELS)}; a uniform run of that fidelity) or a mapping "
            "{name, fidelity, cars: {car: fidelity}} (a mixed-fidelity run); unique names. "
            f"Default [{', '.join(DEFAULT_MODELS)}]."
        ),
    )
    fem: FemSpec = fem_field()
    modal: ModalSettings = Field(default_factory=ModalSettings, description="Modal car model. Default: see ModalSettings (4 modes).")
    measurement: MeasurementSpec | None = Field(default=None, description="Accelerometer model. Default null: records on the model's time grid, no filter, no noise.")
    estimators: Annotated[tuple[EstimatorEntry, ...], AfterValidator(estimators_rule)] = Field(
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
        if any(key in other.model_fields for other in case_classes().values() if other is not cls):
            return f"{key!r} is a key of single-body cases, not of impact cases (an impact has cars and couplers){did_you_mean(key, known)}"
        return super()._unknown_key_rule(key, known)

    @field_validator("couplers", mode="after")
    @classmethod
    def _couplers_join_neighbours(cls, couplers: tuple[CouplerSpec, ...], info: ValidationInfo) -> tuple[CouplerSpec, ...]:
        if not couplers:
            raise PydanticCustomError("couplers_empty", "an impact needs at least one coupler between neighbouring cars")
        return named_couplers(couplers, info.data.get("cars"))

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
    def _rod_order(cls, fem: FemSpec) -> FemSpec:
        problems = _field_output_problems(fem)
        if fem.order is not None and fem.order not in RodBody.element_orders:
            problems.append(Problem(("order",), "impact cars are rods: order 1 (P1) or 2 (P2)", fem.order))
        if problems:
            raise problems_error(problems)
        if fem.order is None:
            return fem.model_copy(update={"order": RodBody.default_order})
        return fem

    @field_validator("estimators", mode="after")
    @classmethod
    def _estimators_have_records(cls, entries: tuple[str | AnnEstimatorSpec, ...], info: ValidationInfo) -> tuple[str | AnnEstimatorSpec, ...]:
        cars, couplers, runs = (info.data.get(key) for key in ("cars", "couplers", "models"))
        if not entries or cars is None or runs is None:
            return entries
        names = [entry_name(entry) for entry in entries]
        car_names = [car.name for car in cars]
        if not any(set(car_fidelities(run, car_names)) == {"fem"} for run in runs):
            rule = "the estimators run on the fem sensor records; add fem (a uniform fem run) to models"
            raise problems_error([Problem((), rule, names)])
        problems = []
        if "inverse_quasi_rigid" in names and couplers is not None:
            problems += quasi_rigid_sensor_problems(names.index("inverse_quasi_rigid"), cars, couplers)
        for i, entry in enumerate(entries):
            if isinstance(entry, AnnEstimatorSpec):
                for kind, contract in entry.contracts.items():
                    problems += [p.under((i, *entry.where(kind))) for p in network_problems(contract, cars, couplers, info.data)]
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
        problems = [p.under(("models",)) for p in problems]
        bends = {car.name: car.body.bends for car in self.cars}
        if self.tolerance is not None and self.tolerance.output == "vertical_acceleration" and not any(bends.values()):
            problems.append(Problem(("tolerance", "output"), "no car bends: vertical accelerations are recorded on cars with a bending_stiffness", "vertical_acceleration"))
        for k, coupler in enumerate(self.couplers):
            flat = [name for name in coupler.between if not bends.get(name, True)]
            if coupler.vertical_offset != 0.0 and flat:
                rule = f"an inclined coupler pushes its cars vertically: cars {', '.join(flat)} need a bending_stiffness"
                problems.append(Problem(("couplers", k, "vertical_offset"), rule, coupler.vertical_offset))
        lowpass, dt = (self.measurement.lowpass if self.measurement is not None else None), self.time.dt
        if lowpass is not None and dt is not None and lowpass >= 0.5 / (dt * self.time.output_stride):
            nyquist = 0.5 / (dt * self.time.output_stride)
            rule = (f"must be below the Nyquist frequency 1/(2 time.dt × time.output_stride) = {nyquist:g} Hz of the stored samples "
                    "the filter runs on: refine time.dt or lower the corner")
            problems.append(Problem(("measurement", "lowpass"), rule, lowpass))
        if problems:
            raise problems_error(problems)
        return self

    @property
    def car_names(self) -> list[str]:
        """Car names in line order."""
        return [car.name for car in self.cars]

    def run_fidelities(self) -> dict[str, tuple[str, ...]]:
        """Run name → the fidelity of each car in line order, in the order of ``models``."""
        return {entry_name(run): car_fidelities(run, self.car_names) for run in self.models}
