"""The ``body`` of a single-body case and of each impact car: a rod or a beam (registry :data:`BODY_TYPES`)."""

import math
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import Field, ValidationInfo, field_validator, model_validator

from femref.case.errors import Problem, problems_error
from femref.case.fields import CaseModel, PositiveReal, foreign_key_rule
from femref.case.plausibility import BOUNDS, profile_problems
from femref.case.profiles import NonNegativeProfile, PositiveProfile, ProfileSpec, UniformProfile, length_average
from femref.core import profiles

__all__ = ["BODY_TYPES", "LOAD_OWNERS", "BeamBody", "BodySchema", "BodySpec", "CarBody", "RodBody"]


class BodySchema(CaseModel):
    """A body of length ``2l`` on ``x ∈ [−l, l]`` (docs/design.md §2); the subclasses name its properties."""

    #: The end-load names this body takes (docs/design.md §2).
    load_names: ClassVar[tuple[str, ...]]
    #: Case-file names of the stiffness and viscosity profiles.
    stiffness_key: ClassVar[str]
    viscosity_key: ClassVar[str]
    #: Finite-element polynomial orders this body can use, and the default.
    element_orders: ClassVar[tuple[int, ...]]
    default_order: ClassVar[int]

    type: str = Field(description="Body type, one of: rod, beam. Required.")
    length: PositiveReal = Field(description="Length 2l of the body (m), > 0; it occupies x ∈ [−l, l]. Required.")
    mass_per_length: PositiveProfile = Field(description="Mass per unit length m(x) (kg/m), a profile with values > 0. Required.")

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        return foreign_key_rule(cls, key, known, BODY_TYPES, "type", "") or super()._unknown_key_rule(key, known)

    @field_validator("*", mode="after")
    @classmethod
    def _profiles_fit_the_body(cls, value: Any, info: ValidationInfo) -> Any:
        length = info.data.get("length")
        if isinstance(value, ProfileSpec) and length is not None:
            problems = value.range_problems(0.5 * length)
            if problems:
                raise problems_error(problems)
        return value

    @model_validator(mode="after")
    def _plausible(self) -> "BodySchema":
        """A length or profile values no rail vehicle has (:mod:`femref.case.plausibility`)."""
        rule = BOUNDS["length"].rule(self.length)
        problems = [Problem(("length",), rule, self.length)] if rule else []
        for name in type(self).model_fields:
            spec = getattr(self, name)
            if isinstance(spec, ProfileSpec):
                problems += profile_problems(name, spec.value_items())
        if problems:
            raise problems_error(problems)
        return self

    @property
    def half_length(self) -> float:
        """``l`` (m)."""
        return 0.5 * self.length

    def profile_specs(self) -> dict[str, ProfileSpec]:
        """The profile specs by case-file name (mass per length, stiffness, viscosity)."""
        return {name: getattr(self, name) for name in ("mass_per_length", self.stiffness_key, self.viscosity_key)}

    def profiles(self) -> dict[str, profiles.Profile]:
        """Built ``femref.core.profiles`` objects by case-file name, and by the generic names
        ``stiffness`` (EA or EI) and ``viscosity`` (cA or cI)."""
        built = {name: spec.build(self.half_length) for name, spec in self.profile_specs().items()}
        return {**built, "stiffness": built[self.stiffness_key], "viscosity": built[self.viscosity_key]}

    def mass(self) -> float:
        """Total mass ``M = ∫ m dx`` (kg)."""
        return self.length * self.mean_mass_per_length()

    def mean_mass_per_length(self) -> float:
        """``m̄ = M / 2l`` (kg/m): the length average of ``m(x)``."""
        return length_average(self.mass_per_length.build(self.half_length), self.half_length)

    def mean_stiffness(self) -> float:
        """Length average of the stiffness profile, ``(1/2l) ∫ EA dx`` (N) or ``(1/2l) ∫ EI dx`` (N·m²)."""
        spec = self.profile_specs()[self.stiffness_key]
        return length_average(spec.build(self.half_length), self.half_length)

    def wave_time(self) -> float:
        """Wave travel time ``T`` (s) that makes frequencies nondimensional, ``λ = ω T`` (docs/design.md §2)."""
        raise NotImplementedError


