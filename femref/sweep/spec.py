"""Sweep files (docs/design.md §6, the layout and the distributions): a base impact case, parameter distributions,
and the samples they give.

Key paths are dotted; integer parts index lists (``couplers.0.law.kelvin_voigt.stiffness``).
They address the *resolved* base case, so a default the base file leaves out (``fem.elements``)
can be swept. Every part but the last must exist in the base case — or in a value of an earlier
``choice``/``grid`` parameter that replaces a parent; when that choice removes a parent in some
samples only, those samples fail (stored as failed samples, :mod:`femref.sweep.store`).

Sampling rule — deterministic and independent of the total count::

    N = samples · n_grid                   n_grid = product of the grid parameters' lengths
    i = draw · n_grid + grid_point         grid_point: C order over the grid parameters (the last varies fastest)
    random values of draw d:  numpy.random.default_rng([seed, d]), drawn in parameter order

so raising ``samples`` keeps every earlier sample identical. A sample's case with a ``measurement``
whose seed the sweep does not set gets :func:`noise_seed`.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import yaml
from pydantic import BeforeValidator, Field, TypeAdapter, ValidationError, model_validator

from femref.case import CaseError, ImpactCase, Problem, load_case, parse_case
from femref.case.errors import problems_error, problems_from
from femref.case.fields import CaseModel, Count, reject_bool
from femref.case.loader import read_yaml_file
from femref.sweep.derive import SubstitutionError, derive_case, substituted_data
from femref.sweep.distributions import AnyDistribution, Choice, Distribution, Grid
from femref.sweep.keypaths import parent_of, key_parts, PathError

__all__ = [
    "FIXED_KEYS",
    "FIXED_PATHS",
    "OutputSettings",
    "Sample",
    "Sweep",
    "SweepFile",
    "load_sweep",
    "noise_seed",
    "parse_sweep",
]

#: Case keys a parameter may not set, nor anything below them: the sweep fixes them.
FIXED_KEYS: Mapping[str, str] = {
    "kind": "a sweep's base case is an impact case; kind is fixed",
    "models": "set the models with the sweep's own models key (one list for every sample)",
    "estimators": "a sweep drops the estimators; they run on the records afterwards",
}
#: Key paths a parameter may not set (keys below them may be): every record spans one time axis.
FIXED_PATHS: Mapping[str, str] = {
    "time": "every record of a sweep spans [0, time.end] of the base case; sweep time.dt or time.output_stride instead",
    "time.end": "every record of a sweep spans [0, time.end] of the base case",
}
#: Group names of the sweep file a model run may not take.
RESERVED_GROUPS = ("parameters", "samples")


RecordLength = Annotated[int, BeforeValidator(reject_bool), Field(ge=2)]


class OutputSettings(CaseModel):
    """Lengths of the fixed-length histories stored per sample (:mod:`femref.sensing.records`)."""

    record_length: RecordLength = Field(default=200, description="Samples per acceleration record over [0, time.end], >= 2. Default 200.")
    force_length: RecordLength = Field(default=200, description="Samples per coupler force history over [0, time.end], >= 2. Default 200.")


def _key_path(path: str) -> str:
    if not path or any(not part or part != part.strip() for part in path.split(".")):
        raise problems_error([Problem((), "a key path is dotted names and list indices, e.g. cars.0.velocity; no empty parts or spaces", path)])
    return path


class SweepFile(CaseModel):
    """What a sweep file says, validated on its own (the key paths are checked against the base case later)."""

    base: str | None = Field(default=None, description="Base impact case file, relative to the sweep file. Give base or case.")
    case: dict[str, Any] | None = Field(default=None, description="Inline base impact case. Give base or case.")
    samples: Count = Field(description="Random draws, >= 1 (per grid point when grid parameters exist). Required.")
    seed: Annotated[int, BeforeValidator(reject_bool), Field(ge=0)] = Field(description="Seed of the draws, an integer >= 0. Required.")
    models: list[Any] | None = Field(default=None, description="Model runs of every sample, as in a case file. Default: the base case's.")
    parameters: dict[Annotated[str, BeforeValidator(_key_path)], AnyDistribution] = Field(
        default_factory=dict, description="Case key path → distribution, applied in order. Default {} (repeats of the base case)."
    )
    outputs: OutputSettings = Field(default_factory=OutputSettings, description="Stored history lengths. Default 200 / 200.")

    @model_validator(mode="after")
    def _one_base(self) -> "SweepFile":
        if (self.base is None) == (self.case is None):
            given = "both" if self.base is not None else "neither"
            raise problems_error([Problem(("base",), f"give exactly one of base (a case file) or case (an inline case); got {given}")])
        return self


_SWEEP_ADAPTER: TypeAdapter[SweepFile] = TypeAdapter(SweepFile)


@dataclass(frozen=True)
class Sample:
    """Sample ``index``: its parameter values, what the file stores for them, and what its case substitutes into the
    base case (the values, then its noise seed: ``measurement.seed``, :func:`noise_seed`, unless the values set it)."""

    index: int
    values: dict[str, Any]
    stored: dict[str, float | int]
    substitutions: dict[str, Any]


@dataclass(frozen=True, eq=False)
class Sweep:
    """A validated sweep: the file, its resolved base case and where relative paths resolve."""

    source: str
    spec: SweepFile
    base_case: ImpactCase
    base_dir: Path

    @functools.cached_property
    def resolved_base(self) -> dict[str, Any]:
        """The resolved base case (models replaced, estimators dropped) as plain data, dumped once: read only."""
        return self.base_case.model_dump(mode="json")

    @property
    def base_data(self) -> dict[str, Any]:
        """A copy of :attr:`resolved_base`, the caller's to change."""
        return copy.deepcopy(self.resolved_base)

    @property
    def grid(self) -> dict[str, Grid]:
        return {path: d for path, d in self.spec.parameters.items() if isinstance(d, Grid)}

    @property
    def grid_shape(self) -> tuple[int, ...]:
        return tuple(len(d.values) for d in self.grid.values())

    @property
    def size(self) -> int:
        """Number of samples ``N = samples · n_grid``."""
        return self.spec.samples * math.prod(self.grid_shape)

    def with_samples(self, samples: int) -> "Sweep":
        """The same sweep with another number of draws (the first ones stay identical)."""
        return dataclasses.replace(self, spec=self.spec.model_copy(update={"samples": samples}))

    def resolved_data(self) -> dict[str, Any]:
        """The sweep file with every default filled in."""
        return self.spec.model_dump(mode="json", exclude_none=True)

    def resolved_yaml(self) -> str:
        return yaml.safe_dump(self.resolved_data(), sort_keys=False, default_flow_style=None, allow_unicode=True, width=100)

    @property
    def spec_hash(self) -> str:
        """SHA-256 of what fixes each sample: the resolved sweep without ``samples``, with the resolved base case.

        Where the base case came from (file name or inline) does not enter; its content does.
        """
        sweep = {k: v for k, v in self.resolved_data().items() if k not in ("samples", "base", "case")}
        text = json.dumps({"sweep": sweep, "base_case": self.resolved_base}, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def sample(self, index: int) -> Sample:
        """Sample ``index`` by the sampling rule (module docstring)."""
        if not 0 <= index < self.size:
            raise IndexError(f"sample index {index} outside 0…{self.size - 1}")
        n_grid = math.prod(self.grid_shape)
        draw, grid_point = divmod(index, n_grid)
        point = dict(zip(self.grid, np.unravel_index(grid_point, self.grid_shape))) if self.grid else {}
        rng = np.random.default_rng([self.spec.seed, draw])
        values: dict[str, Any] = {}
        stored: dict[str, float | int] = {}
        for path, distribution in self.spec.parameters.items():
            values[path], stored[path] = distribution.point(int(point[path])) if isinstance(distribution, Grid) else distribution.draw(rng)
        substitutions = dict(values)
        measured = values["measurement"] if "measurement" in values else self.resolved_base.get("measurement")
        if isinstance(measured, Mapping) and not self._sets_measurement_seed(values):
            substitutions["measurement.seed"] = noise_seed(self.spec.seed, index)
        return Sample(index, values, stored, substitutions)

    def sample_case(self, sample: Sample) -> ImpactCase:
        """A sample's case by substitution into the validated base case (:func:`femref.sweep.derive.derive_case`);
        raises :class:`CaseError` naming the sample and the key path."""
        return derive_case(self.base_case, self.resolved_base, sample.substitutions, self.base_dir, f"{self.source} sample {sample.index}")

    def sample_data(self, sample: Sample) -> dict[str, Any]:
        """A sample's whole case as data (what a case file of the sample holds); raises :class:`CaseError` for a key
        path that does not lead anywhere in this sample."""
        try:
            return substituted_data(self.resolved_base, sample.substitutions)
        except SubstitutionError as error:
            raise CaseError(Problem(("parameters", error.path), f"{error} in this sample"), f"{self.source} sample {sample.index}") from None

    @staticmethod
    def _sets_measurement_seed(values: Mapping[str, Any]) -> bool:
        whole = values.get("measurement")
        return "measurement.seed" in values or (isinstance(whole, Mapping) and "seed" in whole)


def noise_seed(seed: int, index: int) -> int:
    """The measurement noise seed of sample ``index``: ``SeedSequence([seed, index])``'s first word."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate the sweep file at ``path``, its base case and its key paths. Raises :class:`CaseError`."""
    path = Path(path)
    return parse_sweep(read_yaml_file(path, "sweep"), source=str(path), base_dir=path.parent)


def parse_sweep(data: Any, *, source: str = "<sweep>", base_dir: Path | None = None) -> Sweep:
    """Validate parsed sweep YAML. ``base_dir`` is where ``base`` (and an inline case's files) resolve."""
    base_dir = Path(base_dir) if base_dir is not None else Path.cwd()
    if not isinstance(data, Mapping):
        raise CaseError(Problem((), "a sweep file must be a mapping of keys (base, samples, seed, parameters, ...)", data), source)
    try:
        spec = _SWEEP_ADAPTER.validate_python(data)
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None
    base_data, case_dir = _base_data(spec, source, base_dir)
    if spec.models is not None:
        base_data["models"] = spec.models
    base_data["estimators"] = []
    try:
        base_case = parse_case(base_data, source=source, base_dir=case_dir)
    except CaseError as error:  # only the sweep's own overrides can fail here: the base case is valid
        raise CaseError([p.under(() if p.path[:1] == ("models",) else ("case",)) for p in error.problems], source) from None
    reserved = [Problem(("models",), f"run name {name!r} is a group of the sweep file; rename the run", name) for name in base_case.run_fidelities() if name in RESERVED_GROUPS]
    if reserved:
        raise CaseError(reserved, source)
    sweep = Sweep(source=source, spec=spec, base_case=base_case, base_dir=case_dir)
    problems = _key_path_problems(sweep)
    if problems:
        raise CaseError(problems, source)
    return sweep


def _base_data(spec: SweepFile, source: str, base_dir: Path) -> tuple[dict[str, Any], Path]:
    """The base case as resolved data (every default filled in) and its directory; it must be an impact case."""
    if spec.base is not None:
        path = base_dir / spec.base
        if not path.is_file():
            raise CaseError(Problem(("base",), f"base case file not found: {path}", spec.base), source)
        case = load_case(path)  # its own errors name its own file
        case_dir = path.resolve().parent  # absolute: workers may run elsewhere
    else:
        case_dir = base_dir.resolve()
        if spec.case.get("kind") != "impact":
            rule = "a sweep's base case must be kind: impact (sweeps feed the coupler-force networks)"
            raise CaseError(Problem(("case", "kind"), rule, spec.case.get("kind")), source)
        try:
            case = parse_case(spec.case, source=source, base_dir=case_dir)
        except CaseError as error:
            raise CaseError([p.under(("case",)) for p in error.problems], source) from None
    if case.kind != "impact":
        rule = f"a sweep's base case must be kind: impact (sweeps feed the coupler-force networks); {spec.base} is kind: {case.kind}"
        raise CaseError(Problem(("base",), rule), source)
    return case.model_dump(mode="json"), case_dir


def _key_path_problems(sweep: Sweep) -> list[Problem]:
    """Each parameter's key path against the base case and the earlier parameters' possible values."""
    base = sweep.resolved_base
    problems = []
    earlier: list[tuple[tuple[str, ...], Distribution]] = []
    for path, distribution in sweep.spec.parameters.items():
        parts = key_parts(path)
        fixed = FIXED_KEYS.get(parts[0], FIXED_PATHS.get(path))
        if fixed is not None:
            problems.append(Problem(("parameters", path), f"cannot be swept: {fixed}"))
        else:
            rule = _unreachable(base, parts, earlier) or _unknown_last_key(sweep, parts, distribution)
            if rule is not None:
                problems.append(Problem(("parameters", path), rule))
        earlier.append((parts, distribution))
    return problems


def _unknown_last_key(sweep: Sweep, parts: tuple[str, ...], distribution: Distribution) -> str | None:
    """The case schema's rule when the last part is a key the base case lacks and the schema does not know.

    A new key is fine where the case takes names (a new sensor); a misspelt setting would
    fail every sample, so it is refused here, with the schema's own did-you-mean.
    """
    data = sweep.base_data
    try:
        parent = parent_of(data, parts)
    except PathError:
        return None  # reachable through an earlier choice only: judged per sample
    if not isinstance(parent, Mapping) or parts[-1] in parent:
        return None
    parent[parts[-1]] = distribution.example()
    try:
        parse_case(data, source=sweep.source, base_dir=sweep.base_dir)
    except CaseError as error:
        for problem in error.problems:
            if tuple(str(p) for p in problem.path) == parts and problem.rule.startswith("unknown"):
                return f"the case has no such key: {problem.rule}"
    return None


def _unreachable(base: Any, parts: tuple[str, ...], earlier: list[tuple[tuple[str, ...], Distribution]]) -> str | None:
    """None when ``parts`` can be set in the base case or in a value an earlier choice/grid puts above it."""
    try:
        parent_of(base, parts)
        return None
    except PathError as error:
        rule = f"every part of a key path but the last must exist in the base case: {error}"
    for prefix, distribution in reversed(earlier):
        values = distribution.values if isinstance(distribution, (Choice, Grid)) else []
        if len(prefix) < len(parts) and parts[: len(prefix)] == prefix:
            for value in values:
                try:
                    parent_of(value, parts[len(prefix) :])
                    return None
                except PathError:
                    continue
    return rule
