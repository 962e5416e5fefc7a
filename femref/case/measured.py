"""The ``kind: measured`` case: coupler forces, impact type, gear closure, wear and alarm from recorded accelerations.

Every record file is checked when the case is loaded as far as its start tells (:func:`femref.sensing.recordings.probe_recorder`:
it opens, its columns and units resolve, its first chunk's times increase at a rate within the limit, the recorders'
spans overlap); the run streams the files and meets what lies further in (docs/design.md §3.7). A bad file, channel,
unit or time column, or a file beyond the limits of :mod:`femref.sensing.record_files`, is a case error naming the file,
channel and rule; so is an event grid beyond :data:`~femref.sensing.recordings.MAX_EVENT_VALUES`. The relations between keys are checked once
the keys are valid. :func:`femref.scene.build.scene_from_case` turns the case into a
:class:`femref.scene.measured.MeasuredScene`.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

from pydantic import AfterValidator, Field, ValidationInfo, field_validator, model_validator

from femref.case.base import SceneCase
from femref.case.bodies import RodBody
from femref.case.cars import CarName, cars_rule
from femref.case.couplers import Between, CouplerName, named_couplers
from femref.case.coupler_observability import unobservable_couplers
from femref.case.errors import Problem, did_you_mean, problems_error
from femref.case.estimators import ANY_IMPACT, AnnEstimatorSpec, contract_scene_problems, estimator_entry
from femref.case.fields import CaseModel, NonNegativeReal, PositiveReal, ProbeName, Real, duplicates, entry_name, resolve_case_path
from femref.case.records import RecordFileSpec
from femref.core.catalog import MEASURED_ESTIMATORS
from femref.sensing import recordings
from femref.sensing.measurement import FILTER_ORDER
from femref.sensing.network import NetworkContract
from femref.sensing.calibration import CalibrationFileError, read_calibration
from femref.sensing.findings import StatedSpeed
from femref.sensing.trigger import MAX_WINDOW, QUIET, REARM_FRACTION

__all__ = ["KalmanSettings", "MeasuredCarSpec", "MeasuredCase", "MeasuredCouplerSpec"]


class MeasuredCarSpec(CaseModel):
    """A recorded car: a rod body (any profiles), or only its ``mass`` and ``length`` when only rigid
    estimates are wanted, and its accelerometers' positions."""

    name: CarName = Field(description="Car name, unique; channels are named <car>/<sensor>. Required.")
    body: RodBody | None = Field(default=None, description="The car body as a rod (as in impact cases). Give a body, or mass and length.")
    mass: PositiveReal | None = Field(default=None, description="Total mass (kg) of a car without a body.")
    length: PositiveReal | None = Field(default=None, description="Length over the ends (m) of a car without a body.")
    sensors: dict[ProbeName, Real] = Field(
        description="Accelerometers: name → position x (m) within [−l, l]; {} for a car without (only kalman estimates through it). Required.")
    mass_tolerance: Annotated[float, Field(ge=0.0, lt=0.5)] | None = Field(
        default=None,
        description="Relative uncertainty of this car's mass as measured (a weigh-in-motion reading, a waybill's stated tolerance), "
                    "in [0, 0.5); the body's or mass's value is the measured mass. Default null: declared, kalman.mass_tolerance applies.")

    @model_validator(mode="after")
    def _body_or_mass(self) -> "MeasuredCarSpec":
        if self.body is not None and (self.mass is not None or self.length is not None):
            raise problems_error([Problem(("mass",), "give a body or mass and length, not both (the body has its own)")])
        if self.body is None and (self.mass is None or self.length is None):
            missing = [key for key in ("mass", "length") if getattr(self, key) is None]
            raise problems_error([Problem((key,), "required key is missing (a car without a body needs mass and length)") for key in missing])
        l = self.half_length  # noqa: E741
        problems = [Problem(("sensors", name), f"must lie on the car, |x| <= l = {l} m", x) for name, x in self.sensors.items() if abs(x) > l]
        if problems:
            raise problems_error(problems)
        return self

    @property
    def half_length(self) -> float:
        """``l`` (m)."""
        return self.body.half_length if self.body is not None else 0.5 * float(self.length)  # type: ignore[arg-type]


