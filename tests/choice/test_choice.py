"""Model choice (femref.choice, ``femref run --tolerance``): estimates, ladder, the climb, the CLI,
and the spread test of issue 6 — the chosen model's true error against a fine fem across ε."""

from __future__ import annotations

import dataclasses
import math

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import load_case, parse_case
from femref.choice import choose_model, model_ladder, run_rung
from femref.choice.estimates import (
    EPS_LOAD_VALID,
    asymptotic_errors,
    load_epsilon,
    output_distance,
    peak_sampling_error,
    richardson_error,
)
from femref.choice.ladder import Rung, predicted_cost
from femref.cli import main
from femref.case.defaults import default_scene_data
from femref.models.fem import with_elements
from femref.run.scoring import score_impact
from femref.scene.build import scene_from_case

from support.convergence import observed_order
from support.paths import CASES

PEAK = "peak_coupler_force"


# ---------------------------------------------------------------------------------------------
# Estimates on exact data


@pytest.mark.parametrize("order", [1.0, 2.0, 4.0])
def test_richardson_is_exact_for_power_law_errors(order):
    exact, constant, h = 3.0, 0.7, 0.1
    coarse, fine = exact + constant * h**order, exact + constant * (h / 2) ** order
    assert richardson_error(coarse - fine, order) == pytest.approx(coarse - exact, rel=1e-12)
    assert richardson_error(coarse - fine, order, finer=True) == pytest.approx(fine - exact, rel=1e-12)
    with pytest.raises(ValueError, match="order > 0"):
        richardson_error(1.0, 0.0)


def test_load_epsilon_of_a_half_sine_is_pi_squared_epsilon():
    """A smooth half-sine of length T, at rest before contact, has ε_load = π² (T_wave/T)² (to the step's h²)."""
    T, wave_time = 0.2, 0.01
    t = np.linspace(0.0, 0.3, 30001)
    force = np.where(t < T, 1e6 * np.sin(np.pi * t / T) ** 3, 0.0)  # sin³: starts with zero slope and curvature
    # d²/dt² sin³(πt/T) = (π/T)² · 3 s (2c² − s²), s, c = sin, cos: its largest magnitude up to the peak
    s = np.sin(np.pi * t / T)
    curvature = 1e6 * (np.pi / T) ** 2 * np.abs(3 * s * (2 * np.cos(np.pi * t / T) ** 2 - s**2))
    expected = wave_time**2 * np.max(curvature[t <= T / 2]) / 1e6
    assert load_epsilon(t, force, wave_time) == pytest.approx(expected, rel=1e-3)
    sine = np.where(t < T, np.sin(np.pi * t / T), 0.0)
    # a plain sine starts with a kink (slope jumps from 0): seen on the step, ~ T_w² (π/T)/dt ≫ π²ε
    assert load_epsilon(t, sine, wave_time) > 100 * np.pi**2 * (wave_time / T) ** 2


def test_load_epsilon_sees_a_jump_at_contact():
    t = np.linspace(0.0, 0.1, 101)
    smooth = 1e6 * np.sin(np.pi * t / 0.1) ** 3
    jump = smooth + 2e5 * (t < 0.05)
    # the step from rest to 2e5 N in one sample: P̈ ≈ 2e5/dt², so ε_load ≈ T_w² · 2e5/dt² / max P
    assert load_epsilon(t, jump, 0.01) == pytest.approx(0.01**2 * 2e5 / 0.001**2 / jump.max(), rel=0.03)
    assert load_epsilon(t, smooth, 0.01) < 0.02 * load_epsilon(t, jump, 0.01)
    assert load_epsilon(t, np.zeros_like(t), 0.01) == 0.0


def test_peak_sampling_error_bounds_a_sampled_sine_peak():
    T = 1.0
    for offset in (0.0, 0.3, 0.5):
        dt = T / 100
        t = (np.arange(101) + offset) * dt
        force = np.sin(np.pi * t / T)
        missed = 1.0 - force.max()
        bound = peak_sampling_error(force)
        assert missed <= bound * (1 + 1e-3)  # the second difference is P̈ dt² to O(dt⁴)
        assert bound == pytest.approx((np.pi * dt / T) ** 2 / 8, rel=1e-3)


def test_asymptotic_errors_are_the_first_and_next_order_terms():
    assert asymptotic_errors(0.02, 0.1) == pytest.approx((0.022, 0.002))


# ---------------------------------------------------------------------------------------------
# Scenes


