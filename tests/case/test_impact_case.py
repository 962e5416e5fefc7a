"""Valid impact cases: parsing, filled defaults, the resolved-YAML round trip, and the built ImpactScene."""

from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from femref.case import ImpactCase, load_case, parse_case, resolved_yaml
from femref.case.capabilities import MODELS, refusal
from femref.cli import main
from femref.scene.build import scene_from_case
from femref.core.catalog import FIDELITIES
from femref.scene.impact import ImpactScene, Measurement, ModelRun
from femref.fem.build import FemSettings
from reduced.couplers import COUPLER_LAWS, Coupling, KelvinVoigt, StandardLinearDraftGear
from support.case_helpers import write_case

#: The free-to-roll example of docs/design.md §3, verbatim.
DESIGN_EXAMPLE = """\
kind: impact
cars:
  - name: hammer
    body: {type: rod, length: 17.0, mass_per_length: 7000.0,
           axial_stiffness: 3.0e9, axial_viscosity: 2.0e6}
    velocity: 2.2
    sensors: {center: 0.0, front: 8.0}
  - name: anvil
    body: {type: rod, length: 15.0, mass_per_length: 6500.0,
           axial_stiffness: 3.0e9, axial_viscosity: 2.0e6}
    velocity: 0.0
    sensors: {center: 0.0, rear: -7.0}
couplers:
  - name: c1
    between: [hammer, anvil]      # hammer's +l end meets anvil's −l end
    law: {kelvin_voigt: {stiffness: 4.0e7, damping: 3.0e5}}
    contact: compression_only     # free to roll; 'bilateral' for coupled cars
time: {end: 0.5}
models: [fem, quasi_rigid, rigid]
"""

#: Three cars, every coupler law, a mixed run, a measurement and both estimators.
THREE_CARS = """\
kind: impact
cars:
  - name: hammer
    body: {type: rod, length: 17.0, mass_per_length: 7000.0, axial_stiffness: 3.0e9}
    velocity: 2.2
  - name: anvil
    body:
      type: rod
      length: 16.0
      mass_per_length: {piecewise: {breaks: [-4.0, 4.0], values: [5000.0, 8000.0, 5000.0]}}
      axial_stiffness: {linear: {left: 2.0e9, right: 3.0e9}}
    velocity: 0.0
    sensors: {rear: -7.5, center: 0.0, front: 7.5}
  - name: wagon
    body: {type: rod, length: 15.0, mass_per_length: 6500.0, axial_stiffness: 3.0e9, axial_viscosity: 1.0e6}
    velocity: -0.5
    sensors: {rear: -7.0, front: 7.0}
couplers:
  - between: [hammer, anvil]
    law:
      draft_gear: {gear_stiffness: 3.4e7, gear_damping: 5.0e5, stroke: 0.0825, solid_stiffness: 2.0e8}
  - name: rear_coupler
    between: [anvil, wagon]
    law:
      table:
        closure: [0, 0.02, 0.05, 0.08]
        loading: [0, 2.0e5, 1.2e6, 2.5e6]
        unloading: [0, 5.0e4, 4.0e5, 1.5e6]
    contact: bilateral
    slack: 0.01
    tension_slack: 0.02
time: {end: 0.3, dt: 1.0e-4, output_stride: 2}
integrator: {scheme: newmark}
models:
  - rigid
  - {name: rigid_with_fem_anvil, fidelity: rigid, cars: {anvil: fem}}
  - fem
  - {name: mixed, fidelity: quasi_rigid, cars: {hammer: modal, wagon: fem}}
fem: {elements: 32, order: 1}
modal: {modes: 6}
measurement: {rate: 2000.0, lowpass: 500.0, noise: 0.05, seed: 7}
estimators: [inverse_quasi_rigid, inverse_rigid]
"""


@pytest.fixture
def design_case(tmp_path: Path) -> ImpactCase:
    case = load_case(write_case(tmp_path, DESIGN_EXAMPLE))
    assert isinstance(case, ImpactCase)
    return case


@pytest.fixture
def three_cars(tmp_path: Path) -> ImpactCase:
    case = load_case(write_case(tmp_path, THREE_CARS))
    assert isinstance(case, ImpactCase)
    return case


# Parsing and defaults


def test_design_example_parses_with_defaults_filled(design_case: ImpactCase) -> None:
    case = design_case
    assert case.kind == "impact" and case.car_names == ["hammer", "anvil"]
    assert [car.velocity for car in case.cars] == [2.2, 0.0]
    assert case.cars[1].sensors == {"center": 0.0, "rear": -7.0}
    coupler = case.couplers[0]
    assert (coupler.name, coupler.between, coupler.contact, coupler.slack, coupler.tension_slack) == (
        "c1",
        ("hammer", "anvil"),
        "compression_only",
        0.0,
        0.0,
    )
    assert (coupler.law.stiffness, coupler.law.damping) == (4.0e7, 3.0e5)
    assert (case.time.end, case.time.dt, case.time.output_stride) == (0.5, None, 1)
    assert case.integrator.scheme == "generalized_alpha" and case.integrator.rho_inf == 0.8
    assert (case.fem.elements, case.fem.order) == (64, 2)
    assert case.modal.modes == 4
    assert case.measurement is None and case.estimators == ()
    assert case.models == ("fem", "quasi_rigid", "rigid")


