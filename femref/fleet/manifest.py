"""The fleet manifest: cars, draft gears and recordings, each recording expanded into a measured case.

A recording's case is ``defaults`` (every measured-case key but ``kind``, ``cars``, ``couplers`` and ``records``)
plus the entries of its cars (``cars.<name>``, in line order), its couplers (coupler ``k`` joins cars ``k`` and
``k + 1``) and its records; a gear's ``rated_closure_force`` replaces ``checks.rated_closure_force``. That case is
validated by :class:`femref.case.measured.MeasuredCase`, record files included, with paths relative to the
manifest's folder; each of its problems is named by the manifest key path it comes from
(``recordings[3].records[0].file``, ``cars.C0001.sensors.front``, ``defaults.events.trigger`` with the recording
it was found in). Every problem of every recording is found before any work: :func:`load_manifest` raises one
:class:`~femref.case.CaseError` holding them all.

Each :class:`Recording` keeps its expanded case (a plain dict, sent to a Dask worker) and its stamp: the hash of
the resolved case and the size and modification time of every file it reads (:func:`recording_stamp`), so a
rerun knows what changed.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, Field, ValidationError, model_validator

from femref.case import CaseError, Problem, parse_case, resolved_yaml
from femref.case.cars import CarName
from femref.case.couplers import AnyCouplerLaw, CouplerName
from femref.case.errors import did_you_mean, problems_error, problems_from
from femref.case.fields import CaseModel, PositiveReal, name_rule
from femref.case.inputs import case_inputs
from femref.case.loader import read_yaml_file

__all__ = ["Fleet", "FleetManifest", "GearSpec", "Recording", "RecordingCouplerSpec", "RecordingSpec", "load_manifest", "parse_manifest",
           "recording_stamp"]

#: Keys a recording brings itself: ``defaults`` may not hold them.
OWN_KEYS = ("kind", "cars", "couplers", "records")


def _recording_name(name: str) -> str:
    name_rule("recording")(name)
    if not name[0].isalnum():
        raise problems_error([Problem((), "recording names start with a letter or digit (the name is its event file's)", name)])
    return name


def _aware(moment: datetime) -> datetime:
    if moment.tzinfo is None or moment.utcoffset() is None:
        raise problems_error([Problem((), "give the time's zone, e.g. 2026-11-01T06:12:00Z or 2026-11-01T07:12:00+01:00", moment.isoformat())])
    return moment


RecordingName = Annotated[str, AfterValidator(_recording_name)]
#: A date and time with its zone.
ZonedTime = Annotated[datetime, AfterValidator(_aware)]
GearName = Annotated[str, AfterValidator(name_rule("gear"))]


class GearSpec(CaseModel):
    """A draft gear: its force law (as an impact case's coupler takes it: validated, it says what the gear is; the run
    does not use it, the estimators read the force from the accelerations) and its rated closure force, which replaces
    ``checks.rated_closure_force``."""

    law: AnyCouplerLaw | None = Field(default=None, description="The gear's coupler law, as in impact cases (friction_gear, draft_gear, ...). Default none.")
    rated_closure_force: PositiveReal | None = Field(
        default=None, description="The gear's rated closure force (N): the wear check of its couplers. Default: defaults.checks.rated_closure_force.")


class RecordingCouplerSpec(CaseModel):
    """Coupler ``k`` of a recording: it joins the recording's cars ``k`` and ``k + 1`` through ``gear``."""

    name: CouplerName | None = Field(default=None, description="Coupler name, unique in the recording. Default c<k> (1-based).")
    gear: GearName = Field(description="The draft gear it carries: a key of gears. Required.")


class RecordingSpec(CaseModel):
    """One measured run: when and where it was recorded, the cars in line, their couplers and the recorders' files."""

    name: RecordingName = Field(description="Unique; the store's key and its event file's name. Letters, digits, '_', '-', '.'. Required.")
    start: ZonedTime = Field(description="Wall-clock time of t = 0 of the records, with its zone (2026-11-01T06:12:00Z). Required.")
    track: str = Field(default="", description="Where it was recorded. Default empty.")
    cars: tuple[CarName, ...] = Field(min_length=2, description="Keys of cars, in line (front to rear as the records' +x); two or more. Required.")
    couplers: tuple[RecordingCouplerSpec, ...] = Field(min_length=1, description="Coupler k joins cars k and k + 1; one or more. Required.")
    records: tuple[dict[str, Any], ...] = Field(
        min_length=1, description="The recorders' record files, as a measured case's records; paths relative to the manifest. Required.")

    @model_validator(mode="after")
    def _couplers_fit_the_line(self) -> "RecordingSpec":
        if len(self.couplers) > len(self.cars) - 1:
            rule = f"{len(self.cars)} cars have {len(self.cars) - 1} coupler(s) between them; coupler k joins cars k and k + 1"
            raise problems_error([Problem(("couplers",), rule, len(self.couplers))])
        return self


