"""A library of yard impacts simulated by femref itself, each the 1 kHz record of every probe, cached on disk.

Each impact is the default scene's pair of loaded hoppers (119 t behind, 100 t ahead; rod bodies, lading between the
bolsters) run with the fem model through the default measurement chain (1 kHz, 100 Hz fourth-order anti-alias filter,
no noise: the day adds the recorders' noise) until the cars have rung out. Five probes: ``car1`` (the moving car)
rear, centre and front, ``car2`` rear and centre. Three gears:

* ``draft_gear``: the default scene's two M-901E-class gears in series, cars free to roll (they part after the impact);
* ``friction_gear``: the friction gear of cases/impact_friction_gear.yaml (closes solid above ~1.4 m/s), free to roll;
* ``coupled``: the table gear of cases/impact_coupled.yaml, cars coupled before and after (bilateral, 25 mm draft slack);
* ``fleet_friction_gear``: the friction gear with a softer solid stop (the fleet's gears, :mod:`fleet`).

:data:`LIBRARY` holds 15 of them (speeds 1–4 m/s, both impact types femref classifies). :func:`load_library` reads
them from ``build/synthetic/impacts`` and simulates those missing (~20 s each): a file per impact, named by its
gear, speed and a hash of the case it ran, so a changed case is simulated again.
"""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from femref import __version__
from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.run.runner import run_scene
from femref.scene.build import scene_from_case

ROOT = Path(__file__).resolve().parents[2]
CACHE = ROOT / "build" / "synthetic" / "impacts"
SENSORS = {"car1": {"rear": -8.3, "center": 0.0, "front": 8.3}, "car2": {"rear": -8.3, "center": 0.0}}
PROBES = tuple(f"{car}/{sensor}" for car, sensors in SENSORS.items() for sensor in sensors)
RATE = 1000.0
LOWPASS = 100.0
RING_OUT = 2.5
"""s simulated: the cars' accelerations are below 5e-3 m/s² (a tenth of the recorders' noise) in the last 0.25 s."""
COUPLED_RING_OUT = 10.0
"""s simulated of a coupled impact: the cars bump within the 25 mm draft slack for 7–9 s (below 0.05 m/s² after 2.5 s)."""
QUIET_LEVEL = 5e-3

FRICTION_GEAR = {"friction_gear": {"loading": {"cubic": {"linear_stiffness": 1.0e7, "cubic_stiffness": 3.0e9}}, "unloading_ratio": 0.4,
                                   "solid_closure": 0.075, "solid_stiffness": 1.8e9}}
"""cases/impact_friction_gear.yaml's gear: rated closure force k₁δ_s + k₃δ_s³ = 2.016 MN at δ_s = 75 mm."""
COUPLED_GEAR = {"table": {"closure": [0.0, 0.0119, 0.0188, 0.0495, 0.125], "loading": [0.0, 1.0e4, 1.2e5, 6.8e5, 1.35e6],
                          "unloading": [0.0, 3.0e3, 3.6e4, 2.04e5, 4.05e5], "damping": 2.0e4}}
"""cases/impact_coupled.yaml's gear (a table after the friction gear's published envelope)."""
FLEET_FRICTION_GEAR = {"friction_gear": {**FRICTION_GEAR["friction_gear"], "solid_stiffness": 3.0e8}}
"""The friction gear with a solid stop of 3e8 N/m (5× its loading slope at closure): at 1.50–1.62 m/s on these cars
femref's closure detector finds the kink of the force–stroke line ``closed`` in most impacts (22 of the fleet's 30 on
the worn gear, the others ``ambiguous``); behind the case's 1.8e9 N/m stop the solid stretch lasts too few samples at
1 kHz through the 100 Hz filter and reads ``ambiguous``, and stiffer stops or faster impacts fail the detector's F test."""
GEARS = ("draft_gear", "friction_gear", "fleet_friction_gear", "coupled")


@dataclass(frozen=True)
class ImpactSpec:
    """One simulated impact: the ``gear`` (:data:`GEARS`), the moving car's ``speed`` (m/s) and a factor on the friction
    gear's loading curve (``gear_scale``: a worn gear closes at ``gear_scale`` × its rated force)."""

    gear: str
    speed: float
    gear_scale: float = 1.0
    end: float = RING_OUT
    elements: int = 64
    rate: float = RATE
    lowpass: float = LOWPASS

    @property
    def impact_type(self) -> str:
        """The type femref should class it: ``coupled`` (cars coupled before and after) or ``free_to_roll``."""
        return "coupled" if self.gear == "coupled" else "free_to_roll"

    @property
    def name(self) -> str:
        worn = "" if self.gear_scale == 1.0 else f"_x{self.gear_scale:.4f}"
        return f"{self.gear}_{self.speed:.2f}{worn}"


LIBRARY = (
    *(ImpactSpec("draft_gear", v) for v in (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)),
    *(ImpactSpec("friction_gear", v) for v in (1.2, 1.8, 2.4, 3.0)),
    *(ImpactSpec("coupled", v, end=COUPLED_RING_OUT) for v in (1.0, 1.8, 2.6, 3.4)),
)


@dataclass(frozen=True)
class SimulatedImpact:
    """An impact's records from its contact at ``time = 0`` (s, 1 kHz): ``accelerations`` per probe (m/s², through the
    measurement chain), and the fem truth on the model's grid: ``coupler_force`` (N, compression positive) and
    ``closure`` (m) at ``model_time`` (s)."""

    spec: ImpactSpec
    time: np.ndarray
    accelerations: dict[str, np.ndarray]
    model_time: np.ndarray
    coupler_force: np.ndarray
    closure: np.ndarray

    @property
    def peak_force(self) -> float:
        return float(self.coupler_force.max())