def test_minimal_case_fills_every_default() -> None:
    """Only what the scene needs: sensors, coupler names, damping, contact and models default."""
    data = yaml.safe_load(DESIGN_EXAMPLE)
    for car in data["cars"]:
        del car["sensors"]
    del data["couplers"][0]["name"], data["couplers"][0]["contact"], data["models"]
    data["couplers"][0]["law"] = {"kelvin_voigt": {"stiffness": 4.0e7}}
    case = parse_case(data)
    assert [car.sensors for car in case.cars] == [{"center": 0.0}, {"center": 0.0}]
    assert case.couplers[0].name == "c1" and case.couplers[0].contact == "compression_only"
    assert case.couplers[0].law.damping == 0.0
    assert case.models == ("fem", "quasi_rigid", "rigid")


def test_three_car_case_parses(three_cars: ImpactCase) -> None:
    case = three_cars
    assert [c.name for c in case.couplers] == ["c1", "rear_coupler"]
    gear = case.couplers[0].law
    assert (gear.series_stiffness_1, gear.series_stiffness_2) == (4.0e8, 4.0e8)
    table = case.couplers[1].law
    assert (table.damping, table.switch_velocity) == (0.0, 0.01)
    assert case.integrator.rho_inf is None
    assert case.measurement is not None and case.measurement.seed == 7
    assert case.run_fidelities() == {
        "rigid": ("rigid", "rigid", "rigid"),
        "rigid_with_fem_anvil": ("rigid", "fem", "rigid"),
        "fem": ("fem", "fem", "fem"),
        "mixed": ("modal", "quasi_rigid", "fem"),
    }


def test_uniform_run_may_be_written_as_a_mapping() -> None:
    """``{name: rigid, fidelity: rigid}`` is the plain rigid run, so it may take the model's name."""
    data = yaml.safe_load(DESIGN_EXAMPLE)
    data["models"] = ["fem", {"name": "rigid", "fidelity": "rigid", "cars": {"anvil": "rigid"}}]
    assert parse_case(data).run_fidelities()["rigid"] == ("rigid", "rigid")


def test_estimators_accept_a_fem_run_written_as_a_mapping() -> None:
    data = yaml.safe_load(DESIGN_EXAMPLE)
    data["models"] = ["rigid", {"name": "reference", "fidelity": "fem"}]
    data["estimators"] = ["inverse_rigid", "inverse_quasi_rigid"]
    assert parse_case(data).estimators == ("inverse_rigid", "inverse_quasi_rigid")


# Resolved YAML


@pytest.mark.parametrize("text", [DESIGN_EXAMPLE, THREE_CARS], ids=["design example", "three cars"])
def test_resolved_yaml_round_trips(tmp_path: Path, text: str) -> None:
    case = load_case(write_case(tmp_path, text))
    resolved_text = resolved_yaml(case)
    resolved = yaml.safe_load(resolved_text)
    assert resolved["kind"] == "impact"
    assert {"cars", "couplers", "time", "integrator", "models", "fem", "modal", "measurement", "estimators"} <= set(resolved)
    for coupler in resolved["couplers"]:
        assert {"name", "between", "law", "contact", "slack", "tension_slack", "vertical_offset", "pivot_distance"} == set(coupler)
    again = parse_case(resolved)
    assert again == case
    assert resolved_yaml(again) == resolved_text
    assert load_case(write_case(tmp_path, resolved_text, "resolved.yaml")) == case


def test_resolved_yaml_writes_laws_and_runs_in_case_file_form(three_cars: ImpactCase) -> None:
    resolved = yaml.safe_load(resolved_yaml(three_cars))
    assert resolved["couplers"][0]["law"] == {
        "draft_gear": {
            "gear_stiffness": 3.4e7,
            "gear_damping": 5.0e5,
            "stroke": 0.0825,
            "solid_stiffness": 2.0e8,
            "series_stiffness_1": 4.0e8,
            "series_stiffness_2": 4.0e8,
        }
    }
    assert resolved["couplers"][0]["name"] == "c1"
    assert resolved["couplers"][1]["law"]["table"]["switch_velocity"] == 0.01
    assert resolved["models"][1] == {"name": "rigid_with_fem_anvil", "fidelity": "rigid", "cars": {"anvil": "fem"}}
    assert resolved["models"][0] == "rigid"
    assert resolved["integrator"] == {"scheme": "newmark", "rho_inf": None}
    assert resolved["cars"][0]["sensors"] == {"center": 0.0}


def test_cli_validate_prints_the_resolved_impact_case(tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["validate", str(write_case(tmp_path, DESIGN_EXAMPLE))])
    assert result.exit_code == 0, result.output
    resolved = yaml.safe_load(result.output)
    assert resolved["modal"] == {"modes": 4} and resolved["measurement"] is None and resolved["estimators"] == []
    assert resolved["fem"]["order"] == 2
    assert parse_case(resolved) == load_case(tmp_path / "case.yaml")


