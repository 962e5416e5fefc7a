"""Whether a model can serve a particular case: :func:`refusal` gives ``None`` or the reason, worded to follow
"<name> cannot serve this case: ".

Which scene kinds a model serves is :data:`femref.core.catalog.MODELS`; this module adds the limits that
depend on the case itself. It reads a validated case by duck typing, so it imports nothing of the schema.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from femref.core import catalog

Capability = Callable[[Any], "str | None"]


def _kind_served(model: str, case: Any) -> str | None:
    """The catalog's rule: the model serves the case's kind (with the reason why not)."""
    if catalog.serves(model, case.kind):
        return None
    kinds = catalog.MODELS[model].kinds
    if kinds == catalog.IMPACT_KINDS:
        return f"it serves impact cases only (kind: impact), and this is a {case.kind} case"
    return f"it serves {', '.join(kinds)} cases, and this is a {case.kind} case"


def _exact(case: Any) -> str | None:
    """The exact solutions are transfer-matrix solutions over piecewise-constant profiles; in the time domain
    they exist for rods only, and impacts (nonlinear contact) have none."""
    if case.kind in catalog.IMPACT_KINDS:
        return "no exact solution is implemented for impact scenes (nonlinear contact); score against fem"
    body = case.body
    if case.kind == "transient" and body.type != "rod":
        return f"the exact time-domain solution exists for rods only, and this body is a {body.type}"
    varying = [name for name, spec in body.profile_specs().items() if not spec.build(body.half_length).is_piecewise_constant]
    if varying:
        listed = ", ".join(f"body.{name} is {body.profile_specs()[name].tag}" for name in varying)
        return f"it needs piecewise-constant profiles (number or piecewise), but {listed}"
    return None


def _quasi_rigid(case: Any) -> str | None:
    """The quasi-rigid beam expands about the rigid modes of a symmetric body: even profiles only (the quasi-rigid
    rod serves any profile; an impact car that bends is also a quasi-rigid beam)."""
    if case.kind in catalog.IMPACT_KINDS:
        beams = [(f"car {car.name}'s ", car.body.beam()) for car in case.cars if car.body.bends]
    else:
        beams = [("", case.body)] if case.body.type == "beam" else []
    for owner, body in beams:
        odd = _odd_profile(body)
        if odd:
            return f"the quasi-rigid beam needs even profiles m(x), EI(x), cI(x), but {owner}body.{odd} is not even in x"
    return None


def _odd_profile(body: Any) -> str | None:
    """The first of a beam body's profiles that is not even in x (case-file name), or None."""
    x = np.linspace(0.0, body.half_length, 257)
    odd = [name for name, profile in body.profiles().items() if not np.allclose(profile(x), profile(-x), rtol=1e-12, atol=0.0)]
    return odd[0] if odd else None


def _ann(case: Any) -> str | None:
    """A network is an estimator on the fem sensor records (an ``estimators:`` entry of an impact case), never a model run."""
    if case.kind not in catalog.IMPACT_KINDS:
        return f"it serves impact cases only (kind: impact), and this is a {case.kind} case"
    return "a network is an estimator on the fem sensor records, not a model run; list it under estimators: as {name: ann_<name>, network: file.npz}"


#: The case-specific limits, by model name: each reads any case kind and gives the more specific reason.
LIMITS: Mapping[str, Capability] = {"exact": _exact, "quasi_rigid": _quasi_rigid, "ann": _ann}

#: Every model name a case may list (the catalog's, in its order).
MODELS: tuple[str, ...] = tuple(catalog.MODELS)


def refusal(model: str, case: Any) -> str | None:
    """Why ``model`` cannot serve ``case``, or ``None`` when it can (``model`` must be in the catalog)."""
    limit = LIMITS.get(model)
    return (limit(case) if limit else None) or _kind_served(model, case)
