"""``femref bench``: configurations, timing ratios, scores against the finest fem, Pareto front, files.

One small impact case runs through the command once (module fixture, ~2 s); the Pareto
front is checked on hand-made points. Timings are only compared as ratios, never as seconds.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import h5py
import matplotlib.image
import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from rich.cells import cell_len

from support.paths import CASES
from femref.cli.bench import IMPACT_ONLY, bench_command
from femref.bench.configurations import Configuration
from femref.bench.output import COLUMNS, plot_pareto
from femref.bench.pareto import pareto_mask
from femref.bench.run import BenchOutcome, BenchRow


WIDTH = 80  # the terminal width the bench is printed at (COLUMNS)


def small_impact() -> dict:
    """Two stiff 17 m cars (EA 30 GN) on a soft Kelvin–Voigt coupler, 8 linear elements, 0.2 s.

    With these cars the automatic fem step is the mesh's wave period (not the contact
    time), so the step halves with every doubling of the mesh and the fem error falls
    with both.
    """
    rod = {"type": "rod", "length": 17.0, "axial_stiffness": 3.0e10, "axial_viscosity": 2.0e6}
    return {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": {**rod, "mass_per_length": 7000.0}, "velocity": 2.2, "sensors": {"center": 0.0, "front": 8.3}},
            {"name": "anvil", "body": {**rod, "mass_per_length": 5900.0}, "velocity": 0.0, "sensors": {"rear": -8.3, "center": 0.0, "front": 8.3}},
        ],
        "couplers": [{"between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 1.0e7, "damping": 3.0e5}}, "contact": "compression_only"}],
        "time": {"end": 0.2},
        "models": ["fem", "rigid"],
        "fem": {"elements": 8, "order": 1},
        "measurement": {"rate": 1000.0, "lowpass": 100.0, "noise": 0.0, "seed": 1},
        "estimators": ["inverse_rigid", "inverse_quasi_rigid"],
    }


def write_case(folder: Path, data: dict, name: str = "small.yaml") -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """The bench of :func:`small_impact` through the command, printed at ``COLUMNS=80``: (result, table rows, /bench
    attrs, folder)."""
    folder = tmp_path_factory.mktemp("bench")
    case = write_case(folder, small_impact())
    result = CliRunner().invoke(bench_command, [str(case), "-o", str(folder / "bench.h5"), "--repeats", "3", "--plot", str(folder / "bench.png")],
                                env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    with h5py.File(folder / "bench.h5", "r") as h5:
        table = h5["bench"][()]
        attrs = dict(h5["bench"].attrs)
        repeat_times = h5["bench_wall_times_s"][()]
    return SimpleNamespace(result=result, table=table, attrs=attrs, repeat_times=repeat_times, folder=folder)


def flat(output: str) -> str:
    """The output with every run of white space one space: lines wrapped at the width joined again."""
    return " ".join(output.split())


def text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def labels(table) -> list[str]:
    return [text(v) for v in table["label"]]


def test_table_has_one_row_per_configuration_and_every_column(bench):
    assert set(bench.table.dtype.names) == set(COLUMNS)
    assert labels(bench.table) == [
        "fem N=4", "fem N=8", "fem N=16", "fem dt×2", "fem dt×4",
        "modal k=1", "modal k=2", "modal k=4", "quasi_rigid", "rigid",
        "inverse_rigid", "inverse_quasi_rigid",
    ]  # modal k=8 needs 10 DOFs: the 9-node mesh holds 7 elastic modes
    assert all(text(s) == "ok" for s in bench.table["status"])
    assert bench.attrs["repeats"] == 3 and bench.repeat_times.shape == (len(bench.table), 3)
    assert np.allclose(np.median(bench.repeat_times, axis=1), bench.table["wall_time_s"])
    assert "16 elements" in bench.attrs["reference"] and "kind: impact" in bench.attrs["case_yaml"]
    assert set(json.loads(bench.attrs["units"])) == set(COLUMNS)


def test_reference_is_finer_than_every_configuration(bench):
    """2 × the case's elements and half the finest step: no configuration is the reference itself."""
    rows = bench.table
    solves = rows[np.array([text(k) == "solve" for k in rows["kind"]])]
    assert np.all(solves["elements"] <= 16)
    finest = float(np.min(solves["dt_s"]))
    assert f"dt = {0.5 * finest:.6g} s" in bench.attrs["reference"]
    assert np.all(np.isfinite(rows["peak_error"])) and np.all(rows["peak_error"] > 0.0)


