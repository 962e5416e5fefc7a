"""What every case kind has: :class:`SceneCase`, the base of the ``kind:`` models.

The kinds are found by walking its subclasses (:func:`case_classes`), so this module knows none of them.
"""

from typing import Any

from pydantic import Field, model_validator

from femref.case.capabilities import refusal
from femref.case.errors import Problem, problems_error
from femref.case.fields import CaseModel, foreign_key_rule
from femref.core.catalog import SCENE_KINDS

__all__ = ["SceneCase", "case_classes"]


class SceneCase(CaseModel):
    """What every case kind has: ``kind``, ``fem`` settings and a ``models`` list that can serve it."""

    kind: str = Field(description="Case kind. Required.")

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        return foreign_key_rule(cls, key, known, case_classes(), "kind", "-case") or super()._unknown_key_rule(key, known)

    @model_validator(mode="after")
    def _models_serve_the_scene(self) -> "SceneCase":
        models: tuple[str, ...] = getattr(self, "models")
        problems = [
            Problem(("models", i), f"{name} cannot serve this case: {reason}", name)
            for i, name in enumerate(models)
            if (reason := refusal(name, self)) is not None  # type: ignore[arg-type]
        ]
        if problems:
            raise problems_error(problems)
        return self


def case_classes() -> dict[str, type[SceneCase]]:
    """Every case class defined so far by its ``kind``, in catalog order: a subclass of :class:`SceneCase` whose
    ``kind`` has a default (its literal), the shallowest of a kind."""
    found: dict[str, type[SceneCase]] = {}
    pending = list(SceneCase.__subclasses__())
    while pending:
        cls = pending.pop(0)
        pending.extend(cls.__subclasses__())
        kind = cls.model_fields["kind"].default
        if isinstance(kind, str):
            found.setdefault(kind, cls)
    return {kind: found[kind] for kind in SCENE_KINDS if kind in found}
