"""Models that answer a scene: a name → model registry shared by the runner and the schema.

Every model follows one protocol: ``run(scene, progress)`` returns a
:class:`femref.results.ModelResult`. Which model can serve which scene is decided at
validation, by :mod:`femref.case.capabilities`.
"""

from __future__ import annotations

from typing import Callable, Protocol

from femref.results import ModelResult
from femref.scene import Scene

Progress = Callable[[int, int], None]


class Model(Protocol):
    name: str

    def run(self, scene: Scene, progress: Progress | None = None) -> ModelResult: ...


def registry() -> dict[str, Model]:
    """All models by name (imported lazily so that ``femref validate`` stays light)."""
    from femref.models.exact import ExactModel
    from femref.models.fem import FemModel
    from femref.models.quasi_rigid import QuasiRigidModel
    from femref.models.rigid import RigidModel

    models: list[Model] = [FemModel(), ExactModel(), QuasiRigidModel(), RigidModel()]
    return {m.name: m for m in models}
