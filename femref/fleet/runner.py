"""Run a fleet on Dask: every recording not yet stored, one task each, its rows stored as it finishes.

The client (this process) validates the manifest (:func:`femref.fleet.manifest.load_manifest`: bad input is a
CaseError before anything is written), opens the store (:class:`femref.fleet.store.EventStore`) and compares each
recording's stamp with the stored one: a recording stored ``ok`` with the same stamp is skipped, any other
(new, changed, failed before) is run. The runs are :func:`femref.fleet.worker.run_recording` tasks on the cluster
of :func:`femref.core.cluster.dask_client`, streamed back through :func:`femref.core.cluster.bounded_results`
(two per worker thread in flight). Only the client writes the store, one transaction per recording, as each task
finishes: a worker never opens it, so several workers never write it at once.

Resumable and exact. A worker killed (SIGKILL, out of memory) is restarted by its nanny and the scheduler runs its
task again elsewhere; a recording that keeps killing workers is stored ``failed``. Ctrl-C cancels the tasks in
flight and raises :class:`FleetInterrupted`: every recording committed stays, the one in hand is not, and the
temporaries its worker left are removed by the next run (:func:`femref.core.publishing.remove_leftovers`). A rerun
runs what is missing; a changed recording's rows replace its old ones in one transaction; the keys make a
duplicate row impossible.

>>> summary = run_fleet("cases/fleet/yard.yaml", "yard-store", workers=2)            # doctest: +SKIP
>>> summary.run, summary.skipped, summary.failed, f"{summary.events_per_second:.1f} events/s"  # doctest: +SKIP
"""

from __future__ import annotations

import time
import uuid
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from femref.core.cluster import Task, bounded_results, dask_client, in_flight_slots
from femref.fleet.manifest import Fleet, Recording, load_manifest, recording_stamp
from femref.fleet.store import STORE_NAME, EventStore, RecordingRow, sql_time
from femref.fleet.worker import event_path, failed, run_recording

__all__ = ["FleetInterrupted", "FleetSummary", "Progress", "fleet_inputs", "run_fleet"]

#: ``progress(done, total, recording, events)`` after each recording stored in this call (its name and event count).
Progress = Callable[[int, int, str, int], None]


@dataclass
class FleetSummary:
    """What one call did: recordings in the manifest, run now, skipped (stored ok, unchanged), failed now (name,
    message); of the runs: events by type, alarms by level, values (samples × channels) and bytes of record files read,
    and the wall time of the runs (the cluster's start and stop left out)."""

    store: Path
    total: int
    run: int = 0
    skipped: int = 0
    failures: list[tuple[str, str]] = field(default_factory=list)
    events: Counter[str] = field(default_factory=Counter)
    alarms: Counter[str] = field(default_factory=Counter)
    samples: int = 0
    bytes_read: int = 0
    wall_time_s: float = 0.0

    @property
    def failed(self) -> int:
        return len(self.failures)

    @property
    def event_count(self) -> int:
        return sum(self.events.values())

    def _rate(self, amount: float) -> float:
        return amount / self.wall_time_s if self.wall_time_s > 0.0 else 0.0

    @property
    def events_per_second(self) -> float:
        return self._rate(self.event_count)

    @property
    def megabytes_per_second(self) -> float:
        """MB (10⁶ bytes) of record files read per second."""
        return self._rate(self.bytes_read / 1e6)

    @property
    def samples_per_second(self) -> float:
        return self._rate(self.samples)


class FleetInterrupted(KeyboardInterrupt):
    """Ctrl-C during a fleet run: the tasks in flight were cancelled, the recordings stored kept (``summary``)."""

    def __init__(self, summary: FleetSummary) -> None:
        super().__init__(f"fleet interrupted: {summary.run} recordings stored in this call")
        self.summary = summary


def fleet_inputs(fleet: Fleet, out_dir: Path) -> dict[str, Path]:
    """The fleet's inputs an output folder ``out_dir`` could overwrite: the manifest and every file a recording reads
    that lies in ``out_dir`` (a file elsewhere cannot be one the run writes)."""
    inside = Path(out_dir).resolve()
    inputs = {"MANIFEST": fleet.path}
    for recording in fleet.recordings:
        for number, path in enumerate(recording.files):
            if inside in path.resolve().parents:
                inputs[f"recordings[{recording.index}] file {number + 1}"] = path
    return inputs


