"""The ``couplers`` of an impact case: which neighbours each joins, its force law, contact and slack.

Each law (registry :data:`COUPLER_LAW_SPECS`; the friction gear's ``loading`` curve from
:data:`LOADING_CURVE_SPECS`) builds the :mod:`reduced.couplers` law of its class ``law``, which must
have a compiled form. A new law is its module in :mod:`reduced.couplers` and its class here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator
from pydantic_core import PydanticCustomError

from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.fields import CaseModel, NonNegativeReal, PositiveReal, Real, TaggedSpec, duplicates, name_rule, tagged_union
from femref.case.plausibility import BOUNDS, format_number, plausible, sequence_check
from reduced.couplers import (
    CONTACT_KINDS,
    CubicLoading,
    ExponentialLoading,
    HystereticTable,
    KelvinVoigt,
    PowerLawGear,
    StandardLinearDraftGear,
    compiled_form_rule,
    friction_gear,
    rated_closure_force,
)

__all__ = [
    "COUPLER_LAW_SPECS",
    "DEFAULT_SWITCH_VELOCITY",
    "AnyCouplerLaw",
    "CouplerLawSpec",
    "CouplerName",
    "CouplerSpec",
    "CubicLoadingCurve",
    "DraftGearLaw",
    "ExponentialLoadingCurve",
    "FrictionGearLaw",
    "KelvinVoigtLaw",
    "LOADING_CURVE_SPECS",
    "LoadingCurveSpec",
    "PowerLawGearLaw",
    "TableLaw",
]

#: Default of the table law's rate threshold between loading and unloading (m/s).
DEFAULT_SWITCH_VELOCITY = 0.01

#: Closure (m) at which a power law's secant stiffness and damping terms are checked for plausibility
#: (the closure of reduced.couplers.PowerLawGear.reference_stiffness).
REFERENCE_CLOSURE = 0.01

#: Coupler numbers within the plausible range of rail vehicles (femref.case.plausibility).
Stiffness = Annotated[PositiveReal, plausible("coupler_stiffness")]
Damping = Annotated[NonNegativeReal, plausible("coupler_damping")]
Travel = Annotated[NonNegativeReal, plausible("coupler_travel")]


CouplerName = Annotated[str, AfterValidator(name_rule("coupler"))]


class CouplerLawSpec(TaggedSpec):
    """A coupler force law ``P(δ, δ̇, state)`` (N, compression positive), built into a ``reduced.couplers`` law
    of the class ``law``, which must have a compiled form (femref steps impacts compiled)."""

    law: ClassVar[type]

    @model_validator(mode="after")
    def _compiled_form(self) -> "CouplerLawSpec":
        if (rule := compiled_form_rule(self.law)) is not None:
            raise problems_error([Problem((), f"{rule}; every coupler law needs one: impacts are stepped compiled")])
        return self

    def build(self) -> Any:
        """The ``reduced.couplers`` law object: the class ``law`` of the spec's fields."""
        return self.law(**dict(self))


class KelvinVoigtLaw(CouplerLawSpec):
    """Linear spring and dashpot in parallel, ``P = c δ + μ δ̇`` (reduced.couplers.KelvinVoigt)."""

    tag: ClassVar[str] = "kelvin_voigt"
    law: ClassVar[type] = KelvinVoigt
    stiffness: Stiffness = Field(description="Spring stiffness c (N/m), > 0. Required.")
    damping: Damping = Field(default=0.0, description="Dashpot μ (N·s/m), >= 0. Default 0.")


