"""The ``couplers`` of an impact case: which neighbours each joins, its force law, contact and slack.

Coupler laws (registry :data:`COUPLER_LAW_SPECS`): ``kelvin_voigt``, ``draft_gear`` and
``table``, each built into a :mod:`reduced.couplers` law. Whether a coupler's cars exist
and are neighbours in line order is checked on the case (:func:`_coupler_pair_problems`),
once the cars are valid.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator
from pydantic_core import PydanticCustomError

from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, NonNegativeReal, PositiveReal, Real, TaggedSpec, _name_rule, _tagged_union
from femref.case.plausibility import plausible, sequence_check
from reduced import couplers as reduced_couplers
from reduced.couplers import CONTACT_KINDS, KelvinVoigt, StandardLinearDraftGear

__all__ = [
    "COUPLER_LAW_SPECS",
    "DEFAULT_SWITCH_VELOCITY",
    "AnyCouplerLaw",
    "CouplerLawSpec",
    "CouplerName",
    "CouplerSpec",
    "DraftGearLaw",
    "KelvinVoigtLaw",
    "TableLaw",
]

#: Default of the table law's rate threshold between loading and unloading (m/s).
DEFAULT_SWITCH_VELOCITY = 0.01

#: Coupler numbers within the plausible range of rail vehicles (femref.case.plausibility).
Stiffness = Annotated[PositiveReal, plausible("coupler_stiffness")]
Damping = Annotated[NonNegativeReal, plausible("coupler_damping")]
Travel = Annotated[NonNegativeReal, plausible("coupler_travel")]


CouplerName = Annotated[str, AfterValidator(_name_rule("coupler"))]


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
    stiffness: Stiffness = Field(description="Spring stiffness c (N/m), > 0. Required.")
    damping: Damping = Field(default=0.0, description="Dashpot μ (N·s/m), >= 0. Default 0.")

    def build(self) -> KelvinVoigt:
        return KelvinVoigt(stiffness=self.stiffness, damping=self.damping)


class DraftGearLaw(CouplerLawSpec):
    """Standard-linear draft gear with a stroke (reduced.couplers.StandardLinearDraftGear):
    two series springs carry the force to a gear spring with a dashpot, stiffening to
    ``solid_stiffness`` beyond the stroke."""

    tag: ClassVar[str] = "draft_gear"
    gear_stiffness: Stiffness = Field(description="Gear spring c (N/m) while the gear is open, > 0. Required.")
    gear_damping: Annotated[PositiveReal, plausible("coupler_damping")] = Field(description="Gear dashpot μ (N·s/m), > 0. Required.")
    stroke: Annotated[PositiveReal, plausible("coupler_travel")] = Field(description="Gear travel before it closes solid (m), > 0. Required.")
    solid_stiffness: Stiffness = Field(description="Gear stiffness c* beyond the stroke (N/m), > 0. Required.")
    series_stiffness_1: Stiffness = Field(default=4.0e8, description="First series spring c1, car body (N/m), > 0. Default 4e8.")
    series_stiffness_2: Stiffness = Field(default=4.0e8, description="Second series spring c2, coupler (N/m), > 0. Default 4e8.")

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
    closure: Annotated[tuple[Real, ...], AfterValidator(sequence_check("coupler_travel"))] = Field(min_length=2, description="Closures δ (m), strictly increasing from 0; two or more. Required.")
    loading: Annotated[tuple[Real, ...], AfterValidator(sequence_check("coupler_force"))] = Field(min_length=2, description="Force on the loading curve (N) at each closure: starts at 0, never decreases. Required.")
    unloading: tuple[Real, ...] = Field(
        min_length=2, description="Force on the unloading curve (N) at each closure: starts at 0, 0 <= unloading <= loading. Required."
    )
    damping: Damping = Field(default=0.0, description="Viscous term added to either curve (N·s/m), >= 0. Default 0.")
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
        law = reduced_couplers.COUPLER_LAWS.get(self.tag) or getattr(reduced_couplers, "HystereticTable", None)
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
    slack: Travel = Field(default=0.0, description="Initial gap (m), >= 0, closed before the coupler carries compression. Default 0.")
    tension_slack: Travel = Field(
        default=0.0, description="Free play in tension (m), >= 0, bilateral contact only. Default 0."
    )
    vertical_offset: Real = Field(
        default=0.0,
        description="Height of the front car's coupler line above the rear car's (m): the coupler is inclined, so its force "
        "also pushes the cars vertically. Needs pivot_distance and both cars bending. Default 0.",
    )
    pivot_distance: PositiveReal | None = Field(
        default=None, description="Distance between the two cars' coupler pivots (m), > 0: the inclined coupler's length. Required with a vertical_offset."
    )

    @model_validator(mode="after")
    def _tension_slack_bilateral(self) -> "CouplerSpec":
        if self.contact == "compression_only" and self.tension_slack != 0.0:
            rule = "applies to bilateral contact only; compression_only never transmits tension"
            raise problems_error([Problem(("tension_slack",), rule, self.tension_slack)])
        if self.vertical_offset != 0.0:
            if self.pivot_distance is None:
                raise problems_error([Problem(("pivot_distance",), "required with a vertical_offset: the coupler's inclination is offset / pivot_distance")])
            if abs(self.vertical_offset) >= 0.5 * self.pivot_distance:
                raise problems_error([Problem(("vertical_offset",), f"must be below half the pivot distance ({0.5 * self.pivot_distance:g} m): a coupler inclined so far is no longer a buff coupler", self.vertical_offset)])
        return self

    @property
    def slope(self) -> float:
        """``s = vertical_offset / pivot_distance``: the coupler's inclination (small-angle, up toward the front)."""
        return 0.0 if self.vertical_offset == 0.0 else self.vertical_offset / float(self.pivot_distance)


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
