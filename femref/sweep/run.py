"""Run a sweep on dask.distributed and stream the samples into the sweep file as they finish.

The client (this process) ships the sweep — its base case, validated once — pickled with each task (a few kB,
unpickled once per worker: :func:`femref.sweep.worker.sweep_of`), draws each sample (:meth:`Sweep.sample`) and submits the samples in batches of their
drawn values (:func:`batch_size`, up to :data:`MAX_BATCH` samples) as :func:`femref.sweep.worker.run_samples` tasks, keeping
about two per worker thread in flight (``distributed.as_completed`` with ``add``), so a sweep of 10⁵ samples
never queues everything at once. A worker derives each sample's case by substitution and validates it there,
once; a sample whose substitution breaks a rule comes back failed with the key path and the rule. Only the client
writes the file (:class:`femref.sweep.store.SweepStore`), one flushed write of a batch's rows as it finishes.
Batches matter since the stepping was compiled: a rigid sample runs in milliseconds, less than the scheduling,
shipping and HDF5 writing of a task of its own (a 1000-sample rigid sweep on 2 workers ran 7× slower with a
task per sample).

Where the work runs (:func:`femref.core.cluster.dask_client`): a ``distributed.LocalCluster`` of ``workers``
single-threaded processes (default: one per CPU) forked from this one — its imports done, the sweep file closed
while they start —, an existing scheduler (``scheduler="tcp://host:8786"``), or a given ``distributed.Client``;
the batches stream back through :func:`femref.core.cluster.bounded_results`.

>>> summary = run_sweep("cases/sweeps/free_roll_speeds.yaml", "speeds.h5", workers=2)  # doctest: +SKIP
>>> summary.run, summary.failed, f"{summary.runs_per_second:.2f} runs/s"                  # doctest: +SKIP
"""

from __future__ import annotations

import pickle
import time
import uuid
from collections.abc import Callable, Iterator
from contextlib import ExitStack, closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from femref.core.cluster import IN_FLIGHT_PER_THREAD, Task, bounded_results, dask_client, in_flight_slots
from femref.sweep.spec import Sweep, load_sweep
from femref.sweep.store import FAILED, SweepLayout, SweepStore, partial_path
from femref.sweep.worker import run_samples

__all__ = ["SweepInterrupted", "SweepSummary", "run_sweep"]

#: Most samples in one task (:func:`batch_size`).
MAX_BATCH = 128

#: ``progress(done, to_run)`` after each sample stored in this call.
Progress = Callable[[int, int], None]