def impact_case(spec: ImpactSpec, sensors: dict[str, dict[str, float]] = SENSORS) -> dict[str, Any]:
    """The impact case of ``spec``: the default scene with its cars renamed ``car1``, ``car2`` and their ``sensors``,
    the gear, fem only, the measurement chain without noise."""
    data = default_scene_data()
    data["cars"][0].update(name="car1", velocity=spec.speed, sensors=sensors["car1"])
    data["cars"][1].update(name="car2", velocity=0.0, sensors=sensors["car2"])
    coupler = data["couplers"][0]
    coupler["between"] = ["car1", "car2"]
    if spec.gear in ("friction_gear", "fleet_friction_gear"):
        law = copy.deepcopy(FRICTION_GEAR if spec.gear == "friction_gear" else FLEET_FRICTION_GEAR)
        cubic = law["friction_gear"]["loading"]["cubic"]
        cubic.update({key: value * spec.gear_scale for key, value in cubic.items()})
        coupler["law"] = law
    elif spec.gear == "coupled":
        coupler.update(law=copy.deepcopy(COUPLED_GEAR), contact="bilateral", slack=0.0, tension_slack=0.025)
    elif spec.gear != "draft_gear":
        raise ValueError(f"gear must be one of {', '.join(GEARS)}, got {spec.gear!r}")
    data.update(models=["fem"], estimators=[], time={"end": spec.end}, fem={"elements": spec.elements, "order": 2},
                measurement={"rate": spec.rate, "lowpass": spec.lowpass, "noise": 0.0, "seed": 1})
    return data


def simulate(spec: ImpactSpec, sensors: dict[str, dict[str, float]] = SENSORS) -> SimulatedImpact:
    """Run ``spec``'s case with fem (``sensors`` on its cars); RuntimeError if the run fails or the cars have not rung out
    by its end."""
    data = impact_case(spec, sensors)
    probes = [f"{car}/{sensor}" for car, names in sensors.items() for sensor in names]
    fem = run_scene(scene_from_case(parse_case(data, source=f"<synthetic {spec.name}>"))).results[0]
    if not fem.ok:
        raise RuntimeError(f"{spec.name}: the fem run failed: {fem.message}")
    time = np.asarray(fem.measured["time"], dtype=float)
    accelerations = {probe: np.asarray(fem.measured[probe], dtype=float) for probe in probes}
    tail = time >= time[-1] - 0.25
    loudest = max(float(np.abs(a[tail]).max()) for a in accelerations.values())
    if loudest > QUIET_LEVEL:
        raise RuntimeError(f"{spec.name}: the cars still ring at {loudest:.3g} m/s² at {spec.end} s; simulate longer")
    coupler = fem.couplers["c1"]
    return SimulatedImpact(spec, time, accelerations, np.asarray(fem.axes["time"], dtype=float), np.asarray(coupler["force"], dtype=float),
                           np.asarray(coupler["closure"], dtype=float))


def case_hash(spec: ImpactSpec, sensors: dict[str, dict[str, float]] = SENSORS) -> str:
    """Eight hex digits of the case ``spec`` runs and femref's version: the cache key."""
    text = yaml.safe_dump(impact_case(spec, sensors), sort_keys=True) + __version__
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def load_impact(spec: ImpactSpec, cache: Path = CACHE, sensors: dict[str, dict[str, float]] = SENSORS) -> SimulatedImpact:
    """``spec``'s impact from ``cache``, simulated and stored (atomically) when it is not there."""
    path = cache / f"{spec.name}_{spec.elements}el_{case_hash(spec, sensors)}.npz"
    if not path.exists():
        impact = simulate(spec, sensors)
        cache.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(".partial.npz")
        np.savez(partial, time=impact.time, model_time=impact.model_time, coupler_force=impact.coupler_force, closure=impact.closure,
                 spec=json.dumps(spec.__dict__), **{f"a:{probe}": a for probe, a in impact.accelerations.items()})
        partial.replace(path)
    with np.load(path) as stored:
        accelerations = {key[2:]: stored[key] for key in stored.files if key.startswith("a:")}
        return SimulatedImpact(spec, stored["time"], accelerations, stored["model_time"], stored["coupler_force"], stored["closure"])


def load_library(specs: Sequence[ImpactSpec] = LIBRARY, cache: Path = CACHE) -> list[SimulatedImpact]:
    """Every impact of ``specs`` (:func:`load_impact`)."""
    return [load_impact(spec, cache) for spec in specs]


def duration(impact: SimulatedImpact) -> float:
    """s from contact until every probe stays below :data:`QUIET_LEVEL` (m/s²)."""
    loud = np.flatnonzero(np.max([np.abs(a) for a in impact.accelerations.values()], axis=0) > QUIET_LEVEL)
    return float(impact.time[loud[-1]]) if loud.size else 0.0


def main() -> None:
    """Simulate the missing impacts of :data:`LIBRARY` and print each one's peak force and how long it rings."""
    for impact in load_library():
        print(f"{impact.spec.name:>22}  {impact.spec.impact_type:>12}  peak {impact.peak_force / 1e6:6.3f} MN  "
              f"rings {duration(impact):5.2f} s  max |a| {max(np.abs(a).max() for a in impact.accelerations.values()):6.1f} m/s²")


if __name__ == "__main__":
    main()
