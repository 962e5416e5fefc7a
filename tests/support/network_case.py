"""The two-car free-roll impact the network-estimator tests read records from (coarse fem: fast)."""

from __future__ import annotations

from typing import Any

PROBES = ["hammer/center", "hammer/front", "anvil/rear", "anvil/center"]
"""The record channels of the tests' networks."""

RECORD_LENGTH, RECORD_END = 64, 0.25
"""Samples per record and its span (s) of the tests' networks: 252 Hz."""

TWO_CARS: dict[str, Any] = {
    "kind": "impact",
    "cars": [
        {
            "name": "hammer",
            "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6},
            "velocity": 2.2,
            "sensors": {"center": 0.0, "front": 8.0},
        },
        {
            "name": "anvil",
            "body": {"type": "rod", "length": 15.0, "mass_per_length": 6500.0, "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6},
            "velocity": 0.0,
            "sensors": {"center": 0.0, "rear": -7.0},
        },
    ],
    "couplers": [{"name": "c1", "between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
}
"""Kind, cars and coupler of the tests' impact: a 17 m hammer at 2.2 m/s into a 15 m anvil through a Kelvin-Voigt coupler."""
