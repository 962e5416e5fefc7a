"""The settings of a case: the frequency axis (harmonic), time and integrator (transient,
impact), and the finite-element discretisation (every kind)."""

from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from femref.case.bodies import BodySchema
from femref.case.errors import Problem, problems_error
from femref.case.fields import CaseModel, Count, PositiveReal, Real, TaggedSpec, tagged_union
from femref.case.plausibility import plausible

__all__ = [
    "DEFAULT_RHO_INF",
    "FREQUENCY_AXES",
    "INTEGRATORS",
    "FemSpec",
    "FrequencyRange",
    "FrequencySpec",
    "HzRange",
    "IntegratorSettings",
    "LambdaRange",
    "OmegaRange",
    "TimeSettings",
]


#: Most frequencies of one axis (the harmonic models' work is also budgeted, femref.run.budget).
MAX_FREQUENCIES = 1_000_000


class FrequencyRange(TaggedSpec):
    """``num`` frequencies from ``start`` to ``stop``, equally spaced (linear) or in ratio (log)."""

    start: PositiveReal = Field(description="First frequency, > 0. Required.")
    stop: PositiveReal = Field(description="Last frequency, > start (or = start with num 1). Required.")
    num: Count = Field(description="Number of frequencies, an integer >= 1. Required.")
    spacing: Literal["linear", "log"] = Field(default="linear", description="linear or log. Default linear.")

    @model_validator(mode="after")
    def _not_empty(self) -> "FrequencyRange":
        if self.stop < self.start:
            raise problems_error([Problem(("stop",), f"must be greater than start ({self.start}): the range is empty", self.stop)])
        if self.stop == self.start and self.num > 1:
            raise problems_error([Problem(("num",), "must be 1 when stop equals start", self.num)])
        if self.num > MAX_FREQUENCIES:
            rule = f"must be at most {MAX_FREQUENCIES:g}: more frequencies than any response curve needs (the axis alone would hold {8 * self.num:.3g} bytes)"
            raise problems_error([Problem(("num",), rule, self.num)])
        if self.stop > self.start and self.num == 1:
            raise problems_error([Problem(("stop",), "must equal start when num is 1 (one frequency)", self.stop)])
        return self

    def values(self) -> NDArray[np.float64]:
        """The axis in its own unit."""
        spaced = np.geomspace if self.spacing == "log" else np.linspace
        return spaced(self.start, self.stop, self.num)

    def omega(self, body: BodySchema) -> NDArray[np.float64]:
        """Circular frequencies ω (rad/s) for ``body``."""
        raise NotImplementedError


class OmegaRange(FrequencyRange):
    """Circular frequency ω (rad/s)."""

    tag: ClassVar[str] = "omega"

    def omega(self, body: BodySchema) -> NDArray[np.float64]:
        return self.values()


class HzRange(FrequencyRange):
    """Frequency f (Hz); ``ω = 2π f``."""

    tag: ClassVar[str] = "hz"

    def omega(self, body: BodySchema) -> NDArray[np.float64]:
        return 2.0 * np.pi * self.values()


class LambdaRange(FrequencyRange):
    """Nondimensional frequency λ (docs/design.md §2); ``ω = λ / T`` with the body's wave time
    ``T = l√(m̄/EĀ)`` (rod) or ``l²√(m̄/EĪ)`` (beam), length-averaged ``m`` and stiffness."""

    tag: ClassVar[str] = "lambda"

    def omega(self, body: BodySchema) -> NDArray[np.float64]:
        return self.values() / body.wave_time()


#: Frequency axes by case-file name.
FREQUENCY_AXES: Mapping[str, type[FrequencyRange]] = {"omega": OmegaRange, "hz": HzRange, "lambda": LambdaRange}

FrequencySpec = tagged_union(FREQUENCY_AXES, "frequency axis")


class TimeSettings(CaseModel):
    """The simulated interval ``[0, end]`` and its sampling."""

    end: Annotated[PositiveReal, plausible("end_time")] = Field(description="End time (s), > 0. Required.")
    dt: Annotated[PositiveReal, plausible("time_step")] | None = Field(
        default=None,
        description="Time step (s), > 0 and <= end. Default null: automatic (the runner chooses it and records it in the results).",
    )
    output_stride: Count = Field(default=1, description="Store every n-th time step, an integer >= 1. Default 1.")

    @model_validator(mode="after")
    def _dt_fits(self) -> "TimeSettings":
        if self.dt is not None and self.dt > self.end:
            raise problems_error([Problem(("dt",), f"must not exceed time.end ({self.end})", self.dt)])
        return self


#: Time integrators by case-file name.
INTEGRATORS: Mapping[str, str] = {
    "newmark": "average-acceleration Newmark (β = 1/4, γ = 1/2): second order, no numerical damping",
    "generalized_alpha": "Chung-Hulbert generalized-α: second order, high-frequency damping set by rho_inf",
}
IntegratorName = Literal[tuple(INTEGRATORS)]  # type: ignore[valid-type]

#: Spectral radius at infinite frequency used by generalized-α when none is given.
DEFAULT_RHO_INF = 0.8


class IntegratorSettings(CaseModel):
    """The time integrator of the FEM model (docs/design.md §2 hazards: average-acceleration
    Newmark rings on the discontinuous accelerations of an elastic rod; generalized-α
    with ``rho_inf < 1`` damps that ringing)."""

    scheme: IntegratorName = Field(
        default="generalized_alpha",
        description="generalized_alpha (Chung-Hulbert, damps the unresolved highest modes) or newmark (average acceleration, energy conserving, no numerical damping). Default generalized_alpha.",
    )
    rho_inf: Annotated[Real, Field(ge=0, le=1)] | None = Field(
        default=None,
        validate_default=True,
        description=f"Spectral radius at infinite frequency, in [0, 1], generalized_alpha only. Default {DEFAULT_RHO_INF} for generalized_alpha, null (refused if given) for newmark.",
    )

    @field_validator("rho_inf", mode="after")
    @classmethod
    def _for_generalized_alpha(cls, value: float | None, info: ValidationInfo) -> float | None:
        scheme = info.data.get("scheme")
        if scheme == "generalized_alpha" and value is None:
            return DEFAULT_RHO_INF
        if scheme == "newmark" and value is not None:
            raise PydanticCustomError("rho_inf_newmark", "applies to scheme generalized_alpha only (newmark has no numerical damping)")
        return value


class FemSpec(CaseModel):
    """Finite-element discretisation (scikit-fem)."""

    elements: Count = Field(default=64, description="Number of elements, an integer >= 1. Default 64.")
    order: Literal[1, 2, 3] | None = Field(
        default=None,
        description="Polynomial order: rods 1 (P1) or 2 (P2), default 2; beams always use Hermite cubics, order 3 (the default; other values are refused).",
    )
    grading: Annotated[Real, Field(ge=1)] = Field(
        default=1.0,
        description="Ratio of the largest to the smallest element, >= 1, nodes graded toward both ends. Default 1 (uniform).",
    )
    fields: bool = Field(default=False, description="Store the full displacement field u(x) (or w(x)). Default false.")
    field_stride: Count = Field(default=1, description="Store the field at every n-th output sample, an integer >= 1. Default 1.")


def fem_field() -> Any:
    return Field(default_factory=FemSpec, validate_default=True, description="Finite-element settings. Default: see FemSpec.")
