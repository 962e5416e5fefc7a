"""Coupler force laws as small frozen value objects, and the contact that wraps them.

Closure ``δ = x1 − x2`` (m, compression positive), force ``P`` (N, compression
positive); every law has the interface of :class:`CouplerLaw` (:mod:`.base`), one module
each; the contact around a law is :mod:`.coupling`, the registry of laws :mod:`.registry`.
"""

from .base import OPERATIONS, Branch, CouplerLaw, CouplerTangent, PackedLaw
from .coupling import CONTACT_KINDS, CouplerResponse, Coupling
from .draft_gear import StandardLinearDraftGear
from .friction_gear import (
    TABULATION_TOLERANCE,
    CubicLoading,
    ExponentialLoading,
    LoadingCurve,
    friction_gear,
    rated_closure_force,
    tabulation_nodes,
)
from .kelvin_voigt import KelvinVoigt
from .power_law import PowerLawGear
from .registry import COUPLER_LAWS, compiled_form_rule, coupling_from_name, law_module
from .table import HystereticTable

__all__ = [
    "Branch",
    "CONTACT_KINDS",
    "COUPLER_LAWS",
    "CouplerLaw",
    "CouplerResponse",
    "CouplerTangent",
    "Coupling",
    "CubicLoading",
    "ExponentialLoading",
    "HystereticTable",
    "KelvinVoigt",
    "LoadingCurve",
    "OPERATIONS",
    "PackedLaw",
    "PowerLawGear",
    "StandardLinearDraftGear",
    "TABULATION_TOLERANCE",
    "compiled_form_rule",
    "coupling_from_name",
    "friction_gear",
    "law_module",
    "rated_closure_force",
    "tabulation_nodes",
]