def test_fem_errors_fall_as_the_elements_grow(bench):
    rows = bench.table[np.array([text(s) == "elements" for s in bench.table["setting"]])]
    rows = rows[np.argsort(rows["elements"])]
    assert list(rows["elements"]) == [4, 8, 16]
    assert np.all(np.diff(rows["peak_error"]) < 0.0), rows["peak_error"]
    assert np.all(np.diff(rows["rms_error"]) < 0.0), rows["rms_error"]
    assert np.all(np.diff(rows["dt_s"]) <= 0.0)  # each at its own (automatic) step


def test_ratios_are_times_over_the_rigid_time(bench):
    rows = bench.table
    rigid = float(rows["wall_time_s"][labels(rows).index("rigid")])
    assert np.allclose(rows["time_ratio_rigid"], rows["wall_time_s"] / rigid, rtol=1e-12)


def test_pareto_flags_equal_a_brute_force_check(bench):
    t, e = bench.table["wall_time_s"], bench.table["peak_error"]
    expected = [
        not any((t[j] <= t[i] and e[j] <= e[i] and (t[j] < t[i] or e[j] < e[i])) for j in range(len(t)))
        for i in range(len(t))
    ]
    assert list(bench.table["pareto"]) == expected
    shown = flat(bench.result.output).split("Pareto-optimal (fastest first): ")[1].split(" note: ")[0].split(" wrote ")[0].split(", ")
    assert sorted(shown) == sorted(np.array(labels(bench.table))[bench.table["pareto"]])


def test_estimators_have_a_peak_and_rms_error_and_no_steps(bench):
    rows = bench.table[np.array([text(k) == "estimator" for k in bench.table["kind"]])]
    assert [text(m) for m in rows["model"]] == ["inverse_rigid", "inverse_quasi_rigid"]
    assert np.all(rows["steps"] == 0) and np.all(np.isnan(rows["dt_s"]))
    assert np.all(np.isfinite(rows["rms_error"]))
    assert "estimators read the records of fem N=8" in flat(bench.result.output)


def test_plot_is_a_png_that_decodes(bench):
    image = matplotlib.image.imread(bench.folder / "bench.png")
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    assert not list(bench.folder.glob(".*.tmp"))


def test_the_table_is_printed(bench):
    for label in ("fem dt×4", "modal k=4", "quasi_rigid", "inverse_rigid"):
        assert label in bench.result.output
    assert "wrote" in bench.result.output


def test_the_printed_table_fits_80_columns_with_every_figure_whole(bench):
    """At ``COLUMNS=80`` no line is wider, and every row's wall time (ms), ratio to rigid and steps, as stored in
    /bench, are whole words of the output."""
    lines = bench.result.output.splitlines()
    assert max(cell_len(line) for line in lines) <= WIDTH, bench.result.output
    words = bench.result.output.split()
    for row in bench.table:
        assert f"{row['wall_time_s'] * 1e3:.2f}" in words and f"{row['time_ratio_rigid']:.3g}" in words, text(row["label"])
        assert row["steps"] == 0 or str(row["steps"]) in words, text(row["label"])


# ------------------------------------------------------------------- bad input


def test_missing_case_exits_2_and_writes_nothing(tmp_path):
    result = CliRunner().invoke(bench_command, [str(tmp_path / "nope.yaml"), "-o", str(tmp_path / "b.h5"), "--plot", str(tmp_path / "b.png")])
    assert result.exit_code == 2
    assert "case file not found" in result.output
    assert list(tmp_path.iterdir()) == []


