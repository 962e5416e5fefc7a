"""The distributions of a sweep file's ``parameters`` (registry :data:`DISTRIBUTIONS`).

``uniform: [low, high]``, ``log_uniform: [low, high]`` (``log x`` uniform, ``low > 0``),
``normal: {mean, std, clip: [low, high]}`` (draw, then ``np.clip``; ``clip`` optional),
``choice: [v0, v1, …]`` or ``choice: {values: […], weights: […]}`` (any YAML values),
and ``grid: [v0, v1, …]`` (an axis of the cartesian product over all grid parameters).
Each is a tagged spec of the case files' language (:mod:`femref.case.fields`); a random
one draws with the generator the sampling rule gives it (:mod:`femref.sweep.spec`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import Field, field_validator, model_validator

from femref.case.errors import Problem, problems_error
from femref.case.fields import PositiveReal, Real, TaggedSpec, tagged_union

__all__ = [
    "DISTRIBUTIONS",
    "AnyDistribution",
    "Choice",
    "Distribution",
    "Grid",
    "LogUniform",
    "Normal",
    "Uniform",
]


def _pair(data: Any, names: tuple[str, str]) -> Any:
    """``[low, high]`` → ``{low: …, high: …}``; other input is left for the model to judge."""
    if isinstance(data, (list, tuple)):
        if len(data) != 2:
            raise problems_error([Problem((), f"must be a list of two numbers [{', '.join(names)}]", list(data))])
        return dict(zip(names, data))
    return data


class Distribution(TaggedSpec):
    """A parameter's distribution: ``draw(rng)`` gives ``(value put in the case, value stored in the file)``."""

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        return cls._list_form(super()._shorthand(data))

    @classmethod
    def _list_form(cls, data: Any) -> Any:
        return data

    def draw(self, rng: np.random.Generator) -> tuple[Any, float | int]:
        raise NotImplementedError

    def example(self) -> Any:
        """A value the distribution can give (used to check a key path against the case schema)."""
        raise NotImplementedError

    def stored_values(self) -> list[Any] | None:
        """The values the stored indices refer to; None when the file stores the values themselves."""
        return None


class _Bounded(Distribution):
    low: Real = Field(description="Lower bound. Required.")
    high: Real = Field(description="Upper bound, > low. Required.")

    @classmethod
    def _list_form(cls, data: Any) -> Any:
        return _pair(data, ("low", "high"))

    @model_validator(mode="after")
    def _ordered(self) -> "_Bounded":
        if not self.low < self.high:
            raise problems_error([Problem((), "low must be < high", [self.low, self.high])])
        return self

    def example(self) -> float:
        return self.low


class Uniform(_Bounded):
    """``x ~ U(low, high)``."""

    tag: ClassVar[str] = "uniform"

    def draw(self, rng: np.random.Generator) -> tuple[float, float]:
        x = float(rng.uniform(self.low, self.high))
        return x, x


class LogUniform(_Bounded):
    """``log x ~ U(log low, log high)``, ``0 < low < high``: equal odds per decade."""

    tag: ClassVar[str] = "log_uniform"

    @model_validator(mode="after")
    def _positive(self) -> "LogUniform":
        if self.low <= 0.0:
            raise problems_error([Problem(("low",), "must be > 0 (log_uniform draws log x)", self.low)])
        return self

    def draw(self, rng: np.random.Generator) -> tuple[float, float]:
        x = float(np.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        return x, x


class Normal(Distribution):
    """``x = clip(N(mean, std²), low, high)``: a normal draw, clipped when ``clip`` is given."""

    tag: ClassVar[str] = "normal"
    mean: Real = Field(description="Mean. Required.")
    std: PositiveReal = Field(description="Standard deviation, > 0. Required.")
    clip: tuple[Real, Real] | None = Field(default=None, description="[low, high], low < high: np.clip of the draw. Default null: no clip.")

    @field_validator("clip", mode="after")
    @classmethod
    def _ordered(cls, clip: tuple[float, float] | None) -> tuple[float, float] | None:
        if clip is not None and not clip[0] < clip[1]:
            raise problems_error([Problem((), "must be [low, high] with low < high", list(clip))])
        return clip

    def example(self) -> float:
        return self.mean

    def draw(self, rng: np.random.Generator) -> tuple[float, float]:
        x = float(rng.normal(self.mean, self.std))
        if self.clip is not None:
            x = float(np.clip(x, *self.clip))
        return x, x


def _values_form(data: Any) -> Any:
    return {"values": list(data)} if isinstance(data, (list, tuple)) else data


Values = Annotated[list[Any], Field(min_length=1)]


class Choice(Distribution):
    """One of ``values`` (any YAML values), with probabilities ``weights / sum(weights)`` (default equal)."""

    tag: ClassVar[str] = "choice"
    values: Values = Field(description="The values to choose from, at least one. Required.")
    weights: list[Annotated[Real, Field(ge=0)]] | None = Field(default=None, description="Relative weights >= 0, one per value, summing > 0. Default equal.")

    @classmethod
    def _list_form(cls, data: Any) -> Any:
        return _values_form(data)

    @model_validator(mode="after")
    def _weights_fit(self) -> "Choice":
        if self.weights is None:
            return self
        if len(self.weights) != len(self.values):
            rule = f"must give one weight per value ({len(self.values)} values)"
            raise problems_error([Problem(("weights",), rule, self.weights)])
        if not sum(self.weights) > 0.0:
            raise problems_error([Problem(("weights",), "must sum to > 0", self.weights)])
        return self

    def example(self) -> Any:
        return self.values[0]

    def draw(self, rng: np.random.Generator) -> tuple[Any, int]:
        p = None if self.weights is None else np.asarray(self.weights) / sum(self.weights)
        k = int(rng.choice(len(self.values), p=p))
        return self.values[k], k

    def stored_values(self) -> list[Any]:
        return self.values


class Grid(Distribution):
    """Every one of ``values``: an axis of the cartesian product of all grid parameters."""

    tag: ClassVar[str] = "grid"
    values: Values = Field(description="The grid values, at least one. Required.")

    @classmethod
    def _list_form(cls, data: Any) -> Any:
        return _values_form(data)

    @property
    def numeric(self) -> bool:
        """All values are numbers: the file stores them as float64, not as indices."""
        return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in self.values)

    def example(self) -> Any:
        return self.values[0]

    def point(self, k: int) -> tuple[Any, float | int]:
        value = self.values[k]
        return value, (float(value) if self.numeric else k)

    def stored_values(self) -> list[Any] | None:
        return None if self.numeric else self.values


#: Distributions by sweep-file name.
DISTRIBUTIONS: Mapping[str, type[Distribution]] = {
    "uniform": Uniform,
    "log_uniform": LogUniform,
    "normal": Normal,
    "choice": Choice,
    "grid": Grid,
}
AnyDistribution = tagged_union(DISTRIBUTIONS, "distribution")
