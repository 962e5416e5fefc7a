"""The model runs of an impact case: ``models``, ``modal`` and ``tolerance``.

A ``models`` entry is a model name (a uniform run: every car at that fidelity) or a mixed-fidelity run
``{name, fidelity, cars: {car: fidelity}}`` (:class:`ModelRunSpec`); ``tolerance`` asks for the cheapest
model expected within it instead (femref.choice).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator
from pydantic_core import PydanticCustomError

from femref.case.capabilities import MODELS
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, duplicates, entry_name, name_or_model, name_rule, reject_bool
from femref.core.catalog import ESTIMATORS as ESTIMATOR_NAMES
from femref.core.catalog import CHOICE_GROUP, FIDELITIES, SCENE_GROUP, SCORES_GROUP

__all__ = [
    "DEFAULT_MODELS",
    "RESERVED_RUN_NAMES",
    "TOLERANCE_OUTPUTS",
    "Fidelity",
    "ModalSettings",
    "ModelRunEntry",
    "ModelRunSpec",
    "RunName",
    "ToleranceSpec",
]

#: Models run when a case gives no ``models`` list.
DEFAULT_MODELS: tuple[str, ...] = ("fem", "quasi_rigid", "rigid")
#: Result-group names a mixed run may not take (docs/design.md §4: model names, ``ann_<name>``, scores).
RESERVED_RUN_NAMES: tuple[str, ...] = (*MODELS, *ESTIMATOR_NAMES, SCORES_GROUP, SCENE_GROUP, CHOICE_GROUP)

RunName = Annotated[str, AfterValidator(name_rule("run"))]


def _one_of(names: tuple[str, ...], error: str, template: str) -> Callable[[str], str]:
    """A validator: one of ``names``, else the ``error`` with a hint for misspellings and the known names."""

    def check(name: str) -> str:
        if name not in names:
            raise PydanticCustomError(error, template, {"hint": did_you_mean(name, names), "known": ", ".join(names)})
        return name

    return check


#: How one car is modelled within a run: one of ``femref.core.catalog.FIDELITIES``.
Fidelity = Annotated[str, AfterValidator(_one_of(FIDELITIES, "fidelity", "unknown fidelity{hint}; a car is one of {known}"))]


class ModelRunSpec(CaseModel):
    """A mixed-fidelity model run: each car modelled at ``fidelity`` unless overridden in ``cars``."""

    name: RunName = Field(description="Result-group name, unique among the runs; not a model or estimator name (unless this is that model's uniform run). Required.")
    fidelity: Fidelity = Field(description=f"Fidelity of every car not in cars: one of {', '.join(FIDELITIES)}. Required.")
    cars: dict[str, Fidelity] = Field(default_factory=dict, description="Per-car overrides: car name → fidelity. Default {} (no overrides).")

    @model_validator(mode="after")
    def _not_a_reserved_name(self) -> "ModelRunSpec":
        uniform = self.fidelity == self.name and all(f == self.name for f in self.cars.values())
        if self.name in RESERVED_RUN_NAMES and not uniform:
            if self.name in FIDELITIES:
                rule = f"{self.name!r} names the uniform {self.name} run; give a mixed run another name (e.g. {self.fidelity}_with_...)"
            else:
                rule = f"{self.name!r} is a reserved result-group name ({', '.join(RESERVED_RUN_NAMES)}); choose another"
            raise problems_error([Problem(("name",), rule, self.name)])
        if self.name.startswith("ann_"):
            raise problems_error([Problem(("name",), "names starting with 'ann_' are reserved for network estimators (ann_<name>)", self.name)])
        return self

    def fidelities(self, car_names: list[str]) -> tuple[str, ...]:
        """The fidelity of each car, in line order."""
        return tuple(self.cars.get(name, self.fidelity) for name in car_names)


#: A registered model (whether it can serve is checked on the whole case).
ModelName = Annotated[str, AfterValidator(_one_of(MODELS, "model_name", "unknown model{hint}; known models: {known}"))]
#: One entry of ``models``: a model name (a uniform run) or a :class:`ModelRunSpec`.
ModelRunEntry = name_or_model(ModelName, ModelRunSpec, ("plain", "mixed"),
                              ("run_shape", "must be a model name or a mapping {shape}", {"shape": "{name, fidelity, cars}"}))


def runs_rule(runs: tuple[str | ModelRunSpec, ...]) -> tuple[str | ModelRunSpec, ...]:
    """At least one run; run names unique."""
    if not runs:
        raise PydanticCustomError("models_empty", "must list at least one model run ({known})", {"known": ", ".join(FIDELITIES)})
    problems = duplicates([entry_name(run) for run in runs], "run", lambda i: (i,))
    if problems:
        raise problems_error(problems)
    return runs


def car_fidelities(run: str | ModelRunSpec, car_names: list[str]) -> tuple[str, ...]:
    """Per-car fidelities of a run; a plain model name models every car alike."""
    return (run,) * len(car_names) if isinstance(run, str) else run.fidelities(car_names)


class ModalSettings(CaseModel):
    """The modal car model: rigid mode, ``modes`` free-free elastic modes and a static correction."""

    modes: Annotated[int, BeforeValidator(reject_bool), Field(ge=1)] = Field(
        default=4, description="Elastic modes kept per modal car, an integer >= 1. Default 4."
    )


#: Outputs a tolerance may be set on (femref.choice.estimates.OUTPUTS; kept here so the case needs no solver import).
TOLERANCE_OUTPUTS: tuple[str, ...] = ("peak_coupler_force", "coupler_force", "vertical_acceleration")


class ToleranceSpec(CaseModel):
    """The accuracy the run must reach: ``femref run`` then chooses the cheapest model expected
    to meet it (femref.choice). A bare number is ``{value: number}``."""

    value: Annotated[float, BeforeValidator(reject_bool), Field(gt=0.0, lt=1.0, allow_inf_nan=False)] = Field(
        description="Largest acceptable relative error of the output, 0 < value < 1 (0.01 is 1 %). Required."
    )
    output: Literal[TOLERANCE_OUTPUTS] = Field(  # type: ignore[valid-type]
        default="peak_coupler_force",
        description="What the tolerance is on: peak_coupler_force (peak compression, worst coupler), coupler_force (force history, rms) "
        "or vertical_acceleration (sensors of cars that bend, rms, worst sensor). Default peak_coupler_force.",
    )

    @model_validator(mode="before")
    @classmethod
    def _bare_number(cls, data: Any) -> Any:
        return {"value": data} if isinstance(data, (int, float)) and not isinstance(data, bool) else data