class MeasuredCouplerSpec(CaseModel):
    """A coupler between neighbouring recorded cars (its force is what the estimators find)."""

    name: CouplerName | None = Field(default=None, description="Coupler name, unique. Default c<k> for the k-th coupler (1-based).")
    between: Between = Field(description="The two cars it joins, neighbours in line order: [cars[i].name, cars[i+1].name]. Required.")


class ClosingSpeedSpec(CaseModel):
    """A closing speed the user has (radar, a wayside detector), which replaces the estimate from the records."""

    value: PositiveReal = Field(description="The coupler's cars' closing speed at contact (m/s), > 0. Required.")
    uncertainty: NonNegativeReal = Field(description="Its uncertainty (m/s, ± about value), >= 0. Required.")
    time: Real | None = Field(
        default=None, description="Time (s, on the records' clock) inside the window of the event it belongs to. Default null: every event; required with more than one speed."
    )

    def stated(self) -> StatedSpeed:
        return StatedSpeed(self.value, self.uncertainty, self.time)


class EventSettings(CaseModel):
    """How events are cut from the records (:mod:`femref.sensing.trigger`): the trigger and re-arm levels, the
    quiet time before re-arming and the window around the impact."""

    trigger: PositiveReal = Field(description="An event starts where a channel's |a| first exceeds this (m/s²), > 0. Required.")
    pre: NonNegativeReal = Field(default=0.05, description="Window before the trigger (s). Default 0.05.")
    post: PositiveReal = Field(default=0.5, description="Window after the last sample above rearm, while the cars ring (s). Default 0.5.")
    rearm: PositiveReal | None = Field(
        default=None, description=f"Re-arm level (m/s²), in (0, trigger]: samples above it are the cars still ringing. Default {REARM_FRACTION:g} × trigger."
    )
    quiet: PositiveReal = Field(
        default=QUIET, description=f"Time every channel stays below rearm before the trigger re-arms (s); given, shorter than the records. Default {QUIET:g}."
    )
    max_window: PositiveReal = Field(
        default=MAX_WINDOW, description=f"Longest event window (s), >= pre + post; a window that reaches it is flagged capped. Default {MAX_WINDOW:g}."
    )
    closing_speed: ClosingSpeedSpec | tuple[ClosingSpeedSpec, ...] | None = Field(
        default=None,
        description="Closing speeds the user has {value, uncertainty, time} (m/s, m/s, s), one or a list (each with its time): "
                    "they replace the estimates from the records for their events. Default null: estimated.",
    )

    @field_validator("closing_speed", mode="after")
    @classmethod
    def _timed_speeds(cls, speeds: ClosingSpeedSpec | tuple[ClosingSpeedSpec, ...] | None) -> ClosingSpeedSpec | tuple[ClosingSpeedSpec, ...] | None:
        if isinstance(speeds, tuple) and len(speeds) > 1:
            untimed = [Problem((i, "time"), "required when more than one closing speed is given (it names the event)") for i, speed in enumerate(speeds) if speed.time is None]
            if untimed:
                raise problems_error(untimed)
        return speeds

    def stated_speeds(self) -> tuple[StatedSpeed, ...]:
        """The closing speeds the case gives, as :class:`femref.sensing.findings.StatedSpeed`."""
        speeds = self.closing_speed
        if speeds is None:
            return ()
        return tuple(speed.stated() for speed in (speeds if isinstance(speeds, tuple) else (speeds,)))

    @model_validator(mode="after")
    def _trigger_rules(self) -> "EventSettings":
        problems = []
        if self.rearm is not None and self.rearm > self.trigger:
            problems.append(Problem(("rearm",), f"must be <= events.trigger = {self.trigger:g} m/s² (the hysteresis lies below the trigger)", self.rearm))
        if self.max_window < self.pre + self.post:
            problems.append(Problem(("max_window",), f"must be >= events.pre + events.post = {self.pre + self.post:g} s", self.max_window))
        if problems:
            raise problems_error(problems)
        return self

    def span_problems(self, span: float) -> list[Problem]:
        """The settings against the records' common span (s): a window must fit in it, and so must a quiet time
        the case gives (the default may exceed a short record of one impact)."""
        problems = []
        if self.pre + self.post >= span:
            problems.append(Problem(("post",), f"pre + post = {self.pre + self.post:g} s must be shorter than the records' common span of {span:g} s", self.post))
        if "quiet" in self.model_fields_set and self.quiet >= span:
            problems.append(Problem(("quiet",), f"must be shorter than the records' common span of {span:g} s (the trigger could never re-arm)", self.quiet))
        return problems


