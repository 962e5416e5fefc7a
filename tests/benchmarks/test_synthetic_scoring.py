"""benchmarks/bench_stream.py's scoring of a run against the synthetic day's truth, and its comparison of an event with
its hand cut, on events written here whose answers are known."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest

from support.paths import REPO


def _load():
    if "bench_stream" not in sys.modules:
        spec = importlib.util.spec_from_file_location("bench_stream", REPO / "benchmarks" / "bench_stream.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules["bench_stream"] = module
        spec.loader.exec_module(module)
    return sys.modules["bench_stream"]


def event(start: float, kind: str) -> dict:
    return {"start": start, "end": start + 3.0, "trigger_time": start + 0.5, "impact_type": kind}


def test_impacts_found_once_missed_split_and_phantoms_are_counted():
    """Impacts at 100 (found once, right type), 200 (wrong type), 300 (split in two events), 400 (missed); a free-to-roll
    event at 500 holds nothing (a phantom); a joint at 600 classed not an impact, a burst at 700 not found."""
    bench = _load()
    truth = {"impacts": [{"time": t, "type": "free_to_roll"} for t in (100.0, 200.0, 300.0, 400.0)],
             "not_impacts": [{"kind": "track_joint", "time": 600.2}, {"kind": "noise_burst", "time": 700.0}]}
    events = [event(99.6, "free_to_roll"), event(199.6, "coupled"), event(298.0, "free_to_roll"), event(299.9, "free_to_roll"),
              event(500.0, "free_to_roll"), event(600.0, "not_an_impact")]
    found = bench.score(events, truth)
    assert (found["found_once"], found["missed"], found["split"], found["phantoms"]) == (2, 1, 1, 1)
    assert (found["type_agrees"], found["type_differs"]) == (1, 1)
    assert found["trigger_delay_s"] == pytest.approx([0.1, 0.1], abs=1e-9)
    assert found["transients"]["track_joint"] == {"count": 1, "not_an_impact": 1, "classes": ["not_an_impact"]}
    assert found["transients"]["noise_burst"] == {"count": 1, "not_an_impact": 0, "classes": ["not found"]}


def test_an_event_and_its_hand_cut_differ_where_they_differ_beyond_1e_9():
    """Relative differences of 5e-10 pass, 2e-9 does not; a NaN in one, a shape, a string, a key in one are named;
    wall times and the clock group are not compared."""
    bench = _load()
    force = np.linspace(0.0, 1e6, 11)
    run = {"peak": 1e6, "speed": 2.0, "force": force, "nan": 1.0, "basis": "a", "only": 1.0, "x/wall_time_s": 1.0, "clock/r2@correction": 0.1}
    cut = {"peak": 1e6 * (1 + 5e-10), "speed": 2.0 * (1 + 2e-9), "force": np.append(force, 0.0), "nan": np.nan, "basis": "b",
           "x/wall_time_s": 9.0, "clock/r2@correction": 0.0}
    worst, differ = bench.differences(run, cut)
    assert 1.9e-9 < worst < 2.1e-9
    assert [d.split(" ")[0] for d in differ] == ["basis", "force", "nan", "only", "speed"]