class DraftGearLaw(CouplerLawSpec):
    """Standard-linear draft gear with a stroke (reduced.couplers.StandardLinearDraftGear):
    two series springs carry the force to a gear spring with a dashpot, stiffening to
    ``solid_stiffness`` beyond the stroke."""

    tag: ClassVar[str] = "draft_gear"
    law: ClassVar[type] = StandardLinearDraftGear
    gear_stiffness: Stiffness = Field(description="Gear spring c (N/m) while the gear is open, > 0. Required.")
    gear_damping: Annotated[PositiveReal, plausible("coupler_damping")] = Field(description="Gear dashpot μ (N·s/m), > 0. Required.")
    stroke: Annotated[PositiveReal, plausible("coupler_travel")] = Field(description="Gear travel before it closes solid (m), > 0. Required.")
    solid_stiffness: Stiffness = Field(description="Gear stiffness c* beyond the stroke (N/m), > 0. Required.")
    series_stiffness_1: Stiffness = Field(default=4.0e8, description="First series spring c1, car body (N/m), > 0. Default 4e8.")
    series_stiffness_2: Stiffness = Field(default=4.0e8, description="Second series spring c2, coupler (N/m), > 0. Default 4e8.")


class TableLaw(CouplerLawSpec):
    """Tabulated loading and unloading curves with hysteresis (reduced.couplers.HystereticTable):
    the force follows ``loading`` while the closure grows and ``unloading`` while it shrinks
    (the closure rate past ``switch_velocity`` picks the curve), plus ``damping · δ̇``."""

    tag: ClassVar[str] = "table"
    law: ClassVar[type] = HystereticTable
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


class PowerLawGearLaw(CouplerLawSpec):
    """Power-law gear with preload and closure-dependent damping (reduced.couplers.PowerLawGear):
    ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``, ``γ(δ) = Σ_k γ_k |δ|^k``."""

    tag: ClassVar[str] = "power_law"
    law: ClassVar[type] = PowerLawGear
    stiffness: PositiveReal = Field(
        description=f"Spring coefficient c (N/mⁿ), > 0; its secant c·({REFERENCE_CLOSURE * 1e3:g} mm)^(n−1) must be a plausible coupler stiffness. Required."
    )
    exponent: Annotated[Real, Field(ge=1), plausible("gear_exponent")] = Field(
        default=1.0, description="Exponent n, >= 1 (n < 1 is infinitely stiff at zero closure). Default 1."
    )
    preload: Annotated[NonNegativeReal, plausible("coupler_force")] = Field(
        default=0.0, description="Preload N0 (N), >= 0: the force jumps to ±N0 as the closure passes 0. Default 0."
    )
    damping: tuple[NonNegativeReal, ...] = Field(
        default=(0.0,), min_length=1,
        description="Damping coefficients [γ_0, γ_1, …] of γ(δ) = Σ γ_k |δ|^k (γ_k in N·s/m^(k+1)), each >= 0; at least one. Default [0].",
    )

    @model_validator(mode="after")
    def _plausible_at_reference_closure(self) -> "PowerLawGearLaw":
        """``c δ_r^(n−1)`` and each ``γ_k δ_r^k`` at ``δ_r`` = :data:`REFERENCE_CLOSURE` within the coupler bounds."""
        secant = self.stiffness * REFERENCE_CLOSURE ** (self.exponent - 1.0)
        problems = []
        if (rule := BOUNDS["coupler_stiffness"].rule(secant)) is not None:
            problems.append(Problem(("stiffness",), f"its secant c·({REFERENCE_CLOSURE:g} m)^(n−1) = {format_number(secant)} N/m: {rule}", self.stiffness))
        for k, gamma in enumerate(self.damping):
            if (rule := BOUNDS["coupler_damping"].rule(gamma * REFERENCE_CLOSURE**k)) is not None:
                problems.append(Problem(("damping", k), f"γ_{k}·({REFERENCE_CLOSURE:g} m)^{k} = {format_number(gamma * REFERENCE_CLOSURE**k)} N·s/m: {rule}", gamma))
        if problems:
            raise problems_error(problems)
        return self


class LoadingCurveSpec(TaggedSpec):
    """A friction gear's loading curve ``L(δ)`` (N), convex, built into the ``reduced.couplers`` class ``curve``."""

    curve: ClassVar[type]

    def build(self) -> Any:
        return self.curve(**dict(self))


