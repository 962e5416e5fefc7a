"""Bad case files: each raises one CaseError whose message names the file, key path and rule."""

import math
import re
from pathlib import Path
from typing import Any

import pytest

from femref.case import CaseError, load_case
from support.case_helpers import DELETE, edited_copy, expect, load_bad

ROD_HARMONIC: dict[str, Any] = {
    "kind": "harmonic",
    "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9},
    "loads": {"F2": 1.0},
    "frequency": {"lambda": {"start": 0.05, "stop": 3.0, "num": 60}},
}
ROD_TRANSIENT: dict[str, Any] = {
    "kind": "transient",
    "body": {"type": "rod", "length": 16.0, "mass_per_length": 6250.0, "axial_stiffness": 2.0e9},
    "loads": {"F2": {"half_sine": {"amplitude": 1.0e6, "duration": 0.1}}},
    "time": {"end": 0.5},
}
BEAM_TRANSIENT: dict[str, Any] = {
    "kind": "transient",
    "body": {"type": "beam", "length": 17.0, "mass_per_length": 7000.0, "bending_stiffness": 3.0e9},
    "loads": {"N1": 1.0e5},
    "time": {"end": 0.5},
}
BASES = {"rod_harmonic": ROD_HARMONIC, "rod_transient": ROD_TRANSIENT, "beam_transient": BEAM_TRANSIENT}

def edited(base: str, edits: dict[str, Any]) -> dict[str, Any]:
    """A copy of a valid base case with ``edits`` (dotted key path → new value, or DELETE)."""
    return edited_copy(BASES[base], edits)


