"""Valid case files: parsing, filled defaults, built objects, and the resolved-YAML round trip."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydantic import ValidationError

from femref.core import profiles, signals
from femref.case import HarmonicCase, TransientCase, load_case, parse_case, resolved_yaml
from femref.case.profiles import length_average
from support.case_helpers import write_case

ROD_HARMONIC = """\
kind: harmonic
body:
  type: rod
  length: 16.0
  mass_per_length: {piecewise: {breaks: [-4.0, 4.0], values: [3000.0, 9000.0, 3000.0]}}
  axial_stiffness: 2.0e9
  axial_viscosity: 1.0e6
loads: {F2: 1.0}
frequency: {lambda: {start: 0.05, stop: 3.0, num: 60}}
models: [fem, exact, quasi_rigid, rigid]
"""

BEAM_TRANSIENT = """\
kind: transient
body:
  type: beam
  length: 17.0
  mass_per_length: 7000.0
  bending_stiffness: {linear: {left: 2.0e9, right: 3.0e9}}
  bending_viscosity: {table: {x: [-8.5, 0.0, 8.5], values: [1.0e6, 4.0e6, 1.0e6]}}
loads:
  N1: {half_sine: {amplitude: 1.0e5, duration: 0.15}}
  G2: {csv: {path: moment.csv, time_column: t, value_column: G}}