class KalmanSettings(CaseModel):
    """The ``kalman`` estimator's model of each car — its rigid mode and ``modes`` elastic modes — and how far
    the declared cars may be from the real ones (the band covers every model within these tolerances)."""

    modes: Annotated[int, Field(ge=1, le=16)] = Field(default=4, description="Elastic modes per car, 1–16. Default 4.")
    mass_tolerance: Annotated[float, Field(ge=0.0, lt=0.5)] = Field(
        default=0.05, description="Relative uncertainty of the declared masses (waybill), in [0, 0.5); a car with its own "
                                  "cars[i].mass_tolerance (measured) takes that instead. Default 0.05."
    )
    frequency_tolerance: Annotated[float, Field(ge=0.0, lt=0.5)] = Field(
        default=0.15, description="Relative uncertainty of the cars' axial mode frequencies (drawing stiffness), in [0, 0.5). Default 0.15."
    )
    damping_factors: tuple[PositiveReal, PositiveReal] = Field(
        default=(0.6, 1.6), description="Lowest and highest factor on the declared viscosity, low <= 1 <= high. Default [0.6, 1.6]."
    )

    @field_validator("damping_factors", mode="after")
    @classmethod
    def _around_one(cls, factors: tuple[float, float]) -> tuple[float, float]:
        if not factors[0] <= 1.0 <= factors[1]:
            raise problems_error([Problem((), "must be [low, high] with low <= 1 <= high", list(factors))])
        return factors


class CheckSettings(CaseModel):
    """Limits an event is checked against; each optional."""

    alarm: PositiveReal | None = Field(default=None, description="Alarm limit of the coupler force (N). Default null: no alarm check.")
    rated_closure_force: PositiveReal | None = Field(default=None, description="The draft gear's rated closure force (N). Default null: no wear check.")
    wear_tolerance: Annotated[float, Field(gt=0.0, lt=1.0)] = Field(
        default=0.15, description="A gear that closes more than this fraction below its rated force is worn, in (0, 1). Default 0.15."
    )


#: One entry of a measured case's ``estimators``: an estimator's name or a saved network.
MeasuredEstimatorEntry = estimator_entry(MEASURED_ESTIMATORS)


def _estimators_rule(entries: tuple[str | AnnEstimatorSpec, ...]) -> tuple[str | AnnEstimatorSpec, ...]:
    names = [entry_name(entry) for entry in entries]
    problems = duplicates(names, "estimator", lambda i: (i,))
    if not entries:
        problems.append(Problem((), f"name at least one estimator: {', '.join(MEASURED_ESTIMATORS)}"))
    if problems:
        raise problems_error(problems)
    return entries


