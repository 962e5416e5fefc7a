"""Fit the car fidelities' cost model (:meth:`femref.models.base.CarFidelity.cost`: the ladder's and the budget's) on random two-car impacts.

    python benchmarks/fit_ladder_costs.py [--scenes 30] [--seed 0] [--repeats 5] [--json PATH]

The model, per rung of a ladder (µs on this machine; only ratios matter),

    cost = C/2 · (setup + steps · step),   setup = s · x_setup,   step = t · x_step,

with the regressors ``x`` of each fidelity's ``cost_regressors`` (their mean over the cars). Every rung of
every scene's ladder runs ``--repeats`` times **cold**: the built cars
(:func:`femref.models.base.forget_built`) are dropped and the rung's scene copied before each
run, so the cars are assembled, reduced and factorised afresh and everything cached per
system or per scene (packed cars, line plans) is rebuilt — as in a ladder, whose rungs each
run once on their own geometry. A modal rung therefore pays its mesh's assembly even when
the fem rung at the case's ``N`` has run. Per rung the medians over the repeats are kept
(the spikes of a busy machine are single runs), then per family the constants are fitted
by non-negative least squares on **relative** residuals:

* ``s`` on the wall time outside the stepping (``wall_time_s − stepping_time_s``: the
  build, packing and the result's assembly), residual ``(s·x_setup − measured)/measured``;
* ``t`` on the stepping time per step (``stepping_time_s / steps``), the same way.

Relative, because the costs span three decades and the ladder's order depends on their
ratios (absolute residuals would fit the largest runs only); least squares, because it is
linear in the constants, agreeing with a fit of log residuals to first order at the
residuals seen; non-negative, so that no cost falls as a model is refined.

Scenes: two cars (12–25 m, uniform 3–9 t/m or a hopper's lading between the bolsters,
60–130 t; EA 0.5–10 GN; β 0.003–0.3), the first rolling at 0.5–4 m/s into the second;
the coupler a draft gear (the default scene's, 12–25 MN/m, with or without the series
stiffness), a Kelvin–Voigt coupler (1 MN/m–2 GN/m, 0–30 % damping) or the friction-table
gear of ``cases/impact_coupled.yaml`` (bilateral, 25 mm tension slack); ``fem.elements``
16, 32, 48 or 64 (P2); the end at 1.3–1.5 contact times.

Prints, per family and resolution, the median measured and predicted wall time, the
spread of predicted over measured, the median build and packing (``setup_time_s``), time
outside the stepping and time per step; per family the spreads of the wall-time, set-up
and per-step predictions; how many pairs of rungs of one scene more than 10 % apart the
fit and the present constants order right; then the constants to paste into each
``femref/models/<fidelity>.py`` (``setup_us``, ``step_us``). Rungs that fail are listed and left out of the fit.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import statistics
import time
from collections import defaultdict
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import nnls

from femref.case import parse_case
from femref.case.defaults import default_scene_data
from femref.choice.ladder import model_ladder
from femref.models import CAR_FIDELITIES, base
from femref.run import load_compiled_loop
from femref.run.runner import run_model
from femref.scene import ImpactScene
from femref.scene.build import scene_from_case

FAMILIES = tuple(CAR_FIDELITIES)
CASE_ELEMENTS = (16, 32, 48, 64)
"""``fem.elements`` of the random cases (the impact cases use 32–64, the choice tests 16)."""
FRICTION_TABLE = {
    "closure": [0.0, 0.0119, 0.0188, 0.0495, 0.125],
    "loading": [0.0, 1.0e4, 1.2e5, 6.8e5, 1.35e6],
    "unloading": [0.0, 3.0e3, 3.6e4, 2.04e5, 4.05e5],
    "damping": 2.0e4,
}
"""The friction draft gear's envelope of ``cases/impact_coupled.yaml``."""
ORDER_MARGIN = 1.1
"""Pairs of rungs of one scene whose measured wall times differ by more than this factor are checked for order."""


@dataclass(frozen=True)
class RungTiming:
    """One rung of one scene: its regressors, steps and the medians of its cold runs' times (s)."""

    scene: int
    label: str
    family: str
    resolution: int
    case_elements: int
    cars: int
    steps: int
    x_setup: tuple[float, ...]
    x_step: tuple[float, ...]
    setup_time_s: float
    outside_stepping_s: float
    stepping_time_s: float
    wall_time_s: float

    @property
    def step_time_s(self) -> float:
        return self.stepping_time_s / self.steps


