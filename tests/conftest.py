"""Fixtures the whole suite shares: what is expensive to make and the same for every module that uses it."""

from __future__ import annotations

import os

import pytest

# `make test` runs the suite in two processes (pytest-xdist, one per core of the 2-core box); its workers inherit
# COLUMNS=80 and LINES=24 from execnet, which would force a width on every CLI test that leaves COLUMNS unset
# (piped output is one line per row). The tests that check a width set their own.
if os.environ.get("PYTEST_XDIST_WORKER"):
    for name in ("COLUMNS", "LINES"):
        os.environ.pop(name, None)


@pytest.fixture(scope="session")
def dask_client():
    """A client of one local cluster of two single-threaded worker processes on loopback, for the whole session.

    The sweep, study and fleet tests that need a real multi-process cluster share it: its start and the workers'
    imports of femref cost ~13 s busy each time (measured: start 3 s, imports 8 s, close 2 s at load 9 on 2 cores).
    A test that kills a worker leaves it to the nanny, which starts a fresh one.
    """
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None) as local:
        with distributed.Client(local) as client:
            yield client
