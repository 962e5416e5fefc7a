"""Simulated measured events: an impact case run with fem, its records exported as a recorder would, a measured case.

:func:`simulated_event` runs an impact case's fem model with a measurement chain, writes each
car's measured accelerations to its own CSV file (in g, with a quiet stretch of noise before
the impact, a constant offset and a clock of its own) and returns the measured case that
reads them, with the fem run's coupler force as the truth.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from femref.case import parse_case
from femref.events import EventResult, event_file
from femref.run.runner import run_scene
from femref.scene.build import scene_from_case
from femref.sensing.recordings import Recordings
from femref.sensing.stream import search_events
from femref.sensing.trigger import HOLD, MAX_WINDOW, QUIET, Event, TriggerSettings

G = 9.80665


@dataclass
class SimulatedEvent:
    """The measured case (dict and path), the fem truth (time from contact, coupler force and closure δ) and the
    contact time in the records (s)."""

    case: dict[str, Any]
    path: Path
    time: np.ndarray
    force: np.ndarray
    contact_time: float
    closure: np.ndarray


def simulated_event(
    tmp_path: Path,
    impact: dict[str, Any],
    *,
    quiet: float = 0.1,
    clock: float = 100.0,
    offset_g: float = 0.002,
    estimators: tuple[str | dict[str, str], ...] = ("inverse_rigid", "kalman"),
    checks: dict[str, float] | None = None,
    trigger: float = 3.0,
    seed: int = 0,
) -> SimulatedEvent:
    """``impact`` (an impact case dict with a measurement) run with fem, recorded from ``clock`` s after a
    ``quiet`` stretch, one CSV per car; returns the measured case written to ``tmp_path/measured.yaml``."""
    data = copy.deepcopy(impact)
    data["models"], data["estimators"] = ["fem"], []
    fem = run_scene(scene_from_case(parse_case(data, source="<simulated>"))).results[0]
    assert fem.ok, fem.message
    t = fem.measured["time"]
    dt = float(t[1] - t[0])
    noise = data["measurement"].get("noise", 0.0)
    rng = np.random.default_rng(seed)
    before = np.arange(-round(quiet / dt), 0) * dt
    times = np.concatenate([before, t]) + clock
    for car in data["cars"]:
        columns = {"t": times}
        for sensor in car["sensors"]:
            a = fem.measured[f"{car['name']}/{sensor}"]
            columns[sensor] = np.concatenate([rng.normal(0.0, noise, before.size), a]) / G + offset_g
        np.savetxt(tmp_path / f"{car['name']}.csv", np.column_stack(list(columns.values())), delimiter=",", header=",".join(columns), comments="")
    coupler = data["couplers"][0]
    lowpass = data["measurement"].get("lowpass")  # the recorder's anti-alias filter, declared
    case = {
        "kind": "measured",
        "records": [
            {"file": f"{car['name']}.csv", "time": {"column": "t", "unit": "s"},
             "channels": {f"{car['name']}/{s}": {"column": s, "unit": "g"} for s in car["sensors"]},
             **({"anti_alias": {"corner": lowpass, "order": 4}} if lowpass else {})}
            for car in data["cars"]
        ],
        "cars": [{"name": car["name"], "body": car["body"], "sensors": car["sensors"]} for car in data["cars"]],
        "couplers": [{"name": coupler.get("name", "c1"), "between": coupler["between"]}],
        "events": {"trigger": trigger, "pre": 0.05, "post": float(t[-1]) - 0.01},
        "estimators": list(estimators),
    }
    if checks:
        case["checks"] = checks
    path = tmp_path / "measured.yaml"
    path.write_text(yaml.safe_dump(case, sort_keys=False))
    name = case["couplers"][0]["name"]
    return SimulatedEvent(case, path, fem.axes["time"], fem.couplers[name]["force"], clock, fem.couplers[name]["closure"])


def yard_case_with_inverse_estimators(folder: Path) -> Path:
    """cases/measured_yard.yaml (two events) reading the shipped records, with the two inverse estimators only (the
    cheap ones), written to ``folder/yard.yaml``; its path."""
    from support.paths import CASES

    data = yaml.safe_load((CASES / "measured_yard.yaml").read_text())
    for record in data["records"]:
        record["file"] = str(CASES / record["file"])
    data["estimators"] = ["inverse_rigid", "inverse_quasi_rigid"]
    path = folder / "yard.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def run_calibration_sweep(folder: Path, samples: int, record_length: int, force_length: int, **case: Any) -> tuple[Path, Path]:
    """A fem sweep of the default scene over the hammer's speed (uniform 1.5–3 m/s, seed 5) for ``femref calibrate``,
    run in process on one worker into ``folder/cal.h5``; ``case`` updates the base case (e.g. ``time``). Asserts
    every sample ran; returns the sweep file and its results."""
    import distributed

    from femref.case.defaults import default_scene_data
    from femref.sweep import run_sweep

    base = default_scene_data()
    base.update(models=["fem"], estimators=[], **case)
    sweep = {"case": base, "samples": samples, "seed": 5, "models": ["fem"],
             "parameters": {"cars.0.velocity": {"uniform": [1.5, 3.0]}}, "outputs": {"record_length": record_length, "force_length": force_length}}
    (folder / "cal.yaml").write_text(yaml.safe_dump(sweep, sort_keys=False))
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        summary = run_sweep(folder / "cal.yaml", folder / "cal.h5", client=client)
    assert summary.complete and summary.failed == 0
    return folder / "cal.yaml", folder / "cal.h5"


def find_events(recordings: Recordings, trigger: float, pre: float, post: float, *, rearm: float | None = None,
                quiet: float = QUIET, max_window: float = MAX_WINDOW, hold: float = HOLD) -> list[Event]:
    """The trigger's events on the records as they are, no baseline removed (:func:`femref.sensing.trigger.search_events`;
    a measured run removes it); ValueError for settings out of their range (:class:`TriggerSettings`)."""
    return search_events(recordings, TriggerSettings(trigger, pre, post, rearm, quiet, max_window, hold), remove_baseline=False).events


def write_events(path: str | Path, scene_facts: dict[str, Any], events: list[EventResult], case_yaml: str = "") -> Path:
    """Write the event results to ``path`` (atomically, :func:`femref.events.event_file`) and return the path."""
    with event_file(path, scene_facts, case_yaml) as write:
        for event in events:
            write(event)
    return Path(path)