def _scene(law: dict, elements: int = 16, end_factor: float = 1.3, cars: list[dict] | None = None):
    data = default_scene_data()
    data.pop("measurement")
    data.pop("estimators")
    if cars is not None:
        for car, body in zip(data["cars"], cars):
            car["body"] = body
            car["sensors"] = {"center": 0.0}
    data["couplers"][0]["law"] = law
    data["fem"] = {"elements": elements, "order": 2}
    scene = scene_from_case(parse_case(data, source="<test>"))
    data["time"] = {"end": end_factor * scene.contact_time()}
    return scene_from_case(parse_case(data, source="<test>"))


def _reference(scene, elements: int = 128):
    """fem at ``elements`` per car, refined jointly in space and time from the ladder's coarsest fem rung."""
    ladder = model_ladder(scene)
    coarsest = min((r for r in ladder.rungs if r.family == "fem"), key=lambda r: r.resolution)
    fine_scene = dataclasses.replace(scene, fem=dataclasses.replace(scene.fem, elements=elements))
    rung = dataclasses.replace(coarsest, label="reference", scene=fine_scene, dt=coarsest.dt * coarsest.resolution / elements)
    result = run_rung(rung)
    assert result.ok, result.message
    return result


class _Memo:
    """A runner that runs each rung once (the spread test scores every rung after the choice)."""

    def __init__(self) -> None:
        self.results: dict[str, object] = {}
        self.calls: list[str] = []

    def __call__(self, rung: Rung):
        self.calls.append(rung.label)
        if rung.label not in self.results:
            self.results[rung.label] = run_rung(rung)
        return self.results[rung.label]


# ---------------------------------------------------------------------------------------------
# The ladder