@dataclass
class SweepSummary:
    """What one call did: samples in the file, run now, skipped (already stored), failed now."""

    output: Path
    total: int
    run: int = 0
    skipped: int = 0
    failures: list[tuple[int, str]] = field(default_factory=list)
    stored_failed: int = 0
    wall_time_s: float = 0.0
    complete: bool = False

    @property
    def failed(self) -> int:
        return len(self.failures)

    @property
    def path(self) -> Path:
        """Where the samples are now: the output when complete, else its ``.partial``."""
        return self.output if self.complete else partial_path(self.output)

    @property
    def runs_per_second(self) -> float:
        return self.run / self.wall_time_s if self.wall_time_s > 0.0 else 0.0


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep: the futures were cancelled and the stored samples kept (``summary``)."""

    def __init__(self, summary: SweepSummary) -> None:
        super().__init__(f"sweep interrupted: {summary.run} samples stored in this call")
        self.summary = summary


def run_sweep(
    sweep: Sweep | str | Path,
    output: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    limit: int | None = None,
    retry_failed: bool = False,
    progress: Progress | None = None,
) -> SweepSummary:
    """Run every sample of ``sweep`` not yet stored in ``output``; return what was done.

    ``limit`` runs at most that many samples in this call (the file stays ``.partial``).
    ``retry_failed`` runs failed samples again. Raises :class:`CaseError` for a bad sweep
    file or an ``output`` holding another sweep, :class:`SweepInterrupted` on Ctrl-C.
    """
    sweep = sweep if isinstance(sweep, Sweep) else load_sweep(sweep)
    output = Path(output)
    status = SweepStore.stored_status(output, sweep)
    if status is not None and status.size >= sweep.size and not (retry_failed and np.any(status == FAILED)):
        return SweepSummary(output, int(status.size), skipped=int(status.size), stored_failed=int(np.sum(status == FAILED)), complete=True)

    store = SweepStore.open(output, sweep, SweepLayout.of(sweep))
    summary = SweepSummary(output, store.size)
    interrupted = False
    started = time.perf_counter()
    try:
        if store.size > sweep.size:  # a file is never shrunk: run all of its samples
            sweep = sweep.with_samples(store.size // (sweep.size // sweep.spec.samples))
        pending = store.pending(retry_failed)
        summary.skipped = store.size - len(pending)
        todo = pending if limit is None else pending[: max(0, limit)]
        if todo:
            _load_kernels(sweep)
            with ExitStack() as cluster:
                with store.released():  # a local cluster's workers are forks of this process: not of an open HDF5 file
                    connected = cluster.enter_context(dask_client(scheduler, workers, client, fork=True))
                started = time.perf_counter()  # the rate of the runs, without the cluster's start and stop
                _run(connected, sweep, store, todo, summary, progress)
                summary.wall_time_s = time.perf_counter() - started
    except KeyboardInterrupt:
        interrupted = True
        summary.wall_time_s = time.perf_counter() - started
    finally:
        summary.stored_failed = int(np.sum(store.status == FAILED))
        summary.complete = store.close()
    if interrupted:
        raise SweepInterrupted(summary)
    return summary


def _load_kernels(sweep: Sweep) -> None:
    """The batched kernels loaded in this process before the cluster starts (:func:`femref.sweep.batch.load_batch_kernels`:
    a first sweep after an install compiles them here, once, saying so, rather than silently in every worker; a local
    cluster's workers are forks of this process and start with them loaded). A base case whose scene cannot be built
    loads nothing: each sample reports its own failure."""
    from femref.scene.build import scene_from_case
    from femref.sweep.batch import load_batch_kernels

    try:
        scene = scene_from_case(sweep.base_case, sweep.base_dir)
    except Exception:  # noqa: BLE001 (the samples say why, each with its own key path)
        return
    load_batch_kernels(scene)


def batch_size(samples: int, threads: int) -> int:
    """Samples per task: enough that a task outlasts its scheduling and the client's write of its rows
    (a rigid sample runs in milliseconds), few enough that every worker thread gets several
    batches (:data:`IN_FLIGHT_PER_THREAD` in flight each) and rows stream in; at most :data:`MAX_BATCH`."""
    return max(1, min(MAX_BATCH, samples // (4 * IN_FLIGHT_PER_THREAD * max(1, threads))))


def _run(client: Any, sweep: Sweep, store: SweepStore, todo: list[int], summary: SweepSummary, progress: Progress | None) -> None:
    """Submit ``todo`` in batches of drawn values with a bounded number of
    futures in flight; store each batch as it finishes."""
    threads = max(1, sum(client.nthreads().values()))
    size = batch_size(len(todo), threads)
    shipped = pickle.dumps(sweep)  # unpickled once per worker (femref.sweep.worker.sweep_of)
    tag = uuid.uuid4().hex[:8]

    def tasks() -> Iterator[Task]:
        for start in range(0, len(todo), size):
            batch = [sweep.sample(index) for index in todo[start : start + size]]
            yield Task(run_samples, (shipped, [(s.index, s.substitutions) for s in batch]), key=f"femref-samples-{batch[0].index}-{tag}", tag=batch)

    with closing(bounded_results(client, tasks(), in_flight_slots(client))) as finished:
        for batch, future in finished:
            records = _records_of(future, len(batch))
            errors = store.store_batch([s.index for s in batch], [s.stored for s in batch], records)
            summary.failures.extend((sample.index, error) for sample, error in zip(batch, errors) if error)
            summary.run += len(batch)
            if progress is not None:
                progress(summary.run, len(todo))


def _records_of(future: Any, samples: int) -> list[dict[str, Any]]:
    """The worker's records; a batch that killed its workers is the failure of each of its samples, other
    errors are the sweep's."""
    from distributed import KilledWorker

    try:
        return future.result()
    except KilledWorker as error:
        return [{"error": f"a sample of this batch of {samples} killed the workers that ran it ({error})"}] * samples
