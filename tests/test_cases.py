"""Every file in cases/ validates and runs through the command line's own code path."""

from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from femref.cli import main

CASES = sorted((Path(__file__).resolve().parents[1] / "cases").glob("*.yaml"))


def test_there_are_cases():
    assert len(CASES) >= 5


@pytest.mark.parametrize("case", CASES, ids=[c.stem for c in CASES])
def test_case_validates_and_runs(case, tmp_path):
    runner = CliRunner()
    assert runner.invoke(main, ["validate", str(case)]).exit_code == 0
    output = tmp_path / f"{case.stem}.h5"
    result = runner.invoke(main, ["run", str(case), "-o", str(output)])
    assert result.exit_code == 0, result.output
    with h5py.File(output) as h5:
        for model in h5:
            if model != "scores":
                assert h5[model].attrs["status"] == "ok", (model, h5[model].attrs["message"])
        assert "scores" in h5