class CubicLoadingCurve(LoadingCurveSpec):
    """``L(δ) = k1 δ + k3 δ³`` (reduced.couplers.CubicLoading)."""

    tag: ClassVar[str] = "cubic"
    curve: ClassVar[type] = CubicLoading
    linear_stiffness: Annotated[NonNegativeReal, plausible("gear_linear_stiffness")] = Field(description="k1 (N/m), >= 0. Required.")
    cubic_stiffness: Annotated[NonNegativeReal, plausible("gear_cubic_stiffness")] = Field(description="k3 (N/m³), >= 0. Required.")

    @model_validator(mode="after")
    def _rises(self) -> "CubicLoadingCurve":
        if self.linear_stiffness == 0.0 and self.cubic_stiffness == 0.0:
            raise problems_error([Problem(("cubic_stiffness",), "linear_stiffness and cubic_stiffness are both 0: a gear that never pushes", 0.0)])
        return self


class ExponentialLoadingCurve(LoadingCurveSpec):
    """``L(δ) = a (e^{b δ} − 1)`` (reduced.couplers.ExponentialLoading)."""

    tag: ClassVar[str] = "exponential"
    curve: ClassVar[type] = ExponentialLoading
    amplitude: Annotated[PositiveReal, plausible("gear_curve_amplitude")] = Field(description="a (N), > 0. Required.")
    rate: PositiveReal = Field(description="b (1/m), > 0; b·solid_closure within 1e-3–40. Required.")


#: Loading curves of the friction gear by case-file name.
LOADING_CURVE_SPECS: Mapping[str, type[LoadingCurveSpec]] = {"cubic": CubicLoadingCurve, "exponential": ExponentialLoadingCurve}

AnyLoadingCurve = tagged_union(LOADING_CURVE_SPECS, "loading curve")

#: Relative agreement a given ``rated_closure_force`` must have with L(δ_c) (the resolved case writes it exactly).
RATED_FORCE_RTOL = 1e-9


