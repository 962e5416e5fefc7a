"""The ``power_law`` and ``friction_gear`` coupler laws of a case file: what they build, how they run, and
every rule of their keys (a CaseError naming the key path and the rule; exit code 2 on the command line).

Runs through the case: a power law with ``n = 1, N0 = 0, γ = (μ,)`` is the Kelvin-Voigt case to
round-off; an ``n = 1.5`` gear with preload and damping agrees with the two-mass ODE written here
(scipy ``solve_ivp``); a friction gear's case builds the table of its definition and fills in its
rated closure force, which the resolved case keeps on a round trip.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from femref.case import load_case, parse_case, resolved_yaml
from femref.cli import main
from femref.impact import solve_impact
from femref.models import model_form
from femref.scene.build import scene_from_case
from support.case_helpers import DELETE, expect, load_bad

HAMMER, ANVIL = 80.0e3, 60.0e3  # kg
CUBIC = {"cubic": {"linear_stiffness": 1.0e7, "cubic_stiffness": 3.0e9}}
FRICTION_GEAR = {"loading": CUBIC, "unloading_ratio": 0.4, "solid_closure": 0.075, "solid_stiffness": 1.8e9}
POWER_LAW = {"stiffness": 2.0e8, "exponent": 1.5, "preload": 5.0e4, "damping": [1.0e5, 2.0e6]}


def base(law: dict[str, Any], speed: float = 1.5, fidelity: str = "rigid") -> dict[str, Any]:
    """Two 17 m cars, 80 t at ``speed`` against 60 t at rest, joined by ``law``."""

    def car(name: str, mass: float, velocity: float) -> dict[str, Any]:
        body = {"type": "rod", "length": 17.0, "mass_per_length": mass / 17.0, "axial_stiffness": 3.0e9}
        return {"name": name, "body": body, "velocity": velocity, "sensors": {"center": 0.0}}

    return {"kind": "impact", "cars": [car("hammer", HAMMER, speed), car("anvil", ANVIL, 0.0)],
            "couplers": [{"name": "c1", "between": ["hammer", "anvil"], "law": law}],
            "time": {"end": 0.3}, "models": [fidelity], "fem": {"elements": 8}}


def run(data: dict[str, Any], fidelity: str, dt: float):
    scene = scene_from_case(parse_case(data))
    return solve_impact(scene, [model_form(fidelity, "impact")(car, scene, dt) for car in scene.cars], dt)


# ---------------------------------------------------------------------------------------------
# power_law


def test_a_linear_power_law_is_the_kelvin_voigt_case() -> None:
    """``power_law {stiffness c, exponent 1, preload 0, damping [μ]}`` and ``kelvin_voigt {c, μ}``: the same
    fem run (force, closure, every energy account) to 1e-12 of the peaks."""
    power = run(base({"power_law": {"stiffness": 4.0e7, "exponent": 1.0, "preload": 0.0, "damping": [3.0e5]}}, fidelity="fem"), "fem", 1e-4)
    linear = run(base({"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}, fidelity="fem"), "fem", 1e-4)
    assert power.ok and linear.ok
    for key in ("force", "closure"):
        expected = linear.couplers["c1"][key]
        np.testing.assert_allclose(power.couplers["c1"][key], expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))
    for key, expected in linear.energy.items():
        np.testing.assert_allclose(power.energy[key], expected, rtol=0, atol=1e-12 * np.max(linear.energy["total"]))


def power_law_reference(speed: float) -> dict[str, float]:
    """Two rigid cars through ``P = c δ^1.5 + N0 + (γ0 + γ1 δ) δ̇`` while ``δ > 0`` and ``P > 0`` (compression-only
    contact), integrated here by solve_ivp (Radau, rtol 1e-11) to separation: peak force (N), its time (s),
    separation time (s) and the closing speed left at separation (m/s)."""
    c, n, preload, (g0, g1) = POWER_LAW["stiffness"], POWER_LAW["exponent"], POWER_LAW["preload"], POWER_LAW["damping"]
    reduced_mass = HAMMER * ANVIL / (HAMMER + ANVIL)

    def force(d: np.ndarray, rate: np.ndarray) -> np.ndarray:
        return c * np.abs(d) ** n + preload + (g0 + g1 * np.abs(d)) * rate

    def pulls(t: float, y: np.ndarray) -> float:
        return force(y[0], y[1])

    def parts(t: float, y: np.ndarray) -> float:
        return y[0] if t > 0.0 else 1.0

    for event in (pulls, parts):
        event.terminal, event.direction = True, -1
    solution = solve_ivp(lambda t, y: [y[1], -force(y[0], y[1]) / reduced_mass], (0.0, 1.0), [0.0, speed], method="Radau",
                         rtol=1e-11, atol=[1e-13, 1e-11], events=(pulls, parts), dense_output=True)
    assert solution.status == 1
    t = np.linspace(0.0, solution.t[-1], 200_001)
    forces = force(*solution.sol(t))
    k = int(np.argmax(forces))
    return {"peak_force": forces[k], "peak_time": t[k], "separation": solution.t[-1], "rebound": -solution.y[1, -1]}


def test_a_power_law_case_agrees_with_the_two_mass_ode() -> None:
    """n = 1.5 with a 50 kN preload and γ = 1e5 + 2e6 δ (N·s/m), rigid cars at 1.5 m/s, step 2e-5 s: peak
    force (1.81 MN) to 1e-5 (measured 1.3e-7), its time and the separation time within 2 steps (measured
    9.4e-6 s and 7.4e-6 s), the rebound speed (1.23 m/s) to 1e-5 (measured 3e-8)."""
    ref = power_law_reference(1.5)
    dt = 2.0e-5
    result = run(base({"power_law": POWER_LAW}), "rigid", dt)
    assert result.ok, result.message
    force = result.couplers["c1"]["force"]
    k = int(np.argmax(force))
    assert force[k] == pytest.approx(ref["peak_force"], rel=1e-5)
    assert result.time[k] == pytest.approx(ref["peak_time"], abs=2 * dt)
    engaged = result.time[force > 0.0]
    assert engaged[-1] == pytest.approx(ref["separation"], abs=2 * dt)
    velocity = {name: result.sensors[f"{name}/center"]["velocity"][-1] for name in ("hammer", "anvil")}
    assert velocity["anvil"] - velocity["hammer"] == pytest.approx(ref["rebound"], rel=1e-5)


# ---------------------------------------------------------------------------------------------
# friction_gear


def test_a_friction_gear_case_builds_its_table_and_fills_in_the_rated_force(tmp_path: Path) -> None:
    """The case's friction gear: a table law whose loading curve has a node at δ_c = 75 mm, L(δ_c) =
    k1 δ_c + k3 δ_c³ = 2.015625 MN there, the unloading curve 0.4 of it, the solid slope 1.8e9 N/m on
    both curves beyond; ``rated_closure_force`` is filled in with L(δ_c) and the resolved case loads
    back to an equal case (so ``femref validate`` shows the rated force)."""
    case = parse_case(base({"friction_gear": FRICTION_GEAR}))
    spec = case.couplers[0].law
    rated = 1.0e7 * 0.075 + 3.0e9 * 0.075**3
    assert spec.rated_closure_force == pytest.approx(rated, rel=1e-15)
    law = spec.build()
    k = law.closure.index(0.075)
    assert law.loading[k] == pytest.approx(rated, rel=1e-15) and law.unloading[k] == pytest.approx(0.4 * rated, rel=1e-15)
    (up, up_slope, _), (down, down_slope, _) = law.curves(0.09)
    assert (up_slope, down_slope) == (pytest.approx(1.8e9, rel=1e-9), pytest.approx(1.8e9, rel=1e-9))
    assert up == pytest.approx(rated + 1.8e9 * 0.015, rel=1e-12) and down == pytest.approx(0.4 * rated + 1.8e9 * 0.015, rel=1e-12)
    path = tmp_path / "resolved.yaml"
    path.write_text(resolved_yaml(case))
    assert load_case(path) == case
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0 and f"rated_closure_force: {rated!r}" in result.output


def test_an_exponential_friction_gear_case_builds_its_curve() -> None:
    """``exponential {amplitude a, rate b}``: the table's loading at δ_c is a (e^{b δ_c} − 1) (1e5 N, 40 /m,
    δ_c = 75 mm: 1.9086 MN) and between the nodes within 1e-5 of it."""
    gear = {**FRICTION_GEAR, "loading": {"exponential": {"amplitude": 1.0e5, "rate": 40.0}}, "solid_stiffness": 3.0e9}
    law = parse_case(base({"friction_gear": gear})).couplers[0].law.build()
    rated = 1.0e5 * np.expm1(40.0 * 0.075)
    closure = np.linspace(0.0, 0.075, 3001)
    table = np.array([law.curves(d)[0][0] for d in closure])
    assert np.max(np.abs(table - 1.0e5 * np.expm1(40.0 * closure))) <= 1e-5 * rated


def gear(**changes: Any) -> dict[str, Any]:
    return {"friction_gear": {**FRICTION_GEAR, **changes}}


def power(**changes: Any) -> dict[str, Any]:
    return {"power_law": {**POWER_LAW, **changes}}


FG = "couplers[0].law.friction_gear"
PL = "couplers[0].law.power_law"

# (law, key path, rule regex)
RULES = {
    # friction_gear
    "gear loading missing": ({"friction_gear": {k: v for k, v in FRICTION_GEAR.items() if k != "loading"}}, f"{FG}.loading", "required key is missing"),
    "gear loading unknown curve": (gear(loading={"cubik": {"linear_stiffness": 1e7}}), f"{FG}.loading.cubik",
                                   r"unknown loading curve \(did you mean 'cubic'\?\); expected a mapping with exactly one key out of cubic, exponential"),
    "gear loading two curves": (gear(loading={**CUBIC, "exponential": {"amplitude": 1e5, "rate": 40.0}}), f"{FG}.loading",
                                "give exactly one of cubic, exponential; got cubic and exponential together"),
    "gear negative k1": (gear(loading={"cubic": {"linear_stiffness": -1.0, "cubic_stiffness": 3e9}}), f"{FG}.loading.cubic.linear_stiffness", "must be >= 0"),
    "gear k3 missing": (gear(loading={"cubic": {"linear_stiffness": 1e7}}), f"{FG}.loading.cubic.cubic_stiffness", "required key is missing"),
    "gear flat cubic": (gear(loading={"cubic": {"linear_stiffness": 0.0, "cubic_stiffness": 0.0}}), f"{FG}.loading.cubic.cubic_stiffness",
                        "linear_stiffness and cubic_stiffness are both 0: a gear that never pushes"),
    "gear implausible k1": (gear(loading={"cubic": {"linear_stiffness": 1e15, "cubic_stiffness": 0.0}}), f"{FG}.loading.cubic.linear_stiffness",
                            r"a linear stiffness k1 of 1e15 N/m is beyond any rail vehicle .*the plausible range is 1000–1e12 N/m"),
    "gear implausible k3": (gear(loading={"cubic": {"linear_stiffness": 1e7, "cubic_stiffness": 1e16}}), f"{FG}.loading.cubic.cubic_stiffness",
                            r"a cubic stiffness k3 of 1e16 N/m³ is beyond any rail vehicle"),
    "gear zero amplitude": (gear(loading={"exponential": {"amplitude": 0.0, "rate": 40.0}}), f"{FG}.loading.exponential.amplitude", "must be > 0"),
    "gear implausible amplitude": (gear(loading={"exponential": {"amplitude": 1e12, "rate": 40.0}}), f"{FG}.loading.exponential.amplitude",
                                   r"a loading-curve amplitude of 1e12 N is beyond any rail vehicle"),
    "gear zero rate": (gear(loading={"exponential": {"amplitude": 1e5, "rate": 0.0}}), f"{FG}.loading.exponential.rate", "must be > 0"),
    "gear steep exponential": (gear(loading={"exponential": {"amplitude": 1e5, "rate": 1000.0}}), f"{FG}.loading.exponential.rate",
                               r"rate·solid_closure = 75: a loading-curve exponent b·δ_c of 75 \(dimensionless\) is beyond any rail vehicle"),
    "gear unknown curve key": (gear(loading={"cubic": {"linear_stiffness": 1e7, "cubic_stiffness": 3e9, "k5": 1.0}}), f"{FG}.loading.cubic.k5", "unknown key"),
    "gear unloading ratio above 1": (gear(unloading_ratio=1.5), f"{FG}.unloading_ratio", r"must lie in \[0, 1\]: the unloading curve lies between 0 and the loading curve"),
    "gear negative unloading ratio": (gear(unloading_ratio=-0.1), f"{FG}.unloading_ratio", r"must lie in \[0, 1\]"),
    "gear unloading ratio missing": (gear(unloading_ratio=DELETE), f"{FG}.unloading_ratio", "required key is missing"),
    "gear zero solid closure": (gear(solid_closure=0.0), f"{FG}.solid_closure", "must be > 0"),
    "gear implausible solid closure": (gear(solid_closure=20.0), f"{FG}.solid_closure", r"a coupler travel of 20 m is beyond any rail vehicle"),
    "gear rated force beyond a coupler": (gear(loading={"cubic": {"linear_stiffness": 1e7, "cubic_stiffness": 1e12}}, solid_closure=5.0, solid_stiffness=1e12),
                                          f"{FG}.solid_closure", r"the rated closure force L\(5 m\) = 1\.25e14 N: a coupler force of 1\.25e14 N is beyond any rail vehicle"),
    "gear soft solid stop": (gear(solid_stiffness=5.0e7), f"{FG}.solid_stiffness",
                             r"must be at least the loading slope at the solid closure, L'\(0\.075 m\) = 6\.0625e\+07 N/m: the solid stop stiffens the gear"),
    "gear negative solid stiffness": (gear(solid_stiffness=-1.0), f"{FG}.solid_stiffness", "must be > 0"),
    "gear implausible solid stiffness": (gear(solid_stiffness=1e13), f"{FG}.solid_stiffness", r"a coupler stiffness of 1e13 N/m is beyond any rail vehicle"),
    "gear negative damping": (gear(damping=-1.0), f"{FG}.damping", "must be >= 0"),
    "gear zero switch velocity": (gear(switch_velocity=0.0), f"{FG}.switch_velocity", "must be > 0"),
    "gear wrong rated force": (gear(rated_closure_force=2.0e6), f"{FG}.rated_closure_force",
                               r"is derived: it must equal L\(solid_closure\) = 2015624\.9999999998 N \(leave it out and validation fills it in\)"),
    "gear unknown key": (gear(stroke=0.08), f"{FG}.stroke", "unknown key"),
    # power_law
    "power stiffness missing": (power(stiffness=DELETE), f"{PL}.stiffness", "required key is missing"),
    "power zero stiffness": (power(stiffness=0.0), f"{PL}.stiffness", "must be > 0"),
    "power implausible stiffness": (power(stiffness=1e20), f"{PL}.stiffness",
                                    r"its secant c·\(0\.01 m\)\^\(n−1\) = 1e19 N/m: a coupler stiffness of 1e19 N/m is beyond any rail vehicle"),
    "power exponent below 1": (power(exponent=0.5), f"{PL}.exponent", "must be >= 1"),
    "power implausible exponent": (power(exponent=12.0), f"{PL}.exponent", r"a power-law exponent n of 12 \(dimensionless\) is beyond any rail vehicle"),
    "power negative preload": (power(preload=-1.0), f"{PL}.preload", "must be >= 0"),
    "power implausible preload": (power(preload=1e12), f"{PL}.preload", r"a coupler force of 1e12 N is beyond any rail vehicle"),
    "power empty damping": (power(damping=[]), f"{PL}.damping", "must have at least 1 entries"),
    "power negative damping": (power(damping=[1e5, -1.0]), f"{PL}.damping[1]", "must be >= 0"),
    "power implausible damping": (power(damping=[1e5, 1e14]), f"{PL}.damping[1]",
                                  r"γ_1·\(0\.01 m\)\^1 = 1e12 N·s/m: a coupler damping of 1e12 N·s/m is beyond any rail vehicle"),
    "power unknown key": (power(gamma=[1.0]), f"{PL}.gamma", "unknown key"),
}


@pytest.mark.parametrize(("law", "key_path", "rule"), list(RULES.values()), ids=list(RULES))
def test_coupler_law_rule(tmp_path: Path, law: dict[str, Any], key_path: str, rule: str) -> None:
    law = {name: {k: v for k, v in fields.items() if v is not DELETE} for name, fields in law.items()}
    error = load_bad(tmp_path, base(law))
    assert re.search(expect(key_path, rule), str(error)), str(error)
    assert key_path in {p.key_path for p in error.problems}


@pytest.mark.parametrize(
    ("law", "message"),
    [
        (gear(solid_stiffness=5.0e7), f"{FG}.solid_stiffness: must be at least the loading slope at the solid closure"),
        (power(exponent=0.5), f"{PL}.exponent: must be >= 1"),
    ],
    ids=["friction_gear", "power_law"],
)
def test_cli_validate_exits_2_naming_the_key(tmp_path: Path, law: dict[str, Any], message: str) -> None:
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(base(law), sort_keys=False))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    assert f"{path}: {message}" in result.output
    assert list(tmp_path.iterdir()) == [path]
