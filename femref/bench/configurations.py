"""Which runs ``femref bench`` makes of one impact scene, and the reference they are scored against.

The configurations (docs/design.md §7.1): every car fidelity at each resolution its module offers
(:meth:`femref.models.base.CarFidelity.bench`), each at its own step; the case's estimators on the records
of the reference model's run at the case's ``fem.elements``; the reference at the most elements of its
rows with ``dt = ½ min(dt of every run)``, so that no configuration is scored against itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from femref.core.catalog import REFERENCES
from femref.models import CAR_FIDELITIES
from femref.run.timestep import resolution_step, uniform_run
from femref.scene import ImpactScene, ModelRun

__all__ = ["BenchPlan", "Configuration", "bench_plan"]

REFERENCE_DT_FACTOR = 0.5

#: Configuration kinds: a solve of the scene, or an estimator on the fem records.
SOLVE, ESTIMATOR = "solve", "estimator"


@dataclass(frozen=True)
class Configuration:
    """One benchmarked configuration.

    ``family`` is the fidelity or the estimator's name; ``setting``/``value`` the resolution varied (``elements``,
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
        prefix = {"elements": "N=", "dt_factor": "dt×", "modes": "k="}.get(self.setting)
        return f"{self.family} {prefix}{self.value:g}" if prefix else self.family


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
            f"{self.reference.family}, every car at {scene.fem.elements} elements (order {scene.fem.order}), "
            f"dt = {self.reference.dt:.6g} s ({self.reference.dt_rule})"
        )


def bench_plan(scene: ImpactScene) -> BenchPlan:
    """The configurations of ``scene`` and its reference (module docstring)."""
    configurations: list[Configuration] = []
    for family, fidelity in CAR_FIDELITIES.items():
        for level in fidelity.bench(scene):
            dt, rule = resolution_step(family, level)
            configurations.append(Configuration(family, SOLVE, level.setting, float(level.value), level.scene, uniform_run(family, level.scene), dt, rule))
    reference_family = REFERENCES["impact"][0]
    meshes = [i for i, c in enumerate(configurations) if c.family == reference_family and c.setting == "elements"]  # its meshes
    records_from = next(i for i in meshes if configurations[i].value == scene.fem.elements)
    for name in (*scene.estimators, *(network.name for network in scene.networks)):
        configurations.append(Configuration(name, ESTIMATOR))
    finest_dt = min(c.dt for c in configurations if c.kind == SOLVE)
    reference_scene = configurations[max(meshes, key=lambda i: configurations[i].value)].scene
    assert reference_scene is not None  # internal contract: a solve has a scene
    reference = Configuration(reference_family, SOLVE, "reference", math.nan, reference_scene, uniform_run(reference_family, reference_scene),
                              REFERENCE_DT_FACTOR * finest_dt, "½ × the finest step of the configurations")
    return BenchPlan(tuple(configurations), reference, records_from)