def test_ladder_is_ordered_by_cost_and_refines_fem_jointly():
    scene = _scene({"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}, elements=64)
    ladder = model_ladder(scene)
    costs = [r.cost for r in ladder.rungs]
    assert costs == sorted(costs)
    labels = [r.label for r in ladder.rungs]
    assert len(set(labels)) == len(labels)
    fem = sorted((r for r in ladder.rungs if r.family == "fem"), key=lambda r: r.resolution)
    assert [r.resolution for r in fem] == [8, 16, 32, 64, 128]
    assert {round(r.dt * r.resolution, 15) for r in fem} == {round(fem[0].dt * 8, 15)}  # dt ∝ h
    modal = sorted(r.resolution for r in ladder.rungs if r.family == "modal")
    assert modal == [1, 2, 4, 8, 16]
    assert ladder.partner("fem_n8") == "fem_n16" and ladder.partner("fem_n128") is None
    assert ladder.coarser("fem_n128") == "fem_n64" and ladder.coarser("rigid") is None
    assert ladder.partner("rigid") == "quasi_rigid"


def test_predicted_cost_orders_the_default_scene():
    """The cost model (femref.choice.ladder) on the default scene: rigid < quasi_rigid < fem at the
    case's N, every cost positive, growing with fem elements and modal modes (on the ladder, and at
    one step count), and per car. Orders only: no seconds are asserted."""
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    ladder = model_ladder(scene)
    cost = {r.label: r.cost for r in ladder.rungs}
    assert all(c > 0 for c in cost.values())
    assert cost["rigid"] < cost["quasi_rigid"] < cost[f"fem_n{scene.fem.elements}"]
    for family in ("fem", "modal"):
        rungs = sorted((r for r in ladder.rungs if r.family == family), key=lambda r: r.resolution)
        assert len(rungs) == 5 and np.all(np.diff([r.cost for r in rungs]) > 0), family
    steps = 1000
    fem = [predicted_cost("fem", with_elements(scene, n), steps) for n in (4, 8, 64, 512)]
    modal = [predicted_cost("modal", dataclasses.replace(scene, modal_modes=k), steps) for k in (1, 2, 8, 32)]
    assert np.all(np.diff(fem) > 0) and np.all(np.diff(modal) > 0)
    consist = scene_from_case(load_case(CASES / "impact_consist.yaml"))  # five cars
    for family in ("rigid", "quasi_rigid", "fem"):
        assert predicted_cost(family, consist, steps) == pytest.approx(2.5 * predicted_cost(family, with_elements(scene, consist.fem.elements), steps))


def test_ladder_keeps_the_modes_the_mesh_holds_and_at_least_four_elements():
    body = {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    scene = _scene({"kelvin_voigt": {"stiffness": 4.0e7}}, elements=4, cars=[body, body])
    ladder = model_ladder(scene)
    assert min(r.resolution for r in ladder.rungs if r.family == "fem") == 4
    # 4 P2 elements: 9 dofs, at most 7 elastic modes
    assert max(r.resolution for r in ladder.rungs if r.family == "modal") == 4


# ---------------------------------------------------------------------------------------------
# The asymptotic estimates where they hold, and where they do not


@pytest.mark.parametrize("stiffness", [1.0e5, 3.0e5, 1.0e6])
def test_asymptotic_estimates_bound_rigid_and_quasi_rigid_on_a_smooth_impact(stiffness):
    """Undamped Kelvin-Voigt coupler, soft enough that ε_load ≤ EPS_LOAD_VALID: both estimates bound the true error."""
    scene = _scene({"kelvin_voigt": {"stiffness": stiffness, "damping": 0.0}})
    ladder = model_ladder(scene)
    memo = _Memo()
    choice = choose_model(scene, 1e-6, runner=memo)  # unreachable: every rung runs
    assert choice.epsilon_load <= EPS_LOAD_VALID
    reference = _reference(scene)
    rows = {row.rung.label: row for row in choice.rows}
    for label in ("rigid", "quasi_rigid"):
        own, basis = rows[label].estimate, rows[label].basis
        true = output_distance(memo.results[label], reference, PEAK)
        assert true <= own, (label, true, own, basis)
    assert ladder.index("rigid") == 0


def test_rigid_error_is_first_order_in_epsilon():
    """The rigid model's peak error grows like ε¹ (fitted slope on undamped Kelvin-Voigt couplers)."""
    epsilons, errors = [], []
    for stiffness in (3.0e5, 1.0e6, 3.0e6):
        scene = _scene({"kelvin_voigt": {"stiffness": stiffness, "damping": 0.0}})
        rigid = run_rung(model_ladder(scene)["rigid"])
        epsilons.append(scene.epsilon)
        errors.append(output_distance(rigid, _reference(scene, 64), PEAK))
    slope = observed_order(epsilons, errors)
    assert slope == pytest.approx(1.0, abs=0.1)


def test_a_draft_gear_rise_withholds_the_asymptotic_estimate():
    """The default scene's gear rises in ~1 ms: ε_load ≫ 1 although ε = 0.005; rigid is priced by comparison."""
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    choice = choose_model(scene, 0.05)
    assert scene.epsilon < 0.01 and choice.epsilon_load > 1.0
    rows = {row.rung.label: row for row in choice.rows}
    assert choice.chosen == "rigid" and choice.met
    assert rows["rigid"].basis.startswith("difference from")


# ---------------------------------------------------------------------------------------------
# The climb


def test_climb_stops_early_and_records_every_rung():
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    memo = _Memo()
    choice = choose_model(scene, 0.01, runner=memo)
    assert choice.met and choice.chosen_row.estimate <= 0.01
    assert len(choice.rows) == len(model_ladder(scene).rungs)
    assert len(memo.calls) == len(set(memo.calls)) < len(choice.rows)  # each rung once, not all
    ran = [row.rung.label for row in choice.rows if row.ran]
    assert [r.model for r in choice.results] == ran
    chosen_cost = choice.chosen_row.rung.cost
    cheaper_passing = [row for row in choice.rows if row.ran and row.estimate <= 0.01 and row.rung.cost < chosen_cost]
    assert not cheaper_passing


def test_an_unreachable_tolerance_runs_the_ladder_and_keeps_the_best():
    scene = _scene({"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}, elements=8)
    choice = choose_model(scene, 1e-9)
    assert not choice.met
    assert all(row.result is not None for row in choice.rows)
    finite = [row.estimate for row in choice.rows if math.isfinite(row.estimate)]
    assert choice.chosen_row.estimate == min(finite)


def test_a_failing_rung_is_recorded_and_skipped():
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    failing = next(r.label for r in model_ladder(scene).rungs if r.family in ("modal", "fem"))  # the climb runs it

    def runner(rung):
        if rung.label == failing:
            return run_rung(dataclasses.replace(rung, dt=math.nan))  # a step the solver refuses
        return run_rung(rung)

    choice = choose_model(scene, 0.01, runner=runner)
    rows = {row.rung.label: row for row in choice.rows}
    assert rows[failing].result.status == "failed" and rows[failing].basis.startswith("failed")
    assert choice.chosen != failing and choice.met


def test_bad_arguments_are_refused():
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    with pytest.raises(ValueError, match="positive"):
        choose_model(scene, 0.0)
    with pytest.raises(ValueError, match="unknown output"):
        choose_model(scene, 0.01, output="acceleration")


def test_history_output_uses_the_rms_distance():
    scene = scene_from_case(parse_case(default_scene_data(), source="<default>"))
    choice = choose_model(scene, 0.02, output="coupler_force")
    assert choice.output == "coupler_force" and choice.met
    row = choice.chosen_row
    partner = next(r for r in choice.rows if r.ran and r is not row)
    assert output_distance(row.result, partner.result, "coupler_force") == pytest.approx(
        score_impact(partner.result, row.result)["coupler_force_rms_error_max"]
    )


# ---------------------------------------------------------------------------------------------
# Command line


def test_cli_tolerance_writes_every_run_and_the_choice(tmp_path):
    out = tmp_path / "choice.h5"
    result = CliRunner().invoke(main, ["run", "--tolerance", "0.01", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "model choice:" in result.output and "wrote" in result.output
    with h5py.File(out, "r") as h5:
        group = h5["choice"]
        chosen = group.attrs["chosen"]
        assert group.attrs["met"] and group.attrs["tolerance"] == 0.01 and group.attrs["output"] == PEAK
        assert group.attrs["estimate"] <= 0.01
        labels = [s.decode() for s in group["label"][()]]
        ran = group["ran"][()]
        assert chosen in labels and ran[labels.index(chosen)]
        assert {label for label, r in zip(labels, ran) if r} == {k for k in h5 if k not in ("choice", "scene")}
        assert h5[chosen].attrs["status"] == "ok" and f"{chosen}/couplers/c1/force" in h5
        assert yaml.safe_load(h5.attrs["case_yaml"])["tolerance"] == {"value": 0.01, "output": PEAK}
        assert np.all(np.diff(group["predicted_cost"][()]) >= 0)


def test_case_tolerance_key_and_override(tmp_path):
    data = default_scene_data()
    data["tolerance"] = {"value": 0.05, "output": "coupler_force"}
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    out = tmp_path / "a.h5"
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(out)])
    assert result.exit_code == 0, result.output
    with h5py.File(out, "r") as h5:
        assert h5["choice"].attrs["output"] == "coupler_force" and h5["choice"].attrs["tolerance"] == 0.05
    result = CliRunner().invoke(main, ["run", str(case), "--tolerance", "0.2", "-o", str(out)])
    with h5py.File(out, "r") as h5:
        assert h5["choice"].attrs["output"] == "coupler_force" and h5["choice"].attrs["tolerance"] == 0.2


@pytest.mark.parametrize(
    "tolerance, message",
    [(-0.1, "tolerance: must be > 0"), (1.0, "tolerance: must be < 1"), ({"value": 0.01, "output": "acceleration"}, "tolerance.output: must be one of")],
)
def test_bad_tolerance_in_the_case_exits_2_and_writes_nothing(tmp_path, tolerance, message):
    data = default_scene_data()
    data["tolerance"] = tolerance
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    out = tmp_path / "x.h5"
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(out)])
    assert result.exit_code == 2 and message in result.output
    assert not out.exists() and list(tmp_path.iterdir()) == [case]


def test_tolerance_on_a_single_body_case_exits_2(tmp_path):
    out = tmp_path / "x.h5"
    result = CliRunner().invoke(main, ["run", str(CASES / "rod_harmonic.yaml"), "--tolerance", "0.01", "-o", str(out)])
    assert result.exit_code == 2 and "model choice serves impact cases" in result.output
    assert not out.exists()
    result = CliRunner().invoke(main, ["run", "--tolerance", "1.5", "-o", str(out)])
    assert result.exit_code == 2 and not out.exists()


# ---------------------------------------------------------------------------------------------
# The work budget of a climb: every rung, before any runs


def _small_impact(**changes) -> dict:
    rod = {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    data = {"kind": "impact", "cars": [{"name": "hammer", "body": rod, "velocity": 2.0}, {"name": "anvil", "body": rod, "velocity": 0.0}],
            "couplers": [{"between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
            "time": {"end": 0.3}, "models": ["fem", "rigid"]}
    data.update(changes)
    return data


def test_the_budget_lays_out_the_ladder_the_climb_runs():
    """The budget's ladder (no mesh: steps from the sampled wave speed, modes from the DOF count) is the climb's:
    the same rungs at the same steps, each predicted as an impact run of its rung."""
    from femref.choice.ladder import ladder_costs

    for scene in (scene_from_case(parse_case(default_scene_data(), source="<default>")), scene_from_case(load_case(CASES / "impact_consist.yaml"))):
        ladder = model_ladder(scene)
        costs = ladder_costs(scene)
        assert [c.model for c in costs] == [r.label for r in ladder.rungs]
        assert all(c.what == f"the {c.model} rung of the --tolerance ladder" and c.work > 0 for c in costs)
        fem = [c for c in costs if c.model.startswith("fem_n")]
        assert {c.factors["fem.elements"][1] for c in fem} == {scene.fem.elements}  # the case's value, the key to reduce


def test_a_ladder_over_the_budget_is_refused_before_any_work(tmp_path, monkeypatch):
    """A case whose own runs fit a budget its --tolerance ladder does not (every rung: the worst case of a climb) is
    refused by ``femref run --tolerance`` — exit 2, the key and the predicted size of the costliest rung, nothing
    written — and by choose_model before any rung runs; without the tolerance it runs."""
    from femref.case import CaseError
    from femref.choice.ladder import ladder_costs
    from femref.run.budget import BUDGET_VARIABLE, MEMORY_BUDGET, WORK_BUDGET, predict

    data = _small_impact()
    scene = scene_from_case(parse_case(data))

    def limits(costs):
        return max(sum(c.work for c in costs) / WORK_BUDGET, sum(c.memory for c in costs) / MEMORY_BUDGET)

    own, ladder = limits(predict(scene)), limits(ladder_costs(scene))
    assert own < ladder
    factor = repr(math.sqrt(own * ladder))
    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(data))
    out = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(case), "--tolerance", "0.01", "-o", str(out)], env={BUDGET_VARIABLE: factor})
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert f"{case}: fem.elements:" in text and "rung of the --tolerance ladder is predicted at" in text and "DOF-steps" in text, text
    assert "the budget is" in text and not out.exists()
    monkeypatch.setenv(BUDGET_VARIABLE, factor)
    with pytest.raises(CaseError, match="--tolerance ladder"):
        choose_model(scene, 0.01, runner=lambda rung: pytest.fail("a rung ran over the budget"))
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(out)], env={BUDGET_VARIABLE: factor})
    assert result.exit_code == 0, result.output


def test_a_huge_ladder_is_refused_without_building_a_mesh(tmp_path):
    """1e8 elements per car under --tolerance: refused in well under a second (the ladder is laid out without a mesh)."""
    import time

    case = tmp_path / "case.yaml"
    case.write_text(yaml.safe_dump(_small_impact(fem={"elements": 100_000_000})))
    started = time.perf_counter()
    result = CliRunner().invoke(main, ["run", str(case), "--tolerance", "0.01", "-o", str(tmp_path / "out.h5")])
    assert result.exit_code == 2 and ": fem.elements:" in result.output, result.output
    assert time.perf_counter() - started < 2.0


# ---------------------------------------------------------------------------------------------
# The spread test (issue 6 part 3)


def _random_scene(rng: np.random.Generator, elements: int):
    """Two cars (12–25 m, 3–9 t/m, EA 0.5–10 GN, β 0.003–0.3), 0.5–4 m/s, a Kelvin-Voigt coupler
    (0–30 % damping, 1 MN/m–2 GN/m) or the default draft gear: nominal ε from 1e-4 to 1."""
    cars = []
    for _ in range(2):
        length, mass, stiffness = rng.uniform(12, 25), rng.uniform(3000, 9000), 10 ** rng.uniform(8.7, 10)
        beta = 10 ** rng.uniform(-2.5, -0.5)
        viscosity = beta * length / 2 * math.sqrt(mass * stiffness)
        cars.append({"type": "rod", "length": length, "mass_per_length": mass, "axial_stiffness": stiffness, "axial_viscosity": viscosity})
    if rng.uniform() < 0.5:
        k = 10 ** rng.uniform(6, 9.3)
        law = {"kelvin_voigt": {"stiffness": k, "damping": rng.choice([0.0, rng.uniform(0, 0.3)]) * 2 * math.sqrt(k * 6e4)}}
    else:
        law = default_scene_data()["couplers"][0]["law"]
    scene = _scene(law, elements=elements, end_factor=1.5, cars=cars)
    speed = rng.uniform(0.5, 4.0)
    cars_ = (dataclasses.replace(scene.cars[0], velocity=speed), *scene.cars[1:])
    return dataclasses.replace(scene, cars=cars_)


def _spread(seed: int, scenes: int, tolerance: float, reference_elements: int = 128) -> dict[str, list]:
    """Choose a model in each random scene, then score every rung against a fine fem (``reference_elements``
    per car; the ladder's finest fem rung has 32 at the scenes' 16)."""
    rng = np.random.default_rng(seed)
    out: dict[str, list] = {"epsilon": [], "true": [], "over": [], "chosen": []}
    for _ in range(scenes):
        scene = _random_scene(rng, elements=16)
        memo = _Memo()
        choice = choose_model(scene, tolerance, runner=memo)
        reference = _reference(scene, reference_elements)
        ladder = choice.ladder
        true = {r.label: output_distance(memo(r), reference, PEAK) for r in ladder.rungs}
        needed = next((r.label for r in ladder.rungs if true[r.label] <= tolerance), ladder.rungs[-1].label)
        out["epsilon"].append(scene.epsilon)
        out["true"].append(true[choice.chosen])
        out["over"].append(ladder.index(choice.chosen) - ladder.index(needed))
        out["chosen"].append(choice.chosen)
    return out


def _assert_spread(out: dict[str, list], tolerance: float, one_rung_share: float = 0.95) -> None:
    true, over = np.array(out["true"]), np.array(out["over"])
    within = np.mean(true <= tolerance)
    one_rung = np.mean(over <= 1)
    report = f"within {within:.0%}, ≤ 1 rung over {one_rung:.0%}, ε {min(out['epsilon']):.1e}–{max(out['epsilon']):.1e}, chosen {sorted(set(out['chosen']))}"
    assert within >= 0.95, report
    assert one_rung >= one_rung_share, report
    assert max(out["epsilon"]) / min(out["epsilon"]) > 1e2, report  # a spread across ε


def test_chosen_model_meets_the_tolerance_across_epsilon_quick():
    """The default run's spread test: the first 13 random scenes of the 20 below (ε 5e-3 to 0.7), at
    1 %, scored against fem at 64 elements per car — twice the ladder's finest rung (32), its peak
    within 2e-5 of the 128-element reference's on all 20 scenes (measured: 1.3e-5), far below the
    tolerance. Same assertions: within the tolerance, and at most one rung more expensive than
    the cheapest that is, in at least 95 % of the scenes (13 scenes: all of them)."""
    out = _spread(seed=6, scenes=13, tolerance=0.01, reference_elements=64)
    _assert_spread(out, 0.01)


@pytest.mark.slow
def test_chosen_model_meets_the_tolerance_across_epsilon():
    """20 random scenes at 1 %, against fem at 128 elements: the chosen model is within the tolerance,
    and at most one rung more expensive than the cheapest that is, in at least 95 % of them (here: all)."""
    out = _spread(seed=6, scenes=20, tolerance=0.01)
    _assert_spread(out, 0.01)


@pytest.mark.slow
@pytest.mark.parametrize("tolerance, one_rung_share", [(0.01, 0.95), (0.003, 0.85)])
def test_chosen_model_meets_the_tolerance_across_epsilon_study(tolerance, one_rung_share):
    """100 random scenes. Measured: at 1 % all within, 97 % at most one rung over; at 0.3 %
    97 % within, 90 % at most one rung over. "Never more than one rung" cannot hold for any
    estimate: a cheap rung whose errors cancel by luck (rigid 0.02 % off while its
    first-order term is 1.4 %) is "needed" but no estimate can know it."""
    out = _spread(seed=60, scenes=100, tolerance=tolerance)
    _assert_spread(out, tolerance, one_rung_share)


@pytest.mark.parametrize("case", sorted(p.name for p in CASES.glob("impact_*.yaml")))
def test_tolerance_on_every_impact_case(tmp_path, case):
    """``femref run CASE --tolerance 0.01`` on each impact case of cases/: a run within the tolerance, recorded."""
    out = tmp_path / "choice.h5"
    result = CliRunner().invoke(main, ["run", str(CASES / case), "--tolerance", "0.01", "-o", str(out)])
    assert result.exit_code == 0, result.output
    with h5py.File(out, "r") as h5:
        assert h5["choice"].attrs["met"] and h5["choice"].attrs["estimate"] <= 0.01
        assert h5[h5["choice"].attrs["chosen"]].attrs["status"] == "ok"


def test_case_schema_and_estimates_know_the_same_outputs():
    """The case keeps its own list of outputs (no solver import at validation); it must match the estimates'."""
    from femref.case.runs import TOLERANCE_OUTPUTS
    from femref.choice import OUTPUTS

    assert set(TOLERANCE_OUTPUTS) == set(OUTPUTS)
