"""The quasi-rigid tables the set-up builds, for bodies with profile jumps (issue 31): what
tests/reduced/quasi_rigid/test_set_up.py holds a build to against the stored answer of the previous build
(``tests/reduced/quasi_rigid/data/set_up_tables.npz``, written by ``python tests/support/quasi_rigid_tables.py`` at
commit d2318cf).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from reduced.quasi_rigid import QuasiRigidBeam, QuasiRigidRod

STORED = Path(__file__).parents[1] / "reduced" / "quasi_rigid" / "data" / "set_up_tables.npz"
DT = 2.0e-3
PROBES = np.array([-7.3, -2.0, 0.0, 1.5, 6.0])
OMEGA = np.array([0.0, 5.0, 40.0, 300.0])


def bodies() -> dict[str, QuasiRigidRod | QuasiRigidBeam]:
    """Non-uniform bodies with profile jumps: exact time-constant groups (piecewise τ), interpolated ones (a
    continuously varying τ) and a beam with symmetric jumps."""
    def mass(x):
        return np.where(np.abs(x) < 4.0, 6000.0 + 100.0 * x, 3500.0 - 40.0 * x)

    def stiffness(x):
        return np.where(x < 2.0, 2.0e9, 3.1e9)

    def viscosity(x):
        return np.where(x < -4.0, 4.0e6, 1.0e6)

    def beam_mass(x):
        return np.where(np.abs(x) < 3.0, 5000.0 + 50.0 * x * x, 3200.0)

    return {
        "rod": QuasiRigidRod(8.0, mass, stiffness, viscosity, jumps=[-4.0, 2.0, 4.0]),
        "graded": QuasiRigidRod(8.0, mass, lambda x: 2.0e9 * (1.2 + 0.05 * x), lambda x: 1.0e6 * (1.5 + 0.1 * x), jumps=[-4.0, 4.0],
                                max_tau_groups=8),
        "beam": QuasiRigidBeam(8.0, beam_mass, lambda x: np.where(np.abs(x) < 3.0, 4.0e9, 2.5e9), 2.0e6, jumps=[3.0]),
    }


def tables() -> dict[str, NDArray[np.float64]]:
    """Every table of every body by ``body/name``: τ groups, the coefficients at the nodes and at probes (and their
    x-derivatives), the undeformed stepper's step matrices, a harmonic and a transient response."""
    out: dict[str, NDArray[np.float64]] = {}
    t = DT * np.arange(200)
    for name, body in bodies().items():
        out[f"{name}/tau_groups"] = body.tau_groups
        out[f"{name}/node_coefficients"] = body.correction.node_coefficients()
        out[f"{name}/coefficients"] = body.coefficients(PROBES)
        out[f"{name}/slopes"] = body.coefficients(PROBES, 1)
        step = body.stepper(PROBES, initial_shape="undeformed").transition(DT)
        for field in ("transition", "input", "displacement", "velocity", "acceleration"):
            out[f"{name}/step_{field}"] = getattr(step, field)
        J = len(body.load_names)
        unit = {load: float(j + 1) for j, load in enumerate(body.load_names)}
        out[f"{name}/harmonic"] = body.harmonic(OMEGA, PROBES, **unit).acceleration
        pulse = {load: (1.0e5 * (j + 1)) * np.sin(np.pi * np.clip(t / 0.3, 0.0, 1.0)) for j, load in enumerate(body.load_names[:J])}
        response = body.transient(t, PROBES, **pulse)
        out[f"{name}/transient_acceleration"] = response.acceleration
        out[f"{name}/transient_displacement"] = response.displacement
    return out


if __name__ == "__main__":
    STORED.parent.mkdir(exist_ok=True)
    np.savez_compressed(STORED, **tables())
    sys.exit(0)