class MeasuredCase(SceneCase):
    """Recorded accelerations of cars in a line: coupler forces and checks per impact event."""

    #: A measured case runs estimators, not models.
    models: ClassVar[tuple[str, ...]] = ()

    kind: Literal["measured"] = Field(default="measured", description="measured. Required in the case file.")
    records: tuple[RecordFileSpec, ...] = Field(description="The record files, one per recorder; at least one. Required.")
    cars: Annotated[tuple[MeasuredCarSpec, ...], AfterValidator(cars_rule("a measured impact"))] = Field(
        description="Two or more cars in line order (rear to front). Required."
    )
    couplers: tuple[MeasuredCouplerSpec, ...] = Field(description="One or more couplers between neighbouring cars. Required.")
    events: EventSettings = Field(description="Event detection: {trigger, pre, post, rearm, quiet, max_window}. Required (trigger at least).")
    estimators: Annotated[tuple[MeasuredEstimatorEntry, ...], AfterValidator(_estimators_rule)] = Field(
        default=("inverse_rigid",),
        description=f"Estimators run on every event: {', '.join(MEASURED_ESTIMATORS)} or a network {{name: ann_<name>, network: file.npz}}; unique. Default [inverse_rigid].",
    )
    kalman: KalmanSettings = Field(default_factory=KalmanSettings, description="The kalman estimator's car model. Default 4 modes.")
    checks: CheckSettings = Field(default_factory=CheckSettings, description="Alarm and wear limits. Default: none checked.")
    calibration: Path | None = Field(
        default=None,
        description="Calibration file of the inverse estimators' error bands (femref calibrate), relative to the case file. Default null: no band.",
    )

    @field_validator("calibration", mode="after")
    @classmethod
    def _calibration_readable(cls, path: Path | None, info: ValidationInfo) -> Path | None:
        if path is None:
            return None
        path = resolve_case_path(path, info)
        try:
            calibration = read_calibration(path)
        except CalibrationFileError as error:
            raise problems_error([Problem((), str(error))]) from None
        cars = info.data.get("cars")
        if cars is not None and set(calibration.masses) != {car.name for car in cars}:
            rule = f"{path}: attribute masses calibrates cars {', '.join(calibration.masses)}, not this case's {', '.join(car.name for car in cars)}"
            raise problems_error([Problem((), rule)])
        couplers = info.data.get("couplers")  # None: invalid themselves, their own problem is reported
        names = [str(spec.name) for spec in couplers or ()]
        if couplers is not None and calibration.coupler not in names:  # a calibration that would never give a band
            rule = (f"{path}: attribute coupler: the calibration is of coupler {calibration.coupler!r}, which this case does not have; "
                    f"couplers: {', '.join(names)}")
            raise problems_error([Problem((), rule)])
        return path

    @field_validator("records", mode="after")
    @classmethod
    def _some_records(cls, records: tuple[RecordFileSpec, ...]) -> tuple[RecordFileSpec, ...]:
        if not records:
            raise problems_error([Problem((), "name at least one record file")])
        seen: dict[str, int] = {}
        problems = []
        for i, record in enumerate(records):
            for probe in record.channels:
                if probe in seen:
                    problems.append(Problem((i, "channels", probe), f"recorded twice (also in records[{seen[probe]}]); one channel per probe", probe))
                seen.setdefault(probe, i)
        if problems:
            raise problems_error(problems)
        return records

    @field_validator("couplers", mode="after")
    @classmethod
    def _couplers_join_neighbours(cls, couplers: tuple[MeasuredCouplerSpec, ...], info: ValidationInfo) -> tuple[MeasuredCouplerSpec, ...]:
        if not couplers:
            raise problems_error([Problem((), "name at least one coupler between neighbouring cars")])
        return named_couplers(couplers, info.data.get("cars"))

    @model_validator(mode="after")
    def _relations(self) -> "MeasuredCase":
        problems = self._channel_problems() + self._estimator_problems()
        if problems:
            raise problems_error(problems)
        problems = self._record_problems()
        if problems:
            raise problems_error(problems)
        return self

    def _channel_problems(self) -> list[Problem]:
        """Every channel names a declared car and sensor; every car has at least one recorded sensor."""
        sensors = {car.name: car.sensors for car in self.cars}
        problems = []
        recorded: set[str] = set()
        for i, record in enumerate(self.records):
            for probe in record.channels:
                car, sensor = probe.split("/")
                if car not in sensors:
                    problems.append(Problem(("records", i, "channels", probe), f"unknown car {car!r}{did_you_mean(car, list(sensors))}; cars: {', '.join(sensors)}", probe))
                elif sensor not in sensors[car]:
                    known = list(sensors[car])
                    problems.append(Problem(("records", i, "channels", probe), f"car {car} has no sensor {sensor!r}{did_you_mean(sensor, known)}; its sensors: {', '.join(known)}", probe))
                else:
                    recorded.add(car)
        others = [entry for entry in self.estimators if not isinstance(entry, AnnEstimatorSpec) and entry != "kalman"]
        for k, car in enumerate(self.cars):
            if car.name not in recorded and others and not problems:
                rule = (f"no channel of car {car.name} is recorded; map at least one of its sensors in records "
                        f"(only kalman estimates through an uninstrumented car; {', '.join(others)} need every car recorded)")
                problems.append(Problem(("cars", k, "sensors"), rule))
        return problems

    def instrumented(self) -> list[bool]:
        """Per car, whether at least one of its sensors is recorded."""
        recorded = {probe.split("/")[0] for record in self.records for probe in record.channels}
        return [car.name in recorded for car in self.cars]

    def _estimator_problems(self) -> list[Problem]:
        """What each estimator needs of the cars (a rod body; two recorded sensors on a coupler's front car;
        a network's contract against the records)."""
        problems = []
        for i, name in enumerate(self.estimators):
            if isinstance(name, AnnEstimatorSpec):
                for kind, contract in name.contracts.items():
                    where = ("estimators", i) if kind == ANY_IMPACT else ("estimators", i, *name.where(kind))
                    problems += [problem.under(where) for problem in self._network_problems(contract)]
                if "kalman" not in self.estimators:
                    problems.append(Problem(("estimators", i), "a network's records start at contact, read from the kalman force: list kalman among the estimators"))
                continue
            if name in ("kalman", "inverse_quasi_rigid"):
                bodiless = [car.name for car in self.cars if car.body is None]
                if bodiless:
                    problems.append(Problem(("estimators", i), f"{name} needs every car's body (profiles); cars {', '.join(bodiless)} give only mass and length", name))
            if name == "kalman" and not problems:
                index = {car.name: k for k, car in enumerate(self.cars)}
                refused = unobservable_couplers([car.name for car in self.cars], self.instrumented(),
                                                [index[c.between[0]] for c in self.couplers], [str(c.name) for c in self.couplers])
                problems += [Problem(("couplers", coupler), f"kalman cannot observe its force: {why}") for coupler, why in refused.items()]
            if name == "inverse_quasi_rigid":
                by_name = {car.name: car for car in self.cars}
                for coupler in self.couplers:
                    car = by_name[coupler.between[1]]
                    if len(car.sensors) < 2:
                        problems.append(Problem(("estimators", i), f"{name} needs two sensors on car {car.name} (the front car of coupler {coupler.name})", name))
        return problems

    def _network_problems(self, contract: NetworkContract) -> list[Problem]:
        """A network's contract against this case: its coupler, probes recorded, mass inputs declared cars, records
        within the event window after contact, filtered as its training records were."""
        files = {probe: record for record in self.records for probe in record.channels}
        problems = contract_scene_problems(contract, [str(c.name) for c in self.couplers], list(files), "are not recorded; channels",
                                           [car.name for car in self.cars])
        if contract.record_end > self.events.post:
            problems.append(Problem((), f"the network reads {contract.record_end:g} s after contact, beyond events.post = {self.events.post:g} s"))
        trained = contract.measurement
        for probe in (p for p in contract.probes if p in files):
            declared = files[probe].anti_alias
            if trained is not None and trained.lowpass is not None:
                if declared is None:
                    problems.append(Problem((), f"the network was trained on records low-passed at {trained.lowpass:g} Hz (order {FILTER_ORDER}); "
                                                f"declare the anti_alias of the file recording {probe}"))
                elif not (math.isclose(declared.corner, trained.lowpass, rel_tol=1e-6) and declared.order == FILTER_ORDER):
                    problems.append(Problem((), f"the network was trained on records low-passed at {trained.lowpass:g} Hz (order {FILTER_ORDER}); "
                                                f"{probe} is recorded through {declared.corner:g} Hz (order {declared.order})"))
            elif declared is not None:
                problems.append(Problem((), f"the network was trained on unfiltered records; {probe} is recorded through a {declared.corner:g} Hz low-pass"))
        return problems

    def _record_problems(self) -> list[Problem]:
        """Each recorder probed (:func:`~femref.sensing.recordings.probe_recorder`: its files open, their columns and
        units, their first chunk's times and rate); the recorders' names and clocks; the event settings against the span
        they share."""
        problems = []
        spans = []
        rates = []
        names: dict[str, int] = {}
        for i, record in enumerate(self.records):
            source = record.source()
            if record.recorder is not None and record.recorder in names:
                problems.append(Problem(("records", i, "recorder"), f"records[{names[record.recorder]}] has the same name; a recorder's name is unique",
                                        record.recorder))
            if record.recorder is not None:
                names.setdefault(record.recorder, i)
            if i == 0 and record.clock_drift == "estimate":
                problems.append(Problem(("records", 0, "clock_drift"), "the first recorder is the reference the others' clocks are estimated against; "
                                                                         "give its drift in ppm (default 0)", "estimate"))
            try:
                head = recordings.probe_recorder(source)
            except recordings.RecordError as error:
                problems.append(Problem(("records", i), str(error)))
                continue
            record._probed_rate = head.rate
            spans.append((head.first_time, head.last_time))
            rates.append((head.rate, source.path.name))
            if record.anti_alias is not None and record.anti_alias.corner >= 0.5 * head.rate:
                rule = f"must be below the file's Nyquist frequency rate/2 = {0.5 * head.rate:g} Hz"
                problems.append(Problem(("records", i, "anti_alias", "corner"), rule, record.anti_alias.corner))
        if not problems:
            span = min(last for _, last in spans) - max(first for first, _ in spans)
            if span <= 0.0:
                problems.append(Problem(("records",), "the files share no time span (each file's times plus its clock_offset)"))
            else:
                problems += [problem.under(("events",)) for problem in self.events.span_problems(span)]
            problems += self._event_grid_problems(*max(rates), sum(len(record.channels) for record in self.records))
        return problems

    def _event_grid_problems(self, rate: float, file: str, channels: int) -> list[Problem]:
        """An event's grid, ``(max_window × rate + 1) × channels`` values at the highest ``rate`` (Hz, of ``file``), within
        :data:`~femref.sensing.recordings.MAX_EVENT_VALUES`, so no window asks for more before the first one is cut."""
        window = self.events.max_window
        values = (math.floor(window * rate) + 1) * channels
        if values <= recordings.MAX_EVENT_VALUES:
            return []
        longest = math.floor((recordings.MAX_EVENT_VALUES // channels - 1) / rate * 1e3) / 1e3  # s, rounded down to the ms
        rule = (f"an event's grid holds max_window × rate × channels = {window:g} s × {rate:.4g} Hz ({file}) × {channels} = {values:.3g} values; "
                f"the limit is {recordings.MAX_EVENT_VALUES:.3g}: give max_window (and pre + post) at most {longest:g} s")
        return [Problem(("events", "max_window"), rule, window)]

    def record_sources(self) -> tuple[recordings.RecordFile, ...]:
        """Every recorder as :mod:`femref.sensing.recordings` reads it, each named: its ``recorder``, else its first file's
        stem, or its name where stems repeat, or ``records[i]``."""
        sources = [record.source() for record in self.records]
        given = {record.recorder for record in self.records if record.recorder}
        stems = [source.path.stem for source in sources]
        names = []
        for i, (record, source) in enumerate(zip(self.records, sources)):
            candidates = [source.path.stem] if stems.count(source.path.stem) == 1 else []
            candidates += [source.path.name, f"records[{i}]"]
            names.append(record.recorder or next(c for c in candidates if c not in given and c not in names))
        return tuple(dataclasses.replace(source, recorder=name) for source, name in zip(sources, names))

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        if key in ("models", "time", "measurement", "fem", "integrator", "tolerance"):
            return f"{key!r} is a key of simulated cases; a measured case has records, cars, couplers, events, estimators and checks"
        return super()._unknown_key_rule(key, known)
