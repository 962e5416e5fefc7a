"""Where Dask work runs and how it streams back: one home for sweeps (:mod:`femref.sweep.run`) and fleets
(:mod:`femref.fleet.runner`).

:func:`dask_client` gives a ``distributed.Client``: the one given, one of a scheduler at an address, or one of a
new ``LocalCluster`` of single-threaded worker processes (default one per CPU; its nannies restart a worker that
dies, and the scheduler runs the worker's tasks again elsewhere). :func:`bounded_results` submits tasks from a
lazy iterator with at most ``slots`` futures in flight (``distributed.as_completed`` with ``add``) and yields each
as it finishes, so a run of 10⁵ tasks never queues everything at once; on an error or Ctrl-C in the caller the
futures still in flight are cancelled. dask.distributed is imported when a client is made, not with this module.
Tasks are pickled by reference: the client and the workers run the same femref.
"""

from __future__ import annotations

import logging
import os
import signal
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

__all__ = ["IN_FLIGHT_PER_THREAD", "Task", "bounded_results", "dask_client", "default_signals_in_forks", "in_flight_slots"]

#: Futures kept in flight per worker thread: enough to keep every worker busy, few enough to stream.
IN_FLIGHT_PER_THREAD = 2


@dataclass(frozen=True)
class Task:
    """One task to submit: ``function(*args)`` under ``key`` (unique), with ``tag`` (the caller's) given back with its future."""

    function: Callable[..., Any]
    args: tuple[Any, ...]
    key: str
    tag: Any = field(default=None, compare=False)


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, client: Any = None, *, fork: bool = False) -> Iterator[Any]:
    """The given ``client``, a client of ``scheduler`` (``tcp://host:8786``), or a client of a new local cluster of
    ``workers`` single-threaded processes (default: one per CPU), closed when the block ends.

    ``fork``: the local cluster's workers start as forks of this process, with its imports done (a spawned worker
    imports dask, femref and its dependencies first: about 4 s on a busy 2-core machine, against 0.1 s), and with
    the default handlers of SIGINT and SIGTERM (not a command's, :func:`default_signals_in_forks`); only for a
    caller that holds no open file a worker could inherit (an HDF5 file being written). A worker that its nanny
    restarts later is spawned."""
    if client is not None:
        yield client
        return
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler) as remote:  # connect timeout: dask config distributed.comm.timeouts.connect
            yield remote
        return
    import dask

    if fork:
        default_signals_in_forks()
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork"} if fork else {}):
        cluster = LocalCluster(
            n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR
        )
    with cluster, Client(cluster) as local:
        yield local


_forks_reset = False


def default_signals_in_forks() -> None:
    """A process forked from this one from now on starts with Python's default SIGINT and SIGTERM handlers (a
    command's handler, which turns SIGTERM into an interrupt, belongs to the command's own process)."""
    global _forks_reset
    if not _forks_reset:
        os.register_at_fork(after_in_child=_default_signals)
        _forks_reset = True


def _default_signals() -> None:
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def in_flight_slots(client: Any) -> int:
    """Futures to keep in flight on ``client``'s cluster: :data:`IN_FLIGHT_PER_THREAD` per worker thread."""
    return IN_FLIGHT_PER_THREAD * max(1, sum(client.nthreads().values()))


def bounded_results(client: Any, tasks: Iterable[Task], slots: int) -> Iterator[tuple[Any, Any]]:
    """``(tag, future)`` of each of ``tasks`` as it finishes, at most ``slots`` submitted and unfinished at a time.

    ``tasks`` is drawn lazily (it may store or skip work as it is drawn). The futures still in flight are cancelled
    when the caller stops early — an exception in its loop (Ctrl-C) or from ``tasks`` — once the generator is closed:
    iterate it under ``contextlib.closing`` so that happens at once, while the client is still open."""
    from distributed import as_completed

    queue = iter(tasks)
    in_flight: dict[Any, Any] = {}
    finished = as_completed()

    def submit_more() -> None:
        while len(in_flight) < slots and (task := next(queue, None)) is not None:
            future = client.submit(task.function, *task.args, key=task.key, pure=False)
            in_flight[future] = task.tag
            finished.add(future)

    try:
        submit_more()
        for future in finished:
            tag = in_flight.pop(future)
            yield tag, future
            submit_more()
    finally:
        if in_flight:
            client.cancel(list(in_flight))
