"""The ladder of models a choice climbs: every car fidelity at the resolutions it offers, cheapest first.

Each fidelity gives its rungs (:meth:`femref.models.base.CarFidelity.rungs`: e.g. rigid and
quasi-rigid one each, modal a mode count per rung, fem a mesh per rung refined jointly in space and
time), each at its step (:func:`femref.run.timestep.resolution_step`). Each rung has a Richardson
**partner**, the next finer rung of its fidelity; the finest has none. The two fidelities that are
consecutive terms of the low-frequency expansion in ε (``expansion_order`` 0 and 1: rigid and
quasi-rigid) are each other's partners: their difference is the first-order term.

**Cost** is predicted, not measured, so the ladder is ordered before anything runs: the µs of the
rung's cars on the machine that fitted them (:func:`femref.run.budget.run_cost_us`, the one cost
model of the fidelities, which the work budget prices runs by too; only ratios order the rungs).
The set-up is cold: every car assembled, reduced and factorised afresh, as each rung of a ladder
runs once on its own geometry. A run's set-up is worth about 135 (fem, 128 elements) to 4,000
(modal, one mode) of its steps.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

from femref.core.timegrid import steps_to
from femref.models import CAR_FIDELITIES
from femref.models.base import Resolution
from femref.models.fem import rod_dofs
from femref.run.budget import Cost, approximate_step, check_costs, impact_run_cost, run_cost_us
from femref.run.timestep import StepRule, impact_time_step, resolution_step, uniform_run
from femref.scene import ImpactScene, ModelRun

__all__ = ["Ladder", "Rung", "check_ladder_budget", "ladder_costs", "model_ladder", "predicted_cost"]


def predicted_cost(family: str, scene: ImpactScene, steps: int) -> float:
    """The µs of a run of ``scene`` with every car at fidelity ``family`` (:func:`femref.run.budget.run_cost_us`)."""
    return run_cost_us(scene, uniform_run(family, scene), steps)


@dataclass(frozen=True)
class Rung:
    """One model at one resolution: how to run it (``scene``, ``run``, ``dt``) and what it is predicted to cost.

    ``family`` is the fidelity; ``resolution`` the value of the setting its rungs vary (modes, elements per car),
    0 when it has one rung.
    """

    label: str
    family: str
    resolution: int
    scene: ImpactScene
    run: ModelRun
    dt: float
    dt_rule: str
    cost: float


@dataclass(frozen=True)
class Ladder:
    """The rungs cheapest first, each rung's Richardson partner (label → label), and the rungs of the expansion in ε,
    zeroth order first (empty without both)."""

    rungs: tuple[Rung, ...]
    partners: dict[str, str]
    expansion: tuple[str, ...] = ()

    def __getitem__(self, label: str) -> Rung:
        return next(rung for rung in self.rungs if rung.label == label)

    def index(self, label: str) -> int:
        return next(i for i, rung in enumerate(self.rungs) if rung.label == label)

    def partner(self, label: str) -> str | None:
        return self.partners.get(label)

    def coarser(self, label: str) -> str | None:
        """The rung whose partner ``label`` is, within its family."""
        rung = self[label]
        return next((c for c, p in self.partners.items() if p == label and self[c].family == rung.family), None)


def model_ladder(scene: ImpactScene, step: StepRule = impact_time_step, mesh_dofs: Callable[[ImpactScene], int] | None = None) -> Ladder:
    """The rungs of ``scene`` ordered by predicted cost, and their partners (module docstring).

    ``step`` gives each run's step (default: the runner's rule on the mesh); ``mesh_dofs`` the DOFs of the smallest
    car's mesh that bound the mode counts (``k ≤ ndof − 2``; default: counted on the mesh). The work budget lays out
    the same ladder without building a mesh (:func:`ladder_costs`).
    """
    ndof = None if mesh_dofs is None else mesh_dofs(scene)
    rungs: list[Rung] = []
    partners: dict[str, str] = {}
    terms: dict[int, str] = {}
    for name in reversed(CAR_FIDELITIES):  # coarsest first: the order of equal costs
        fidelity = CAR_FIDELITIES[name]
        levels = fidelity.rungs(scene, ndof)
        rungs.extend(_rung(name, level, step) for level in levels)
        partners.update({a.label: b.label for a, b in zip(levels, levels[1:])})
        if fidelity.expansion_order in (0, 1) and len(levels) == 1:
            terms[fidelity.expansion_order] = levels[0].label
    expansion = (terms[0], terms[1]) if len(terms) == 2 else ()
    if expansion:
        partners.update({expansion[0]: expansion[1], expansion[1]: expansion[0]})
    rungs.sort(key=lambda rung: rung.cost)
    return Ladder(tuple(rungs), partners, expansion)


def ladder_costs(scene: ImpactScene) -> list[Cost]:
    """Every rung of the ladder of ``scene`` priced by the work budget: ``impact_run_cost(rung.scene, rung.run,
    rung.dt)`` (:func:`femref.run.budget.impact_run_cost`, work units and bytes, not the µs that order the rungs),
    the ladder laid out without a mesh — steps by :func:`femref.run.budget.approximate_step`, mode counts by the DOFs
    of :func:`femref.run.budget.rod_dofs` — so pricing a huge case costs nothing. A rung's ``fem.elements`` factor
    names the case's value, the key to reduce."""
    ladder = model_ladder(scene, step=lambda s, run: (approximate_step(s, run), "predicted"),
                          mesh_dofs=lambda s: min(rod_dofs(car.body, s.fem.elements, s.fem.order) for car in s.cars))
    costs = []
    for rung in ladder.rungs:
        cost = impact_run_cost(rung.scene, rung.run, rung.dt)
        factors = {key: (ratio, scene.fem.elements if key == "fem.elements" else value) for key, (ratio, value) in cost.factors.items()}
        costs.append(dataclasses.replace(cost, model=rung.label, factors=factors, what=f"the {rung.label} rung of the --tolerance ladder"))
    return costs


def check_ladder_budget(scene: ImpactScene, source: str = "<case>") -> list[Cost]:
    """Refuse a ``--tolerance`` run when ``Σ`` over every rung (:func:`ladder_costs`: the worst case of a climb, which
    may run them all) exceeds the work budget (:func:`femref.run.budget.check_costs`, ``FEMREF_BUDGET``): a CaseError
    at ``source`` naming the key and the costliest rung's predicted size. Returns the costs otherwise."""
    costs = ladder_costs(scene)
    return check_costs(costs, source, f"the {len(costs)} runs of the --tolerance ladder")


def _rung(family: str, level: Resolution, step: StepRule) -> Rung:
    dt, rule = resolution_step(family, level, step)
    resolution = 0 if math.isnan(level.value) else int(level.value)
    return Rung(level.label, family, resolution, level.scene, uniform_run(family, level.scene, level.label), dt, rule,
                predicted_cost(family, level.scene, steps_to(level.scene.end, dt)))
