"""Models that answer a scene, by name: the registry the runner reads.

One module per model, named as the model in :data:`femref.core.catalog.MODELS`, each holding its
single-body and car forms (:mod:`.base`) and its instance as ``MODEL``; a model serves the scene kinds
its catalog entry lists.
"""

from importlib import import_module

from femref.core.catalog import FIDELITIES
from femref.core.catalog import MODELS as CATALOG
from femref.models.base import FORMS, CarFidelity, Model, Progress, ProgressFor

#: Model name → model, for every catalog name a model implements (``ann`` is an estimator, not a model).
REGISTRY: dict[str, Model] = {name: import_module(f"femref.models.{name}").MODEL for name, entry in CATALOG.items() if entry.kinds}
#: Fidelity name → its model, finest first (:data:`femref.core.catalog.FIDELITIES`).
CAR_FIDELITIES: dict[str, CarFidelity] = {name: REGISTRY[name] for name in FIDELITIES}  # type: ignore[misc]


def model_form(name: str, kind: str):
    """The method of model ``name`` that serves scenes of ``kind`` (``harmonic``, ``transient`` or ``car``).

    Raises ValueError when the catalog says the model does not serve the kind.
    """
    if name not in REGISTRY or kind not in CATALOG[name].kinds:
        raise ValueError(f"model {name!r} does not serve {kind} scenes")
    return getattr(REGISTRY[name], FORMS[kind])


__all__ = ["CAR_FIDELITIES", "FORMS", "REGISTRY", "CarFidelity", "Model", "Progress", "ProgressFor", "model_form"]
