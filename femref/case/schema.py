"""Case-file schema (DESIGN.md §3): frozen pydantic models of harmonic and transient scenes.

Every model is frozen, forbids unknown keys (with a "did you mean …?" hint) and
accepts finite numbers only. Defaults are documented in each field's description
and filled in the validated case, so ``resolved_yaml`` shows everything a run used.

Layout, shared with the impact case (:mod:`femref.case.impact`):

* numbers: :data:`Real`, :data:`PositiveReal`, :data:`NonNegativeReal`, :data:`Count`;
* profiles (registry :data:`PROFILES`): a number or ``{piecewise|linear|table: …}``,
  each with ``build(half_length) -> femref.profiles`` object;
* load signals (registry :data:`SIGNALS`): a number or ``{half_sine|ramp_step|csv: …}``,
  each with ``build(base_dir) -> femref.signals`` object;
* bodies (registry :data:`BODY_TYPES`): :class:`RodBody`, :class:`BeamBody`;
* settings: :class:`TimeSettings`, :class:`IntegratorSettings` (registry
  :data:`INTEGRATORS`), :class:`FemSettings`, the ``models`` list (registry
  ``femref.case.capabilities.MODELS``);
* cases (registry :data:`CASE_KINDS`): :class:`HarmonicCase`, :class:`TransientCase`,
  :class:`~femref.case.impact.ImpactCase` (in :mod:`femref.case.impact`, imported at the
  bottom of this module), and :data:`Case`, their union discriminated on ``kind``.

Validation runs in two stages. Each key is first checked on its own (type, sign,
finiteness, shape) and every failure is reported. Rules that relate keys — profile
breaks and probes against the body length, loads and element order against the body
type, ``dt`` against ``end``, models against the scene — run once the keys they
relate are valid themselves (a bad ``length`` hides the breaks check, not the others).

Validators raise :func:`~femref.case.errors.problems_error`; the loader turns the
pydantic error into one :class:`~femref.case.errors.CaseError`. Pass
``context={"base_dir": Path}`` to resolve relative CSV paths (default: the working
directory).
"""

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    PlainValidator,
    Tag,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)
from pydantic_core import PydanticCustomError

from femref import profiles, signals
from femref.case.capabilities import MODELS, refusal
from femref.case.errors import Problem, did_you_mean, problems_error, problems_from

__all__ = [
    "BODY_TYPES",
    "CASE_KINDS",
    "FREQUENCY_AXES",
    "INTEGRATORS",
    "PROFILES",
    "SIGNALS",
    "BeamBody",
    "Body",
    "Case",
    "CaseModel",
    "ConstantSignal",
    "CsvSignal",
    "FemSettings",
    "FrequencyRange",
    "HalfSineSignal",
    "HarmonicCase",
    "HarmonicLoads",
    "HzRange",
    "ImpactCase",
    "IntegratorSettings",
    "LambdaRange",
    "LinearProfile",
    "OmegaRange",
    "PiecewiseProfile",
    "ProfileSpec",
    "RampStepSignal",
    "RodBody",
    "SignalSpec",
    "TableProfile",
    "TimeSettings",
    "TransientCase",
    "TransientLoads",
    "UniformProfile",
]


# ---------------------------------------------------------------------------------------------
# Numbers


def _reject_bool(value: Any) -> Any:
    """YAML ``true``/``yes`` would otherwise pass as the number 1."""
    if isinstance(value, bool):
        raise PydanticCustomError("number_not_bool", "must be a number, not true/false")
    return value


