"""The single-body cases, ``kind: harmonic`` and ``kind: transient`` (docs/design.md §3):
one body under end loads, observed at probes.

The body's loads not given are 0, other bodies' loads are refused; every load level lies within
``BOUNDS["end_force"]`` (F, N) or ``BOUNDS["end_moment"]`` (G, N·m), the harmonic axis within
``BOUNDS["frequency"]`` (hz) or ``BOUNDS["circular_frequency"]`` (omega; lambda as ω = λ/T on the body).
"""

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import AfterValidator, Field, ValidationInfo, field_validator, model_serializer, model_validator
from pydantic_core import PydanticCustomError

from femref.case.base import SceneCase
from femref.case.bodies import LOAD_OWNERS, BodySpec
from femref.case.capabilities import MODELS
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, ProbeName, Real, validate_collecting
from femref.case.plausibility import BOUNDS, Bound, format_number
from femref.case.settings import FemSpec, FrequencyRange, FrequencySpec, IntegratorSettings, TimeSettings, fem_field
from femref.case.signals import AnySignal
from femref.core import signals

__all__ = ["HarmonicCase", "HarmonicLoads", "Loads", "ModelList", "SingleBodyCase", "TransientCase", "TransientLoads", "load_bound"]


_LOAD_DOC = {
    "F1": "Rod: axial force at x = −l",
    "F2": "Rod: axial force at x = +l",
    "N1": "Beam: shear force at x = −l",
    "N2": "Beam: shear force at x = +l",
    "G1": "Beam: bending moment at x = −l",
    "G2": "Beam: bending moment at x = +l",
}


def load_bound(name: str) -> Bound:
    """The plausibility bound of load ``name``: ``end_moment`` for the moments G1, G2, else ``end_force``."""
    return BOUNDS["end_moment" if name.startswith("G") else "end_force"]


def _load_field(name: str, what: str) -> Any:
    unit = "N·m" if name.startswith("G") else "N"
    body = LOAD_OWNERS[name]
    return Field(default=None, description=f"{_LOAD_DOC[name]} ({unit}), {what}. Default 0 on a {body}; refused on other bodies.")


class Loads(CaseModel):
    """End loads (docs/design.md §2; tension positive): rod ``F1, F2``; beam ``N1, N2, G1, G2``; at least one
    non-zero. Loads of other body types are ``None`` and left out of the resolved case."""

    def items(self) -> list[tuple[str, Any]]:
        """``(name, load)`` for every load that applies, in field order."""
        return [(name, getattr(self, name)) for name in type(self).model_fields if getattr(self, name) is not None]

    @staticmethod
    def _is_zero(load: Any) -> bool:
        raise NotImplementedError

    @staticmethod
    def _level_problems(load: Any, bound: Bound) -> list[Problem]:
        """The load's levels outside ``bound``, key paths below the load."""
        raise NotImplementedError

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return {name: value for name, value in handler(self).items() if value is not None}

    @model_validator(mode="after")
    def _plausible_levels(self) -> "Loads":
        """Every load level within ``BOUNDS["end_force"]`` (F, N: forces) or ``BOUNDS["end_moment"]`` (G, N·m)."""
        problems = [p.under((name,)) for name, load in self.items() for p in self._level_problems(load, load_bound(name))]
        if problems:
            raise problems_error(problems)
        return self

    @model_validator(mode="after")
    def _not_all_zero(self) -> "Loads":
        if all(self._is_zero(load) for _, load in self.items()):
            raise problems_error([Problem((), "all end loads are zero; give at least one non-zero load (rod: F1, F2; beam: N1, N2, G1, G2)")])
        return self


