"""The quasi-rigid cars' state-space matrices, for cars with profile jumps (issue 31): what
tests/models/test_quasi_rigid_build.py holds the car build to against the stored answer of the previous build
(``tests/models/data/quasi_rigid_cars.npz``, written by ``python tests/support/quasi_rigid_cars.py`` at commit 2017624).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.core.body import Body
from femref.core.profiles import Linear, Piecewise, Table, Uniform
from femref.models.base import forget_built
from femref.models.quasi_rigid import quasi_rigid_car
from femref.scene.impact import Car

STORED = Path(__file__).parents[1] / "models" / "data" / "quasi_rigid_cars.npz"
DT = 2.5e-4
TIME_SCALES = (0.01, 0.05, 0.3)
FIELDS = ("transition", "input", "end_displacement", "end_velocity", "sensor_displacement", "sensor_velocity",
          "sensor_acceleration", "velocity_state", "load_state", "kinetic_form", "strain_form", "work_map", "momentum")


def cars() -> dict[str, Car]:
    """Non-uniform cars with profile jumps: piecewise mass, stiffness and viscosity (exact τ groups, three of
    them), a tabulated mass with a linear viscosity (interpolated τ groups), an elastic car, and a car that bends."""
    l = 8.5
    mass = Piecewise((-6.5, -1.0, 6.5), (3500.0, 8200.0, 6100.0, 3500.0))
    stiffness = Piecewise((-2.0, 3.0), (3.0e9, 2.2e9, 3.4e9))
    viscosity = Piecewise((-4.0, 5.0), (2.0e6, 5.0e6, 1.0e6))
    stepped = Body("rod", l, mass, stiffness, viscosity, 0.01)
    graded = Body("rod", l, Table((-l, -2.0, 3.0, l), (3000.0, 9000.0, 7000.0, 2500.0)), Uniform(3.0e9),
                  Linear(1.0e6, 4.0e6, l), 0.01)
    elastic = Body("rod", l, mass, stiffness, Uniform(0.0), 0.01)
    beam = Body("beam", l, Piecewise((-6.5, 6.5), (3500.0, 8000.0, 3500.0)), Uniform(4.0e9), Uniform(1.0e6), 0.01)
    sensors = {"rear": -8.3, "centre": 0.0, "middle": 2.7, "front": 8.3}
    return {
        "stepped": Car("stepped", stepped, 1.5, sensors),
        "graded": Car("graded", graded, -0.5, {"centre": 0.0, "front": 8.0}),
        "elastic": Car("elastic", elastic, 2.0, {"front": 8.3}),
        "bending": Car("bending", Body("rod", l, beam.mass_per_length, Uniform(3.0e9), Uniform(2.0e6), 0.01), 1.0,
                       {"centre": 0.0, "front": 8.3}, bending=beam, coupler_offset=(0.4, 0.3), coupler_slope=(0.02, -0.01)),
    }


def tables() -> dict[str, NDArray[np.float64]]:
    """Every matrix of every car's :class:`StateSpaceSystem` by ``car/field``, its τ groups and ε at three load time
    scales, each car built afresh."""
    out: dict[str, NDArray[np.float64]] = {}
    for name, car in cars().items():
        forget_built()
        system = quasi_rigid_car(car, DT)
        for field in FIELDS:
            out[f"{name}/{field}"] = np.asarray(getattr(system, field), dtype=float)
        out[f"{name}/tau_groups"] = np.array(system.settings["tau_groups"])
        out[f"{name}/epsilon"] = np.array([system.settings_of_time_scale(scale)["epsilon"] for scale in TIME_SCALES])
    return out


if __name__ == "__main__":
    STORED.parent.mkdir(exist_ok=True)
    np.savez_compressed(STORED, **tables())
    sys.exit(0)