def random_body(rng: np.random.Generator) -> dict[str, Any]:
    """A rod car: 12–25 m, EA 0.5–10 GN, β 0.003–0.3; uniform 3–9 t/m or 3.5 t/m over 2 m ends and the lading between."""
    length, stiffness, beta = rng.uniform(12.0, 25.0), 10 ** rng.uniform(8.7, 10.0), 10 ** rng.uniform(-2.5, -0.5)
    if rng.uniform() < 0.5:
        mass_per_length: float | dict = rng.uniform(3000.0, 9000.0)
        mean_mass_per_length = mass_per_length
    else:
        end, gross = length / 2.0 - 2.0, rng.uniform(60.0e3, 130.0e3)
        lading = (gross - 3500.0 * 4.0) / (length - 4.0)
        mass_per_length = {"piecewise": {"breaks": [-end, end], "values": [3500.0, lading, 3500.0]}}
        mean_mass_per_length = gross / length
    viscosity = beta * length / 2.0 * math.sqrt(mean_mass_per_length * stiffness)
    return {"type": "rod", "length": length, "mass_per_length": mass_per_length, "axial_stiffness": stiffness, "axial_viscosity": viscosity}


def random_coupler(rng: np.random.Generator) -> dict[str, Any]:
    """A draft gear, a Kelvin–Voigt coupler or the friction-table gear (module docstring), one third each."""
    kind = rng.integers(3)
    coupler: dict[str, Any] = {"name": "c1", "between": ["hammer", "anvil"], "contact": "compression_only"}
    if kind == 0:
        gear = dict(default_scene_data()["couplers"][0]["law"]["draft_gear"])
        gear.update(gear_stiffness=rng.uniform(1.2e7, 2.5e7), gear_damping=rng.uniform(1.0e5, 2.5e5))
        if rng.uniform() < 0.5:
            del gear["series_stiffness_1"], gear["series_stiffness_2"]
        coupler["law"] = {"draft_gear": gear}
    elif kind == 1:
        stiffness = 10 ** rng.uniform(6.0, 9.3)
        coupler["law"] = {"kelvin_voigt": {"stiffness": stiffness, "damping": rng.uniform(0.0, 0.3) * 2.0 * math.sqrt(stiffness * 6.0e4)}}
    else:
        coupler.update(law={"table": FRICTION_TABLE}, contact="bilateral", slack=0.0, tension_slack=0.025)
    return coupler


def random_scene(rng: np.random.Generator, index: int) -> ImpactScene:
    """A random two-car impact (module docstring), ending 1.3–1.5 contact times after contact."""
    data = default_scene_data()
    del data["measurement"], data["estimators"]
    hammer, anvil = random_body(rng), random_body(rng)
    data["cars"] = [
        {"name": "hammer", "body": hammer, "velocity": rng.uniform(0.5, 4.0), "sensors": {"center": 0.0, "front": hammer["length"] / 2 - 0.2}},
        {"name": "anvil", "body": anvil, "velocity": 0.0, "sensors": {"rear": 0.2 - anvil["length"] / 2, "center": 0.0, "front": anvil["length"] / 2 - 0.2}},
    ]
    data["couplers"] = [random_coupler(rng)]
    data["fem"] = {"elements": int(rng.choice(CASE_ELEMENTS)), "order": 2}
    source = f"<random scene {index}>"
    data["time"] = {"end": rng.uniform(1.3, 1.5) * scene_from_case(parse_case(data, source=source)).contact_time()}
    return scene_from_case(parse_case(data, source=source))


def time_ladders(scenes: list[ImpactScene], repeats: int) -> tuple[list[RungTiming], list[str]]:
    """Every rung of every scene's ladder run cold (module docstring) ``repeats`` times, in whole passes over
    the scenes, so that a slow spell of the machine falls on one run of many rungs rather than on every run
    of a few: per rung the medians, and the rungs that failed (left out)."""
    ladders = [model_ladder(scene).rungs for scene in scenes]
    times: dict[tuple[int, str], list[tuple[int, float, float, float, float]]] = defaultdict(list)
    failed: dict[tuple[int, str], str] = {}
    for repeat in range(repeats):
        started = time.perf_counter()
        for index, rungs in enumerate(ladders):
            for rung in rungs:
                if (index, rung.label) in failed:
                    continue
                base.forget_built()
                result = run_model(dataclasses.replace(rung.scene), rung.run, rung.dt, rung.dt_rule)
                if not result.ok:
                    failed[(index, rung.label)] = result.message
                    continue
                settings = result.settings
                times[(index, rung.label)].append(
                    (settings["steps"], settings["setup_time_s"], result.wall_time_s - settings["stepping_time_s"], settings["stepping_time_s"], result.wall_time_s)
                )
        print(f"pass {repeat + 1}/{repeats}: {time.perf_counter() - started:.1f} s", flush=True)
    timings = []
    for index, (scene, rungs) in enumerate(zip(scenes, ladders)):
        for rung in rungs:
            if (index, rung.label) in failed:
                continue
            steps, setup, outside_stepping, stepping, wall = np.median(np.array(times[(index, rung.label)]), axis=0)
            x_setup, x_step = regressors(rung.family, rung.scene)
            timings.append(
                RungTiming(index, rung.label, rung.family, rung.resolution, scene.fem.elements, len(scene.cars), int(steps), x_setup, x_step,
                           float(setup), float(outside_stepping), float(stepping), float(wall))
            )
    return timings, [f"scene {index} {label}: {message}" for (index, label), message in failed.items()]


