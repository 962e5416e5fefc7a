"""What a model is: a name and any of three forms, one per way a scene uses it.

* ``harmonic(scene) -> ModelResult`` — a single body's frequency response;
* ``transient(scene, progress) -> ModelResult`` — a single body under end-load histories;
* ``car(car, scene, integrator, dt, loads) -> CarModel`` — one car of an impact, built
  once per run and stepped by :func:`femref.impact.solve_impact`.

A model that lacks a form cannot serve that scene kind; which kinds each model serves
is :data:`femref.core.catalog.MODELS`, and a test holds the two together. The runner
(:mod:`femref.run`) times every call and records a failure as the model's status.
"""

from __future__ import annotations

from typing import Callable, Protocol

Progress = Callable[[int, int], None]
"""``progress(done, total)`` steps, called at output steps."""

#: The method a model offers for each scene kind.
FORMS: dict[str, str] = {"harmonic": "harmonic", "transient": "transient", "impact": "car"}


class Model(Protocol):
    """A model: its catalog name; the forms it offers are plain methods (module docstring)."""

    name: str
