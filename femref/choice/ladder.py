"""The ladder of models a choice climbs: every impact model at the resolutions it may run, cheapest first.

Rungs (for a case with ``fem.elements = N``):

* ``rigid`` and ``quasi_rigid`` at their automatic step (:func:`femref.run.timestep.impact_time_step`);
* ``modal_k<k>`` for ``k`` in :data:`femref.run.resolutions.MODE_COUNTS` that the case's mesh holds
  (:func:`femref.run.resolutions.mode_counts`), each at its own automatic step;
* ``fem_n<n>`` for ``n = N·2^j`` (:data:`FEM_LEVELS`, at least :data:`femref.run.resolutions.MIN_ELEMENTS`),
  refined **jointly in space and time**: the coarsest level steps at its automatic step
  ``dt₀`` (or the case's ``time.dt``) and level ``n`` at ``dt₀·n₀/n``. Refining the mesh
  alone would leave the time error of a step set by the contact time untouched, and
  Richardson between two levels would then see no change (measured: on stiff couplers
  fem at 8, 16 and 32 elements agreed to 1e-5 while all were 0.17 % off).

Each rung has a Richardson **partner**, the next finer level of its family (``modal``
``k → 2k``, ``fem`` ``n → 2n``; ``rigid`` ↔ ``quasi_rigid``, whose difference is the
first-order term of the asymptotic expansion). The finest level of a family has none.

**Cost** is predicted, not measured, so the ladder is ordered before anything runs. For a
run of ``C`` cars and ``steps`` steps, in microseconds on the machine that fitted it (only
ratios matter: they order the rungs),

    cost = C/2 · (setup + steps · step),   setup = s · x_setup,   step = t · x_step,

with the regressors ``x`` of :func:`cost_regressors` and their coefficients ``s`` in
:data:`SETUP_COST_US`, ``t`` in :data:`STEP_COST_US` (``N`` the case's ``fem.elements``,
``k`` the modes, ``n`` the elements per car of a fem rung):

* ``rigid``, ``quasi_rigid``: ``setup = s₀``, ``step = t₀``;
* ``modal``: ``setup = s₀ + s₁·N + s₂·k`` (the case's mesh assembled, then the eigen-solve
  of ``k`` modes, the static correction and packing), ``step = t₀ + t₁·(k+1)²`` (dense
  ``(k+1)``-DOF cars);
* ``fem``: ``setup = s₀ + s₁·n``, ``step = t₀ + t₁·n`` (banded cars).

The set-up is cold: every car assembled, reduced and factorised afresh, as each rung of a
ladder runs once on its own geometry (a modal rung pays its mesh's assembly even when the
fem rung at ``N`` has run). Fitted by ``benchmarks/fit_ladder_costs.py`` (defaults: every
rung of 30 random two-car impacts with draft-gear, Kelvin–Voigt and friction-table
couplers, ``N`` = 16–64, 353 rungs; a 2-core AMD EPYC, busy) on the median of five cold
runs per rung, by relative-error least squares with non-negative coefficients: the set-up
on the wall time outside the stepping, the step on the stepping time per step. Predicted
over measured wall time per rung: −5 % to +5 % (10th–90th percentile), at most 18 % off;
the same within one scene (its median error divided out: a scene-wide speed does not change
its ladder's order). A run's set-up is worth about 135 (fem, 128 elements) to 4,000 (modal,
one mode) of its steps: rigid 1.3 ms and 1.9 µs a step, quasi-rigid 5.1 ms and 4.6 µs,
modal 9.6–15 ms and 2.4–11 µs, fem 5.1–6.2 ms and 4.4–46 µs (4–128 P2 elements per car,
the order every case uses). Re-run the script when the build or the stepping changes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from femref.core.timegrid import steps_to
from femref.run.budget import Cost, approximate_step, check_costs, impact_run_cost, rod_dofs
from femref.run.resolutions import MIN_ELEMENTS, MODE_COUNTS, mode_counts, with_elements
from femref.run.timestep import impact_time_step
from femref.scene import ImpactScene, ModelRun

__all__ = ["FEM_LEVELS", "SETUP_COST_US", "STEP_COST_US", "Ladder", "Rung", "StepRule", "check_ladder_budget", "cost_regressors", "ladder_costs", "model_ladder",
           "predicted_cost"]

FEM_LEVELS: tuple[int, ...] = (-3, -2, -1, 0, 1)
"""fem rungs at ``N·2^j`` elements per car for these ``j`` (``N`` the case's ``fem.elements``)."""
SETUP_COST_US: dict[str, tuple[float, ...]] = {
    "rigid": (1268.0,),
    "quasi_rigid": (5064.0,),
    "modal": (8930.0, 23.5, 303.3),
    "fem": (5090.0, 8.671),
}
"""Set-up of a two-car run (µs on the fitting machine, cold: cars built, reduced, factorised and packed,
the result assembled), the coefficients of :func:`cost_regressors`' ``x_setup``: ``s₀`` (rigid,
quasi_rigid), ``s₀ + s₁·N + s₂·k`` (modal), ``s₀ + s₁·n`` (fem). Fitted on the wall time outside the
stepping by ``benchmarks/fit_ladder_costs.py`` (module docstring)."""
STEP_COST_US: dict[str, tuple[float, ...]] = {
    "rigid": (1.868,),
    "quasi_rigid": (4.556,),
    "modal": (2.258, 0.03005),
    "fem": (3.042, 0.3329),
}
"""One step of a two-car run (µs on the fitting machine), the coefficients of :func:`cost_regressors`'
``x_step``: ``t₀`` (rigid, quasi_rigid), ``t₀ + t₁·(k+1)²`` (modal), ``t₀ + t₁·n`` (fem). Fitted on the
stepping time per step by ``benchmarks/fit_ladder_costs.py`` (module docstring)."""


def cost_regressors(family: str, scene: ImpactScene) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``(x_setup, x_step)`` of a ``family`` run of ``scene``: ``cost = C/2 · (s·x_setup + steps · t·x_step)``.

    ``N = scene.fem.elements`` is the modal car's mesh, ``k = scene.modal_modes``, ``n =
    scene.fem.elements`` the fem car's elements per car.
    """
    if family in ("rigid", "quasi_rigid"):
        return (1.0,), (1.0,)
    if family == "modal":
        k = scene.modal_modes
        return (1.0, scene.fem.elements, k), (1.0, (k + 1) ** 2)
    if family == "fem":
        return (1.0, scene.fem.elements), (1.0, scene.fem.elements)
    raise ValueError(f"no cost model for the {family!r} family")


def predicted_cost(family: str, scene: ImpactScene, steps: int) -> float:
    """``cost = C/2 · (s·x_setup + steps · t·x_step)`` (µs, module docstring) of a uniform ``family`` run of ``scene``'s ``C`` cars."""
    x_setup, x_step = cost_regressors(family, scene)
    setup = sum(s * x for s, x in zip(SETUP_COST_US[family], x_setup, strict=True))
    step = sum(t * x for t, x in zip(STEP_COST_US[family], x_step, strict=True))
    return len(scene.cars) / 2.0 * (setup + steps * step)


@dataclass(frozen=True)
class Rung:
    """One model at one resolution: how to run it (``scene``, ``run``, ``dt``) and what it is predicted to cost.

    ``family`` is ``rigid``, ``quasi_rigid``, ``modal`` or ``fem``; ``resolution`` the
    modes (modal) or elements per car (fem), 0 for the others.
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
    """The rungs cheapest first, and each rung's Richardson partner (label → label)."""

    rungs: tuple[Rung, ...]
    partners: dict[str, str]

    def __getitem__(self, label: str) -> Rung:
        return next(rung for rung in self.rungs if rung.label == label)

    def index(self, label: str) -> int:
        return next(i for i, rung in enumerate(self.rungs) if rung.label == label)

    def partner(self, label: str) -> str | None:
        return self.partners.get(label)

    def coarser(self, label: str) -> str | None:
        """The rung whose partner ``label`` is, within its family (modal and fem only)."""
        rung = self[label]
        return next((c for c, p in self.partners.items() if p == label and self[c].family == rung.family and rung.family in ("modal", "fem")), None)


StepRule = Callable[[ImpactScene, ModelRun], tuple[float, str]]
"""A run's step and its rule: :func:`femref.run.timestep.impact_time_step` (on the mesh), or the budget's prediction."""


def model_ladder(scene: ImpactScene, step: StepRule = impact_time_step, mesh_dofs: Callable[[ImpactScene], int] | None = None) -> Ladder:
    """The rungs of ``scene`` ordered by predicted cost, and their partners (module docstring).

    ``step`` gives each run's step (default: the runner's rule on the mesh); ``mesh_dofs`` the DOFs of the smallest
    car's mesh that bound the mode counts (``k ≤ ndof − 2``; default :func:`femref.run.resolutions.mode_counts` on
    the mesh). The work budget lays out the same ladder without building a mesh (:func:`ladder_costs`).
    """
    rungs = [_rung("rigid", "rigid", 0, scene, step), _rung("quasi_rigid", "quasi_rigid", 0, scene, step)]
    partners = {"rigid": "quasi_rigid", "quasi_rigid": "rigid"}
    modes = mode_counts(scene, MODE_COUNTS, None if mesh_dofs is None else mesh_dofs(scene))
    for k in modes:
        rungs.append(_rung(f"modal_k{k}", "modal", k, dataclasses.replace(scene, modal_modes=k), step))
    partners.update({f"modal_k{k}": f"modal_k{2 * k}" for k in modes if 2 * k in modes})
    elements = sorted({max(MIN_ELEMENTS, round(scene.fem.elements * 2.0**j)) for j in FEM_LEVELS})
    coarsest = with_elements(scene, elements[0])
    dt0, rule0 = step(coarsest, _uniform_run("fem", scene))
    for n in elements:
        dt = dt0 * elements[0] / n
        rule = rule0 if n == elements[0] else f"{rule0} at {elements[0]} elements, × {elements[0]}/{n}"
        rungs.append(_rung(f"fem_n{n}", "fem", n, with_elements(scene, n), step, dt=dt, dt_rule=rule))
    partners.update({f"fem_n{a}": f"fem_n{b}" for a, b in zip(elements, elements[1:])})
    rungs.sort(key=lambda rung: rung.cost)
    return Ladder(tuple(rungs), partners)


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


def _uniform_run(family: str, scene: ImpactScene, label: str | None = None) -> ModelRun:
    return ModelRun(label or family, (family,) * len(scene.cars))


def _rung(label: str, family: str, resolution: int, scene: ImpactScene, step: StepRule, dt: float | None = None, dt_rule: str = "") -> Rung:
    run = _uniform_run(family, scene, label)
    if dt is None:
        dt, dt_rule = step(scene, run)
    return Rung(label, family, resolution, scene, run, dt, dt_rule, predicted_cost(family, scene, steps_to(scene.end, dt)))
