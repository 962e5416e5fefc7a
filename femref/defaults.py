"""The built-in default scene of ``femref run`` with no case file.

Until impact scenes exist: a realistic loaded car body, 2l = 16 m and 100 t
(m = 6250 kg/m), equivalent axial stiffness 2.5 GN (first free-free axial mode
≈ 20 Hz), Voigt viscosity 2 MN·s (β ≈ 0.06), struck at its front end (x = +l) by a
half-sine coupler force of 1.5 MN in compression lasting 120 ms (F2 = −1.5 MN: the
internal force at +l, tension positive). ε = (T_wave/T_load)² ≈ 0.006.
"""

from __future__ import annotations

from typing import Any

DEFAULT_SCENE_SOURCE = "<default scene>"


def default_scene_data() -> dict[str, Any]:
    return {
        "kind": "transient",
        "body": {
            "type": "rod",
            "length": 16.0,
            "mass_per_length": 6250.0,
            "axial_stiffness": 2.5e9,
            "axial_viscosity": 2.0e6,
        },
        "loads": {"F2": {"half_sine": {"amplitude": -1.5e6, "duration": 0.12}}},
        "time": {"end": 0.4},
        "models": ["fem", "exact", "quasi_rigid", "rigid"],
        "fem": {"elements": 64, "order": 2},
    }
