"""Coupler force laws as small frozen value objects, and the contact that wraps them.

Closure ``δ = x1 − x2`` (m, compression positive), force ``P`` (N, compression
positive); every law has the interface of :class:`CouplerLaw`. Modules:

* :mod:`.base` — the law interface (a module of plain functions on packed parameters and a class
  deriving from :class:`PackedLaw`), :class:`CouplerTangent`, the :class:`CouplerLaw` protocol, ``Branch``;
* :mod:`.kelvin_voigt` — :class:`KelvinVoigt`, ``P = c δ + μ δ̇``;
* :mod:`.power_law` — :class:`PowerLawGear`, ``P = sgn(δ) (c |δ|ⁿ + N0) + γ(δ) δ̇``;
* :mod:`.draft_gear` — :class:`StandardLinearDraftGear`, series springs and a gear with a stroke;
* :mod:`.table` — :class:`HystereticTable`, tabulated loading/unloading curves;
* :mod:`.friction_gear` — :func:`friction_gear`, a friction gear with hysteresis and a solid stop
  (:class:`CubicLoading` or :class:`ExponentialLoading`) tabulated as a :class:`HystereticTable`;
* :mod:`.coupling` — :class:`Coupling` (contact, slack), :class:`CouplerResponse`, :data:`CONTACT_KINDS`;
* :mod:`.registry` — :data:`COUPLER_LAWS`, found in the law modules, :func:`compiled_form_rule`
  and :func:`coupling_from_name`.
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
