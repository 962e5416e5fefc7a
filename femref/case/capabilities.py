"""Which model can serve which scene: the registry the case schema and its messages share.

``MODELS`` maps each model name of a case's ``models:`` list to a function
``case -> reason | None``: ``None`` when the model can serve the scene, otherwise the
reason it cannot, worded to follow "<name> cannot serve this case: ". A model that
cannot serve a scene is refused at validation (DESIGN.md §4), never skipped at run time.

Every function first looks at ``kind``: single-body cases have a ``body``, impact cases
(:mod:`femref.case.impact`) have ``cars`` and no ``body``. For an impact case, ``fem``,
``modal``, ``quasi_rigid`` and ``rigid`` serve (they are the per-car fidelities of
``femref.impact.scene.FIDELITIES``); ``exact`` and ``ann`` are refused with the reason
(a network estimator of an impact is an entry of ``estimators:``, not a model run).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover - typing only
    from femref.case.schema import Case

Capability = Callable[["Case"], str | None]

#: Case kinds with one body under end loads.
SINGLE_BODY_KINDS = ("harmonic", "transient")
#: Case kinds the impact-only models serve.
IMPACT_KINDS = ("impact",)


def _serves_every_scene(case: "Case") -> str | None:
    """``fem`` and ``rigid`` serve every harmonic, transient and impact scene."""
    return None


def _impact_only(case: "Case") -> str | None:
    if case.kind in IMPACT_KINDS:
        return None
    return f"it serves impact cases only (kind: impact), and this is a {case.kind} case"


def _exact(case: "Case") -> str | None:
    """The exact solutions are transfer-matrix solutions over piecewise-constant profiles.

    In the time domain (transient) they exist for rods only; impacts (nonlinear contact)
    have none.
    """
    if case.kind in IMPACT_KINDS:
        return "no exact solution is implemented for impact scenes (nonlinear contact); score against fem"
    body: Any = case.body
    if case.kind == "transient" and body.type != "rod":
        return f"the exact time-domain solution exists for rods only, and this body is a {body.type}"
    varying = [name for name, spec in body.profile_specs().items() if not spec.build(body.half_length).is_piecewise_constant]
    if varying:
        listed = ", ".join(f"body.{name} is {body.profile_specs()[name].tag}" for name in varying)
        return f"it needs piecewise-constant profiles (number or piecewise), but {listed}"
    return None


def _quasi_rigid(case: "Case") -> str | None:
    """The quasi-rigid beam expands about the rigid modes of a symmetric body: even profiles only.

    Impact cars are rods, which the quasi-rigid rod serves with any profile.
    """
    if case.kind in IMPACT_KINDS:
        return None
    body: Any = case.body
    if body.type != "beam":
        return None
    x = np.linspace(0.0, body.half_length, 257)
    odd = [name for name, profile in body.profiles().items() if not np.allclose(profile(x), profile(-x), rtol=1e-12, atol=0.0)]
    if odd:
        return f"the quasi-rigid beam needs even profiles m(x), EI(x), cI(x), but body.{odd[0]} is not even in x"
    return None


def _ann(case: "Case") -> str | None:
    """A network is an estimator on the fem sensor records, not a model run of the scene.

    Networks serve impacts only, as entries of ``estimators:`` (a mapping with the saved
    network file, :class:`femref.case.impact.AnnEstimatorSpec`); as a ``models:`` entry
    ``ann`` is refused for every case kind, with the reason pointing there.
    """
    if case.kind not in IMPACT_KINDS:
        return _impact_only(case)
    return "a network is an estimator on the fem sensor records, not a model run; list it under estimators: as {name: ann_<name>, network: file.npz}"


#: name → capability function, in the order the names are documented.
MODELS: Mapping[str, Capability] = {
    "fem": _serves_every_scene,
    "exact": _exact,
    "quasi_rigid": _quasi_rigid,
    "rigid": _serves_every_scene,
    "modal": _impact_only,
    "ann": _ann,
}


def refusal(model: str, case: "Case") -> str | None:
    """Why ``model`` cannot serve ``case``, or ``None`` when it can (``model`` must be registered)."""
    return MODELS[model](case)