def _is_number(value: Any) -> bool:
    """A number, or text that reads as one (YAML 1.1 reads ``1e9`` as text)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return True
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return False
        return True
    return False


#: A finite real number (NaN and ±inf are refused by every model's configuration).
Real = Annotated[float, BeforeValidator(_reject_bool)]
PositiveReal = Annotated[Real, Field(gt=0)]
NonNegativeReal = Annotated[Real, Field(ge=0)]
#: An integer >= 1 (element counts, strides, sample counts).
Count = Annotated[int, BeforeValidator(_reject_bool), Field(ge=1)]


# ---------------------------------------------------------------------------------------------
# Base model: frozen, unknown keys refused with a hint, several problems collected


def _validate_collecting(handler: Callable[[Any], Any], data: Any, problems: list[Problem]) -> Any:
    """Run ``handler(data)``; raise its problems together with ``problems`` if there are any."""
    try:
        result = handler(data)
    except ValidationError as error:
        problems = [*problems, *problems_from(error, data)]
    if problems:
        raise problems_error(problems)
    return result


class CaseModel(BaseModel):
    """Base of every case-file model: frozen, finite numbers, unknown keys refused with a hint."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        """Rewrite an accepted short form of the input (a number, a ``{tag: …}`` wrapper)."""
        return data

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        hint = did_you_mean(key, known)
        return f"unknown key{hint}" if hint else f"unknown key; expected one of: {', '.join(known)}"

    @model_validator(mode="wrap")
    @classmethod
    def _known_keys_only(cls, data: Any, handler: Callable[[Any], Any]) -> Any:
        data = cls._shorthand(data)
        if not isinstance(data, Mapping):
            return handler(data)
        fields = cls.model_fields
        unknown = [key for key in data if key not in fields]
        if not unknown:
            return handler(data)
        problems = [Problem((str(key),), cls._unknown_key_rule(key, list(fields))) for key in unknown]
        return _validate_collecting(handler, {k: v for k, v in data.items() if k in fields}, problems)


def _foreign_key_rule(
    cls: type[CaseModel], key: Any, known: list[str], family: Mapping[str, type[CaseModel]], tag_field: str, noun: str
) -> str | None:
    """``'axial_stiffness' is a rod key, not a beam key`` when ``key`` belongs to a sibling model."""
    own = cls.model_fields[tag_field].default
    for name, other in family.items():
        if other is not cls and key in other.model_fields:
            return f"{key!r} is a {name}{noun} key, not a {own}{noun} key{did_you_mean(key, known)}"
    return None


class TaggedSpec(CaseModel):
    """A spec written ``{tag: {fields…}}`` in the case file (the tag picks the class)."""

    tag: ClassVar[str]

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        if isinstance(data, Mapping) and len(data) == 1 and cls.tag in data:
            return data[cls.tag]
        return data

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return {self.tag: handler(self)}


def _tagged_union(registry: Mapping[str, type[TaggedSpec]], what: str, number_tag: str | None = None) -> Any:
    """The type "a number (if ``number_tag``) or a mapping with exactly one key of ``registry``"."""
    named = [name for name in registry if name != number_tag]
    expected = ("a number or " if number_tag else "") + f"a mapping with exactly one key out of {', '.join(named)}"

    def tag_of(value: Any) -> str | None:
        if isinstance(value, TaggedSpec):
            return value.tag
        if number_tag is not None and _is_number(value):
            return number_tag
        if isinstance(value, Mapping) and len(value) == 1:
            return next(iter(value))
        return None

    def check_shape(value: Any) -> Any:
        if isinstance(value, TaggedSpec) or (number_tag is not None and _is_number(value)):
            return value
        if not isinstance(value, Mapping):
            raise PydanticCustomError("spec_shape", "{rule}", {"rule": f"must be {expected}"})
        unknown = [key for key in value if key not in named]
        if unknown:
            raise problems_error([Problem((k,), f"unknown {what}{did_you_mean(k, named)}; expected {expected}") for k in unknown])
        if len(value) != 1:
            given = f"got {' and '.join(map(str, value))} together" if value else "got an empty mapping"
            raise problems_error([Problem((), f"give exactly one of {', '.join(named)}; {given}")])
        return value

    members = tuple(Annotated[cls, Tag(name)] for name, cls in registry.items())
    return Annotated[Union[members], Discriminator(tag_of), BeforeValidator(check_shape)]  # noqa: UP007


# ---------------------------------------------------------------------------------------------
# Profiles


class ProfileSpec(TaggedSpec):
    """A spatial profile of a section property along ``x ∈ [−l, l]`` (DESIGN.md §3)."""

    def build(self, half_length: float) -> profiles.Profile:
        """The ``femref.profiles`` object on a body of half length ``l`` (m)."""
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
    value: Real = Field(description="The value everywhere (units of the property). Required.")

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        return {"value": data} if _is_number(data) else data

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return self.value

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
            problems.append(
                Problem(
                    ("values",),
                    f"must have one value per piece: len(breaks) + 1 = {len(self.breaks) + 1} entries, not {len(self.values)}",
                    list(self.values),
                )
            )
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


_AnyProfile = _tagged_union(PROFILES, "profile kind", number_tag="uniform")
#: A profile whose values are all > 0 (mass per length, stiffness).
PositiveProfile = Annotated[_AnyProfile, AfterValidator(_values_at_least(0.0, strict=True))]
#: A profile whose values are all >= 0 (viscosity).
NonNegativeProfile = Annotated[_AnyProfile, AfterValidator(_values_at_least(0.0, strict=False))]


def length_average(profile: profiles.Profile, half_length: float) -> float:
    """``(1/2l) ∫_{−l}^{l} p(x) dx``.

    Exact for every profile kind here: each is linear between its jumps and kinks, and
    the midpoint rule on those segments integrates a linear function exactly.
    """
    inner = sorted({p for p in (*profile.jumps, *profile.kinks) if -half_length < p < half_length})
    edges = np.array([-half_length, *inner, half_length], dtype=float)
    mids = 0.5 * (edges[:-1] + edges[1:])
    return float(np.sum(profile(mids) * np.diff(edges)) / (2.0 * half_length))


# ---------------------------------------------------------------------------------------------
# Bodies


class Body(CaseModel):
    """A body of length ``2l`` on ``x ∈ [−l, l]`` (DESIGN.md §2); the subclasses name its properties."""

    #: The end-load names this body takes (DESIGN.md §2).
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
        return _foreign_key_rule(cls, key, known, BODY_TYPES, "type", "") or super()._unknown_key_rule(key, known)

    @field_validator("*", mode="after")
    @classmethod
    def _profiles_fit_the_body(cls, value: Any, info: ValidationInfo) -> Any:
        length = info.data.get("length")
        if isinstance(value, ProfileSpec) and length is not None:
            problems = value.range_problems(0.5 * length)
            if problems:
                raise problems_error(problems)
        return value

    @property
    def half_length(self) -> float:
        """``l`` (m)."""
        return 0.5 * self.length

    def profile_specs(self) -> dict[str, ProfileSpec]:
        """The profile specs by case-file name (mass per length, stiffness, viscosity)."""
        return {name: getattr(self, name) for name in ("mass_per_length", self.stiffness_key, self.viscosity_key)}

    def profiles(self) -> dict[str, profiles.Profile]:
        """Built ``femref.profiles`` objects by case-file name, and by the generic names
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
        """Wave travel time ``T`` (s) that makes frequencies nondimensional, ``λ = ω T`` (DESIGN.md §2)."""
        raise NotImplementedError