class FrictionGearLaw(CouplerLawSpec):
    """Friction draft gear with hysteresis and a solid stop (reduced.couplers.friction_gear, a tabulated
    HystereticTable): ``loading`` L(δ) up to the ``solid_closure`` δ_c, unloading ``U = r L``, both rising
    with ``solid_stiffness`` k_s beyond δ_c; ``P = U + (L − U) clip(δ̇/v_s, 0, 1) + c_v δ̇``, odd in (δ, δ̇).
    Its rated closure force ``L(δ_c)`` is filled in as ``rated_closure_force``."""

    tag: ClassVar[str] = "friction_gear"
    law: ClassVar[type] = HystereticTable
    loading: AnyLoadingCurve = Field(description="Loading curve L(δ) up to the solid closure: exactly one of cubic {linear_stiffness k1 N/m, "
                                     "cubic_stiffness k3 N/m³} (L = k1 δ + k3 δ³) or exponential {amplitude a N, rate b 1/m} (L = a (e^{bδ} − 1)). Required.")
    unloading_ratio: Real = Field(description="r = U/L on the gear travel, in [0, 1]: friction gears 0.3–0.5, polymer-like gears near 1. Required.")
    solid_closure: Annotated[PositiveReal, plausible("coupler_travel")] = Field(description="Closure δ_c (m) at which the gear closes solid, > 0 (typically 0.06–0.09). Required.")
    solid_stiffness: Stiffness = Field(description="Stiffness k_s (N/m) beyond the solid closure, at least the loading slope L'(δ_c) (real gears 20–50× that). Required.")
    damping: Damping = Field(default=0.0, description="Viscous term c_v δ̇ added to either curve (N·s/m), >= 0. Default 0.")
    switch_velocity: PositiveReal = Field(
        default=DEFAULT_SWITCH_VELOCITY,
        description=f"Closure rate (m/s) over which the force blends between the curves, > 0. Default {DEFAULT_SWITCH_VELOCITY}.",
    )
    rated_closure_force: PositiveReal | None = Field(
        default=None,
        description="Derived, L(δ_c) (N): the force at which the gear closes solid. Leave it out: validation fills it in (femref validate "
        f"shows it); given, it must equal L(δ_c) to a relative {RATED_FORCE_RTOL:g}.",
    )

    @model_validator(mode="after")
    def _gear(self) -> "FrictionGearLaw":
        problems = self._curve_problems()
        if problems:
            raise problems_error(problems)
        curve = self.loading.build()
        rated = rated_closure_force(curve, self.solid_closure)
        if (rule := BOUNDS["coupler_force"].rule(rated)) is not None:
            problems.append(Problem(("solid_closure",), f"the rated closure force L({self.solid_closure:g} m) = {format_number(rated)} N: {rule}", self.solid_closure))
        slope = curve.slope(self.solid_closure)
        if self.solid_stiffness < slope:
            rule = f"must be at least the loading slope at the solid closure, L'({self.solid_closure:g} m) = {slope:.6g} N/m: the solid stop stiffens the gear"
            problems.append(Problem(("solid_stiffness",), rule, self.solid_stiffness))
        if self.rated_closure_force is not None and abs(self.rated_closure_force - rated) > RATED_FORCE_RTOL * rated:
            rule = f"is derived: it must equal L(solid_closure) = {rated!r} N (leave it out and validation fills it in)"
            problems.append(Problem(("rated_closure_force",), rule, self.rated_closure_force))
        if problems:
            raise problems_error(problems)
        object.__setattr__(self, "rated_closure_force", rated)  # the filled-in derived key (frozen model)
        return self

    def _curve_problems(self) -> list[Problem]:
        """The unloading ratio's rule and an exponential curve's exponent ``b δ_c`` (before L(δ_c) is evaluated)."""
        problems = []
        if not 0.0 <= self.unloading_ratio <= 1.0:
            problems.append(Problem(("unloading_ratio",), "must lie in [0, 1]: the unloading curve lies between 0 and the loading curve", self.unloading_ratio))
        if isinstance(self.loading, ExponentialLoadingCurve):
            exponent = self.loading.rate * self.solid_closure
            if (rule := BOUNDS["gear_curve_exponent"].rule(exponent)) is not None:
                problems.append(Problem(("loading", "exponential", "rate"), f"rate·solid_closure = {format_number(exponent)}: {rule}", self.loading.rate))
        return problems

    def build(self) -> HystereticTable:
        return friction_gear(
            self.loading.build(),
            unloading_ratio=self.unloading_ratio,
            solid_closure=self.solid_closure,
            solid_stiffness=self.solid_stiffness,
            damping=self.damping,
            switch_velocity=self.switch_velocity,
        )


#: Coupler laws by case-file name.
COUPLER_LAW_SPECS: Mapping[str, type[CouplerLawSpec]] = {
    "kelvin_voigt": KelvinVoigtLaw,
    "draft_gear": DraftGearLaw,
    "table": TableLaw,
    "power_law": PowerLawGearLaw,
    "friction_gear": FrictionGearLaw,
}

AnyCouplerLaw = tagged_union(COUPLER_LAW_SPECS, "coupler law")


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
    law: AnyCouplerLaw = Field(description=f"Force law: exactly one of {', '.join(COUPLER_LAW_SPECS)}. Required.")
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


def named_couplers(couplers: tuple[Any, ...], cars: tuple[Any, ...] | None) -> tuple[Any, ...]:
    """The couplers, the k-th unnamed one named ``c<k>``; names unique, each between neighbours in line order
    (checked against ``cars`` unless they are invalid themselves, None)."""
    named = tuple(c if c.name is not None else c.model_copy(update={"name": f"c{k + 1}"}) for k, c in enumerate(couplers))
    problems = duplicates([c.name for c in named], "coupler", lambda k: (k, "name"))
    if cars is not None:
        problems += coupler_pair_problems(named, [car.name for car in cars])
    if problems:
        raise problems_error(problems)
    return named


def coupler_pair_problems(couplers: tuple[CouplerSpec, ...], names: list[str]) -> list[Problem]:
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
