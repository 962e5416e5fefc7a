"""Bad impact cases: each raises one CaseError whose message names the key path and the rule.

One test per rule of the ``kind: impact`` schema (femref.case.impact), on edits of one valid
three-car case; then several problems in one error, and the command line (exit code 2,
nothing written).
"""

import math
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner

from femref.case import parse_case
from femref.cli import main
from support.case_helpers import DELETE, edited_copy, expect, load_bad

TABLE_LAW = {"closure": [0.0, 0.02, 0.05, 0.08], "loading": [0.0, 2.0e5, 1.2e6, 2.5e6], "unloading": [0.0, 5.0e4, 4.0e5, 1.5e6]}
DRAFT_GEAR = {"gear_stiffness": 3.4e7, "gear_damping": 5.0e5, "stroke": 0.0825, "solid_stiffness": 2.0e8}

#: A valid case: hammer → anvil → wagon, a Kelvin-Voigt coupler and a table coupler.
BASE: dict[str, Any] = {
    "kind": "impact",
    "cars": [
        {
            "name": "hammer",
            "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6},
            "velocity": 2.2,
            "sensors": {"center": 0.0, "front": 8.0},
        },
        {
            "name": "anvil",
            "body": {"type": "rod", "length": 15.0, "mass_per_length": 6500.0, "axial_stiffness": 3.0e9},
            "velocity": 0.0,
            "sensors": {"center": 0.0},
        },
        {
            "name": "wagon",
            "body": {"type": "rod", "length": 16.0, "mass_per_length": 6000.0, "axial_stiffness": 3.0e9},
            "velocity": 0.0,
            "sensors": {"rear": -7.0, "center": 0.0},
        },
    ],
    "couplers": [
        {"name": "c1", "between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}},
        {"name": "c2", "between": ["anvil", "wagon"], "law": {"table": TABLE_LAW}, "contact": "bilateral"},
    ],
    "time": {"end": 0.5},
    "models": ["fem", "quasi_rigid", "rigid"],
}

def edited(edits: dict[str, Any]) -> dict[str, Any]:
    """A copy of BASE with ``edits`` (dotted key path, list indices as numbers → new value, or DELETE)."""
    return edited_copy(BASE, edits)


def test_base_case_is_valid() -> None:
    assert parse_case(edited({})).car_names == ["hammer", "anvil", "wagon"]


def table(**changes: Any) -> dict[str, Any]:
    return {"table": {**TABLE_LAW, **changes}}


# (edits, key path, rule regex)
RULES = {
    # cars
    "fewer than 2 cars": ({"cars": [BASE["cars"][0]], "couplers": DELETE}, "cars", r"an impact needs at least 2 cars, in line order \(rear to front\); got 1"),
    "duplicate car names": ({"cars.2.name": "hammer"}, "cars[2].name", "duplicate car name; 'hammer' is already used at index 0"),
    "car name with a slash": ({"cars.0.name": "car/1"}, "cars[0].name", "car names use letters, digits, '_', '-' and '.' only"),
    "beam body": (
        {"cars.1.body": {"type": "beam", "length": 15.0, "mass_per_length": 6500.0, "bending_stiffness": 3.0e9}},
        "cars[1].body.type",
        r"impact cars are rods \(type: rod\); a car that bends is a rod with bending_stiffness \(and bending_viscosity\); got 'beam'",
    ),
    "body type missing": ({"cars.1.body.type": DELETE}, "cars[1].body.type", r"required key is missing; impact cars are rods \(type: rod\)"),
    "bending viscosity of a car that does not bend": ({"cars.1.body.bending_viscosity": 1.0e5}, "cars[1].body.bending_viscosity", r"needs bending_stiffness: a car without it does not bend"),
    "coupler offset of a car that does not bend": ({"cars.1.coupler_offset": [0.6, 0.6]}, "cars[1].coupler_offset", r"a coupler offset bends the car: give the body a bending_stiffness"),
    "quasi_rigid on an uneven car that bends": ({"cars.0.body.bending_stiffness": {"linear": {"left": 1.0e10, "right": 2.0e10}},
                                                 "models": ["fem", "quasi_rigid"]}, "models[1]",
                                                r"quasi_rigid cannot serve this case: the quasi-rigid beam needs even profiles m\(x\), EI\(x\), cI\(x\), but car hammer's body.bending_stiffness is not even in x"),
    "inclined coupler without pivots": ({"couplers.0.vertical_offset": 0.03}, "couplers[0].pivot_distance",
                                        r"required with a vertical_offset: the coupler's inclination is offset / pivot_distance"),
    "inclined coupler on cars that do not bend": ({"couplers.0.vertical_offset": 0.03, "couplers.0.pivot_distance": 1.8}, "couplers[0].vertical_offset",
                                                  r"an inclined coupler pushes its cars vertically: cars hammer, anvil need a bending_stiffness"),
    "vertical tolerance without a car that bends": ({"tolerance": {"value": 0.1, "output": "vertical_acceleration"}}, "tolerance.output",
                                                    r"no car bends: vertical accelerations are recorded on cars with a bending_stiffness"),
    "coupler offset beyond the car": ({"cars.1.body.bending_stiffness": 1.0e10, "cars.1.coupler_offset": [0.6, 9.0]}, "cars[1].coupler_offset", r"must be shorter than the car's half-length"),
    "velocity not finite": ({"cars.0.velocity": math.inf}, "cars[0].velocity", r"must be a finite number \(not NaN or infinity\); got inf"),
    "velocity NaN": ({"cars.0.velocity": math.nan}, "cars[0].velocity", "must be a finite number"),
    "velocity missing": ({"cars.0.velocity": DELETE}, "cars[0].velocity", "required key is missing"),
    "sensor outside the car": ({"cars.0.sensors.front": 9.0}, "cars[0].sensors.front", re.escape("must lie on the car, |x| <= l = 8.5 m (within [-8.5, 8.5]); got 9.0")),
    "sensor behind the car": ({"cars.2.sensors.rear": -8.5}, "cars[2].sensors.rear", re.escape("must lie on the car, |x| <= l = 8.0 m")),
    "no sensors": ({"cars.1.sensors": {}}, "cars[1].sensors", "must name at least one sensor"),
    "unknown car key": ({"cars.0.speed": 2.0}, "cars[0].speed", "unknown key; expected one of: name, body, velocity, sensors"),
    # couplers: names and pairs
    "no couplers": ({"couplers": []}, "couplers", "an impact needs at least one coupler"),
    "couplers missing": ({"couplers": DELETE}, "couplers", "required key is missing"),
    "unknown car in between": ({"couplers.0.between": ["hammer", "anvl"]}, "couplers[0].between[1]", r"unknown car \(did you mean 'anvil'\?\); cars: hammer, anvil, wagon; got 'anvl'"),
    "between with three names": ({"couplers.0.between": ["hammer", "anvil", "wagon"]}, "couplers[0].between", r"must be a list of two car names in line order, \[rear, front\]"),
    "between a single name": ({"couplers.0.between": "hammer"}, "couplers[0].between", r"must be a list of two car names"),
    "non-neighbour couplers": (
        {"couplers.0.between": ["hammer", "wagon"]},
        "couplers[0].between",
        re.escape("hammer (cars[0]) and wagon (cars[2]) are not neighbours; a coupler joins [cars[i], cars[i+1]]: one of [hammer, anvil], [anvil, wagon]"),
    ),
    "reversed order": (
        {"couplers.0.between": ["anvil", "hammer"]},
        "couplers[0].between",
        re.escape("lists the cars in reverse order; the rear car comes first, in line order: [hammer, anvil]"),
    ),
    "same car twice": ({"couplers.0.between": ["anvil", "anvil"]}, "couplers[0].between", "names the same car twice"),
    "two couplers on one pair": (
        {"couplers.1.between": ["hammer", "anvil"]},
        "couplers[1].between",
        re.escape("cars hammer and anvil already have a coupler (couplers[0]); one coupler per pair"),
    ),
    "duplicate coupler names": ({"couplers.1.name": "c1"}, "couplers[1].name", "duplicate coupler name; 'c1' is already used at index 0"),
    "default name taken": ({"couplers.0.name": "c2", "couplers.1.name": DELETE}, "couplers[1].name", "duplicate coupler name; 'c2' is already used at index 0"),
    # coupler laws
    "negative stroke": ({"couplers.0.law": {"draft_gear": {**DRAFT_GEAR, "stroke": -0.08}}}, "couplers[0].law.draft_gear.stroke", r"must be > 0; got -0\.08"),
    "draft gear missing key": ({"couplers.0.law": {"draft_gear": {"gear_stiffness": 3.4e7}}}, "couplers[0].law.draft_gear.stroke", "required key is missing"),
    "zero stiffness": ({"couplers.0.law.kelvin_voigt.stiffness": 0.0}, "couplers[0].law.kelvin_voigt.stiffness", "must be > 0"),
    "negative damping": ({"couplers.0.law.kelvin_voigt.damping": -1.0}, "couplers[0].law.kelvin_voigt.damping", "must be >= 0"),
    "law with no key": ({"couplers.0.law": {}}, "couplers[0].law", "give exactly one of kelvin_voigt, draft_gear, table, power_law, friction_gear; got an empty mapping"),
    "law with two keys": (
        {"couplers.0.law": {"kelvin_voigt": {"stiffness": 4.0e7}, "draft_gear": DRAFT_GEAR}},
        "couplers[0].law",
        "give exactly one of kelvin_voigt, draft_gear, table, power_law, friction_gear; got kelvin_voigt and draft_gear together",
    ),
    "unknown law name": ({"couplers.0.law": {"kelvin_voight": {"stiffness": 4.0e7}}}, "couplers[0].law.kelvin_voight", r"unknown coupler law \(did you mean 'kelvin_voigt'\?\)"),
    "law as a number": ({"couplers.0.law": 4.0e7}, "couplers[0].law", "must be a mapping with exactly one key out of kelvin_voigt, draft_gear, table, power_law, friction_gear"),
    # table law
    "table of one point": (
        {"couplers.1.law": {"table": {"closure": [0.0], "loading": [0.0], "unloading": [0.0]}}},
        "couplers[1].law.table.closure",
        "must have at least 2 entries",
    ),
    "table closure not from 0": ({"couplers.1.law": table(closure=[0.01, 0.02, 0.05, 0.08])}, "couplers[1].law.table.closure[0]", "must be 0: the table starts at zero closure"),
    "table closure not increasing": ({"couplers.1.law": table(closure=[0.0, 0.05, 0.05, 0.08])}, "couplers[1].law.table.closure", "must increase strictly"),
    "table loading length": ({"couplers.1.law": table(loading=[0.0, 2.0e5, 1.2e6])}, "couplers[1].law.table.loading", "must have one force per closure point: 4 entries, not 3"),
    "table unloading length": ({"couplers.1.law": table(unloading=[0.0, 5.0e4])}, "couplers[1].law.table.unloading", "must have one force per closure point: 4 entries, not 2"),
    "table loading not from 0": ({"couplers.1.law": table(loading=[1.0e3, 2.0e5, 1.2e6, 2.5e6])}, "couplers[1].law.table.loading[0]", "must be 0: no force at zero closure"),
    "table unloading not from 0": ({"couplers.1.law": table(unloading=[1.0, 5.0e4, 4.0e5, 1.5e6])}, "couplers[1].law.table.unloading[0]", "must be 0: no force at zero closure"),
    "table loading decreasing": ({"couplers.1.law": table(loading=[0.0, 2.0e5, 1.0e5, 2.5e6])}, "couplers[1].law.table.loading", "must not decrease"),
    "table unloading negative": ({"couplers.1.law": table(unloading=[0.0, -5.0e4, 4.0e5, 1.5e6])}, "couplers[1].law.table.unloading[1]", "must be >= 0"),
    "table unloading above loading": (
        {"couplers.1.law": table(unloading=[0.0, 3.0e5, 4.0e5, 1.5e6])},
        "couplers[1].law.table.unloading[1]",
        r"must not exceed loading\[1\] = 200000\.0: unloading lies below loading",
    ),
    "table that carries no force": (
        {"couplers.1.law": table(loading=[0.0, 0.0, 0.0, 0.0], unloading=[0.0, 0.0, 0.0, 0.0])},
        "couplers[1].law.table.loading",
        "must rise above 0",
    ),
    "table curves crossing beyond the last point": (
        {"couplers.1.law": table(unloading=[0.0, 5.0e4, 4.0e5, 2.4e6])},
        "couplers[1].law.table.unloading",
        "beyond the last closure the curves continue with their last slopes",
    ),
    "table negative damping": ({"couplers.1.law": table(damping=-1.0)}, "couplers[1].law.table.damping", "must be >= 0"),
    "table zero switch velocity": ({"couplers.1.law": table(switch_velocity=0.0)}, "couplers[1].law.table.switch_velocity", "must be > 0"),
    # contact and slack
    "tension_slack with compression_only": ({"couplers.0.tension_slack": 0.01}, "couplers[0].tension_slack", "applies to bilateral contact only; compression_only never transmits tension"),
    "negative slack": ({"couplers.0.slack": -0.01}, "couplers[0].slack", "must be >= 0"),
    "unknown contact": ({"couplers.0.contact": "coupled"}, "couplers[0].contact", "must be one of 'compression_only' or 'bilateral'"),
    # models
    "unknown fidelity in a models mapping": ({"models": ["fem", {"name": "mix", "fidelity": "rigd"}]}, "models[1].fidelity", r"unknown fidelity \(did you mean 'rigid'\?\); a car is one of fem, modal, quasi_rigid, rigid"),
    "unknown fidelity in an override": ({"models": ["fem", {"name": "mix", "fidelity": "rigid", "cars": {"anvil": "exact"}}]}, "models[1].cars.anvil", "unknown fidelity; a car is one of"),
    "override naming an unknown car": ({"models": ["fem", {"name": "mix", "fidelity": "rigid", "cars": {"anvl": "fem"}}]}, "models[1].cars.anvl", r"unknown car \(did you mean 'anvil'\?\); cars: hammer, anvil, wagon"),
    "duplicate run names": ({"models": ["fem", {"name": "mix", "fidelity": "rigid"}, {"name": "mix", "fidelity": "fem"}]}, "models[2]", "duplicate run name; 'mix' is already used at index 1"),
    "model listed twice": ({"models": ["fem", "rigid", "fem"]}, "models[2]", "duplicate run name; 'fem' is already used at index 0"),
    "mixed run named like a model": (
        {"models": ["fem", {"name": "rigid", "fidelity": "rigid", "cars": {"anvil": "fem"}}]},
        "models[1].name",
        "'rigid' names the uniform rigid run; give a mixed run another name",
    ),
    "run named exact": ({"models": ["fem", {"name": "exact", "fidelity": "fem"}]}, "models[1].name", "'exact' is a reserved result-group name"),
    "run named scene": ({"models": ["fem", {"name": "scene", "fidelity": "fem"}]}, "models[1].name", "'scene' is a reserved result-group name"),
    "run named ann_": ({"models": ["fem", {"name": "ann_mlp", "fidelity": "fem"}]}, "models[1].name", "names starting with 'ann_' are reserved"),
    "run without a name": ({"models": ["fem", {"fidelity": "rigid"}]}, "models[1].name", "required key is missing"),
    "run neither name nor mapping": ({"models": ["fem", 3]}, "models[1]", r"must be a model name or a mapping \{name, fidelity, cars\}"),
    "unknown model": ({"models": ["fem", "rigd"]}, "models[1]", r"unknown model \(did you mean 'rigid'\?\)"),
    "no models": ({"models": []}, "models", "must list at least one model run"),
    "exact refused": (
        {"models": ["fem", "exact"]},
        "models[1]",
        re.escape("exact cannot serve this case: no exact solution is implemented for impact scenes (nonlinear contact); score against fem"),
    ),
    "ann refused": (
        {"models": ["ann", "fem"]},
        "models[0]",
        re.escape("ann cannot serve this case: a network is an estimator on the fem sensor records, not a model run; list it under estimators:"),
    ),
    # settings
    "lowpass at Nyquist": ({"measurement": {"rate": 2000.0, "lowpass": 1000.0}}, "measurement.lowpass", r"must be below the Nyquist frequency rate/2 = 1000 Hz; got 1000\.0"),
    "lowpass above Nyquist": ({"measurement": {"rate": 2000.0, "lowpass": 1500.0}}, "measurement.lowpass", "must be below the Nyquist frequency"),
    "negative noise": ({"measurement": {"noise": -0.1}}, "measurement.noise", "must be >= 0"),
    "negative seed": ({"measurement": {"seed": -1}}, "measurement.seed", "must be >= 0"),
    "zero rate": ({"measurement": {"rate": 0.0}}, "measurement.rate", "must be > 0"),
    "unknown estimator": ({"estimators": ["inverse_rigd"]}, "estimators[0]", r"unknown estimator \(did you mean 'inverse_rigid'\?\); known estimators: inverse_rigid, inverse_quasi_rigid"),
    "estimator listed twice": ({"estimators": ["inverse_rigid", "inverse_rigid"]}, "estimators[1]", "is listed twice"),
    "estimators without fem": (
        {"models": ["rigid", {"name": "mix", "fidelity": "fem", "cars": {"anvil": "rigid"}}], "estimators": ["inverse_rigid"]},
        "estimators",
        r"the estimators run on the fem sensor records; add fem \(a uniform fem run\) to models",
    ),
    "estimator missing sensors": (
        {"estimators": ["inverse_rigid", "inverse_quasi_rigid"]},
        "estimators[1]",
        re.escape("inverse_quasi_rigid needs >= 2 sensors on the front car of every coupler; car 'anvil' (front of coupler c1) has 1: center"),
    ),
    "modal modes zero": ({"modal": {"modes": 0}}, "modal.modes", "must be >= 1; got 0"),
    "modal modes not an integer": ({"modal": {"modes": 2.5}}, "modal.modes", "must be an integer"),
    "fem order 3": ({"fem": {"order": 3}}, "fem.order", r"impact cars are rods: order 1 \(P1\) or 2 \(P2\)"),
    "dt zero": ({"time.dt": 0.0}, "time.dt", "must be > 0"),
    "rho_inf with newmark": ({"integrator": {"scheme": "newmark", "rho_inf": 0.5}}, "integrator.rho_inf", "applies to scheme generalized_alpha only"),
    # unknown keys
    "single-body key": ({"body": {"type": "rod"}}, "body", "'body' is a key of single-body cases, not of impact cases"),
    "unknown top-level key": ({"coupler": []}, "coupler", r"unknown key \(did you mean 'couplers'\?\)"),
    "unknown coupler key": ({"couplers.0.gap": 0.01}, "couplers[0].gap", "unknown key"),
    "unknown measurement key": ({"measurement": {"lowpas": 100.0}}, "measurement.lowpas", r"unknown key \(did you mean 'lowpass'\?\)"),
}


@pytest.mark.parametrize(("edits", "key_path", "rule"), list(RULES.values()), ids=list(RULES))
def test_impact_rule(tmp_path: Path, edits: dict[str, Any], key_path: str, rule: str) -> None:
    error = load_bad(tmp_path, edited(edits))
    assert re.search(expect(key_path, rule), str(error)), str(error)
    assert key_path in {p.key_path for p in error.problems}


def test_several_problems_come_in_one_error(tmp_path: Path) -> None:
    edits = {
        "cars.0.velocity": math.nan,
        "couplers.0.law": {"draft_gear": {**DRAFT_GEAR, "stroke": -0.08}},
        "couplers.1.tension_slack": -1.0,
        "modal": {"modes": 0},
        "measurement": {"rate": 1000.0, "lowpass": 600.0},
        "estimators": ["inverse_rigd"],
    }
    error = load_bad(tmp_path, edited(edits))
    assert {p.key_path for p in error.problems} == {
        "cars[0].velocity",
        "couplers[0].law.draft_gear.stroke",
        "couplers[1].tension_slack",
        "modal.modes",
        "measurement.lowpass",
        "estimators[0]",
    }
    assert len(str(error).splitlines()) == 6


def test_relations_between_valid_keys_are_all_reported(tmp_path: Path) -> None:
    """Bad couplers, run overrides and a sensor shortage are reported together."""
    edits = {
        "couplers.0.between": ["anvil", "hammer"],
        "couplers.1.between": ["anvil", "wagn"],
        "models": ["fem", {"name": "mix", "fidelity": "rigid", "cars": {"hamer": "fem"}}],
    }
    error = load_bad(tmp_path, edited(edits))
    assert {p.key_path for p in error.problems} == {"couplers[0].between", "couplers[1].between[1]", "models[1].cars.hamer"}


# The command line: exit code 2 with the key path, nothing written


CLI_CASES = {
    "unknown car in between": ({"couplers.0.between": ["hammer", "anvl"]}, "couplers[0].between[1]: unknown car (did you mean 'anvil'?)"),
    "non-neighbour couplers": ({"couplers.0.between": ["hammer", "wagon"]}, "couplers[0].between: hammer (cars[0]) and wagon (cars[2]) are not neighbours"),
    "sensor outside the car": ({"cars.0.sensors.front": 9.0}, "cars[0].sensors.front: must lie on the car, |x| <= l = 8.5 m"),
    "negative stroke": ({"couplers.0.law": {"draft_gear": {**DRAFT_GEAR, "stroke": -0.08}}}, "couplers[0].law.draft_gear.stroke: must be > 0"),
    "exact refused": ({"models": ["fem", "exact"]}, "models[1]: exact cannot serve this case: no exact solution is implemented for impact scenes"),
}


@pytest.mark.parametrize(("edits", "message"), list(CLI_CASES.values()), ids=list(CLI_CASES))
def test_cli_validate_exits_2_and_writes_nothing(tmp_path: Path, edits: dict[str, Any], message: str) -> None:
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(edited(edits), sort_keys=False))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    assert f"{path}: {message}" in result.output
    assert "kind: impact" not in result.output  # no resolved case printed
    assert list(tmp_path.iterdir()) == [path]


def test_cli_run_exits_2_before_any_work(tmp_path: Path) -> None:
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(edited({"couplers.0.between": ["anvil", "hammer"]}), sort_keys=False))
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert "couplers[0].between: lists the cars in reverse order" in result.output
    assert list(tmp_path.iterdir()) == [path]