class RodBody(Body):
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


class BeamBody(Body):
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


#: Body types by case-file name.
BODY_TYPES: Mapping[str, type[Body]] = {"rod": RodBody, "beam": BeamBody}
#: Every end-load name, and the body type that takes it.
LOAD_OWNERS: Mapping[str, str] = {load: name for name, body in BODY_TYPES.items() for load in body.load_names}

BodySpec = Annotated[Union[RodBody, BeamBody], Field(discriminator="type")]  # noqa: UP007


# ---------------------------------------------------------------------------------------------
# Load signals (transient)


class SignalSpec(TaggedSpec):
    """An end-load history ``f(t)`` (N or N·m), built into a ``femref.signals`` object."""

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        """The signal object; ``base_dir`` resolves a relative CSV path (default: working directory)."""
        raise NotImplementedError

    @property
    def is_zero(self) -> bool:
        """True when the history is zero at all times (as far as known without reading files)."""
        return False


class ConstantSignal(SignalSpec):
    """A constant load switched on at ``t = 0`` (a step); written as a plain number."""

    tag: ClassVar[str] = "constant"
    value: Real = Field(description="Load after t = 0 (N or N·m). Required.")

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        return {"value": data} if _is_number(data) else data

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return self.value

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.Constant(self.value)

    @property
    def is_zero(self) -> bool:
        return self.value == 0.0


