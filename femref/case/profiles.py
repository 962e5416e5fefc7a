"""Profiles of the case file: a section property along the body, ``x ∈ [−l, l]`` (docs/design.md §3).

A profile is a number or ``{piecewise|linear|table: …}`` (registry :data:`PROFILES`); whether its
breaks and positions fit on the body is checked by the body (:meth:`ProfileSpec.range_problems`).
"""

from collections.abc import Callable, Mapping
from typing import Annotated, ClassVar

import numpy as np
from pydantic import AfterValidator, Field, model_validator

from femref.case.errors import Problem, problems_error
from femref.case.fields import Real, TaggedSpec, tagged_union
from femref.core import profiles

__all__ = [
    "PROFILES",
    "LinearProfile",
    "NonNegativeProfile",
    "PiecewiseProfile",
    "PositiveProfile",
    "ProfileSpec",
    "TableProfile",
    "UniformProfile",
    "length_average",
]


class ProfileSpec(TaggedSpec):
    """A spatial profile of a section property along ``x ∈ [−l, l]`` (docs/design.md §3)."""

    def build(self, half_length: float) -> profiles.Profile:
        """The ``femref.core.profiles`` object on a body of half length ``l`` (m)."""
        raise NotImplementedError

    def value_items(self) -> list[tuple[tuple[str | int, ...], float]]:
        """``(key path below the profile key, value)`` for each property value given."""
        raise NotImplementedError

    def range_problems(self, half_length: float) -> list[Problem]:
        """Positions that do not fit on a body of half length ``l``."""
        return []


class UniformProfile(ProfileSpec):
    """The same value everywhere; written as a plain number."""

    tag: ClassVar[str] = "uniform"
    number_field: ClassVar[str | None] = "value"
    value: Real = Field(description="The value everywhere (units of the property). Required.")

    def build(self, half_length: float) -> profiles.Profile:
        return profiles.Uniform(self.value)

    def value_items(self) -> list[tuple[tuple[str | int, ...], float]]:
        return [((), self.value)]


class PiecewiseProfile(ProfileSpec):
    """``values[k]`` between consecutive ``breaks`` (the body ends close the first and last pieces)."""

    tag: ClassVar[str] = "piecewise"
    breaks: tuple[Real, ...] = Field(description="Jump positions (m), strictly increasing, strictly inside (−l, l). Required.")
    values: tuple[Real, ...] = Field(min_length=1, description="One value per piece: len(breaks) + 1 entries. Required.")

    @model_validator(mode="after")
    def _consistent(self) -> "PiecewiseProfile":
        problems = []
        if any(a >= b for a, b in zip(self.breaks, self.breaks[1:])):
            problems.append(Problem(("breaks",), "must increase strictly", list(self.breaks)))
        if len(self.values) != len(self.breaks) + 1:
            rule = f"must have one value per piece: len(breaks) + 1 = {len(self.breaks) + 1} entries, not {len(self.values)}"
            problems.append(Problem(("values",), rule, list(self.values)))
        if problems:
            raise problems_error(problems)
        return self

    def build(self, half_length: float) -> profiles.Profile:
        return profiles.Piecewise(tuple(self.breaks), tuple(self.values))

    def value_items(self) -> list[tuple[tuple[str | int, ...], float]]:
        return [((self.tag, "values", i), v) for i, v in enumerate(self.values)]

    def range_problems(self, half_length: float) -> list[Problem]:
        if all(-half_length < b < half_length for b in self.breaks):
            return []
        rule = f"must lie strictly inside the body ({-half_length}, {half_length})"
        return [Problem((self.tag, "breaks"), rule, list(self.breaks))]


class LinearProfile(ProfileSpec):
    """Linear from ``left`` at ``x = −l`` to ``right`` at ``x = +l``."""

    tag: ClassVar[str] = "linear"
    left: Real = Field(description="Value at x = −l. Required.")
    right: Real = Field(description="Value at x = +l. Required.")

    def build(self, half_length: float) -> profiles.Profile:
        return profiles.Linear(self.left, self.right, half_length)

    def value_items(self) -> list[tuple[tuple[str | int, ...], float]]:
        return [((self.tag, "left"), self.left), ((self.tag, "right"), self.right)]


class TableProfile(ProfileSpec):
    """Linear interpolation between ``(x, value)`` pairs, held constant beyond the first and last ``x``."""

    tag: ClassVar[str] = "table"
    x: tuple[Real, ...] = Field(min_length=2, description="Positions (m), strictly increasing, within [−l, l]; two or more. Required.")
    values: tuple[Real, ...] = Field(min_length=2, description="One value per position. Required.")

    @model_validator(mode="after")
    def _consistent(self) -> "TableProfile":
        problems = []
        if any(a >= b for a, b in zip(self.x, self.x[1:])):
            problems.append(Problem(("x",), "must increase strictly", list(self.x)))
        if len(self.values) != len(self.x):
            problems.append(Problem(("values",), f"must have one value per position: {len(self.x)} entries, not {len(self.values)}", list(self.values)))
        if problems:
            raise problems_error(problems)
        return self

    def build(self, half_length: float) -> profiles.Profile:
        return profiles.Table(tuple(self.x), tuple(self.values))

    def value_items(self) -> list[tuple[tuple[str | int, ...], float]]:
        return [((self.tag, "values", i), v) for i, v in enumerate(self.values)]

    def range_problems(self, half_length: float) -> list[Problem]:
        if all(-half_length <= v <= half_length for v in self.x):
            return []
        return [Problem((self.tag, "x"), f"must lie within the body [{-half_length}, {half_length}]", list(self.x))]


#: Profile kinds by case-file name ("uniform" is written as a plain number).
PROFILES: Mapping[str, type[ProfileSpec]] = {
    "uniform": UniformProfile,
    "piecewise": PiecewiseProfile,
    "linear": LinearProfile,
    "table": TableProfile,
}


def _values_at_least(bound: float, strict: bool) -> Callable[[ProfileSpec], ProfileSpec]:
    rule = f"must be {'>' if strict else '>='} {bound:g}"

    def check(spec: ProfileSpec) -> ProfileSpec:
        bad = [Problem(path, rule, v) for path, v in spec.value_items() if (v <= bound if strict else v < bound)]
        if bad:
            raise problems_error(bad)
        return spec

    return check


_AnyProfile = tagged_union(PROFILES, "profile kind", number_tag="uniform")
#: A profile whose values are all > 0 (mass per length, stiffness).
PositiveProfile = Annotated[_AnyProfile, AfterValidator(_values_at_least(0.0, strict=True))]
#: A profile whose values are all >= 0 (viscosity).
NonNegativeProfile = Annotated[_AnyProfile, AfterValidator(_values_at_least(0.0, strict=False))]


def length_average(profile: profiles.Profile, half_length: float) -> float:
    """``(1/2l) ∫_{−l}^{l} p(x) dx``, exact: every profile kind is linear between its jumps and kinks, where the
    midpoint rule integrates it exactly."""
    inner = sorted({p for p in (*profile.jumps, *profile.kinks) if -half_length < p < half_length})
    edges = np.array([-half_length, *inner, half_length], dtype=float)
    mids = 0.5 * (edges[:-1] + edges[1:])
    return float(np.sum(profile(mids) * np.diff(edges)) / (2.0 * half_length))