# (base, edits, key path, rule regex)
SCHEMA_CASES = {
    # unknown and missing keys
    "unknown key with hint": ("rod_harmonic", {"body.mass_per_lenght": 6250.0}, "body.mass_per_lenght", r"unknown key \(did you mean 'mass_per_length'\?\)"),
    "unknown top-level key": ("rod_harmonic", {"frequncy": {}}, "frequncy", r"unknown key \(did you mean 'frequency'\?\)"),
    "unknown key, no hint": ("rod_harmonic", {"colour": "red"}, "colour", r"unknown key; expected one of: kind, body"),
    "missing key": ("rod_harmonic", {"body.axial_stiffness": DELETE}, "body.axial_stiffness", "required key is missing"),
    "missing length": ("rod_harmonic", {"body.length": DELETE}, "body.length", "required key is missing"),
    "missing loads": ("rod_harmonic", {"loads": DELETE}, "loads", "required key is missing"),
    "missing frequency": ("rod_harmonic", {"frequency": DELETE}, "frequency", "required key is missing"),
    "missing time.end": ("rod_transient", {"time": {"dt": 0.001}}, "time.end", "required key is missing"),
    "harmonic key in a transient case": ("rod_transient", {"frequency": {"hz": {}}}, "frequency", "'frequency' is a harmonic-case key, not a transient-case key"),
    "unknown kind": ("rod_harmonic", {"kind": "modal"}, "kind", r"must be one of 'harmonic', 'transient', 'impact', 'measured'; got 'modal'"),
    "missing kind": ("rod_harmonic", {"kind": DELETE}, "kind", "required key is missing; one of: harmonic, transient"),
    "unknown body type": ("rod_harmonic", {"body.type": "shell"}, "body.type", r"must be one of 'rod', 'beam'; got 'shell'"),
    "missing body type": ("rod_harmonic", {"body.type": DELETE}, "body.type", "required key is missing"),
    "beam key on a rod": ("rod_harmonic", {"body.bending_stiffness": 1.0e9}, "body.bending_stiffness", "'bending_stiffness' is a beam key, not a rod key"),
    "rod key on a beam": ("beam_transient", {"body.axial_viscosity": 1.0e6}, "body.axial_viscosity", "'axial_viscosity' is a rod key, not a beam key"),
    # non-physical numbers
    "negative mass": ("rod_harmonic", {"body.mass_per_length": -6250.0}, "body.mass_per_length", r"must be > 0; got -6250\.0"),
    "zero length": ("rod_harmonic", {"body.length": 0.0}, "body.length", r"must be > 0; got 0\.0"),
    "NaN stiffness": ("rod_harmonic", {"body.axial_stiffness": math.nan}, "body.axial_stiffness", r"must be a finite number \(not NaN or infinity\); got nan"),
    "infinite length": ("rod_harmonic", {"body.length": math.inf}, "body.length", "must be a finite number"),
    "negative viscosity": ("rod_harmonic", {"body.axial_viscosity": -1.0}, "body.axial_viscosity", r"must be >= 0; got -1\.0"),
    "text with a unit": ("rod_harmonic", {"body.length": "16 m"}, "body.length", "must be a number; got '16 m'"),
    "boolean as a number": ("rod_harmonic", {"body.length": True}, "body.length", "must be a number, not true/false"),
    "mapping expected": ("rod_harmonic", {"body": 5}, "body", "must be a mapping of keys; got 5"),
    # profiles
    "breaks outside the body": (
        "rod_harmonic",
        {"body.mass_per_length": {"piecewise": {"breaks": [-9.0, 4.0], "values": [3000.0, 9000.0, 3000.0]}}},
        "body.mass_per_length.piecewise.breaks",
        re.escape("must lie strictly inside the body (-8.0, 8.0); got [-9.0, 4.0]"),
    ),
    "break on the body end": (
        "rod_harmonic",
        {"body.axial_stiffness": {"piecewise": {"breaks": [8.0], "values": [1.0e9, 2.0e9]}}},
        "body.axial_stiffness.piecewise.breaks",
        "must lie strictly inside the body",
    ),
    "unsorted breaks": (
        "rod_harmonic",
        {"body.mass_per_length": {"piecewise": {"breaks": [4.0, -4.0], "values": [3000.0, 9000.0, 3000.0]}}},
        "body.mass_per_length.piecewise.breaks",
        r"must increase strictly; got \[4\.0, -4\.0\]",
    ),
    "values/breaks count mismatch": (
        "rod_harmonic",
        {"body.mass_per_length": {"piecewise": {"breaks": [-4.0, 4.0], "values": [3000.0, 9000.0]}}},
        "body.mass_per_length.piecewise.values",
        r"must have one value per piece: len\(breaks\) \+ 1 = 3 entries, not 2",
    ),
    "negative piecewise value": (
        "rod_harmonic",
        {"body.mass_per_length": {"piecewise": {"breaks": [0.0], "values": [3000.0, -1.0]}}},
        "body.mass_per_length.piecewise.values[1]",
        r"must be > 0; got -1\.0",
    ),
    "table x outside the body": (
        "rod_harmonic",
        {"body.axial_viscosity": {"table": {"x": [-8.0, 0.0, 8.5], "values": [1.0, 4.0, 1.0]}}},
        "body.axial_viscosity.table.x",
        re.escape("must lie within the body [-8.0, 8.0]; got [-8.0, 0.0, 8.5]"),
    ),
    "table count mismatch": (
        "rod_harmonic",
        {"body.axial_viscosity": {"table": {"x": [-8.0, 8.0], "values": [1.0, 4.0, 1.0]}}},
        "body.axial_viscosity.table.values",
        "must have one value per position",
    ),
    "linear profile reaching zero": ("rod_harmonic", {"body.axial_stiffness": {"linear": {"left": 1.0e9, "right": 0.0}}}, "body.axial_stiffness.linear.right", "must be > 0"),
    "misspelt profile kind": ("rod_harmonic", {"body.axial_stiffness": {"lineer": {"left": 1.0, "right": 2.0}}}, "body.axial_stiffness.lineer", r"unknown profile kind \(did you mean 'linear'\?\)"),
    "two profile kinds at once": (
        "rod_harmonic",
        {"body.axial_stiffness": {"linear": {"left": 1.0, "right": 2.0}, "table": {"x": [0, 1], "values": [1, 1]}}},
        "body.axial_stiffness",
        "give exactly one of piecewise, linear, table; got linear and table together",
    ),
    # loads
    "beam loads on a rod": ("rod_harmonic", {"loads.G1": 5.0}, "loads.G1", "G1 is a beam load; a rod takes F1, F2"),
    "rod load on a beam": ("beam_transient", {"loads.F1": 5.0}, "loads.F1", "F1 is a rod load; a beam takes N1, N2, G1, G2"),
    "all loads zero": ("rod_harmonic", {"loads": {"F1": 0.0}}, "loads", "all end loads are zero"),
    "half-sine of zero duration": ("rod_transient", {"loads.F2": {"half_sine": {"amplitude": 1.0, "duration": 0.0}}}, "loads.F2.half_sine.duration", "must be > 0"),
    "ramp starting before t = 0": ("rod_transient", {"loads.F2": {"ramp_step": {"amplitude": 1.0, "rise": 0.1, "start": -0.1}}}, "loads.F2.ramp_step.start", "must be >= 0"),
    "unknown signal kind": ("rod_transient", {"loads.F2": {"halfsine": {"amplitude": 1.0}}}, "loads.F2.halfsine", r"unknown signal kind \(did you mean 'half_sine'\?\)"),
    # probes
    "probe outside the body": ("rod_harmonic", {"probes": {"front": 9.0}}, "probes.front", re.escape("must lie on the body, within [-8.0, 8.0]; got 9.0")),
    "probe name with a slash": ("rod_harmonic", {"probes": {"car/front": 1.0}}, "probes.car/front", "probe names use letters, digits"),
    # time and integrator
    "dt zero": ("rod_transient", {"time.dt": 0.0}, "time.dt", r"must be > 0; got 0\.0"),
    "dt negative": ("rod_transient", {"time.dt": -1.0e-4}, "time.dt", "must be > 0"),
    "dt longer than end": ("rod_transient", {"time.dt": 1.0}, "time.dt", r"must not exceed time\.end \(0\.5\); got 1\.0"),
    "end zero": ("rod_transient", {"time.end": 0.0}, "time.end", "must be > 0"),
    "output stride zero": ("rod_transient", {"time.output_stride": 0}, "time.output_stride", "must be >= 1"),
    "unknown integrator": ("rod_transient", {"integrator": {"scheme": "rk4"}}, "integrator.scheme", "must be one of 'newmark' or 'generalized_alpha'"),
    "rho_inf with newmark": ("rod_transient", {"integrator": {"scheme": "newmark", "rho_inf": 0.5}}, "integrator.rho_inf", "applies to scheme generalized_alpha only"),
    "rho_inf above one": ("rod_transient", {"integrator": {"scheme": "generalized_alpha", "rho_inf": 1.5}}, "integrator.rho_inf", "must be <= 1"),
    # frequency axis
    "stop below start": ("rod_harmonic", {"frequency": {"omega": {"start": 10.0, "stop": 5.0, "num": 10}}}, "frequency.omega.stop", r"must be greater than start \(10\.0\): the range is empty"),
    "num zero": ("rod_harmonic", {"frequency": {"omega": {"start": 1.0, "stop": 5.0, "num": 0}}}, "frequency.omega.num", "must be >= 1; got 0"),
    "num not an integer": ("rod_harmonic", {"frequency": {"hz": {"start": 1.0, "stop": 5.0, "num": 2.5}}}, "frequency.hz.num", "must be an integer"),
    "start zero": ("rod_harmonic", {"frequency": {"hz": {"start": 0.0, "stop": 5.0, "num": 5}}}, "frequency.hz.start", "must be > 0"),
    "single point with num > 1": ("rod_harmonic", {"frequency": {"hz": {"start": 5.0, "stop": 5.0, "num": 3}}}, "frequency.hz.num", "must be 1 when stop equals start"),
    "num 1 with stop above start": ("rod_harmonic", {"frequency": {"hz": {"start": 5.0, "stop": 6.0, "num": 1}}}, "frequency.hz.stop", "must equal start when num is 1"),
    "two frequency axes": (
        "rod_harmonic",
        {"frequency": {"omega": {"start": 1.0, "stop": 2.0, "num": 2}, "hz": {"start": 1.0, "stop": 2.0, "num": 2}}},
        "frequency",
        "give exactly one of omega, hz, lambda; got omega and hz together",
    ),
    "no frequency axis": ("rod_harmonic", {"frequency": {}}, "frequency", "give exactly one of omega, hz, lambda; got an empty mapping"),
    "bad spacing": ("rod_harmonic", {"frequency.lambda.spacing": "geometric"}, "frequency.lambda.spacing", "must be one of 'linear' or 'log'"),
    # fem
    "zero elements": ("rod_harmonic", {"fem": {"elements": 0}}, "fem.elements", "must be >= 1"),
    "grading below one": ("rod_harmonic", {"fem": {"grading": 0.5}}, "fem.grading", "must be >= 1"),
    "order 3 on a rod": ("rod_harmonic", {"fem": {"order": 3}}, "fem.order", r"a rod uses order 1 \(P1\) or 2 \(P2\)"),
    "order on a beam": ("beam_transient", {"fem": {"order": 2}}, "fem.order", "a beam always uses Hermite cubic elements"),
    # models
    "exact for a linear profile": (
        "rod_harmonic",
        {"body.axial_stiffness": {"linear": {"left": 2.0e9, "right": 3.0e9}}, "models": ["fem", "exact"]},
        "models[1]",
        "exact cannot serve this case: it needs piecewise-constant profiles .* body.axial_stiffness is linear",
    ),
    "exact for a transient beam": ("beam_transient", {"models": ["exact"]}, "models[0]", "exact cannot serve this case: the exact time-domain solution exists for rods only"),
    "quasi_rigid for an uneven beam": (
        "beam_transient",
        {"body.mass_per_length": {"linear": {"left": 5000.0, "right": 7000.0}}, "models": ["fem", "quasi_rigid"]},
        "models[1]",
        "quasi_rigid cannot serve this case: the quasi-rigid beam needs even profiles .* body.mass_per_length is not even",
    ),
    "modal outside impacts": ("rod_harmonic", {"models": ["fem", "modal"]}, "models[1]", r"modal cannot serve this case: it serves impact cases only"),
    "ann outside impacts": ("rod_transient", {"models": ["ann"]}, "models[0]", r"ann cannot serve this case: it serves impact cases only"),
    "unknown model name": ("rod_harmonic", {"models": ["fem", "rigd"]}, "models[1]", r"unknown model \(did you mean 'rigid'\?\); known models: fem, exact"),
    "model listed twice": ("rod_harmonic", {"models": ["fem", "rigid", "fem"]}, "models[2]", "is listed twice"),
    "no models": ("rod_harmonic", {"models": []}, "models", "must list at least one model"),
    "models not a list": ("rod_harmonic", {"models": "fem"}, "models", "must be a list"),
}


