"""Models that answer a scene, by name: the registry the runner reads.

One module per model (:mod:`.fem`, :mod:`.exact`, :mod:`.quasi_rigid`, :mod:`.rigid`,
:mod:`.modal`), each holding its single-body and car forms (:mod:`.base`). The names are those of
:data:`femref.core.catalog.MODELS`; a model serves the scene kinds its catalog entry lists.
"""

from femref.core.catalog import MODELS as CATALOG
from femref.models.base import FORMS, Model, Progress, ProgressFor
from femref.models.exact import ExactModel
from femref.models.fem import FemModel
from femref.models.modal import ModalModel
from femref.models.quasi_rigid import QuasiRigidModel
from femref.models.rigid import RigidModel

#: Model name → model, for every catalog name a model implements (``ann`` is an estimator, not a model).
REGISTRY: dict[str, Model] = {m.name: m for m in (FemModel(), ExactModel(), QuasiRigidModel(), RigidModel(), ModalModel())}


def model_form(name: str, kind: str):
    """The method of model ``name`` that serves scenes of ``kind`` (``harmonic``, ``transient`` or ``car``).

    Raises ValueError when the catalog says the model does not serve the kind.
    """
    if name not in REGISTRY or kind not in CATALOG[name].kinds:
        raise ValueError(f"model {name!r} does not serve {kind} scenes")
    return getattr(REGISTRY[name], FORMS[kind])


__all__ = ["FORMS", "REGISTRY", "Model", "Progress", "ProgressFor", "model_form"]