class HarmonicLoads(Loads):
    """Complex amplitudes are real here: every load is in phase (factor ``e^{−iωt}``)."""

    F1: Real | None = _load_field("F1", "harmonic amplitude")
    F2: Real | None = _load_field("F2", "harmonic amplitude")
    N1: Real | None = _load_field("N1", "harmonic amplitude")
    N2: Real | None = _load_field("N2", "harmonic amplitude")
    G1: Real | None = _load_field("G1", "harmonic amplitude")
    G2: Real | None = _load_field("G2", "harmonic amplitude")

    @staticmethod
    def _is_zero(load: Any) -> bool:
        return load == 0.0

    @staticmethod
    def _level_problems(load: Any, bound: Bound) -> list[Problem]:
        rule = bound.rule(load)
        return [] if rule is None else [Problem((), rule, load)]


_SIGNAL_DOC = "a history: a number (constant from t = 0) or one of half_sine, ramp_step, csv"


class TransientLoads(Loads):
    """Load histories; a plain number is a constant load switched on at ``t = 0``."""

    F1: AnySignal | None = _load_field("F1", _SIGNAL_DOC)
    F2: AnySignal | None = _load_field("F2", _SIGNAL_DOC)
    N1: AnySignal | None = _load_field("N1", _SIGNAL_DOC)
    N2: AnySignal | None = _load_field("N2", _SIGNAL_DOC)
    G1: AnySignal | None = _load_field("G1", _SIGNAL_DOC)
    G2: AnySignal | None = _load_field("G2", _SIGNAL_DOC)

    @staticmethod
    def _is_zero(load: Any) -> bool:
        return load.is_zero

    @staticmethod
    def _level_problems(load: Any, bound: Bound) -> list[Problem]:
        return load.level_problems(bound)


def _model_names(names: tuple[str, ...]) -> tuple[str, ...]:
    if not names:
        raise PydanticCustomError("models_empty", "must list at least one model ({known})", {"known": ", ".join(MODELS)})
    problems = []
    for i, name in enumerate(names):
        if name not in MODELS:
            problems.append(Problem((i,), f"unknown model{did_you_mean(name, MODELS)}; known models: {', '.join(MODELS)}", name))
        elif name in names[:i]:
            problems.append(Problem((i,), "is listed twice", name))
    if problems:
        raise problems_error(problems)
    return names


#: The ``models`` list: registered names (``femref.case.capabilities.MODELS``), unique, non-empty.
ModelList = Annotated[tuple[str, ...], AfterValidator(_model_names)]


def _models_field() -> Any:
    return Field(
        default=("fem",),
        description=f"Models to run and compare, unique names out of {', '.join(MODELS)}; each must be able to serve the scene. Default [fem].",
    )


class SingleBodyCase(SceneCase):
    """One body under end loads, observed at probes (harmonic and transient cases)."""

    body: BodySpec = Field(description="The body: a rod or a beam. Required.")
    loads: Loads = Field(description="End loads; the body's loads not given are 0; at least one non-zero. Required.")
    probes: dict[ProbeName, Real] | None = Field(
        default=None,
        validate_default=True,
        description="Named positions x (m) within [−l, l] where results are recorded. Default {left: −l, center: 0, right: +l}.",
    )

    @field_validator("loads", mode="wrap")
    @classmethod
    def _loads_of_the_body(cls, value: Any, handler: Callable[[Any], Any], info: ValidationInfo) -> Any:
        body = info.data.get("body")
        if body is None or not isinstance(value, Mapping):
            return handler(value)
        takes = f"a {body.type} takes {', '.join(body.load_names)}"
        problems = []
        for key in value:
            if key in body.load_names:
                continue
            if key in LOAD_OWNERS:
                problems.append(Problem((key,), f"{key} is a {LOAD_OWNERS[key]} load; {takes}", value[key]))
            else:
                problems.append(Problem((str(key),), f"unknown load{did_you_mean(key, body.load_names)}; {takes}"))
        given = {k: v for k, v in value.items() if k in body.load_names}
        return validate_collecting(handler, {**{name: 0.0 for name in body.load_names}, **given}, problems)

    @field_validator("probes", mode="after")
    @classmethod
    def _probes_on_the_body(cls, value: dict[str, float] | None, info: ValidationInfo) -> dict[str, float] | None:
        body = info.data.get("body")
        if body is None:
            return value
        l = body.half_length  # noqa: E741
        if value is None:
            return {"left": -l, "center": 0.0, "right": l}
        if not value:
            raise PydanticCustomError("probes_empty", "must name at least one probe (or be left out for left, center, right)")
        problems = [Problem((name,), f"must lie on the body, within [{-l}, {l}]", x) for name, x in value.items() if not -l <= x <= l]
        if problems:
            raise problems_error(problems)
        return value

    @field_validator("fem", mode="after", check_fields=False)
    @classmethod
    def _order_for_the_body(cls, fem: FemSpec, info: ValidationInfo) -> FemSpec:
        body = info.data.get("body")
        if body is None:
            return fem
        if fem.order is None:
            return fem.model_copy(update={"order": body.default_order})
        if fem.order not in body.element_orders:
            rod = "a rod uses order 1 (P1) or 2 (P2)"
            rule = rod if body.type == "rod" else "a beam always uses Hermite cubic elements (order 3); leave order out"
            raise problems_error([Problem(("order",), rule, fem.order)])
        return fem