class RodBody(BodySchema):
    """Longitudinal Kelvin-Voigt rod: ``F = EA u_x + cA u_xt``, ``F_x = m u_tt``; end loads ``F(∓l) = F1, F2``."""

    load_names: ClassVar[tuple[str, ...]] = ("F1", "F2")
    stiffness_key: ClassVar[str] = "axial_stiffness"
    viscosity_key: ClassVar[str] = "axial_viscosity"
    element_orders: ClassVar[tuple[int, ...]] = (1, 2)
    default_order: ClassVar[int] = 2

    type: Literal["rod"] = "rod"
    axial_stiffness: PositiveProfile = Field(description="Axial stiffness EA(x) (N), a profile with values > 0. Required.")
    axial_viscosity: NonNegativeProfile = Field(
        default=UniformProfile(value=0.0),
        description="Axial viscosity cA(x) (N·s), Kelvin-Voigt, a profile with values >= 0. Default 0 (elastic).",
    )

    def wave_time(self) -> float:
        """``T = l √(m̄ / EĀ)`` with the length averages of ``m`` and ``EA``."""
        return self.half_length * math.sqrt(self.mean_mass_per_length() / self.mean_stiffness())


class BeamBody(BodySchema):
    """Euler-Bernoulli beam: ``G = EI w_xx + cI w_xxt``, ``N = G_x``, ``N_x + m w_tt = 0``;
    end loads ``N(∓l) = N1, N2``, ``G(∓l) = G1, G2``."""

    load_names: ClassVar[tuple[str, ...]] = ("N1", "N2", "G1", "G2")
    stiffness_key: ClassVar[str] = "bending_stiffness"
    viscosity_key: ClassVar[str] = "bending_viscosity"
    element_orders: ClassVar[tuple[int, ...]] = (3,)
    default_order: ClassVar[int] = 3

    type: Literal["beam"] = "beam"
    bending_stiffness: PositiveProfile = Field(description="Bending stiffness EI(x) (N·m²), a profile with values > 0. Required.")
    bending_viscosity: NonNegativeProfile = Field(
        default=UniformProfile(value=0.0),
        description="Bending viscosity cI(x) (N·m²·s), Kelvin-Voigt, a profile with values >= 0. Default 0 (elastic).",
    )

    def wave_time(self) -> float:
        """``T = l² √(m̄ / EĪ)`` with the length averages of ``m`` and ``EI``."""
        return self.half_length**2 * math.sqrt(self.mean_mass_per_length() / self.mean_stiffness())


class CarBody(RodBody):
    """An impact car's body: a rod, and — with ``bending_stiffness`` — also an Euler-Bernoulli beam on the
    same axis with the same mass (vertical motion and pitch; docs/design.md §3.3)."""

    bending_stiffness: PositiveProfile | None = Field(
        default=None, description="Bending stiffness EI(x) (N·m²) about the horizontal axis, a profile with values > 0. Default null: the car does not bend."
    )
    bending_viscosity: NonNegativeProfile = Field(
        default=UniformProfile(value=0.0),
        description="Bending viscosity cI(x) (N·m²·s), Kelvin-Voigt, a profile with values >= 0. Default 0 (elastic); needs bending_stiffness.",
    )

    @model_validator(mode="after")
    def _viscosity_needs_stiffness(self) -> "CarBody":
        zero = isinstance(self.bending_viscosity, UniformProfile) and self.bending_viscosity.value == 0.0
        if self.bending_stiffness is None and not zero:
            raise problems_error([Problem(("bending_viscosity",), "needs bending_stiffness: a car without it does not bend")])
        return self

    @property
    def bends(self) -> bool:
        return self.bending_stiffness is not None

    def beam(self) -> BeamBody:
        """The body's bending as a :class:`BeamBody` (same length and mass); ValueError if it does not bend."""
        if self.bending_stiffness is None:
            raise ValueError("this car body has no bending_stiffness")
        return BeamBody(type="beam", length=self.length, mass_per_length=self.mass_per_length,
                        bending_stiffness=self.bending_stiffness, bending_viscosity=self.bending_viscosity)


#: Body types by case-file name.
BODY_TYPES: Mapping[str, type[BodySchema]] = {"rod": RodBody, "beam": BeamBody}
#: Every end-load name, and the body type that takes it.
LOAD_OWNERS: Mapping[str, str] = {load: name for name, body in BODY_TYPES.items() for load in body.load_names}

BodySpec = Annotated[Union[RodBody, BeamBody], Field(discriminator="type")]  # noqa: UP007