def regressors(family: str, scene: ImpactScene) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The mean over the cars of the fidelity's ``(x_setup, x_step)``: a two-car run costs ``s·x_setup``, ``t·x_step``."""
    fidelity = CAR_FIDELITIES[family]
    rows = [fidelity.cost_regressors(car, scene) for car in scene.cars]
    return tuple(np.mean([r[0] for r in rows], axis=0).tolist()), tuple(np.mean([r[1] for r in rows], axis=0).tolist())


def relative_nnls(x: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """``c ≥ 0`` minimising ``Σ ((x c − m)/m)²``."""
    coefficients, _ = nnls(x / measured[:, None], np.ones_like(measured))
    return coefficients


def fit_constants(timings: list[RungTiming]) -> tuple[dict[str, tuple[float, ...]], dict[str, tuple[float, ...]]]:
    """Per family, the set-up and per-step coefficients (µs) of a two-car run (module docstring)."""
    setup_us, step_us = {}, {}
    for family in FAMILIES:
        rows = [t for t in timings if t.family == family]
        scale = np.array([t.cars / 2.0 for t in rows])
        setup_us[family] = tuple(relative_nnls(np.array([t.x_setup for t in rows]), np.array([t.outside_stepping_s for t in rows]) * 1e6 / scale))
        step_us[family] = tuple(relative_nnls(np.array([t.x_step for t in rows]), np.array([t.step_time_s for t in rows]) * 1e6 / scale))
    return setup_us, step_us


def predicted_parts_us(timing: RungTiming, setup_us: dict, step_us: dict) -> tuple[float, float]:
    """Predicted set-up and per-step time (µs) of ``timing``'s rung under the coefficients ``setup_us``, ``step_us``."""
    scale = timing.cars / 2.0
    return scale * float(np.dot(setup_us[timing.family], timing.x_setup)), scale * float(np.dot(step_us[timing.family], timing.x_step))


def spread(ratios: list[float]) -> str:
    """Predicted/measured − 1 as median [10th, 90th percentile] (max |·|), in %."""
    errors = 100.0 * (np.array(ratios) - 1.0)
    low, median, high = np.percentile(errors, [10, 50, 90])
    return f"{median:+6.1f} [{low:+6.1f}, {high:+6.1f}] (max {np.max(np.abs(errors)):5.1f})"


def report(timings: list[RungTiming], setup_us: dict, step_us: dict) -> dict[str, dict[str, str]]:
    """Print measured against predicted per family and resolution, and the spread per family; returns the spreads."""
    groups: dict[tuple[str, int], list[RungTiming]] = defaultdict(list)
    for t in timings:
        groups[(t.family, t.resolution)].append(t)
    print("\nmedian over scenes; error = predicted/measured − 1, median [10th, 90th percentile] (max |error|), %")
    print(f"{'rung':<12} {'runs':>4} {'wall ms':>9} {'pred ms':>9} {'wall error %':>38} {'set-up ms':>9} {'non-step ms':>11} {'step µs':>8}")
    for (family, resolution), rows in sorted(groups.items(), key=lambda item: (FAMILIES.index(item[0][0]), item[0][1])):
        predicted = [_predicted_wall_s(t, setup_us, step_us) for t in rows]
        label = rows[0].label
        print(
            f"{label:<12} {len(rows):4d} {statistics.median(t.wall_time_s for t in rows) * 1e3:9.2f} {statistics.median(predicted) * 1e3:9.2f} "
            f"{spread([p / t.wall_time_s for p, t in zip(predicted, rows)]):>38} "
            f"{statistics.median(t.setup_time_s for t in rows) * 1e3:9.2f} {statistics.median(t.outside_stepping_s for t in rows) * 1e3:11.2f} "
            f"{statistics.median(t.step_time_s for t in rows) * 1e6:8.2f}"
        )
    wall_ratio = {id(t): _predicted_wall_s(t, setup_us, step_us) / t.wall_time_s for t in timings}
    scene_ratio = {scene: statistics.median(wall_ratio[id(t)] for t in timings if t.scene == scene) for scene in {t.scene for t in timings}}
    spreads: dict[str, dict[str, str]] = {}
    print("\nper family; within a scene: each scene's median error divided out (a scene-wide speed, of the machine or the")
    print("scene, does not change a ladder's order)")
    print(f"{'family':<12} {'wall error %':>38} {'within a scene %':>38} {'set-up error %':>38} {'per-step error %':>38}")
    for family in (*FAMILIES, "all"):
        rows = [t for t in timings if family in (t.family, "all")]
        parts = [predicted_parts_us(t, setup_us, step_us) for t in rows]
        spreads[family] = {
            "wall": spread([wall_ratio[id(t)] for t in rows]),
            "within_scene": spread([wall_ratio[id(t)] / scene_ratio[t.scene] for t in rows]),
            "setup": spread([s * 1e-6 / t.outside_stepping_s for (s, _), t in zip(parts, rows)]),
            "step": spread([p * 1e-6 / t.step_time_s for (_, p), t in zip(parts, rows)]),
        }
        print(f"{family:<12} " + " ".join(f"{spreads[family][key]:>38}" for key in ("wall", "within_scene", "setup", "step")))
    return spreads


def _predicted_wall_s(timing: RungTiming, setup_us: dict, step_us: dict) -> float:
    """``cost`` (s) of ``timing``'s rung under the coefficients ``setup_us``, ``step_us``."""
    setup, step = predicted_parts_us(timing, setup_us, step_us)
    return (setup + timing.steps * step) * 1e-6


def order_agreement(timings: list[RungTiming], setup_us: dict, step_us: dict, margin: float = ORDER_MARGIN) -> tuple[int, int]:
    """Pairs of rungs of one scene whose measured wall times differ by more than ``margin``×, and how many of them the prediction orders right."""
    right = total = 0
    by_scene: dict[int, list[RungTiming]] = defaultdict(list)
    for t in timings:
        by_scene[t.scene].append(t)
    for rows in by_scene.values():
        for i, a in enumerate(rows):
            for b in rows[i + 1:]:
                if max(a.wall_time_s, b.wall_time_s) > margin * min(a.wall_time_s, b.wall_time_s):
                    total += 1
                    right += (a.wall_time_s < b.wall_time_s) == (_predicted_wall_s(a, setup_us, step_us) < _predicted_wall_s(b, setup_us, step_us))
    return right, total


def constants_text(setup_us: dict, step_us: dict) -> str:
    """The coefficients as they read in each ``femref/models/<fidelity>.py``."""

    def literal(values: tuple[float, ...]) -> tuple[float, ...]:
        return tuple(float(f"{v:.4g}") for v in values)

    return "\n".join(f"femref/models/{family}.py: setup_us = {literal(setup_us[family])}, step_us = {literal(step_us[family])}" for family in FAMILIES)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=30, help="random two-car scenes (default 30)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the scenes (default 0)")
    parser.add_argument("--repeats", type=int, default=5, help="cold runs per rung, their median kept (default 5)")
    parser.add_argument("--json", metavar="PATH", help="write every rung's timings, the constants and the spreads here")
    args = parser.parse_args()
    started = time.perf_counter()
    rng = np.random.default_rng(args.seed)
    scenes = [random_scene(rng, i) for i in range(args.scenes)]
    load_compiled_loop(scenes[0])
    print(f"compiled loop loaded in {time.perf_counter() - started:.1f} s (compiling, after its source changed)")
    for index, scene in enumerate(scenes):
        print(f"scene {index:3d}: ε {scene.epsilon:8.2e}, N {scene.fem.elements:3d}, {type(scene.couplers[0].coupling.law).__name__}")
    timings, failed = time_ladders(scenes, args.repeats)
    for message in failed:
        print(f"not fitted (failed): {message}")
    setup_us, step_us = fit_constants(timings)
    spreads = report(timings, setup_us, step_us)
    right, total = order_agreement(timings, setup_us, step_us)
    current_right, _ = order_agreement(timings, {f: CAR_FIDELITIES[f].setup_us for f in FAMILIES}, {f: CAR_FIDELITIES[f].step_us for f in FAMILIES})
    print(f"\nrung pairs of one scene more than {ORDER_MARGIN}× apart: {right}/{total} ordered right by the fit, {current_right}/{total} by the present constants")
    elapsed = time.perf_counter() - started
    print(f"\n{len(timings)} rungs of {args.scenes} scenes × {args.repeats} cold runs in {elapsed:.0f} s. Constants (µs, two-car run):\n")
    print(constants_text(setup_us, step_us))
    if args.json:
        with open(args.json, "w") as out:
            json.dump(
                {"seed": args.seed, "scenes": args.scenes, "repeats": args.repeats, "elapsed_s": elapsed, "setup_cost_us": setup_us,
                 "step_cost_us": step_us, "spread_percent": spreads, "failed": failed, "rungs": [dataclasses.asdict(t) for t in timings]},
                out, indent=1,
            )
        print(f"\nwrote {args.json}")


if __name__ == "__main__":
    main()