class HarmonicCase(SingleBodyCase):
    """Frequency response of one body to in-phase harmonic end loads (factor ``e^{−iωt}``)."""

    kind: Literal["harmonic"] = Field(default="harmonic", description="harmonic. Required in the case file.")
    loads: HarmonicLoads = Field(description="Harmonic load amplitudes (N or N·m); the body's loads not given are 0; at least one non-zero. Required.")
    frequency: FrequencySpec = Field(description="Frequency axis: exactly one of omega (rad/s), hz, lambda (nondimensional). Required.")
    fem: FemSpec = fem_field()
    models: ModelList = _models_field()

    @field_validator("frequency", mode="after")
    @classmethod
    def _plausible_frequencies(cls, axis: FrequencyRange, info: ValidationInfo) -> FrequencyRange:
        """``start`` and ``stop`` within ``BOUNDS["frequency"]`` (hz) or ``BOUNDS["circular_frequency"]`` (omega; lambda
        as ω = λ/T with the body's wave time T, checked once the body is valid)."""
        body = info.data.get("body")
        if axis.tag == "lambda" and body is None:
            return axis
        problems = []
        for key in ("start", "stop"):
            value = getattr(axis, key)
            if axis.tag == "hz":
                rule = BOUNDS["frequency"].rule(value)
            elif axis.tag == "lambda":
                wave_time = body.wave_time()
                rule = BOUNDS["circular_frequency"].rule(value / wave_time)
                rule = rule and f"λ = {format_number(value)} on this body is ω = λ/T with its wave time T = {wave_time:.3g} s: {rule}"
            else:
                rule = BOUNDS["circular_frequency"].rule(value)
            if rule is not None:
                problems.append(Problem((axis.tag, key), rule, value))
        if problems:
            raise problems_error(problems)
        return axis

    def omega(self) -> NDArray[np.float64]:
        """The circular frequencies ω (rad/s) of the sweep."""
        return self.frequency.omega(self.body)

    def load_amplitudes(self) -> dict[str, float]:
        """Amplitude of every load the body takes (N or N·m)."""
        return dict(self.loads.items())


class TransientCase(SingleBodyCase):
    """Response of one body to end-load histories, from rest at ``t = 0``."""

    kind: Literal["transient"] = Field(default="transient", description="transient. Required in the case file.")
    loads: TransientLoads = Field(description="End-load histories; the body's loads not given are 0; at least one non-zero. Required.")
    time: TimeSettings = Field(description="Simulated interval and step. Required (time.end at least).")
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings, description="Time integrator. Default generalized_alpha with rho_inf 0.8.")
    fem: FemSpec = fem_field()
    models: ModelList = _models_field()

    def load_signals(self, base_dir: Path | None = None) -> dict[str, signals.Signal]:
        """Every load the body takes, as ``femref.core.signals`` objects."""
        return {name: spec.build(base_dir) for name, spec in self.loads.items()}