@pytest.mark.parametrize(("base", "edits", "key_path", "rule"), list(SCHEMA_CASES.values()), ids=list(SCHEMA_CASES))
def test_schema_rule(tmp_path: Path, base: str, edits: dict[str, Any], key_path: str, rule: str) -> None:
    error = load_bad(tmp_path, edited(base, edits))
    assert re.search(expect(key_path, rule), str(error)), str(error)
    assert key_path in {p.key_path for p in error.problems}


def test_error_attributes_and_message_format(tmp_path: Path) -> None:
    data = edited("rod_harmonic", {"body.mass_per_length": {"piecewise": {"breaks": [-9.0, 4.0], "values": [3000.0, 9000.0, 3000.0]}}})
    error = load_bad(tmp_path, data)
    assert isinstance(error, ValueError)
    assert (error.key_path, error.rule, error.value) == (
        "body.mass_per_length.piecewise.breaks",
        "must lie strictly inside the body (-8.0, 8.0)",
        [-9.0, 4.0],
    )
    assert str(error) == f"{error.source}: body.mass_per_length.piecewise.breaks: must lie strictly inside the body (-8.0, 8.0); got [-9.0, 4.0]"


def test_several_problems_come_in_one_error(tmp_path: Path) -> None:
    data = edited("rod_transient", {"body.length": -1.0, "body.axial_stiffness": math.inf, "time.dt": 0.0, "fem": {"elements": 0}, "colour": 1})
    error = load_bad(tmp_path, data)
    assert {p.key_path for p in error.problems} == {"body.length", "body.axial_stiffness", "time.dt", "fem.elements", "colour"}
    assert len(str(error).splitlines()) == 5