class HalfSineSignal(SignalSpec):
    """``A sin(π (t − start)/duration)`` during the pulse, zero elsewhere."""

    tag: ClassVar[str] = "half_sine"
    amplitude: Real = Field(description="Peak load A (N or N·m). Required.")
    duration: PositiveReal = Field(description="Pulse length (s), > 0. Required.")
    start: NonNegativeReal = Field(default=0.0, description="Pulse start (s), >= 0. Default 0.")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.HalfSine(self.amplitude, self.duration, self.start)

    @property
    def is_zero(self) -> bool:
        return self.amplitude == 0.0


class RampStepSignal(SignalSpec):
    """A linear rise from 0 at ``start`` to ``amplitude`` at ``start + rise``, then held."""

    tag: ClassVar[str] = "ramp_step"
    amplitude: Real = Field(description="Held load (N or N·m). Required.")
    rise: NonNegativeReal = Field(description="Rise time (s), >= 0 (0 is a step). Required.")
    start: NonNegativeReal = Field(default=0.0, description="Start of the rise (s), >= 0. Default 0.")

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        return signals.RampStep(self.amplitude, self.rise, self.start)

    @property
    def is_zero(self) -> bool:
        return self.amplitude == 0.0


def _csv_column(value: Any) -> int | str:
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    if isinstance(value, str) and value.strip():
        return value
    raise PydanticCustomError("csv_column", "must be a column name or a 0-based column index")


CsvColumn = Annotated[int | str, PlainValidator(_csv_column)]


def resolve_case_path(path: Path, info: ValidationInfo) -> Path:
    """A file path of a case, absolute: relative paths are relative to the case file's directory.

    The directory comes in the validation context (``base_dir``, set by the loader);
    without one, the working directory.
    """
    base_dir = Path((info.context or {}).get("base_dir") or Path.cwd())
    path = path.expanduser()
    return path if path.is_absolute() else (base_dir / path).resolve()


class CsvSignal(SignalSpec):
    """Samples from a CSV file, interpolated linearly, zero outside the recorded times.

    The file is read and checked when the case is loaded. A relative ``path`` is
    relative to the case file's directory and is stored resolved (absolute), so the
    resolved case reads the same file from anywhere.
    """

    tag: ClassVar[str] = "csv"
    path: Path = Field(description="CSV file, relative to the case file's directory. Required.")
    time_column: CsvColumn = Field(default=0, description="Time column (s): header name or 0-based index. Default 0.")
    value_column: CsvColumn = Field(default=1, description="Load column (N or N·m): header name or 0-based index. Default 1.")

    @field_validator("path", mode="after")
    @classmethod
    def _resolve(cls, path: Path, info: ValidationInfo) -> Path:
        return resolve_case_path(path, info)

    @model_validator(mode="after")
    def _readable(self) -> "CsvSignal":
        problem = self._file_problem()
        if problem is not None:
            raise problems_error([Problem(("path",), problem)])
        return self

    def _file_problem(self) -> str | None:
        try:
            times, values = signals.read_csv_columns(self.path, self.time_column, self.value_column)
        except FileNotFoundError:
            return f"CSV file {self.path} does not exist"
        except OSError as error:
            return f"cannot read CSV file {self.path}: {error.strerror or error}"
        except ValueError as error:  # empty, missing column, a cell that is not a number
            return str(error)
        if times.size < 2:
            return f"CSV file {self.path} needs two or more samples, has {times.size}"
        for name, column in (("time", times), ("value", values)):
            bad = np.flatnonzero(~np.isfinite(column))
            if bad.size:
                return f"CSV file {self.path}: {name} in data row {bad[0] + 1} is not a finite number ({column[bad[0]]})"
        steps = np.flatnonzero(np.diff(times) <= 0.0)
        if steps.size:
            k = steps[0]
            return f"CSV file {self.path}: time must increase strictly; data row {k + 2} has t = {times[k + 1]} after t = {times[k]}"
        return None

    def build(self, base_dir: Path | None = None) -> signals.Signal:
        path = self.path if self.path.is_absolute() else Path(base_dir or Path.cwd()) / self.path
        return signals.Tabulated.from_csv(path, self.time_column, self.value_column)


