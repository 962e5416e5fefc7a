"""The work of one recording of a fleet, run on a Dask worker: its measured case in, its store rows out.

:func:`run_recording` is a top-level function (Dask pickles it by reference) that never raises for a recording
that cannot be run: the recording's case parsed again from its plain data, its work budget checked
(:func:`femref.flow.plan_case`), then :func:`femref.run.measured.run_measured` with a sink that makes each event's
store rows from its full result (:func:`femref.fleet.rows.event_rows`) and writes it to ``<out>/events/<name>.h5``
(:func:`femref.events.event_file`: under a temporary name, renamed when every event is in; the temporaries of a
worker killed before are removed first). A record that turns out bad during the run, events over the budget or any
other error make the recording ``failed`` with its message; its event file is then not written. The worker never opens the store: the client writes what this returns.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from femref import __version__
from femref.events import EventResult, event_file
from femref.fleet.manifest import Recording
from femref.fleet.rows import RecordingFacts, event_rows

__all__ = ["EVENTS_FOLDER", "event_path", "failed", "run_recording"]

#: The folder of the event files in a fleet's output folder.
EVENTS_FOLDER = "events"


def event_path(out_dir: Path, name: str) -> Path:
    """Where recording ``name``'s event file goes: ``<out>/events/<name>.h5``."""
    return Path(out_dir) / EVENTS_FOLDER / f"{name}.h5"


def failed(message: str) -> dict[str, Any]:
    """The result of a recording that could not be run: no rows, nothing read, ``message`` why."""
    return {"status": "failed", "message": message, "events": [], "estimates": [], "event_count": 0, "samples": 0, "bytes_read": 0,
            "seconds": 0.0, "femref_version": __version__}


def run_recording(recording: Recording, base_dir: str, source: str, out_dir: str) -> dict[str, Any]:
    """Run ``recording`` (module docstring); a dict of ``status`` (ok, failed), ``message``, ``events`` and
    ``estimates`` (the store rows), ``event_count``, ``samples`` (values read: samples × channels), ``bytes_read``
    (of its record files), ``seconds`` (this run) and ``femref_version``."""
    from femref.case import CaseError, parse_case
    from femref.flow import plan_case
    from femref.run.measured import run_measured
    from femref.sensing.recordings import RecordError

    started = time.perf_counter()
    path = event_path(Path(out_dir), recording.name)
    events: list[dict[str, Any]] = []
    estimates: list[dict[str, Any]] = []
    try:
        case = parse_case(recording.case, source=source, base_dir=Path(base_dir))
        scene = plan_case(case, Path(base_dir), source).scene
        facts = RecordingFacts.of(recording, Path(base_dir), path.relative_to(Path(out_dir)).as_posix())
        with event_file(path, scene.facts(), recording.resolved) as writer:
            def sink(event: EventResult) -> EventResult:
                rows = event_rows(facts, scene.couplers, event)
                events.extend(rows[0])
                estimates.extend(rows[1])
                return writer(event)

            outcome = run_measured(scene, sink=sink, source=source)
        result = {"status": "ok", "message": "", "events": events, "estimates": estimates, "event_count": len(outcome.events),
                  "samples": outcome.stream.samples, "bytes_read": outcome.stream.bytes, "femref_version": __version__}
    except (CaseError, RecordError) as error:
        result = failed(str(error))
    except Exception as error:  # the recording is stored as failed with why, and the fleet goes on
        result = failed(f"{type(error).__name__}: {error}")
    result["seconds"] = time.perf_counter() - started
    return result
