"""The Dask helpers sweeps and fleets share (femref.core.cluster): tasks drawn lazily with at most ``slots`` in flight,
every result back, and the tasks in flight cancelled when the caller stops."""

from __future__ import annotations

import time
from contextlib import closing

import distributed
import pytest

from femref.core.cluster import Task, bounded_results, in_flight_slots


def _square(x: int, pause: float) -> int:
    time.sleep(pause)
    return x * x


@pytest.fixture(scope="module")
def client():
    with distributed.Client(processes=False, n_workers=2, threads_per_worker=1, dashboard_address=":0") as connected:
        yield connected


def test_tasks_stream_back_with_at_most_slots_in_flight(client):
    drawn, done, most = [0], [0], [0]

    def tasks():
        for x in range(12):
            drawn[0] += 1
            most[0] = max(most[0], drawn[0] - done[0])
            yield Task(_square, (x, 0.01), key=f"square-{x}", tag=x)

    results = {}
    with closing(bounded_results(client, tasks(), slots=3)) as finished:
        for x, future in finished:
            results[x] = future.result()
            done[0] += 1
    assert results == {x: x * x for x in range(12)} and most[0] == 3
    assert in_flight_slots(client) == 4  # two per worker thread


class _CancelSpy:
    """A client that records what is cancelled through it."""

    def __init__(self, client) -> None:
        self.client, self.cancelled = client, []

    def submit(self, *args, **kwargs):
        return self.client.submit(*args, **kwargs)

    def cancel(self, futures) -> None:
        self.cancelled += futures
        self.client.cancel(futures)


def test_closing_the_stream_cancels_the_tasks_in_flight(client):
    """Six slow tasks, four slots: after the first result the caller stops; the three still in flight are cancelled and
    the last two were never submitted."""
    spy = _CancelSpy(client)
    drawn = []

    def tasks():
        for x in range(6):
            drawn.append(x)
            yield Task(_square, (x, 0.5), key=f"slow-{x}", tag=x)

    stream = bounded_results(spy, tasks(), slots=4)
    x, future = next(stream)
    assert future.result() == x * x
    stream.close()
    assert drawn == [0, 1, 2, 3] and sorted(f.key for f in spy.cancelled) == sorted(f"slow-{k}" for k in drawn if k != x)
    time.sleep(0.1)
    assert all(f.status == "cancelled" for f in spy.cancelled)
