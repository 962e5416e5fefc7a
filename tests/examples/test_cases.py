"""Every file in cases/ validates, runs through the command line's own code path, and keeps its headline numbers.

The headline scalars (peak coupler force or peak acceleration, energy balance) are held
to ``baselines.json`` with per-key tolerances (:mod:`support.headlines`).
"""

import json

import h5py
import pytest
from click.testing import CliRunner

from femref.cli import main
from support.headlines import BASELINES, check, headlines
from support.paths import CASES as CASE_DIR

CASES = sorted(CASE_DIR.glob("*.yaml"))


def test_there_are_cases():
    assert len(CASES) >= 5


def test_every_case_has_a_baseline():
    assert sorted(json.loads(BASELINES.read_text())["cases"]) == [case.stem for case in CASES]


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_case_validates_runs_and_keeps_its_headlines(case, tmp_path):
    runner = CliRunner()
    assert runner.invoke(main, ["validate", str(case)]).exit_code == 0
    output = tmp_path / f"{case.stem}.h5"
    result = runner.invoke(main, ["run", str(case), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output) as h5:
        if h5["scene"].attrs["kind"] == "measured":
            statuses = [(e, c, g.attrs["status"]) for e in h5["events"] for c, g in _estimates(h5["events"][e])]
            assert statuses and all(status == "ok" for *_, status in statuses), statuses
        else:
            for model in h5:
                if model not in ("scores", "scene"):
                    assert h5[model].attrs["status"] == "ok", (model, h5[model].attrs["message"])
            assert "scores" in h5
    assert check(case.stem, headlines(output), json.loads(BASELINES.read_text())) == []


def _estimates(event):
    """``(estimator/coupler, group)`` of every force estimate of an event group."""
    return [(f"{name}/{coupler}", group[coupler]) for name, group in event.items() if name not in ("records", "closure") for coupler in group]