# CSV load histories, checked when the case is loaded


def csv_case(tmp_path: Path, csv_text: str | None, **columns: Any) -> CaseError:
    if csv_text is not None:
        (tmp_path / "force.csv").write_text(csv_text)
    data = edited("rod_transient", {"loads.F2": {"csv": {"path": "force.csv", **columns}}})
    return load_bad(tmp_path, data)


@pytest.mark.parametrize(
    ("csv_text", "columns", "rule"),
    [
        (None, {}, "CSV file .*force.csv does not exist"),
        ("", {}, "CSV file .*force.csv is empty"),
        ("time,force\n", {}, "CSV file .*force.csv has no data rows"),
        ("0.0,1.0\n0.2,2.0\n0.1,3.0\n", {}, "CSV file .*force.csv: time must increase strictly; data row 3 has t = 0.1 after t = 0.2"),
        ("0.0,1.0\n0.0,2.0\n", {}, "CSV file .*force.csv: time must increase strictly; data row 2 has t = 0.0 after t = 0.0"),
        ("0.0,1.0\n0.1,lots\n", {}, "CSV file .*force.csv, line 2: expected numbers"),
        ("0.0,1.0\n0.1,nan\n", {}, "CSV file .*force.csv: value in data row 2 is not a finite number"),
        ("0.0,1.0\n", {}, "CSV file .*force.csv needs two or more samples, has 1"),
        ("t,F\n0.0,1.0\n0.1,2.0\n", {"value_column": "G"}, "CSV file .*force.csv has no column 'G'"),
    ],
    ids=["missing", "empty", "header only", "time decreasing", "time repeated", "not a number", "nan", "one sample", "unknown column"],
)
def test_csv_rule(tmp_path: Path, csv_text: str | None, columns: dict[str, Any], rule: str) -> None:
    error = csv_case(tmp_path, csv_text, **columns)
    assert re.search(expect("loads.F2.csv.path", rule), str(error)), str(error)


