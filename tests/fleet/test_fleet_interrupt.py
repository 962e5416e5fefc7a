"""Ctrl-C in ``femref fleet`` and the rerun: exit 130, no event file half-written under its final name, the committed
rows intact, and after the rerun the store of an uninterrupted run — no row twice, none missing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import distributed
import h5py
import pandas as pd
import pytest
import yaml

from femref.events import COMPLETE
from femref.fleet.runner import run_fleet
from femref.fleet.store import read_estimates, read_events, read_recordings
from support.fleet import PAIRS, write_fleet

#: Enough recordings that the interrupt lands while most are still to run.
RECORDINGS = 24


@pytest.fixture(scope="module")
def in_process():
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        yield client


def _rows(store) -> list[pd.DataFrame]:
    return [read_events(store).sort_values(["event_key", "coupler"], ignore_index=True),
            read_estimates(store).sort_values(["event_key", "coupler", "estimator"], ignore_index=True),
            read_recordings(store).drop(columns=["seconds"])]


def test_ctrl_c_keeps_what_is_committed_and_a_rerun_completes_the_store(tmp_path, fleet_records, in_process):
    manifest = write_fleet(tmp_path, fleet_records, [(i / 2, ("low", "high")[i % 2], *PAIRS[i % 3]) for i in range(RECORDINGS)])
    out = tmp_path / "out"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    command = [sys.executable, "-c", "from femref.cli import main; main()", "fleet", str(manifest), "-o", str(out), "--workers", "1", "--progress"]
    run = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in run.stderr:  # until the first recording is stored
            if line.startswith("fleet: 1/"):
                break
        run.send_signal(signal.SIGINT)
        stdout, stderr = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    assert run.returncode == 130, (stdout, stderr)
    assert "interrupted:" in stderr and "run again to resume" in stderr and "Traceback" not in stderr, stderr
    store = out / "events.sqlite"
    recordings = read_recordings(store)
    stored = set(recordings["name"])
    assert 1 <= len(stored) < RECORDINGS and (recordings["status"] == "ok").all()
    events = read_events(store)
    assert set(events["recording"]) == stored and len(events) == len(stored)  # each committed recording whole: one event
    for path in (out / "events").glob("*.h5"):  # a final name holds a complete event file, or none is there
        with h5py.File(path) as h5:
            assert h5.attrs[COMPLETE], path
    interrupted = _rows(store)

    summary = run_fleet(manifest, out, client=in_process)
    assert (summary.run, summary.skipped) == (RECORDINGS - len(stored), len(stored)) and not summary.failures
    run_fleet(manifest, tmp_path / "uninterrupted", client=in_process)
    for rerun, whole in zip(_rows(store), _rows(tmp_path / "uninterrupted" / "events.sqlite")):
        pd.testing.assert_frame_equal(rerun, whole)
    events = read_events(store)
    assert len(events) == RECORDINGS and events["event_key"].is_unique
    before = interrupted[0].set_index("event_key")
    pd.testing.assert_frame_equal(events.set_index("event_key").loc[before.index].sort_index(), before.sort_index())
    names = {recording["name"] for recording in yaml.safe_load(manifest.read_text())["recordings"]}
    left = [path for path in (out / "events").iterdir() if not path.name.endswith(".writer")]  # (test_fleet_run: a kill's empty sidecar)
    assert {path.stem for path in left} == names and all(path.suffix == ".h5" for path in left)  # every event file, no temporary
