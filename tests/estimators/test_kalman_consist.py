"""The kalman estimator over a consist, as a measured case runs it (issue 32 item 1).

Against something independent of it: a three-car consist simulated by fem through the measurement chain and read
back as a measured case (benchmarks/bench_consist_kalman.py builds both), each coupler's kalman peak against the fem
force; the layout rule that refuses an unobservable coupler at validation against the PBH test on the estimator's
own model (:func:`reduced.kalman.undetectable_couplers`); the end loads against the impact loop's coupler maps.
"""

from __future__ import annotations

import importlib.util
import itertools
import json
import re
import sys

import h5py
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.api import run_case
from femref.case import load_case
from femref.case.coupler_observability import unobservable_couplers
from femref.cli import main
from femref.estimators import KalmanEstimator, Recorded
from femref.estimators.kalman import KALMAN_NIS_RANGE, line_cars
from femref.impact.kernels.loop import coupler_maps
from femref.run.event_budget import kalman_states
from femref.scene.build import scene_from_case
from femref.scene.measured import KalmanModel, MeasuredCoupler
from femref.sensing.noise_gate import quiet_corrected
from reduced import kalman
from support.paths import CASES, REPO


def _bench():
    name = "bench_consist_kalman"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / "bench_consist_kalman.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # dataclasses look their module up while the class is made
        spec.loader.exec_module(module)
    return sys.modules[name]


bench = _bench()
SPEC = bench.ConsistSpec(3, "free_to_roll", 2.0, elements=32, end=0.8)


@pytest.fixture(scope="module")
def fem_run(tmp_path_factory):
    return bench.simulate(SPEC, tmp_path_factory.mktemp("fem"))


@pytest.mark.parametrize("blind, tolerance", [(None, 0.015), (1, 0.03)])
def test_a_three_car_consist_end_to_end(fem_run, tmp_path, blind, tolerance):
    """Striker into a coupled pair (draft gears, 20 mm slack in the cut): each coupler's kalman peak within 1.5 %
    of the fem force's peak (3 % with the struck car uninstrumented; measured 0.3–0.8 %), the fem peak inside the
    band at the kalman peak, the band no wider than ±15 %, a contact instant per coupler after the record's start, the
    second coupler's later (its gear closes after the first)."""
    rows = bench.scored(SPEC, fem_run, tmp_path, blind)
    assert [r["coupler"] for r in rows] == ["c1", "c2"]
    for r in rows:
        assert r["status"] == "ok"
        assert abs(r["error"]) <= tolerance, r
        assert r["covered"], r
        assert r["upper"] - r["lower"] <= 0.3 * r["truth"], r
    contacts = [r["contact_time"] for r in rows]
    assert bench.CLOCK - 0.01 < contacts[0] < contacts[1] < bench.CLOCK + 0.3


def test_an_unobservable_coupler_is_refused_at_validation(fem_run, tmp_path):
    """Cars car1 and car2 unrecorded: c2 has no instrumented car on either side; ``femref run`` exits 2 naming
    ``couplers.c2`` and the reason, and writes nothing."""
    case = bench.measured_case(SPEC, fem_run, tmp_path, blind=1)
    case["records"] = [r for r in case["records"] if not r["file"].startswith("car2")]
    case["cars"][2]["sensors"] = {}
    path = tmp_path / "measured.yaml"
    path.write_text(yaml.safe_dump(case, sort_keys=False))
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert "couplers.c2: kalman cannot observe its force: no instrumented car feels its force: cars car1 and car2 carry no sensors" in result.output
    assert "couplers.c1" not in result.output
    assert not output.exists() and not list(tmp_path.glob("out*"))
    case["estimators"] = ["kalman", "inverse_rigid"]
    path.write_text(yaml.safe_dump(case, sort_keys=False))
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2 and "only kalman estimates through an uninstrumented car" in result.output


def test_the_layout_rule_is_the_pbh_test_of_the_estimators_model():
    """Every layout of 3 and 4 cars with at least one recorded (couplers between all neighbours, and a 4-car line
    missing its middle coupler): the couplers the case refuses are the ones the PBH test on the estimator's model
    names undetectable (:func:`reduced.kalman.undetectable_couplers`; cases/impact_consist.yaml's cars, four modes)."""
    scene = scene_from_case(load_case(CASES / "impact_consist.yaml"))
    estimator = KalmanEstimator(KalmanModel(), {})
    checked = 0
    for count, rears in ((3, (0, 1)), (4, (0, 1, 2)), (4, (0, 2))):
        cars = scene.cars[:count]
        couplers = [MeasuredCoupler(f"c{j + 1}", rear) for j, rear in enumerate(rears)]
        for layout in itertools.product((False, True), repeat=count):
            if not any(layout):
                continue
            refused = unobservable_couplers([c.name for c in cars], layout, rears, [c.name for c in couplers])
            records = {f"{car.name}/{s}": np.zeros(4) for car, on in zip(cars, layout) if on for s in car.sensors}
            model, _ = estimator.cars(Recorded(np.arange(4) * 1e-3, records, cars, couplers))
            found = kalman.undetectable_couplers(kalman.augmented_model(model, 1e-3, 0.05))
            assert set(refused) == {couplers[c].name for _, named in found for c in named}, (count, rears, layout)
            checked += 1
    assert checked == 7 + 15 + 15