# Capabilities

NETWORK_ENTRY = "{name: ann_<name>, network: file.npz}"


def test_capabilities_of_an_impact_case(design_case: ImpactCase) -> None:
    """Per-car fidelities serve impacts; exact and ann are refused with a reason; nothing needs ``.body``."""
    served = {name: refusal(name, design_case) for name in MODELS}
    assert {name for name, reason in served.items() if reason is None} == set(FIDELITIES)
    assert served["exact"] == "no exact solution is implemented for impact scenes (nonlinear contact); score against fem"
    assert served["ann"] == f"a network is an estimator on the fem sensor records, not a model run; list it under estimators: as {NETWORK_ENTRY}"


# The built scene


def test_design_example_builds_the_impact_scene(design_case: ImpactCase) -> None:
    scene = scene_from_case(design_case)
    assert isinstance(scene, ImpactScene) and scene.kind == "impact"
    hammer, anvil = scene.cars
    assert (hammer.name, anvil.name) == ("hammer", "anvil")
    assert (hammer.velocity, anvil.velocity) == (2.2, 0.0)
    # M = m · 2l: 7000 · 17 and 6500 · 15
    assert hammer.mass == pytest.approx(119000.0, rel=1e-12)
    assert anvil.mass == pytest.approx(97500.0, rel=1e-12)
    assert hammer.body.kind == "rod" and hammer.body.half_length == 8.5
    assert scene.probes == {"hammer/center": (0, 0.0), "hammer/front": (0, 8.0), "anvil/center": (1, 0.0), "anvil/rear": (1, -7.0)}
    (coupler,) = scene.couplers
    assert (coupler.name, coupler.rear, coupler.front) == ("c1", 0, 1)
    assert coupler.coupling == Coupling(KelvinVoigt(4.0e7, 3.0e5), "compression_only", 0.0, 0.0)
    assert scene.runs == (ModelRun("fem", ("fem", "fem")), ModelRun("quasi_rigid", ("quasi_rigid",) * 2), ModelRun("rigid", ("rigid",) * 2))
    assert scene.models == ("fem", "quasi_rigid", "rigid")
    assert (scene.end, scene.dt, scene.output_stride) == (0.5, None, 1)
    assert (scene.integrator, scene.rho_inf) == ("generalized_alpha", 0.8)
    assert scene.fem == FemSettings(elements=64, order=2)
    assert scene.modal_modes == 4 and scene.measurement is None and scene.estimators == ()


def test_three_car_case_builds_the_impact_scene(three_cars: ImpactCase) -> None:
    scene = scene_from_case(three_cars)
    assert [car.name for car in scene.cars] == ["hammer", "anvil", "wagon"]
    assert [car.velocity for car in scene.cars] == [2.2, 0.0, -0.5]
    assert scene.cars[1].sensors == {"rear": -7.5, "center": 0.0, "front": 7.5}
    # anvil: 8 m at 5000 kg/m and 8 m at 8000 kg/m; the jumps are kept on the body
    assert scene.cars[1].mass == pytest.approx(104000.0, rel=1e-12)
    assert set(scene.cars[1].body.jumps) >= {-4.0, 4.0}
    gear_coupler, table_coupler = scene.couplers
    assert (gear_coupler.name, gear_coupler.rear) == ("c1", 0)
    assert (table_coupler.name, table_coupler.rear, table_coupler.front) == ("rear_coupler", 1, 2)
    assert gear_coupler.coupling == Coupling(
        StandardLinearDraftGear(4.0e8, 4.0e8, 3.4e7, 5.0e5, 0.0825, 2.0e8), "compression_only", 0.0, 0.0
    )
    table = table_coupler.coupling
    assert isinstance(table.law, COUPLER_LAWS["table"])
    assert (table.contact, table.slack, table.tension_slack) == ("bilateral", 0.01, 0.02)
    assert tuple(table.law.closure) == (0.0, 0.02, 0.05, 0.08) and tuple(table.law.unloading)[-1] == 1.5e6
    assert (table.law.damping, table.law.switch_velocity) == (0.0, 0.01)
    assert scene.runs == (
        ModelRun("rigid", ("rigid", "rigid", "rigid")),
        ModelRun("rigid_with_fem_anvil", ("rigid", "fem", "rigid")),
        ModelRun("fem", ("fem", "fem", "fem")),
        ModelRun("mixed", ("modal", "quasi_rigid", "fem")),
    )
    assert scene.runs[1].uniform is None and scene.runs[2].uniform == "fem"
    assert (scene.end, scene.dt, scene.output_stride) == (0.3, 1.0e-4, 2)
    assert (scene.integrator, scene.rho_inf) == ("newmark", 1.0)
    assert scene.fem == FemSettings(elements=32, order=1)
    assert scene.modal_modes == 6
    assert scene.measurement == Measurement(rate=2000.0, lowpass=500.0, noise=0.05, seed=7)
    assert scene.estimators == ("inverse_quasi_rigid", "inverse_rigid")
    assert scene.contact_time() > 0.0 and scene.epsilon > 0.0