class FleetManifest(CaseModel):
    """A fleet: its name, what every recording shares, its cars and gears, and its recordings."""

    fleet: str = Field(min_length=1, description="The fleet's name. Required.")
    defaults: dict[str, Any] = Field(default_factory=dict, description="Measured-case keys every recording shares (events, estimators, "
                                                                       "checks, kalman, calibration, ...). Default none.")
    cars: dict[CarName, dict[str, Any]] = Field(description="Car name → its measured-case entry without name (body, or mass and length; sensors). Required.")
    gears: dict[GearName, GearSpec] = Field(default_factory=dict, description="Gear name → {law, rated_closure_force}. Default none.")
    recordings: tuple[RecordingSpec, ...] = Field(min_length=1, description="The recordings; one or more. Required.")

    @model_validator(mode="after")
    def _references(self) -> "FleetManifest":
        problems = [Problem(("defaults", key), f"a recording gives its own {key}; defaults hold the other measured-case keys") for key in self.defaults
                    if key in OWN_KEYS]
        problems += [Problem(("cars", name, "name"), "the car's name is its key in cars") for name, entry in self.cars.items() if "name" in entry]
        seen: dict[str, int] = {}
        for i, recording in enumerate(self.recordings):
            if recording.name in seen:
                problems.append(Problem(("recordings", i, "name"), f"also the name of recordings[{seen[recording.name]}]; names are unique", recording.name))
            seen.setdefault(recording.name, i)
            problems += [Problem(("recordings", i, "cars", k), f"unknown car{did_you_mean(car, list(self.cars))}; cars: {_listing(self.cars)}", car)
                         for k, car in enumerate(recording.cars) if car not in self.cars]
            problems += [Problem(("recordings", i, "couplers", k, "gear"), f"unknown gear{did_you_mean(c.gear, list(self.gears))}; "
                                 f"gears: {_listing(self.gears)}", c.gear) for k, c in enumerate(recording.couplers) if c.gear not in self.gears]
            ratings = {self.gears[c.gear].rated_closure_force for c in recording.couplers if c.gear in self.gears} - {None}
            if len(ratings) > 1:
                rule = f"the gears of one recording share their rated_closure_force (a measured case checks one); found {sorted(ratings)} N"
                problems.append(Problem(("recordings", i, "couplers"), rule))
        if problems:
            raise problems_error(problems)
        return self


def _listing(names: Mapping[str, Any], shown: int = 10) -> str:
    """The first ``shown`` of ``names``, comma-separated (a fleet may have thousands of cars)."""
    listed = list(names)
    return (", ".join(listed[:shown]) + (f", … ({len(listed)} in all)" if len(listed) > shown else "")) or "none"


@dataclass(frozen=True)
class Recording:
    """One recording of a fleet, expanded: its measured ``case`` (plain data, paths relative to the manifest's folder),
    its resolved case and the files it reads (what :func:`recording_stamp` stamps), and what the store records of it."""

    index: int
    name: str
    start: datetime
    track: str
    cars: tuple[str, ...]
    couplers: tuple[str, ...]
    gears: tuple[str, ...]
    case: dict[str, Any]
    resolved: str
    files: tuple[Path, ...]
    record_files: tuple[Path, ...]
    calibration: Path | None
    networks: tuple[Path, ...]
    alarm_limit: float | None
    rated_closure_force: float | None
    wear_tolerance: float

    @property
    def wear_limit(self) -> float | None:
        """The closure force (N) below which the gear is worn: rated × (1 − wear tolerance); None without a rating."""
        return None if self.rated_closure_force is None else self.rated_closure_force * (1.0 - self.wear_tolerance)


@dataclass(frozen=True)
class Fleet:
    """A validated manifest: its name, file, folder and every recording expanded."""

    name: str
    path: Path
    base_dir: Path
    recordings: tuple[Recording, ...]


def load_manifest(path: str | Path, progress: Callable[[int, int], None] | None = None) -> Fleet:
    """Read, validate and expand the manifest at ``path`` (module docstring); CaseError naming every problem.
    ``progress(done, total)`` after each recording validated (its record files are read)."""
    path = Path(path)
    return parse_manifest(read_yaml_file(path, "manifest"), source=str(path), base_dir=path.resolve().parent, progress=progress)


def parse_manifest(data: Any, *, source: str = "<manifest>", base_dir: Path | None = None, progress: Callable[[int, int], None] | None = None) -> Fleet:
    """Validate parsed YAML into a :class:`Fleet`; ``source`` names it in errors, ``base_dir`` resolves relative paths
    (default: the working folder), ``progress`` as :func:`load_manifest`'s."""
    base_dir = Path.cwd() if base_dir is None else Path(base_dir)
    if not isinstance(data, Mapping):
        raise CaseError(Problem((), "a manifest is a mapping of keys (fleet, defaults, cars, gears, recordings)", data), source)
    try:
        manifest = FleetManifest.model_validate(data)
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None
    problems: dict[tuple[Any, str], Problem] = {}
    recordings = []
    for i, spec in enumerate(manifest.recordings):
        data_i = expanded_case(manifest, spec)
        try:
            case = parse_case(data_i, source=source, base_dir=base_dir)
        except CaseError as error:
            for problem in error.problems:
                found = _manifest_problem(problem, i, spec, manifest)
                problems.setdefault((found.path, problem.rule), found)
        else:
            recordings.append(_recording(i, spec, data_i, case, base_dir))
        if progress is not None:
            progress(i + 1, len(manifest.recordings))
    if problems:
        raise CaseError(list(problems.values()), source)
    return Fleet(manifest.fleet, Path(source), base_dir, tuple(recordings))