def test_the_end_loads_are_the_impact_loops_coupler_maps():
    """``line_cars`` on cases/impact_consist.yaml's five cars and four couplers: each car's ``B_c`` equals the impact
    loop's ``Bc``."""
    scene = scene_from_case(load_case(CASES / "impact_consist.yaml"))
    ours = line_cars(len(scene.cars), [c.rear for c in scene.couplers])
    assert [i for i, _ in ours] == list(range(5))
    for (_, b), (bc, _) in zip(ours, coupler_maps(scene)):
        np.testing.assert_array_equal(b, bc)


def test_the_budget_prices_the_lines_filter(fem_run, tmp_path):
    """``kalman_states`` of the three-car case with the struck car unrecorded against the state the estimator
    builds: three cars of 4 modes, two forces, a 4th-order filter on each of the four recorded channels."""
    bench.measured_case(SPEC, fem_run, tmp_path, blind=1)
    scene = scene_from_case(load_case(tmp_path / "measured.yaml"))
    records = {probe: np.zeros(4) for probe in scene.anti_alias}
    model, probes = KalmanEstimator(scene.kalman, scene.anti_alias).cars(Recorded(np.arange(4) * 1e-3, records, scene.cars, scene.couplers))
    assert len(probes) == 4
    assert kalman.augmented_model(model, 1e-3, 0.05).transition.shape[0] == kalman_states(scene) == 3 * 8 + 2 + 4 * 4


def test_femref_run_writes_and_prints_each_couplers_estimate_and_contact(fem_run, tmp_path):
    """The struck car unrecorded, through ``femref run -o``: exit 0; the result file holds a kalman group per coupler
    with its band around the force and its contact instant in its settings; the console table a row per coupler
    with that contact instant."""
    bench.measured_case(SPEC, fem_run, tmp_path, blind=1)
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(tmp_path / "measured.yaml"), "-o", str(output)], env={"COLUMNS": "250"})
    assert result.exit_code == 0, result.output
    contacts = {}
    with h5py.File(output, "r") as h5:
        (event,) = h5["events"].values()
        for coupler in ("c1", "c2"):
            group = event[f"kalman/{coupler}"]
            force, lower, upper = (group[name][()] for name in ("force", "force_lower", "force_upper"))
            assert np.all(lower <= force) and np.all(force <= upper) and force.max() > 1e6
            contacts[coupler] = json.loads(group.attrs["settings"])["contact_time"]
    assert bench.CLOCK - 0.01 < contacts["c1"] < contacts["c2"] < bench.CLOCK + 0.3
    assert "contact s" in result.output
    for coupler, contact in contacts.items():
        assert re.search(rf"kalman @{coupler}\s.*{contact:.4f}", result.output), result.output


def test_two_cars_give_the_one_coupler_estimators_numbers():
    """cases/measured_yard.yaml's first event (hammer into anvil) through the line's estimator against the one-coupler
    path it replaced (``CoupledCars`` with ``coupler_load`` (0, −1) and (−1, 0), ``estimate_force_with_variants``):
    force and band equal to 1e-12 of the peak; no contact instant is computed for one coupler (a network asks)."""
    scene = scene_from_case(load_case(CASES / "measured_yard.yaml"))
    event = run_case(CASES / "measured_yard.yaml").events[0]
    _, noise, _ = quiet_corrected(event.time, event.records, event.trigger_time)
    recorded = Recorded(event.time, event.records, scene.cars, scene.couplers, noise)
    estimator = KalmanEstimator(scene.kalman, scene.anti_alias)
    (estimate,) = estimator.estimate(recorded)
    line, probes = estimator.cars(recorded)
    rear, front = (kalman.CarDynamics(c.mass, c.damping, c.stiffness, c.load_map, c.sensor_map, b)
                   for c, b in zip(line.cars, ((0.0, -1.0), (-1.0, 0.0))))
    cars = kalman.CoupledCars(rear, front, line.sensor_filter)
    model = scene.kalman
    before = kalman.estimate_force_with_variants(
        [cars, *kalman.corner_models(cars, model.frequency_tolerance, model.damping_factors)], event.time,
        np.column_stack([event.records[p] for p in probes]), [noise[p] for p in probes], variant_force_rate="nominal",
        mass_tolerance=model.mass_tolerance, nis_range=KALMAN_NIS_RANGE)
    assert estimate.status == before.status == "ok"
    scale = float(np.max(before.force))
    for ours, theirs in ((estimate.force, before.force), (estimate.lower, before.lower), (estimate.upper, before.upper)):
        np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=1e-12 * scale)
    assert "contact_time" not in estimate.settings and not recorded.contacts