#: Load-signal kinds by case-file name ("constant" is written as a plain number).
SIGNALS: Mapping[str, type[SignalSpec]] = {
    "constant": ConstantSignal,
    "half_sine": HalfSineSignal,
    "ramp_step": RampStepSignal,
    "csv": CsvSignal,
}

AnySignal = _tagged_union(SIGNALS, "signal kind", number_tag="constant")


# ---------------------------------------------------------------------------------------------
# End loads


_LOAD_DOC = {
    "F1": "Rod: axial force at x = −l",
    "F2": "Rod: axial force at x = +l",
    "N1": "Beam: shear force at x = −l",
    "N2": "Beam: shear force at x = +l",
    "G1": "Beam: bending moment at x = −l",
    "G2": "Beam: bending moment at x = +l",
}


def _load_field(name: str, what: str) -> Any:
    unit = "N·m" if name.startswith("G") else "N"
    body = LOAD_OWNERS[name]
    return Field(default=None, description=f"{_LOAD_DOC[name]} ({unit}), {what}. Default 0 on a {body}; refused on other bodies.")


class Loads(CaseModel):
    """End loads (DESIGN.md §2; tension positive): rod ``F1, F2``; beam ``N1, N2, G1, G2``.

    The case fills the body's loads that are not given with 0 and refuses the loads of
    other body types; at least one load must be non-zero. Loads that do not apply are
    ``None`` and are left out of the resolved case.
    """

    def items(self) -> list[tuple[str, Any]]:
        """``(name, load)`` for every load that applies, in field order."""
        return [(name, getattr(self, name)) for name in type(self).model_fields if getattr(self, name) is not None]

    @staticmethod
    def _is_zero(load: Any) -> bool:
        raise NotImplementedError

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return {name: value for name, value in handler(self).items() if value is not None}

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


# ---------------------------------------------------------------------------------------------
# Frequency axis (harmonic)


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
        if self.stop > self.start and self.num == 1:
            raise problems_error([Problem(("stop",), "must equal start when num is 1 (one frequency)", self.stop)])
        return self

    def values(self) -> NDArray[np.float64]:
        """The axis in its own unit."""
        spaced = np.geomspace if self.spacing == "log" else np.linspace
        return spaced(self.start, self.stop, self.num)

    def omega(self, body: Body) -> NDArray[np.float64]:
        """Circular frequencies ω (rad/s) for ``body``."""
        raise NotImplementedError


class OmegaRange(FrequencyRange):
    """Circular frequency ω (rad/s)."""

    tag: ClassVar[str] = "omega"

    def omega(self, body: Body) -> NDArray[np.float64]:
        return self.values()


class HzRange(FrequencyRange):
    """Frequency f (Hz); ``ω = 2π f``."""

    tag: ClassVar[str] = "hz"

    def omega(self, body: Body) -> NDArray[np.float64]:
        return 2.0 * np.pi * self.values()


class LambdaRange(FrequencyRange):
    """Nondimensional frequency λ (DESIGN.md §2); ``ω = λ / T`` with the body's wave time
    ``T = l√(m̄/EĀ)`` (rod) or ``l²√(m̄/EĪ)`` (beam), length-averaged ``m`` and stiffness."""

    tag: ClassVar[str] = "lambda"

    def omega(self, body: Body) -> NDArray[np.float64]:
        return self.values() / body.wave_time()


#: Frequency axes by case-file name.
FREQUENCY_AXES: Mapping[str, type[FrequencyRange]] = {"omega": OmegaRange, "hz": HzRange, "lambda": LambdaRange}

