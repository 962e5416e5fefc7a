"""The verification figures (``femref figures``) show what they claim: the numbers drawn are asserted here."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from femref.cli import main
from femref.verification import fem_convergence, harmonic_against_exact, quasi_rigid_epsilon

PNG = b"\x89PNG\r\n\x1a\n"


def test_fem_convergence_orders():
    """Rod P1 order 2, rod P2 and beam Hermite order 4 (displacements against the exact solution)."""
    figure = fem_convergence()
    assert figure.png.startswith(PNG)
    assert figure.numbers["order_rod_p1"] == pytest.approx(2.0, abs=0.1)
    assert figure.numbers["order_rod_p2"] == pytest.approx(4.0, abs=0.2)
    assert figure.numbers["order_beam"] == pytest.approx(4.0, abs=0.2)


@pytest.mark.parametrize("body", ["rod", "beam"])
def test_harmonic_figure_fem_on_exact_and_quasi_rigid_close_at_low_lambda(body):
    """At β = 0.1, 1, 5: FEM (32 elements) within 1e-5 of exact up to λ = 3; quasi-rigid within 2e-3 up to λ = 0.5."""
    figure = harmonic_against_exact(body)
    assert figure.png.startswith(PNG)
    for beta in ("0.1", "1", "5"):
        assert figure.numbers[f"fem_error_beta_{beta}"] < 1e-5
        assert figure.numbers[f"quasi_rigid_error_lambda_0.5_beta_{beta}"] < 2e-3


def test_quasi_rigid_error_slope_in_epsilon():
    assert quasi_rigid_epsilon().numbers["slope"] == pytest.approx(2.0, abs=0.2)


def test_command_writes_every_figure(tmp_path: Path):
    result = CliRunner().invoke(main, ["figures", "-o", str(tmp_path)])
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["fem_convergence.png", "harmonic_beam.png", "harmonic_rod.png", "quasi_rigid_epsilon.png"]
    assert all((tmp_path / n).read_bytes().startswith(PNG) for n in names)