def test_csv_negative_column_index(tmp_path: Path) -> None:
    error = csv_case(tmp_path, "0.0,1.0\n0.1,2.0\n", time_column=-1)
    assert re.search(expect("loads.F2.csv.time_column", "must be a column name or a 0-based column index"), str(error))


# Files and YAML


def write_text(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "case.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "rule"),
    [
        ("- kind: harmonic\n- body: {}\n", r"a case must be a mapping of keys \(kind, body, loads, \.\.\.\), not a list"),
        ("42\n", "a case must be a mapping of keys .*, not a single int value; got 42"),
        ("just some words\n", "a case must be a mapping of keys .*, not a single str value"),
        ("", "the case is empty"),
        ("kind: harmonic\nbody: {type: rod\n", "YAML syntax error at line 3, column 1: expected ',' or '}'"),
        ("kind: harmonic\n  body: 3\n", "YAML syntax error at line 2"),
        ("kind: harmonic\nkind: transient\n", "YAML syntax error at line 2, column 1: found duplicate key 'kind'"),
    ],
    ids=["list", "scalar", "text", "empty", "unclosed brace", "bad indentation", "duplicate key"],
)
def test_yaml_rule(tmp_path: Path, text: str, rule: str) -> None:
    path = write_text(tmp_path, text)
    with pytest.raises(CaseError, match=rf"^{re.escape(str(path))}: {rule}"):
        load_case(path)


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.yaml"
    with pytest.raises(CaseError, match=rf"^{re.escape(str(path))}: case file not found$"):
        load_case(path)


def test_directory_instead_of_file(tmp_path: Path) -> None:
    with pytest.raises(CaseError, match="cannot read the case file"):
        load_case(tmp_path)


def test_binary_file(tmp_path: Path) -> None:
    path = tmp_path / "case.yaml"
    path.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(CaseError, match="not a text"):
        load_case(path)
