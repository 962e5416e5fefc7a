"""Sweep files: distributions, the sampling rule, key paths and every bad-input rule.

No sample is run here (see test_sweep_run.py); these tests draw samples and validate
their cases. Statistical checks use fixed seeds, so they are deterministic; their
bounds are several standard errors wide, and a wrong distribution misses them by far.
"""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from scipy import stats

from support.paths import CASES
from femref.case import CaseError
from femref.cli import main
from femref.sweep import load_sweep, parse_sweep
from femref.sweep.spec import noise_seed


def small_impact(measurement: bool = True) -> dict:
    """Two 16 m cars, a Kelvin-Voigt coupler, 8 P1 elements per car, 0.3 s."""
    body = {"type": "rod", "length": 16.0, "mass_per_length": 6000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
    case = {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": dict(body), "velocity": 2.0, "sensors": {"center": 0.0, "front": 7.5}},
            {"name": "anvil", "body": dict(body), "velocity": 0.0, "sensors": {"rear": -7.5}},
        ],
        "couplers": [{"between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
        "time": {"end": 0.3},
        "models": ["fem", "rigid"],
        "fem": {"elements": 8, "order": 1},
    }
    if measurement:
        case["measurement"] = {"rate": 1000.0, "lowpass": 100.0, "noise": 0.01, "seed": 3}
    return case


def sweep_of(parameters: dict, samples: int = 5, seed: int = 7, **extra):
    return parse_sweep({"case": small_impact(), "samples": samples, "seed": seed, "parameters": parameters, **extra}, source="sweep.yaml")


def drawn(sweep, path: str) -> np.ndarray:
    return np.array([sweep.sample(i).values[path] for i in range(sweep.size)])


# ---------------------------------------------------------------------------------------------
# Distributions


def test_uniform_fills_its_interval_evenly():
    sweep = sweep_of({"cars.0.velocity": {"uniform": [0.5, 4.0]}}, samples=1000)
    v = drawn(sweep, "cars.0.velocity")
    assert v.min() >= 0.5 and v.max() < 4.0
    assert stats.kstest(v, stats.uniform(0.5, 3.5).cdf).pvalue > 0.01
    assert abs(v.mean() - 2.25) < 4 * 3.5 / math.sqrt(12 * 1000)


def test_log_uniform_is_uniform_in_log():
    sweep = sweep_of({"cars.1.body.axial_stiffness": {"log_uniform": [1.0e9, 6.0e9]}}, samples=1000)
    k = drawn(sweep, "cars.1.body.axial_stiffness")
    assert k.min() >= 1.0e9 and k.max() <= 6.0e9
    low, high = math.log(1.0e9), math.log(6.0e9)
    assert stats.kstest(np.log(k), stats.uniform(low, high - low).cdf).pvalue > 0.01
    assert stats.kstest(k, stats.uniform(1.0e9, 5.0e9).cdf).pvalue < 1e-6  # not uniform in k itself


def test_normal_is_normal_and_clipped_within_clip():
    free = drawn(sweep_of({"cars.0.body.axial_viscosity": {"normal": {"mean": 2.0e6, "std": 5.0e5}}}, samples=1000), "cars.0.body.axial_viscosity")
    assert stats.kstest(free, stats.norm(2.0e6, 5.0e5).cdf).pvalue > 0.01
    clipped_spec = {"normal": {"mean": 2.0e6, "std": 5.0e5, "clip": [1.5e6, 3.0e6]}}
    clipped = drawn(sweep_of({"cars.0.body.axial_viscosity": clipped_spec}, samples=1000), "cars.0.body.axial_viscosity")
    assert clipped.min() == 1.5e6 and clipped.max() == 3.0e6
    # draw then clip: the same draws, with the tails piled on the bounds (Φ(−1) ≈ 15.9 %, Φ(−2) ≈ 2.3 %)
    np.testing.assert_array_equal(clipped, np.clip(free, 1.5e6, 3.0e6))
    for fraction, expected in ((np.mean(clipped == 1.5e6), stats.norm.cdf(-1.0)), (np.mean(clipped == 3.0e6), stats.norm.cdf(-2.0))):
        assert abs(fraction - expected) < 4 * math.sqrt(expected * (1 - expected) / 1000)


def test_choice_frequencies_follow_the_weights():
    laws = [{"kelvin_voigt": {"stiffness": 4.0e7}}, {"kelvin_voigt": {"stiffness": 8.0e7}}, {"kelvin_voigt": {"stiffness": 1.6e8}}]
    sweep = sweep_of({"couplers.0.law": {"choice": {"values": laws, "weights": [3, 1, 0]}}}, samples=1000)
    index = np.array([sweep.sample(i).stored["couplers.0.law"] for i in range(sweep.size)])
    assert set(index) == {0, 1}  # weight 0: never
    assert abs(np.mean(index == 0) - 0.75) < 4 * math.sqrt(0.75 * 0.25 / 1000)
    sample = sweep.sample(0)
    assert sweep.sample_data(sample)["couplers"][0]["law"] == laws[sample.stored["couplers.0.law"]]


def test_equal_weights_by_default_and_any_yaml_values():
    sweep = sweep_of({"couplers.0.contact": {"choice": ["compression_only", "bilateral"]}}, samples=400)
    contact = drawn(sweep, "couplers.0.contact")
    assert abs(np.mean(contact == "bilateral") - 0.5) < 4 * math.sqrt(0.25 / 400)
    assert sweep.sample_case(sweep.sample(int(np.argmax(contact == "bilateral")))).couplers[0].contact == "bilateral"


# ---------------------------------------------------------------------------------------------
# The sampling rule


PARAMETERS = {
    "cars.0.velocity": {"uniform": [0.5, 4.0]},
    "cars.1.body.axial_stiffness": {"log_uniform": [1.0e9, 6.0e9]},
    "couplers.0.law.kelvin_voigt.damping": {"normal": {"mean": 3.0e5, "std": 1.0e5, "clip": [1.0e5, 5.0e5]}},
}


def test_sampling_is_deterministic_and_follows_the_rule():
    a, b = sweep_of(PARAMETERS), sweep_of(PARAMETERS)
    for i in range(a.size):
        assert a.sample(i) == b.sample(i)
    rng = np.random.default_rng([7, 3])  # draw 3, no grid: sample 3; parameters drawn in order
    velocity = rng.uniform(0.5, 4.0)
    stiffness = math.exp(rng.uniform(math.log(1.0e9), math.log(6.0e9)))
    assert a.sample(3).values["cars.0.velocity"] == velocity
    assert a.sample(3).values["cars.1.body.axial_stiffness"] == pytest.approx(stiffness, rel=1e-15)
    assert sweep_of(PARAMETERS, seed=8).sample(3).values != a.sample(3).values


def test_raising_samples_keeps_the_earlier_samples():
    grid = {**PARAMETERS, "fem.elements": {"grid": [8, 16]}}
    short, long = sweep_of(grid, samples=3), sweep_of(grid, samples=10)
    assert (short.size, long.size) == (6, 20)
    for i in range(short.size):
        assert short.sample(i) == long.sample(i)
    assert short.spec_hash == long.spec_hash


def test_grid_is_a_cartesian_product_per_draw():
    sweep = sweep_of(
        {
            "fem.elements": {"grid": [8, 16]},
            "cars.0.velocity": {"uniform": [0.5, 4.0]},
            "couplers.0.contact": {"grid": ["compression_only", "bilateral"]},
            "cars.0.sensors.front": {"grid": [5.0, 6.0, 7.0]},
        },
        samples=4,
    )
    assert sweep.grid_shape == (2, 2, 3) and sweep.size == 4 * 12
    points = []
    for draw in range(4):
        samples = [sweep.sample(draw * 12 + g) for g in range(12)]
        combos = [(s.values["fem.elements"], s.values["couplers.0.contact"], s.values["cars.0.sensors.front"]) for s in samples]
        assert len(set(combos)) == 12  # every grid point once per draw
        assert combos[1] == (8, "compression_only", 6.0) and combos[3] == (8, "bilateral", 5.0)  # the last varies fastest
        assert len({s.values["cars.0.velocity"] for s in samples}) == 1  # one draw: one set of random values
        points.append(samples[0].values["cars.0.velocity"])
    assert len(set(points)) == 4
    assert sweep.sample(5).stored["fem.elements"] == 8.0  # numeric grid: the value; other grids: the index
    assert sweep.sample(5).stored["couplers.0.contact"] == 1


def test_key_paths_into_lists_and_mappings():
    sweep = sweep_of(
        {
            "cars.1.sensors.rear": {"grid": [-7.0]},
            "cars.0.sensors.mid": {"grid": [2.0]},  # the last part may be a new key (a new sensor)
            "couplers.0.law.kelvin_voigt.stiffness": {"grid": [5.0e7]},
            "cars.1": {"choice": [{"name": "anvil", "body": small_impact()["cars"][1]["body"], "velocity": -1.0}]},
            "cars.1.velocity": {"grid": [-0.5]},  # applied after the whole car was replaced
        }
    )
    case = sweep.sample_case(sweep.sample(0))
    stepped = sweep_of({"time.dt": {"grid": [1.0e-3]}})
    assert stepped.sample_case(stepped.sample(0)).time.dt == 1.0e-3
    assert case.cars[0].sensors == {"center": 0.0, "front": 7.5, "mid": 2.0}
    assert case.cars[1].sensors == {"center": 0.0}  # the replaced car has the default sensor
    assert case.cars[1].velocity == -0.5
    assert case.couplers[0].law.stiffness == 5.0e7


def test_a_choice_that_removes_a_later_path_fails_those_samples_only():
    laws = {"choice": [{"kelvin_voigt": {"stiffness": 4.0e7}}, {"draft_gear": {"gear_stiffness": 1.7e7, "stroke": 0.165}}]}
    sweep = sweep_of({"couplers.0.law": laws, "couplers.0.law.kelvin_voigt.damping": {"uniform": [1.0e5, 5.0e5]}}, samples=20)
    samples = [sweep.sample(i) for i in range(sweep.size)]
    failed = [s for s in samples if s.stored["couplers.0.law"] == 1]
    assert 0 < len(failed) < len(samples)
    for derived in (sweep.sample_case, sweep.sample_data):
        with pytest.raises(CaseError, match=rf"sample {failed[0].index}: parameters.couplers.0.law.kelvin_voigt.damping: no key 'kelvin_voigt'"):
            derived(failed[0])
    ok = next(s for s in samples if s.stored["couplers.0.law"] == 0)
    assert sweep.sample_case(ok).couplers[0].law.damping == ok.values["couplers.0.law.kelvin_voigt.damping"]


def test_samples_that_fail_case_validation_name_the_sample_and_key_path():
    sweep = sweep_of({"cars.1.body.axial_stiffness": {"normal": {"mean": 1.0e9, "std": 2.0e9}}}, samples=20)
    samples = [sweep.sample(i) for i in range(sweep.size)]
    negative = next(s for s in samples if s.values["cars.1.body.axial_stiffness"] <= 0)
    with pytest.raises(CaseError, match=rf"sweep.yaml sample {negative.index}: cars\[1\].body.axial_stiffness: must be > 0"):
        sweep.sample_case(negative)


def test_models_replaced_and_estimators_dropped():
    case = small_impact()
    case["estimators"] = ["inverse_rigid"]
    sweep = parse_sweep({"case": case, "samples": 2, "seed": 0, "models": ["rigid"]})
    data = sweep.sample_data(sweep.sample(1))
    assert data["models"] == ["rigid"] and data["estimators"] == []
    default = parse_sweep({"case": case, "samples": 2, "seed": 0})
    assert default.sample_data(default.sample(0))["models"] == ["fem", "rigid"]


def test_each_sample_gets_its_own_noise_seed():
    sweep = sweep_of(PARAMETERS, samples=6)
    seeds = [sweep.sample_data(sweep.sample(i))["measurement"]["seed"] for i in range(6)]
    assert seeds == [noise_seed(7, i) for i in range(6)] and len(set(seeds)) == 6
    assert seeds[2] == int(np.random.SeedSequence([7, 2]).generate_state(1)[0])
    own = sweep_of({**PARAMETERS, "measurement.seed": {"grid": [11, 12]}}, samples=2)
    assert [own.sample_data(own.sample(i))["measurement"]["seed"] for i in range(4)] == [11, 12, 11, 12]
    quiet = parse_sweep({"case": small_impact(measurement=False), "samples": 2, "seed": 7})
    assert quiet.sample_data(quiet.sample(1))["measurement"] is None


def test_spec_hash_covers_what_fixes_the_samples():
    reference = sweep_of(PARAMETERS)
    assert sweep_of(PARAMETERS, samples=9).spec_hash == reference.spec_hash
    changed = {**PARAMETERS, "cars.0.velocity": {"uniform": [0.5, 4.5]}}
    other_base = small_impact()
    other_base["time"]["end"] = 0.25
    others = [
        sweep_of(PARAMETERS, seed=8),
        sweep_of(changed),
        sweep_of(PARAMETERS, outputs={"record_length": 100}),
        sweep_of(PARAMETERS, models=["fem"]),
        parse_sweep({"case": other_base, "samples": 5, "seed": 7, "parameters": PARAMETERS}),
    ]
    assert len({reference.spec_hash, *(s.spec_hash for s in others)}) == 1 + len(others)


def test_resolved_sweep_loads_back_to_the_same_sweep():
    sweep = sweep_of({**PARAMETERS, "couplers.0.contact": {"choice": {"values": ["compression_only", "bilateral"], "weights": [1, 2]}}})
    again = parse_sweep(yaml.safe_load(sweep.resolved_yaml()))
    assert again.spec_hash == sweep.spec_hash
    assert all(again.sample(i) == sweep.sample(i) for i in range(sweep.size))


def test_base_file_resolves_relative_to_the_sweep_file(tmp_path):
    (tmp_path / "base.yaml").write_text(yaml.safe_dump(small_impact()))
    (tmp_path / "sweeps").mkdir()
    path = tmp_path / "sweeps" / "s.yaml"
    path.write_text(yaml.safe_dump({"base": "../base.yaml", "samples": 3, "seed": 1, "parameters": {"cars.0.velocity": {"uniform": [1, 2]}}}))
    sweep = load_sweep(path)
    assert sweep.base_dir == tmp_path and sweep.size == 3
    assert 1.0 <= sweep.sample_case(sweep.sample(2)).cars[0].velocity < 2.0


def test_the_example_sweep_validates():
    sweep = load_sweep(CASES / "sweeps" / "free_roll_speeds.yaml")
    assert sweep.size == 20
    for i in range(sweep.size):
        sweep.sample_case(sweep.sample(i))


# ---------------------------------------------------------------------------------------------
# Bad input: one CaseError naming the key path and the rule


BAD_PARAMETERS = [
    ({"cars.0.velocty": {"uniform": [1, 2]}}, r"parameters.cars.0.velocty: the case has no such key: unknown key \(did you mean 'velocity'\?\)"),
    ({"cars.0.bdy.axial_stiffness": {"uniform": [1, 2]}}, r"parameters.cars.0.bdy.axial_stiffness: every part .* no key 'bdy' under cars.0 \(did you mean 'body'\?\)"),
    ({"cars.2.velocity": {"uniform": [1, 2]}}, r"parameters.cars.2.velocity: .*index 2 is out of range; cars has 2 entries"),
    ({"cars.first.velocity": {"uniform": [1, 2]}}, r"parameters.cars.first.velocity: .*cars is a list; index it with an integer"),
    ({"cars.0.velocity.x": {"uniform": [1, 2]}}, r"parameters.cars.0.velocity.x: .*cars.0.velocity is a single value"),
    ({"measurement.noise": {"uniform": [1, 2]}}, None),  # valid here; refused below on a base without measurement
    ({"time.end": {"uniform": [0.2, 0.3]}}, r"parameters.time.end: cannot be swept"),
    ({"time": {"choice": [{"end": 0.2}]}}, r"parameters.time: cannot be swept: .* sweep time.dt"),
    ({"estimators.0": {"choice": ["inverse_rigid"]}}, r"parameters.estimators.0: cannot be swept: a sweep drops the estimators"),
    ({"models": {"choice": [["fem"]]}}, r"parameters.models: cannot be swept: set the models with the sweep's own models key"),
    ({"cars..velocity": {"uniform": [1, 2]}}, r"parameters.cars..velocity: a key path is dotted names"),
    ({"cars.0.velocity": {"uniform": [2, 1]}}, r"parameters.cars.0.velocity.uniform: low must be < high"),
    ({"cars.0.velocity": {"uniform": [1, 2, 3]}}, r"parameters.cars.0.velocity.uniform: must be a list of two numbers \[low, high\]"),
    ({"cars.0.velocity": {"uniform": [1, "fast"]}}, r"parameters.cars.0.velocity.uniform: must be a number; got 'fast'"),
    ({"cars.0.velocity": {"unifrom": [1, 2]}}, r"parameters.cars.0.velocity.unifrom: unknown distribution \(did you mean 'uniform'\?\)"),
    ({"cars.0.velocity": {"uniform": [1, 2], "grid": [1]}}, r"parameters.cars.0.velocity: give exactly one of"),
    ({"cars.0.velocity": 2.0}, r"parameters.cars.0.velocity: must be a mapping with exactly one key out of uniform, log_uniform"),
    ({"cars.0.velocity": {"log_uniform": [0.0, 2.0]}}, r"parameters.cars.0.velocity.log_uniform.low: must be > 0"),
    ({"cars.0.velocity": {"normal": {"mean": 1.0, "std": 0.0}}}, r"parameters.cars.0.velocity.normal.std: must be > 0"),
    ({"cars.0.velocity": {"normal": {"mean": 1.0, "std": 1.0, "clip": [2.0, 1.0]}}}, r"parameters.cars.0.velocity.normal.clip: must be \[low, high\] with low < high"),
    ({"cars.0.velocity": {"normal": {"mean": 1.0, "sigma": 1.0}}}, r"parameters.cars.0.velocity.normal.sigma: unknown key"),
    ({"cars.0.velocity": {"choice": []}}, r"parameters.cars.0.velocity.choice: must have at least 1 entries"),
    ({"cars.0.velocity": {"choice": {"values": [1, 2], "weights": [1, -1]}}}, r"parameters.cars.0.velocity.choice.weights\[1\]: must be >= 0"),
    ({"cars.0.velocity": {"choice": {"values": [1, 2], "weights": [0, 0]}}}, r"parameters.cars.0.velocity.choice.weights: must sum to > 0"),
    ({"cars.0.velocity": {"choice": {"values": [1, 2], "weights": [1]}}}, r"parameters.cars.0.velocity.choice.weights: must give one weight per value \(2 values\)"),
    ({"cars.0.velocity": {"grid": []}}, r"parameters.cars.0.velocity.grid: must have at least 1 entries"),
]


@pytest.mark.parametrize("parameters, message", BAD_PARAMETERS, ids=[next(iter(p)) + f"-{i}" for i, (p, _) in enumerate(BAD_PARAMETERS)])
def test_bad_parameters_name_the_key_path_and_rule(parameters, message):
    if message is None:
        assert sweep_of(parameters).size == 5
        with pytest.raises(CaseError, match=r"parameters.measurement.noise: .*measurement is a single value \(None\)"):
            parse_sweep({"case": small_impact(measurement=False), "samples": 1, "seed": 0, "parameters": parameters})
        return
    with pytest.raises(CaseError, match=message) as raised:
        sweep_of(parameters)
    assert str(raised.value).startswith("sweep.yaml: ")


@pytest.mark.parametrize(
    "change, message",
    [
        ({"sample": 3}, r"sample: unknown key \(did you mean 'samples'\?\)"),
        ({"samples": 0}, r"samples: must be >= 1"),
        ({"samples": True}, r"samples: must be a number, not true/false"),
        ({"seed": -1}, r"seed: must be >= 0"),
        ({"seed": None}, r"seed: "),
        ({"base": "base.yaml"}, r"base: give exactly one of base \(a case file\) or case \(an inline case\); got both"),
        ({"case": None}, r"base: give exactly one of base .*; got neither"),
        ({"models": ["fem", "femm"]}, r"models\[1\]: unknown model \(did you mean 'fem'\?\)"),
        ({"outputs": {"record_length": 1}}, r"outputs.record_length: must be >= 2"),
        ({"outputs": {"length": 100}}, r"outputs.length: unknown key"),
        ({"case": {"kind": "transient"}}, r"case.kind: a sweep's base case must be kind: impact"),
        ({"case": {"kind": "impact", "cars": []}}, r"case.cars: an impact needs at least 2 cars"),
    ],
)
def test_bad_sweep_keys_name_the_key_path_and_rule(change, message):
    data = {"case": small_impact(), "samples": 2, "seed": 0, **change}
    data = {k: v for k, v in data.items() if v is not None or k == "seed"}
    with pytest.raises(CaseError, match=message):
        parse_sweep(data, source="sweep.yaml")


def write(path: Path, data) -> Path:
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return path


def test_cli_exits_2_for_bad_sweep_files(tmp_path):
    runner = CliRunner()
    harmonic = CASES / "rod_harmonic.yaml"
    cases = [
        (write(tmp_path / "a.yaml", {"case": small_impact(), "samples": 2, "seed": 0, "parameters": {"cars.0.velocty": {"uniform": [1, 2]}}}), "parameters.cars.0.velocty"),
        (write(tmp_path / "b.yaml", {"case": small_impact(), "samples": 2, "seed": 0, "parameters": {"cars.0.velocity": {"uniform": [3, 1]}}}), "low must be < high"),
        (write(tmp_path / "c.yaml", {"base": str(harmonic), "samples": 2, "seed": 0}), "base: a sweep's base case must be kind: impact"),
        (write(tmp_path / "d.yaml", {"base": "missing.yaml", "samples": 2, "seed": 0}), "base: base case file not found"),
        (write(tmp_path / "e.yaml", "samples: 2\nsamples: 3\n"), "YAML syntax error"),
        (tmp_path / "nope.yaml", "sweep file not found"),
    ]
    for path, message in cases:
        result = runner.invoke(main, ["sweep", str(path), "-o", str(tmp_path / "out.h5")])
        assert result.exit_code == 2, (path, result.output)
        assert message in result.output and str(path) in result.output
    both = runner.invoke(main, ["sweep", str(cases[0][0]), "--scheduler", "tcp://127.0.0.1:8786", "--workers", "2"])
    assert both.exit_code == 2 and "--workers sizes the local cluster" in both.output
    assert not list(tmp_path.glob("out.h5*"))
