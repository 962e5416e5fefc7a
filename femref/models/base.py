"""What a model is: a name and any of three forms, one per way a scene uses it.

* ``harmonic(scene) -> ModelResult`` — a single body's frequency response;
* ``transient(scene, progress) -> ModelResult`` — a single body under end-load histories;
* ``car(car, scene, dt) -> CarSystem`` — one car of an impact as the linear system the
  impact solver steps (:mod:`femref.impact.systems`), stepped by :func:`femref.impact.solve_impact`.

A model that lacks a form cannot serve that scene kind; which kinds each model serves
is :data:`femref.core.catalog.MODELS`, and a test holds the two together. The runner
(:mod:`femref.run`) times every call and records a failure as the model's status.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Callable, Hashable, Protocol, TypeVar

Progress = Callable[[int, int], None]
"""``progress(done, total)`` steps, called at output steps."""

ProgressFor = Callable[[str], "Progress | None"]
"""``progress_for(stage)`` → the stage's :data:`Progress` callback, or None: the progress hook of a run of several
stages (models of a scene, events of a measured case, estimators being calibrated), called when each starts
(``femref.cli.common.model_progress`` supplies it)."""

#: The method a model offers for each scene kind.
FORMS: dict[str, str] = {"harmonic": "harmonic", "transient": "transient", "impact": "car"}


class Model(Protocol):
    """A model: its catalog name; the forms it offers are plain methods (module docstring)."""

    name: str


T = TypeVar("T")

_BUILT: OrderedDict[Hashable, object] = OrderedDict()
BUILT_CAPACITY = 64
"""How many built cars (operators, modes, coefficients) are kept for reuse."""


def built_once(key: Hashable, build: Callable[[], T]) -> T:
    """``build()``, or what an earlier call with an equal ``key`` built (least recently used first out).

    The models key a car by its body's geometry (:attr:`femref.core.body.Body.geometry`), its
    sensor positions and their own settings, so the runs of a scene, of a sweep, a study,
    the bench or the choice ladder assemble, factorise and reduce each car once per process.
    What is built is shared: it must not be changed.
    """
    try:
        hash(key)
    except TypeError:  # a profile that cannot be a key is built every time
        return build()
    if key in _BUILT:
        _BUILT.move_to_end(key)
        return _BUILT[key]  # type: ignore[return-value]
    value = build()
    _BUILT[key] = value
    if len(_BUILT) > BUILT_CAPACITY:
        _BUILT.popitem(last=False)
    return value


def forget_built() -> None:
    """Drop every kept build: the next run of any geometry builds its cars afresh (what a benchmark
    times when it compares a cold run with a tool that keeps nothing between runs)."""
    _BUILT.clear()