def test_invalid_case_exits_2_with_the_key_path_and_writes_nothing(tmp_path):
    data = small_impact()
    data["fem"]["elements"] = -3
    case = write_case(tmp_path, data)
    result = CliRunner().invoke(bench_command, [str(case), "-o", str(tmp_path / "b.h5"), "--plot", str(tmp_path / "b.png")])
    assert result.exit_code == 2
    assert "fem.elements" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.yaml"]


def test_single_body_case_exits_2(tmp_path):
    case = CASES / "rod_transient_half_sine.yaml"
    result = CliRunner().invoke(bench_command, [str(case), "-o", str(tmp_path / "b.h5")])
    assert result.exit_code == 2
    assert IMPACT_ONLY in result.output
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------- Pareto front on hand-made points


def test_pareto_front_of_a_staircase():
    """(1, 5), (2, 3), (3, 4), (4, 1): (3, 4) is beaten by (2, 3) on both; the rest are optimal."""
    assert list(pareto_mask([1, 2, 3, 4], [5, 3, 4, 1])) == [True, True, False, True]


def test_pareto_ties_in_time_keep_the_more_accurate():
    """Same time: the larger error is dominated (no faster, strictly worse); same error: the slower one is."""
    assert list(pareto_mask([1, 1, 2], [2, 1, 0.5])) == [False, True, True]
    assert list(pareto_mask([1, 2, 3], [1, 1, 0.5])) == [True, False, True]


def test_pareto_duplicates_are_both_optimal():
    """Identical points dominate neither each other."""
    assert list(pareto_mask([1, 1, 3], [2, 2, 1])) == [True, True, True]
    assert list(pareto_mask([1, 1, 0.5], [2, 2, 1])) == [False, False, True]


def test_pareto_nan_is_never_optimal_and_dominates_nothing():
    nan = math.nan
    assert list(pareto_mask([1, 2, nan, 4], [nan, 3, 0.1, 1])) == [False, True, False, True]
    assert list(pareto_mask([nan], [nan])) == [False]
    assert list(pareto_mask([], [])) == []


def test_pareto_zero_error_and_single_point():
    assert list(pareto_mask([5, 1], [0.0, 1.0])) == [True, True]
    assert list(pareto_mask([3], [0.2])) == [True]


def test_pareto_matches_brute_force_on_random_points():
    rng = np.random.default_rng(7)
    t = rng.integers(0, 6, 200).astype(float)
    e = rng.integers(0, 6, 200).astype(float)
    t[rng.random(200) < 0.1] = np.nan
    e[rng.random(200) < 0.1] = np.nan
    ok = ~(np.isnan(t) | np.isnan(e))
    expected = [
        bool(ok[i]) and not any(ok[j] and t[j] <= t[i] and e[j] <= e[i] and (t[j] < t[i] or e[j] < e[i]) for j in range(200))
        for i in range(200)
    ]
    assert list(pareto_mask(t, e)) == expected


def test_pareto_rejects_mismatched_shapes():
    with pytest.raises(ValueError, match="one length"):
        pareto_mask([1, 2], [1])


def test_plot_survives_zero_and_nan_errors(tmp_path):
    """A zero and a NaN error are drawn at the floor (a log axis shows neither); the PNG still decodes."""
    rows = [
        BenchRow(Configuration("rigid", "solve"), wall_times_s=(0.01,), peak_error=0.05),
        BenchRow(Configuration("fem", "solve", "elements", 8), wall_times_s=(0.1,), peak_error=0.0),
        BenchRow(Configuration("ann_x", "estimator"), wall_times_s=(0.001,), peak_error=math.nan),
        BenchRow(Configuration("modal", "solve", "modes", 2), status="failed", message="boom"),
    ]
    for row, optimal in zip(rows, pareto_mask([r.wall_time_s for r in rows], [r.peak_error for r in rows])):
        row.pareto = bool(optimal)
    outcome = BenchOutcome(SimpleNamespace(reference_description="hand-made"), rows, 1, 1.0, 10)
    path = plot_pareto(tmp_path / "p.png", outcome)
    assert matplotlib.image.imread(path).ndim == 3
