"""Models that answer a scene: a name → model registry shared by the runner and the schema.

Every model follows one protocol: ``serves(scene)`` returns None or the reason it cannot
serve the scene, and ``run(scene, progress)`` returns a :class:`femref.results.ModelResult`.
"""

from __future__ import annotations

from typing import Callable, Protocol

from femref.results import ModelResult
from femref.scene import Scene

Progress = Callable[[int, int], None]


class Model(Protocol):
    name: str

    def serves(self, scene: Scene) -> str | None: ...

    def run(self, scene: Scene, progress: Progress | None = None) -> ModelResult: ...


def registry() -> dict[str, Model]:
    """All models by name (imported lazily so that ``femref validate`` stays light)."""
    from femref.models.exact import ExactModel
    from femref.models.fem import FemModel
    from femref.models.rigid import RigidModel

    models: list[Model] = [FemModel(), ExactModel(), RigidModel()]
    return {m.name: m for m in models}