def run_fleet(fleet: Fleet | str | Path, out_dir: str | Path, *, scheduler: str | None = None, workers: int | None = None, client: Any = None,
              progress: Progress | None = None) -> FleetSummary:
    """Run every recording of ``fleet`` not stored ``ok`` with its current stamp into the store in ``out_dir`` (made if
    absent, in an existing folder); return what was done. Raises CaseError for a bad manifest, StoreError for an
    ``out_dir`` holding something else than this fleet's store, :class:`FleetInterrupted` on Ctrl-C."""
    fleet = fleet if isinstance(fleet, Fleet) else load_manifest(fleet)
    out_dir = Path(out_dir)
    out_dir.mkdir(exist_ok=True)
    with EventStore(out_dir / STORE_NAME, fleet.name) as store:
        stored = store.stamps()
        stamps = {recording.name: recording_stamp(recording) for recording in fleet.recordings}
        todo = [recording for recording in fleet.recordings if stored.get(recording.name) != (stamps[recording.name], "ok")]
        summary = FleetSummary(store.path, len(fleet.recordings), skipped=len(fleet.recordings) - len(todo))
        if not todo:
            return summary
        started = time.perf_counter()
        try:
            with dask_client(scheduler, workers, client) as connected, closing(_results(connected, fleet, todo, out_dir)) as results:
                started = time.perf_counter()
                for recording, result in results:
                    _store(store, recording, stamps[recording.name], result, out_dir, summary)
                    if progress is not None:
                        progress(summary.run, len(todo), recording.name, result["event_count"])
                summary.wall_time_s = time.perf_counter() - started
        except KeyboardInterrupt:
            summary.wall_time_s = time.perf_counter() - started
            raise FleetInterrupted(summary) from None
    return summary


def _results(client: Any, fleet: Fleet, todo: list[Recording], out_dir: Path) -> Iterator[tuple[Recording, dict[str, Any]]]:
    """Each of ``todo`` run on ``client`` and its worker's result, as they finish (a recording that killed the workers
    that ran it: a failed result); closed, it cancels the tasks in flight."""
    from distributed import KilledWorker

    def tasks() -> Iterator[Task]:
        for recording in todo:
            source = f"{fleet.path}, recording {recording.name}"
            yield Task(run_recording, (recording, str(fleet.base_dir), source, str(out_dir.resolve())),
                       key=f"femref-recording-{recording.index}-{uuid.uuid4().hex[:8]}", tag=recording)

    with closing(bounded_results(client, tasks(), in_flight_slots(client))) as finished:
        for recording, future in finished:
            try:
                result = future.result()
            except KilledWorker as error:
                result = failed(f"the recording killed the workers that ran it ({error})")
            yield recording, result


def _store(store: EventStore, recording: Recording, stamp: str, result: dict[str, Any], out_dir: Path, summary: FleetSummary) -> None:
    """Commit ``recording``'s result (one transaction) and count it; a failed recording's old event file is removed."""
    path = event_path(out_dir, recording.name)
    row = RecordingRow(
        name=recording.name, stamp=stamp, status=result["status"], message=result["message"], events=result["event_count"],
        samples=result["samples"], bytes_read=result["bytes_read"], seconds=result["seconds"], femref_version=result["femref_version"],
        start=sql_time(recording.start), track=recording.track, event_file=path.relative_to(out_dir).as_posix() if result["status"] == "ok" else "",
    )
    store.put(row, result["events"], result["estimates"])
    summary.run += 1
    if result["status"] != "ok":
        path.unlink(missing_ok=True)
        summary.failures.append((recording.name, result["message"]))
        return
    kinds = {row["event_key"]: (row["event_type"], row["alarm"]) for row in result["events"]}
    summary.events.update(kind for kind, _ in kinds.values())
    summary.alarms.update(alarm for _, alarm in kinds.values() if alarm != "none")
    summary.samples += result["samples"]
    summary.bytes_read += result["bytes_read"]
