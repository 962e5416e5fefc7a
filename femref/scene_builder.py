"""From a validated case (:mod:`femref.case`) to the resolved scene.

Single-body cases (harmonic, transient) become a :class:`femref.scene.Scene`; impact
cases become a :class:`femref.impact.scene.ImpactScene`
(:func:`femref.impact.build.impact_scene_from_case`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from femref.case import Case
from femref.case.schema import Body as BodySpec
from femref.case.schema import FemSettings as FemSpec
from femref.scene import Body, FemSettings, Scene

if TYPE_CHECKING:  # pragma: no cover - typing only
    from femref.impact.scene import ImpactScene


def body_from_spec(spec: BodySpec) -> Body:
    """The resolved body of a body spec: built profiles and the wave travel time (shared with impact cars)."""
    built = spec.profiles()
    return Body(
        kind=spec.type,
        half_length=spec.half_length,
        mass_per_length=built["mass_per_length"],
        stiffness=built["stiffness"],
        viscosity=built["viscosity"],
        wave_travel_time=spec.wave_time(),
    )


def body_of(case: Case) -> Body:
    """The resolved body of a single-body case."""
    return body_from_spec(case.body)


def fem_settings_of(fem: FemSpec) -> FemSettings:
    """The resolved finite-element settings (the case has filled in the element order)."""
    return FemSettings(elements=fem.elements, order=fem.order, grading=fem.grading, fields=fem.fields, field_stride=fem.field_stride)


def scene_from_case(case: Case, base_dir: Path | None = None) -> Scene | ImpactScene:
    """Resolve a case: profiles, signals, the frequency axis and settings; impact cases go to their builder."""
    if case.kind == "impact":
        from femref.impact.build import impact_scene_from_case  # it builds on this module

        return impact_scene_from_case(case, base_dir)
    common = dict(body=body_of(case), probes=dict(case.probes), models=tuple(case.models), fem=fem_settings_of(case.fem))
    if case.kind == "harmonic":
        loads = {name: complex(value) for name, value in case.load_amplitudes().items() if value != 0}
        return Scene(kind="harmonic", loads=loads, omega=np.asarray(case.omega(), dtype=float), **common)
    return Scene(
        kind="transient",
        loads=case.load_signals(base_dir),
        end=case.time.end,
        dt=case.time.dt,
        output_stride=case.time.output_stride,
        integrator=case.integrator.scheme,
        rho_inf=case.integrator.rho_inf if case.integrator.rho_inf is not None else 1.0,
        **common,
    )