def expanded_case(manifest: FleetManifest, spec: RecordingSpec) -> dict[str, Any]:
    """The measured case of recording ``spec`` (module docstring), as plain data."""
    case: dict[str, Any] = {"kind": "measured", **manifest.defaults}
    case["cars"] = [{"name": name, **manifest.cars[name]} for name in spec.cars]
    case["couplers"] = [{**({"name": c.name} if c.name is not None else {}), "between": [spec.cars[k], spec.cars[k + 1]]}
                        for k, c in enumerate(spec.couplers)]
    case["records"] = [dict(record) for record in spec.records]
    rating = _rating(manifest, spec)
    if rating is not None:
        checks = manifest.defaults.get("checks")
        case["checks"] = {**(checks if isinstance(checks, Mapping) else {}), "rated_closure_force": rating}
    return case


def _rating(manifest: FleetManifest, spec: RecordingSpec) -> float | None:
    """The rated closure force the recording's gears give (validation made them agree); None: none gives one."""
    return next((manifest.gears[c.gear].rated_closure_force for c in spec.couplers if manifest.gears[c.gear].rated_closure_force is not None), None)


def _manifest_problem(problem: Problem, i: int, spec: RecordingSpec, manifest: FleetManifest) -> Problem:
    """``problem`` of recording ``i``'s expanded case, at the manifest key path it comes from; a problem outside the
    recording's own keys says in which recording it was found."""
    path = problem.path
    head, rest = (path[0], path[1:]) if path else (None, ())
    own = ("recordings", i)
    if head == "records":
        return Problem((*own, "records", *rest), problem.rule, problem.value)
    if head == "couplers":
        rest = rest[:1] if rest[1:2] == ("between",) else rest
        return Problem((*own, "couplers", *rest), problem.rule, problem.value)
    if head == "cars" and rest and isinstance(rest[0], int) and rest[0] < len(spec.cars):
        if rest[1:2] in ((), ("name",)):
            return Problem((*own, "cars", rest[0]), problem.rule, problem.value)
        return _found_in(Problem(("cars", spec.cars[rest[0]], *rest[1:]), problem.rule, problem.value), spec)
    if head == "cars":
        return Problem((*own, "cars"), problem.rule, problem.value)
    if path[:2] == ("checks", "rated_closure_force") and _rating(manifest, spec) is not None:
        gear = next(c.gear for c in spec.couplers if manifest.gears[c.gear].rated_closure_force is not None)
        return _found_in(Problem(("gears", gear, "rated_closure_force"), problem.rule, problem.value), spec)
    if head is None:
        return Problem(own, problem.rule, problem.value)
    return _found_in(Problem(("defaults", *path), problem.rule, problem.value), spec)


def _found_in(problem: Problem, spec: RecordingSpec) -> Problem:
    return Problem(problem.path, f"{problem.rule} (in recording {spec.name})", problem.value)


def _recording(index: int, spec: RecordingSpec, case_data: dict[str, Any], case: Any, base_dir: Path) -> Recording:
    """The :class:`Recording` of a validated case (the case itself is not kept: it may hold what validation read)."""
    inputs = case_inputs(case, base_dir)
    records = tuple(path for key, path in inputs.items() if key.startswith("records"))
    networks = tuple(path for key, path in inputs.items() if key.startswith("estimators"))
    return Recording(
        index=index, name=spec.name, start=spec.start.astimezone(timezone.utc), track=spec.track, cars=spec.cars,
        couplers=tuple(str(c.name) for c in case.couplers), gears=tuple(c.gear for c in spec.couplers), case=case_data,
        resolved=resolved_yaml(case), files=tuple(inputs.values()), record_files=records, calibration=case.calibration, networks=networks,
        alarm_limit=case.checks.alarm, rated_closure_force=case.checks.rated_closure_force, wear_tolerance=case.checks.wear_tolerance,
    )


def recording_stamp(recording: Recording) -> str:
    """What a rerun compares: the SHA-256 of the resolved case and each file's path, size (bytes) and modification time
    (ns), as JSON text. A file gone gives size and time -1 (the run then fails, naming it)."""
    files = []
    for path in recording.files:
        try:
            status = os.stat(path)
            files.append([str(path), status.st_size, status.st_mtime_ns])
        except OSError:
            files.append([str(path), -1, -1])
    return json.dumps({"case": hashlib.sha256(recording.resolved.encode()).hexdigest(), "files": files}, separators=(",", ":"))
