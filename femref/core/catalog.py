"""The one catalog of names: scene kinds, models, car fidelities, estimators, references.

Every other list of these names is read from here. Adding a model is one entry here and
one module in :mod:`femref.models`; a test holds the registry to this catalog.

A model serves a scene kind when its entry lists the kind; whether it can serve a
particular case (e.g. ``exact`` needs piecewise-constant profiles) is decided at
validation by :mod:`femref.case.capabilities`. A model that serves impacts is a car
fidelity (listed again in :data:`FIDELITIES`): each car of an impact run is modelled at one of
them, and its module says how it steps, costs and is refined (:class:`femref.models.base.CarFidelity`).
"""

from __future__ import annotations

from dataclasses import dataclass

#: Scene kinds with one body under end loads.
SINGLE_BODY_KINDS: tuple[str, ...] = ("harmonic", "transient")
#: Scene kinds of cars in a line joined by couplers.
IMPACT_KINDS: tuple[str, ...] = ("impact",)
#: Scene kinds the models simulate.
SIMULATED_KINDS: tuple[str, ...] = (*SINGLE_BODY_KINDS, *IMPACT_KINDS)
#: Scene kinds of recorded accelerations: estimators run on them, no model does.
MEASURED_KINDS: tuple[str, ...] = ("measured",)
#: Every scene kind a case may declare (``kind:``), in documentation order.
SCENE_KINDS: tuple[str, ...] = (*SIMULATED_KINDS, *MEASURED_KINDS)


@dataclass(frozen=True)
class ModelEntry:
    """A model name, the scene kinds it serves and what it is."""

    name: str
    kinds: tuple[str, ...]
    summary: str


#: Every model name a case's ``models:`` may list, in documentation (and error-message) order.
MODELS: dict[str, ModelEntry] = {
    entry.name: entry
    for entry in (
        ModelEntry("fem", SIMULATED_KINDS, "finite elements (scikit-fem rods and beams): the reference"),
        ModelEntry("exact", SINGLE_BODY_KINDS, "closed forms, transfer matrices, inverse Laplace (piecewise-constant bodies)"),
        ModelEntry("quasi_rigid", SIMULATED_KINDS, "low-frequency perturbation of rigid-body motion (reduced.quasi_rigid)"),
        ModelEntry("rigid", SIMULATED_KINDS, "rigid bodies"),
        ModelEntry("modal", IMPACT_KINDS, "rigid mode, lowest elastic modes and a static correction of the fem car"),
        ModelEntry("ann", (), "a saved network: an estimator on the fem records, listed under estimators:"),
    )
}

#: What a car can be modelled as within one impact run: the models that serve impacts, finest first.
FIDELITIES: tuple[str, ...] = ("fem", "modal", "quasi_rigid", "rigid")
assert set(FIDELITIES) == {name for name, entry in MODELS.items() if "impact" in entry.kinds}  # one list of names

#: Inverse estimators: coupler forces from the fem run's acceleration records.
ESTIMATORS: tuple[str, ...] = ("inverse_rigid", "inverse_quasi_rigid")
#: Estimators of a measured case: the inverse ones and the joint input-state (augmented Kalman) one.
MEASURED_ESTIMATORS: tuple[str, ...] = (*ESTIMATORS, "kalman")

#: Result-file groups beside the model groups (so no run may take their names): the scores, the scene's
#: facts, a model choice.
SCORES_GROUP = "scores"
SCENE_GROUP = "scene"
CHOICE_GROUP = "choice"

#: Reference model of each scene kind, first available wins.
REFERENCES: dict[str, tuple[str, ...]] = {"harmonic": ("exact", "fem"), "transient": ("exact", "fem"), "impact": ("fem",)}


def serves(model: str, kind: str) -> bool:
    """Whether ``model`` serves scenes of ``kind`` at all (case-specific limits aside)."""
    return kind in MODELS[model].kinds
