"""Which runs ``femref bench`` makes of one impact scene, and the reference they are scored against.

Rules (docs/design.md §7: each model at several resolutions, scored against the finest fem):

* **fem**, every car a fem car: at ``N × {1/4, 1/2, 1, 2}`` elements (``N`` the case's
  ``fem.elements``; never fewer than :data:`MIN_ELEMENTS`; repeated counts made once),
  each at its own step (:func:`femref.run.timestep.impact_time_step`: the case's ``time.dt``
  or the automatic step, which shrinks with the mesh); and at ``N`` elements with
  ``dt × {2, 4}`` of that step (``dt × 1`` is the ``N``-element row).
* **modal**, every car modal (mode shapes from the case's fem mesh):
  :data:`femref.run.resolutions.MODE_COUNTS` elastic modes and the case's ``modal.modes``,
  each at its own step; counts the mesh cannot hold (more than ``ndof − 2`` of its
  smallest car) are left out.
* **quasi_rigid** and **rigid**, every car so: one run each at its own step.
* **estimators** the case lists (``estimators:``, inverse and network): one row each,
  reading the records of the fem run at the case's settings (``N`` elements, ``dt × 1``),
  measured as the case says — as ``femref run`` feeds them.
* **reference**: fem at ``2N`` elements (the finest mesh above, ``max(2N, MIN_ELEMENTS)``) with
  ``dt = ½ min(dt of every run above)``, so it is finer in space and time than every
  configuration, and none of them is scored against itself.

Mixed-fidelity runs of the case (``models:`` entries with per-car overrides) are not
benchmarked: the trade is measured per model family.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from femref.run.resolutions import MIN_ELEMENTS, mode_counts, with_elements
from femref.run.timestep import impact_time_step
from femref.scene import ImpactScene, ModelRun

__all__ = [
    "DT_FACTORS",
    "ELEMENT_FACTORS",
    "BenchPlan",
    "Configuration",
    "bench_plan",
    "element_counts",
]

ELEMENT_FACTORS: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0)
"""fem element counts as multiples of the case's ``fem.elements``."""
DT_FACTORS: tuple[float, ...] = (1.0, 2.0, 4.0)
"""fem steps at the case's element count, as multiples of its step."""
REFERENCE_DT_FACTOR = 0.5

#: Configuration kinds: a solve of the scene, or an estimator on the fem records.
SOLVE, ESTIMATOR = "solve", "estimator"


@dataclass(frozen=True)
class Configuration:
    """One benchmarked configuration.

    ``family`` is the model (``fem``, ``modal``, ``quasi_rigid``, ``rigid``) or the
    estimator's name; ``setting``/``value`` the resolution varied (``elements``,
    ``dt_factor``, ``modes``; ``""``/NaN when none). A ``solve`` configuration steps
    ``scene`` with ``run`` at ``dt``; an ``estimator`` configuration has no scene of its
    own (it reads the records of the plan's ``records_from`` run).
    """

    family: str
    kind: str
    setting: str = ""
    value: float = math.nan
    scene: ImpactScene | None = None
    run: ModelRun | None = None
    dt: float = math.nan
    dt_rule: str = ""

    @property
    def label(self) -> str:
        """Short name for tables and plots, e.g. ``fem N=32``, ``fem dt×2``, ``modal k=4``, ``rigid``."""
        if self.setting == "elements":
            return f"{self.family} N={self.value:g}"
        if self.setting == "dt_factor":
            return f"{self.family} dt×{self.value:g}"
        if self.setting == "modes":
            return f"{self.family} k={self.value:g}"
        return self.family


@dataclass(frozen=True)
class BenchPlan:
    """The configurations in table order, the reference, and which configuration's records the estimators read."""

    configurations: tuple[Configuration, ...]
    reference: Configuration
    records_from: int

    @property
    def reference_description(self) -> str:
        scene = self.reference.scene
        assert scene is not None  # internal contract: the reference is a solve
        return (
            f"fem, every car at {scene.fem.elements} elements (order {scene.fem.order}), "
            f"dt = {self.reference.dt:.6g} s ({self.reference.dt_rule})"
        )


def element_counts(elements: int) -> list[int]:
    """``max(MIN_ELEMENTS, round(elements × f))`` for ``f`` in :data:`ELEMENT_FACTORS`, and ``elements`` itself
    (the case's count, even below the minimum), ascending, unique."""
    return sorted({elements, *(max(MIN_ELEMENTS, round(elements * f)) for f in ELEMENT_FACTORS)})


def _solve(family: str, scene: ImpactScene, setting: str = "", value: float = math.nan, dt_factor: float = 1.0) -> Configuration:
    run = ModelRun(family, (family,) * len(scene.cars))
    dt, rule = impact_time_step(scene, run)
    if dt_factor != 1.0:
        rule = f"{dt_factor:g} × ({rule})"
    return Configuration(family, SOLVE, setting, float(value), scene, run, dt * dt_factor, rule)


def bench_plan(scene: ImpactScene) -> BenchPlan:
    """The configurations of ``scene`` and its reference (module docstring)."""
    n = scene.fem.elements
    configurations: list[Configuration] = []
    for elements in element_counts(n):
        configurations.append(_solve("fem", with_elements(scene, elements), "elements", elements))
    records_from = next(i for i, c in enumerate(configurations) if c.value == n)
    fem_scene = with_elements(scene, n)
    for factor in DT_FACTORS[1:]:
        configurations.append(_solve("fem", fem_scene, "dt_factor", factor, dt_factor=factor))
    for modes in mode_counts(scene):
        configurations.append(_solve("modal", dataclasses.replace(scene, modal_modes=modes), "modes", modes))
    configurations.append(_solve("quasi_rigid", scene))
    configurations.append(_solve("rigid", scene))
    for name in (*scene.estimators, *(network.name for network in scene.networks)):
        configurations.append(Configuration(name, ESTIMATOR))
    finest_dt = min(c.dt for c in configurations if c.kind == SOLVE)
    reference_scene = with_elements(scene, max(element_counts(n)))
    reference = Configuration(
        "fem",
        SOLVE,
        "reference",
        math.nan,
        reference_scene,
        ModelRun("fem", ("fem",) * len(scene.cars)),
        REFERENCE_DT_FACTOR * finest_dt,
        "½ × the finest step of the configurations",
    )
    return BenchPlan(tuple(configurations), reference, records_from)
