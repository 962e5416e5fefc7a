"""From a validated case (:mod:`femref.case`) to the resolved :class:`femref.scene.Scene`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from femref.case import Case
from femref.scene import Body, FemSettings, Scene


def body_of(case: Case) -> Body:
    spec = case.body
    built = spec.profiles()
    return Body(
        kind=spec.type,
        half_length=spec.half_length,
        mass_per_length=built["mass_per_length"],
        stiffness=built["stiffness"],
        viscosity=built["viscosity"],
        wave_travel_time=spec.wave_time(),
    )


def scene_from_case(case: Case, base_dir: Path | None = None) -> Scene:
    """Resolve profiles, signals, the frequency axis and settings of a single-body case."""
    fem = case.fem
    settings = FemSettings(
        elements=fem.elements, order=fem.order, grading=fem.grading, fields=fem.fields, field_stride=fem.field_stride
    )
    common = dict(body=body_of(case), probes=dict(case.probes), models=tuple(case.models), fem=settings)
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