FrequencySpec = _tagged_union(FREQUENCY_AXES, "frequency axis")


# ---------------------------------------------------------------------------------------------
# Time, integrator, finite elements


class TimeSettings(CaseModel):
    """The simulated interval ``[0, end]`` and its sampling."""

    end: PositiveReal = Field(description="End time (s), > 0. Required.")
    dt: PositiveReal | None = Field(
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
    """The time integrator of the FEM model (DESIGN.md §2 hazards: average-acceleration
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


class FemSettings(CaseModel):
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


# ---------------------------------------------------------------------------------------------
# Cases


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


def _fem_field() -> Any:
    return Field(default_factory=FemSettings, validate_default=True, description="Finite-element settings. Default: see FemSettings.")


def _probe_name(name: str) -> str:
    if not name or not all(c.isalnum() or c in "_-." for c in name):
        raise PydanticCustomError("probe_name", "probe names use letters, digits, '_', '-' and '.' only")
    return name


ProbeName = Annotated[str, AfterValidator(_probe_name)]


class SceneCase(CaseModel):
    """What every case kind has: ``kind``, ``fem`` settings and a ``models`` list that can serve it."""

    kind: str = Field(description="Case kind. Required.")

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        return _foreign_key_rule(cls, key, known, CASE_KINDS, "kind", "-case") or super()._unknown_key_rule(key, known)

    @model_validator(mode="after")
    def _models_serve_the_scene(self) -> "SceneCase":
        models: tuple[str, ...] = getattr(self, "models")
        problems = [
            Problem(("models", i), f"{name} cannot serve this case: {reason}", name)
            for i, name in enumerate(models)
            if (reason := refusal(name, self)) is not None  # type: ignore[arg-type]
        ]
        if problems:
            raise problems_error(problems)
        return self


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
        return _validate_collecting(handler, {**{name: 0.0 for name in body.load_names}, **given}, problems)

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
    def _order_for_the_body(cls, fem: FemSettings, info: ValidationInfo) -> FemSettings:
        body = info.data.get("body")
        if body is None:
            return fem
        if fem.order is None:
            return fem.model_copy(update={"order": body.default_order})
        if fem.order not in body.element_orders:
            rule = {
                "rod": "a rod uses order 1 (P1) or 2 (P2)",
                "beam": "a beam always uses Hermite cubic elements (order 3); leave order out",
            }.get(body.type, f"must be one of {body.element_orders}")
            raise problems_error([Problem(("order",), rule, fem.order)])
        return fem


class HarmonicCase(SingleBodyCase):
    """Frequency response of one body to in-phase harmonic end loads (factor ``e^{−iωt}``)."""

    kind: Literal["harmonic"] = Field(default="harmonic", description="harmonic. Required in the case file.")
    loads: HarmonicLoads = Field(description="Harmonic load amplitudes (N or N·m); the body's loads not given are 0; at least one non-zero. Required.")
    frequency: FrequencySpec = Field(description="Frequency axis: exactly one of omega (rad/s), hz, lambda (nondimensional). Required.")
    fem: FemSettings = _fem_field()
    models: ModelList = _models_field()

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
    fem: FemSettings = _fem_field()
    models: ModelList = _models_field()

    def load_signals(self, base_dir: Path | None = None) -> dict[str, signals.Signal]:
        """Every load the body takes, as ``femref.signals`` objects."""
        return {name: spec.build(base_dir) for name, spec in self.loads.items()}


# The impact case lives in its own module, built on the pieces above (imported last: it imports them).
from femref.case.impact import ImpactCase  # noqa: E402

#: Case kinds by case-file name.
CASE_KINDS: Mapping[str, type[SceneCase]] = {"harmonic": HarmonicCase, "transient": TransientCase, "impact": ImpactCase}

#: Any case, discriminated on ``kind``.
Case = Annotated[Union[HarmonicCase, TransientCase, ImpactCase], Field(discriminator="kind")]  # noqa: UP007
