"""Values no rail vehicle can have are refused at validation (femref.case.plausibility): ``femref run`` exits 2,
names the key and says the value is beyond (or below) any rail vehicle, and writes nothing."""

from __future__ import annotations

import copy

import pytest
import yaml
from click.testing import CliRunner

from femref.case import CaseError, parse_case
from femref.cli import main

IMPACT = {
    "kind": "impact",
    "cars": [
        {"name": "hammer", "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9}, "velocity": 2.0},
        {"name": "anvil", "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9}, "velocity": 0.0},
    ],
    "couplers": [{"between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
    "time": {"end": 0.3},
    "models": ["rigid"],
}


def _with(path: tuple, value) -> dict:
    data = copy.deepcopy(IMPACT)
    *head, last = path
    target = data
    for key in head:
        target = target[key]
    target[last] = value
    return data


def _run(tmp_path, data: dict):
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    out = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(out)])
    return result, out


PROBES = [
    # (id, key path in the case, value, key in the message, words in the message)
    ("EA 1e308", ("cars", 0, "body", "axial_stiffness"), 1e308, "cars[0].body.axial_stiffness", "beyond any rail vehicle"),
    ("EA 1 N", ("cars", 0, "body", "axial_stiffness"), 1.0, "cars[0].body.axial_stiffness", "below any rail vehicle"),
    ("EI 1e20", ("cars", 1, "body", "bending_stiffness"), 1e20, "cars[1].body.bending_stiffness", "beyond any rail vehicle"),
    ("mass 3.5e-9 kg/m", ("cars", 1, "body", "mass_per_length"), 3.5e-9, "cars[1].body.mass_per_length", "below any rail vehicle"),
    ("mass 1e9 kg/m", ("cars", 1, "body", "mass_per_length"), 1e9, "cars[1].body.mass_per_length", "beyond any rail vehicle"),
    ("density contrast 2.5e6", ("cars", 1, "body", "mass_per_length"), {"piecewise": {"breaks": [0.0], "values": [5.0e6, 2.0]}},
     "cars[1].body.mass_per_length", "span a factor"),
    ("stiffness contrast 1e7", ("cars", 0, "body", "axial_stiffness"), {"linear": {"left": 3.0e6, "right": 3.0e13}},
     "cars[0].body.axial_stiffness", "span a factor"),
    ("length 1e5 m", ("cars", 0, "body", "length"), 1e5, "cars[0].body.length", "beyond any rail vehicle"),
    ("length 1 mm", ("cars", 0, "body", "length"), 1e-3, "cars[0].body.length", "below any rail vehicle"),
    ("cA 1e20", ("cars", 0, "body", "axial_viscosity"), 1e20, "cars[0].body.axial_viscosity", "beyond any rail vehicle"),
    ("speed 1e308", ("cars", 0, "velocity"), 1e308, "cars[0].velocity", "beyond any rail vehicle"),
    ("speed -1e4", ("cars", 0, "velocity"), -1e4, "cars[0].velocity", "beyond any rail vehicle"),
    ("coupler stiffness 1e15", ("couplers", 0, "law"), {"kelvin_voigt": {"stiffness": 1e15}}, "couplers[0].law.kelvin_voigt.stiffness", "beyond any rail vehicle"),
    ("coupler stiffness 1 N/m", ("couplers", 0, "law"), {"kelvin_voigt": {"stiffness": 1.0}}, "couplers[0].law.kelvin_voigt.stiffness", "below any rail vehicle"),
    ("coupler damping 1e12", ("couplers", 0, "law"), {"kelvin_voigt": {"stiffness": 4e7, "damping": 1e12}}, "couplers[0].law.kelvin_voigt.damping",
     "beyond any rail vehicle"),
    ("gear stroke 100 m", ("couplers", 0, "law"), {"draft_gear": {"gear_stiffness": 1.7e7, "gear_damping": 2.5e5, "stroke": 100.0, "solid_stiffness": 1e8}},
     "couplers[0].law.draft_gear.stroke", "beyond any rail vehicle"),
    ("table force 1e12", ("couplers", 0, "law"), {"table": {"closure": [0.0, 0.1], "loading": [0.0, 1e12], "unloading": [0.0, 1e6]}},
     "couplers[0].law.table.loading[1]", "beyond any rail vehicle"),
    ("slack 1 km", ("couplers", 0, "slack"), 1000.0, "couplers[0].slack", "beyond any rail vehicle"),
    ("time.end 1e6 s", ("time",), {"end": 1e6}, "time.end", "beyond any rail vehicle"),
    ("time.dt 1e-12 s", ("time",), {"end": 0.3, "dt": 1e-12}, "time.dt", "below any rail vehicle"),
]


@pytest.mark.parametrize(("path", "value", "key", "words"), [p[1:] for p in PROBES], ids=[p[0] for p in PROBES])
def test_an_implausible_value_is_refused_by_femref_run(tmp_path, path, value, key, words):
    """Exit 2, the key path and the rule on stderr, no result file."""
    data = _with(path, value)
    if key.startswith("cars[1].body.bending_stiffness"):
        data["cars"][1]["body"]["bending_stiffness"] = value
    result, out = _run(tmp_path, data)
    assert result.exit_code == 2, result.output
    assert f"{key}:" in result.output and words in result.output, result.output
    assert not out.exists()


def test_the_message_quotes_the_rail_vehicle_range():
    with pytest.raises(CaseError, match=r"cars\[0\]\.body\.axial_stiffness: an axial stiffness EA of 1e308 N is beyond any rail vehicle "
                                        r"\(car bodies 1e8–1e11 N\); the plausible range is 1e5–1e14 N"):
        parse_case(_with(("cars", 0, "body", "axial_stiffness"), 1e308))


def test_a_harmonic_axis_of_a_billion_frequencies_is_refused(tmp_path):
    data = {"kind": "harmonic", "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2e9},
            "loads": {"F2": 1.0}, "frequency": {"lambda": {"start": 0.05, "stop": 3.0, "num": 1_000_000_000}}, "models": ["rigid"]}
    result, out = _run(tmp_path, data)
    assert result.exit_code == 2 and "frequency.lambda.num:" in result.output and "must be at most 1e+06" in result.output, result.output
    assert not out.exists()


EXTREMES = [
    ("bending stiffness ×1e-3, β 1e-6", {"bending_stiffness": 4.0e6, "bending_viscosity": 1e-6 * 72.25 * (7000.0 * 4.0e6) ** 0.5}),
    ("bending stiffness ×1e4, β 1e4", {"bending_stiffness": 4.0e13, "bending_viscosity": 1e4 * 72.25 * (7000.0 * 4.0e13) ** 0.5}),
    ("axial β 1e4", {"axial_viscosity": 1e4 * 8.5 * (7000.0 * 3.0e9) ** 0.5}),
    ("axial stiffness ×1e4", {"axial_stiffness": 3.0e13}),
    ("segment contrast 1e-3", {"mass_per_length": {"piecewise": {"breaks": [0.0], "values": [7000.0, 7.0]}}}),
    ("segment contrast 1e3", {"mass_per_length": {"piecewise": {"breaks": [0.0], "values": [7000.0, 7.0e6]}}}),
]


@pytest.mark.parametrize("body", [e[1] for e in EXTREMES], ids=[e[0] for e in EXTREMES])
def test_the_test_suites_extreme_studies_stay_plausible(body):
    """The studies the suite runs at extremes (tests/impact, tests/models) are not refused."""
    data = copy.deepcopy(IMPACT)
    data["cars"][1]["body"].update(body)
    parse_case(data)


@pytest.mark.parametrize("change", [
    {"velocity": 0.0}, {"velocity": 10.0}, {"velocity": -2.0},
])
def test_speeds_of_studies_stay_plausible(change):
    data = copy.deepcopy(IMPACT)
    data["cars"][0].update(change)
    parse_case(data)


@pytest.mark.parametrize("law", [{"kelvin_voigt": {"stiffness": 1e5, "damping": 0.0}}, {"kelvin_voigt": {"stiffness": 1e10, "damping": 1e6}}])
def test_coupler_extremes_of_studies_stay_plausible(law):
    parse_case(_with(("couplers", 0, "law"), law))


# --- end loads and harmonic frequencies of single-body cases ------------------------------------------

ROD = {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2e9}
BEAM = {"type": "beam", "length": 17.0, "mass_per_length": 7000.0, "bending_stiffness": 3e9}


def _harmonic(body: dict = ROD, loads: dict | None = None, frequency: dict | None = None) -> dict:
    return {"kind": "harmonic", "body": copy.deepcopy(body), "loads": loads or {"F2": 1.0e5},
            "frequency": frequency or {"hz": {"start": 0.5, "stop": 60.0, "num": 5}}, "models": ["rigid"]}


def _transient(body: dict = ROD, loads: dict | None = None) -> dict:
    return {"kind": "transient", "body": copy.deepcopy(body), "loads": loads or {"F2": {"half_sine": {"amplitude": -1.0e6, "duration": 0.05}}},
            "time": {"end": 0.1}, "models": ["rigid"]}


SINGLE_BODY_PROBES = [
    # (id, case, key in the message, words in the message)
    ("harmonic F2 1e12 N", _harmonic(loads={"F2": 1e12}), "loads.F2", "an end force of 1e12 N is beyond any rail vehicle"),
    ("harmonic G1 -1e13 N·m", _harmonic(BEAM, loads={"G1": -1e13}), "loads.G1", "an end moment of -1e13 N·m is beyond any rail vehicle"),
    ("constant F2 2e10 N", _transient(loads={"F2": 2e10}), "loads.F2", "beyond any rail vehicle"),
    ("half-sine amplitude 1e12 N", _transient(loads={"F2": {"half_sine": {"amplitude": 1e12, "duration": 0.05}}}),
     "loads.F2.half_sine.amplitude", "beyond any rail vehicle"),
    ("ramp level 5e11 N·m", _transient(BEAM, loads={"G2": {"ramp_step": {"amplitude": 5e11, "rise": 0.01}}}),
     "loads.G2.ramp_step.amplitude", "an end moment of 5e11 N·m is beyond any rail vehicle"),
    ("half-sine of 1 ns", _transient(loads={"F2": {"half_sine": {"amplitude": 1e6, "duration": 1e-9}}}),
     "loads.F2.half_sine.duration", "below any rail vehicle"),
    ("ramp rising for 12 days", _transient(loads={"F2": {"ramp_step": {"amplitude": 1e6, "rise": 1e6}}}),
     "loads.F2.ramp_step.rise", "beyond any rail vehicle"),
    ("hz stop 10 MHz", _harmonic(frequency={"hz": {"start": 1.0, "stop": 1e7, "num": 5}}), "frequency.hz.stop",
     "a frequency of 1e7 Hz is beyond any rail vehicle (structural modes of car bodies 1–200 Hz)"),
    ("omega start and stop 1e8 rad/s", _harmonic(frequency={"omega": {"start": 1e8, "stop": 2e8, "num": 5}}), "frequency.omega.start",
     "beyond any rail vehicle"),
    ("lambda stop 1e9", _harmonic(frequency={"lambda": {"start": 0.05, "stop": 1e9, "num": 5}}), "frequency.lambda.stop",
     "is ω = λ/T with its wave time"),
]


@pytest.mark.parametrize(("data", "key", "words"), [p[1:] for p in SINGLE_BODY_PROBES], ids=[p[0] for p in SINGLE_BODY_PROBES])
def test_an_implausible_load_or_frequency_is_refused_by_femref_run(tmp_path, data, key, words):
    """Exit 2, the key path, the rule and the rail-vehicle range, no result file."""
    result, out = _run(tmp_path, data)
    text = " ".join(result.output.split())
    assert result.exit_code == 2, result.output
    assert f"{key}:" in text and words in text and "rail vehicle" in text, text
    assert not out.exists()


def test_a_load_records_largest_value_is_bounded_and_its_row_named(tmp_path):
    """A CSV record peaking at -3e12 N: exit 2 at loads.F2.csv.path, naming the data row of the peak."""
    (tmp_path / "force.csv").write_text("time,force\n0.0,0.0\n0.01,-1.0e6\n0.02,-3.0e12\n0.03,0.0\n")
    data = _transient(loads={"F2": {"csv": {"path": "force.csv", "time_column": "time", "value_column": "force"}}})
    result, out = _run(tmp_path, data)
    text = " ".join(result.output.split())
    assert result.exit_code == 2, result.output
    assert "loads.F2.csv.path:" in text and "data row 3 (the largest |value|): an end force of -3e12 N is beyond any rail vehicle" in text, text
    assert not out.exists()


def test_a_negative_frequency_is_refused(tmp_path):
    """Below zero the axis's own rule answers (frequencies are > 0), also exit 2 at the key."""
    result, out = _run(tmp_path, _harmonic(frequency={"hz": {"start": -5.0, "stop": 60.0, "num": 5}}))
    assert result.exit_code == 2 and "frequency.hz.start: must be > 0" in result.output, result.output
    assert not out.exists()


def test_the_end_force_message_quotes_the_rail_vehicle_range():
    with pytest.raises(CaseError, match=r"loads\.F2\.half_sine\.amplitude: an end force of 1e12 N is beyond any rail vehicle "
                                        r"\(coupler and end forces 1e4–1e7 N\); the plausible range is 0–1e10 N"):
        parse_case(_transient(loads={"F2": {"half_sine": {"amplitude": 1e12, "duration": 0.05}}}))


@pytest.mark.parametrize("data", [
    _transient(loads={"F2": 0.0, "F1": 1e-3}),  # small and zero loads are fine
    _transient(loads={"F2": {"ramp_step": {"amplitude": -1e10, "rise": 0.0}}}),  # a step at the bound
    _transient(loads={"F2": {"half_sine": {"amplitude": 4e6, "duration": 1e-7}}}),
    _transient(loads={"F2": {"ramp_step": {"amplitude": 1e6, "rise": 1e5}}}),
    _transient(BEAM, loads={"G1": 1e11, "N2": 1e10}),
    _harmonic(frequency={"hz": {"start": 1e-3, "stop": 1e6, "num": 5}}),
    _harmonic(frequency={"omega": {"start": 1.0, "stop": 6.0e6, "num": 5}}),
    _harmonic(frequency={"lambda": {"start": 0.05, "stop": 3.0, "num": 5}}),
], ids=["small loads", "step of 1e10 N", "pulse of 0.1 µs", "ramp over 1e5 s", "beam at the bounds", "hz to 1 MHz", "omega to 6e6",
        "lambda to 3"])
def test_single_body_studies_stay_plausible(data):
    parse_case(data)