probes: {center: 0.0, front: 8.0}
time: {end: 0.5, dt: 1.0e-4}
"""

MOMENT_CSV = "t,G\n0.0,0.0\n0.1,2.5e4\n0.2,0.0\n"


@pytest.fixture
def beam_case_file(tmp_path: Path) -> Path:
    (tmp_path / "moment.csv").write_text(MOMENT_CSV)
    return write_case(tmp_path, BEAM_TRANSIENT)


def test_rod_harmonic_parses_with_defaults_filled(tmp_path: Path) -> None:
    case = load_case(write_case(tmp_path, ROD_HARMONIC))
    assert isinstance(case, HarmonicCase)
    assert case.body.type == "rod" and case.body.half_length == 8.0
    assert case.load_amplitudes() == {"F1": 0.0, "F2": 1.0}
    assert case.probes == {"left": -8.0, "center": 0.0, "right": 8.0}
    assert case.frequency.spacing == "linear"
    assert (case.fem.elements, case.fem.order, case.fem.grading, case.fem.fields, case.fem.field_stride) == (64, 2, 1.0, False, 1)
    assert case.models == ("fem", "exact", "quasi_rigid", "rigid")
    with pytest.raises(ValidationError, match="frozen"):
        case.body.length = 1.0  # type: ignore[misc]


def test_rod_profiles_and_lambda_axis(tmp_path: Path) -> None:
    """λ = ω l √(m̄/EA): with m̄ = (8·3000 + 8·9000)/16 = 6000 kg/m, EA = 2e9 N, l = 8 m."""
    case = load_case(write_case(tmp_path, ROD_HARMONIC))
    built = case.body.profiles()
    assert isinstance(built["mass_per_length"], profiles.Piecewise)
    assert built["stiffness"] is built["axial_stiffness"] and built["viscosity"] is built["axial_viscosity"]
    assert built["mass_per_length"](np.array([-6.0, 0.0, 6.0])).tolist() == [3000.0, 9000.0, 3000.0]
    assert case.body.mean_mass_per_length() == pytest.approx(6000.0, rel=1e-14)
    assert case.body.mass() == pytest.approx(96000.0, rel=1e-14)
    wave_time = 8.0 * math.sqrt(6000.0 / 2.0e9)
    omega = case.omega()
    assert omega.shape == (60,)
    assert omega[0] == pytest.approx(0.05 / wave_time, rel=1e-14)
    assert omega[-1] == pytest.approx(3.0 / wave_time, rel=1e-14)


def test_rod_harmonic_round_trips_through_resolved_yaml(tmp_path: Path) -> None:
    case = load_case(write_case(tmp_path, ROD_HARMONIC))
    text = resolved_yaml(case)
    resolved = yaml.safe_load(text)
    assert resolved["probes"] == {"left": -8.0, "center": 0.0, "right": 8.0}
    assert resolved["fem"]["order"] == 2 and resolved["loads"] == {"F1": 0.0, "F2": 1.0}
    assert resolved["body"]["mass_per_length"] == {"piecewise": {"breaks": [-4.0, 4.0], "values": [3000.0, 9000.0, 3000.0]}}
    again = load_case(write_case(tmp_path, text, "resolved.yaml"))
    assert again == case
    assert resolved_yaml(again) == text


def test_beam_transient_parses_with_defaults_filled(beam_case_file: Path) -> None:
    case = load_case(beam_case_file)
    assert isinstance(case, TransientCase)
    assert case.body.type == "beam"
    assert (case.time.end, case.time.dt, case.time.output_stride) == (0.5, 1.0e-4, 1)
    assert case.integrator.scheme == "generalized_alpha" and case.integrator.rho_inf == 0.8
    assert case.fem.order == 3  # Hermite cubics
    assert case.models == ("fem",)
    assert case.probes == {"center": 0.0, "front": 8.0}
    assert [name for name, _ in case.loads.items()] == ["N1", "N2", "G1", "G2"]
    assert case.loads.G2.path == beam_case_file.parent / "moment.csv"  # resolved, absolute


def test_beam_transient_builds_signals_and_profiles(beam_case_file: Path) -> None:
    case = load_case(beam_case_file)
    built = case.load_signals()
    assert isinstance(built["N1"], signals.HalfSine) and built["N1"].duration == 0.15
    assert isinstance(built["N2"], signals.Constant) and built["N2"].value == 0.0
    assert isinstance(built["G2"], signals.Tabulated)
    assert built["G2"](np.array([0.05, 0.1, 0.3])).tolist() == [1.25e4, 2.5e4, 0.0]
    stiffness = case.body.profiles()["stiffness"]
    assert isinstance(stiffness, profiles.Linear) and stiffness(np.array([0.0]))[0] == 2.5e9
    assert case.body.mean_stiffness() == pytest.approx(2.5e9, rel=1e-14)
    # table 1e6 → 4e6 → 1e6 over ±8.5 m: the length average is 2.5e6
    assert length_average(case.body.profiles()["viscosity"], 8.5) == pytest.approx(2.5e6, rel=1e-14)


def test_beam_transient_round_trips_from_another_directory(beam_case_file: Path, tmp_path: Path) -> None:
    case = load_case(beam_case_file)
    text = resolved_yaml(case)
    resolved = yaml.safe_load(text)
    assert resolved["integrator"] == {"scheme": "generalized_alpha", "rho_inf": 0.8}
    assert resolved["loads"]["N2"] == 0.0
    assert resolved["body"]["bending_stiffness"] == {"linear": {"left": 2.0e9, "right": 3.0e9}}
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    assert load_case(write_case(elsewhere, text)) == case


def test_generalized_alpha_gets_default_rho_inf() -> None:
    data = yaml.safe_load(BEAM_TRANSIENT.replace("moment.csv", "unused"))
    data["loads"] = {"N1": 1.0}
    data["integrator"] = {"scheme": "generalized_alpha"}
    case = parse_case(data)
    assert case.integrator.rho_inf == 0.8


def test_newmark_has_no_rho_inf() -> None:
    data = yaml.safe_load(BEAM_TRANSIENT.replace("moment.csv", "unused"))
    data["loads"] = {"N1": 1.0}
    data["integrator"] = {"scheme": "newmark"}
    case = parse_case(data)
    assert case.integrator.rho_inf is None


def test_frequency_axes_and_spacing() -> None:
    data = yaml.safe_load(ROD_HARMONIC)
    data["frequency"] = {"hz": {"start": 1.0, "stop": 100.0, "num": 3, "spacing": "log"}}
    assert parse_case(data).omega() == pytest.approx(2 * np.pi * np.array([1.0, 10.0, 100.0]), rel=1e-14)
    data["frequency"] = {"omega": {"start": 5.0, "stop": 5.0, "num": 1}}
    assert parse_case(data).omega().tolist() == [5.0]


def test_exact_serves_piecewise_rod_transient() -> None:
    data = yaml.safe_load(ROD_HARMONIC)
    del data["frequency"]
    data.update(kind="transient", time={"end": 0.1}, models=["fem", "exact", "rigid", "quasi_rigid"])
    data["loads"]["F1"] = {"ramp_step": {"amplitude": -2.0, "rise": 0.01}}
    case = parse_case(data)
    assert case.models == ("fem", "exact", "rigid", "quasi_rigid")
    assert case.time.dt is None


def test_yaml_1e9_reads_as_a_number(tmp_path: Path) -> None:
    case = load_case(write_case(tmp_path, ROD_HARMONIC.replace("2.0e9", "2e9")))
    assert case.body.axial_stiffness.value == 2.0e9
