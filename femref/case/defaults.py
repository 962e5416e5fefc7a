"""The built-in default scene of ``femref run`` with no case file: a free-to-roll yard impact.

Two loaded covered hoppers 17 m over the ends (docs/design.md §8, the source study's test pair): the hammer,
263,000 lb ≈ 119 t, rolls at 2.2 m/s (≈ 4.9 mph) into the anvil, 220,000 lb ≈ 100 t, at rest; the lading sits
between the bolsters (|x| < 6.5 m); axial stiffness 3 GN (first free-free axial mode ≈ 19 Hz), Voigt viscosity
2 MN·s (β ≈ 0.05). The coupler is the two cars' M-901E-class draft gears in series (each 34 MN/m secant to
2.52 MN at 74 mm): one standard-linear gear of 17 MN/m, 165 mm stroke, 100 MN/m solid, 0.25 MN·s/m, 400 MN/m of
series stiffness. At 2.2 m/s the gears take about 120 mm and 2 MN over a ~0.18 s pulse: ε ≈ 0.005.

The accelerometers record at 1 kHz through a 100 Hz anti-alias filter with 0.05 m/s² of noise: the filter keeps
the cars' first axial modes and removes the wave transients of the gear's fast initial rise, which the two-term
quasi-rigid inverse cannot use (its peak-force error is about 100 % through 500 Hz, 9 % through 100 Hz).
"""

from __future__ import annotations

from typing import Any

DEFAULT_SCENE_SOURCE = "<default scene>"


def covered_hopper(gross_mass: float) -> dict[str, Any]:
    """A 17 m loaded covered hopper of ``gross_mass`` (kg): 3500 kg/m over each 2 m end, the rest between."""
    end_mass = 3500.0 * 2.0 * 2.0
    return {
        "type": "rod",
        "length": 17.0,
        "mass_per_length": {"piecewise": {"breaks": [-6.5, 6.5], "values": [3500.0, (gross_mass - end_mass) / 13.0, 3500.0]}},
        "axial_stiffness": 3.0e9,
        "axial_viscosity": 2.0e6,
    }


def default_scene_data() -> dict[str, Any]:
    return {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": covered_hopper(119.0e3), "velocity": 2.2, "sensors": {"center": 0.0, "front": 8.3}},
            {"name": "anvil", "body": covered_hopper(100.0e3), "velocity": 0.0, "sensors": {"rear": -8.3, "center": 0.0, "front": 8.3}},
        ],
        "couplers": [
            {
                "name": "c1",
                "between": ["hammer", "anvil"],
                "law": {
                    "draft_gear": {
                        "gear_stiffness": 1.7e7,
                        "gear_damping": 2.5e5,
                        "stroke": 0.165,
                        "solid_stiffness": 1.0e8,
                        "series_stiffness_1": 4.0e8,
                        "series_stiffness_2": 4.0e8,
                    }
                },
                "contact": "compression_only",
            }
        ],
        "time": {"end": 0.5},
        "models": ["fem", "modal", "quasi_rigid", "rigid"],
        "fem": {"elements": 64, "order": 2},
        "measurement": {"rate": 1000.0, "lowpass": 100.0, "noise": 0.05, "seed": 1},
        "estimators": ["inverse_rigid", "inverse_quasi_rigid"],
    }
