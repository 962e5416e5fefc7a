"""Rigid two-mass impacts: Kelvin-Voigt coupler (source Fig. 3.5) and standard-linear draft gear with stroke (Fig. 3.8).

Kelvin-Voigt coupler (docs/formulas.md §A1), closed form with the corrected exponent and
frequency::

    m* x'' + μ x' + c x = 0,   x(0) = 0,   x'(0) = −v,   m* = m1 m2/(m1 + m2)
    α = −μ/(2m*),   β = √(c/m* − α²),   A = c + μα
    P(t) = v e^{αt} (A sin(βt)/β + μ cos βt)                      (compression positive)
    peak at βt_p = atan2(β(c + 2μα), μβ² − αA):   P_max/v = e^{αt_p}(A sin(βt_p)/β + μ cos βt_p)
    undamped (μ = 0):   P_max = √(c m*) v

Standard-linear draft gear with stroke s (docs/formulas.md §A4)::

    P = (δ − x_g)/D,   μ ẋ_g = P − F_g(x_g),   F_g = c x_g (|x_g| ≤ s),  c* x_g + (c − c*) s sgn x_g (beyond)
    closing needs at least the quasi-static energy  m* v²/2 ≥ c s²/2 + D (c s)²/2
    no-dissipation peak estimate (gear solid):  D P²/2 + c s²/2 + (P² − (c s)²)/(2c*) = m* v²/2

Source: Fig. 3.5 showed the coupler force of the rigid Kelvin-Voigt model at 2, 4 and 6 m/s,
Fig. 3.8 the standard-linear gear with stroke at the same speeds (curves only; the notes give
no values and not the study's coupler or gear parameters).

Here: the study's test pair, hammer 263,000 lb (119 t) into anvil 220,000 lb (100 t) at rest
(:meth:`reduced.rigid.ImpactPair.source_study`), free to roll. The gear is
:meth:`reduced.couplers.StandardLinearDraftGear.m901e_like` — one M-901E-class (AAR Group J)
gear, the standard gear of such hoppers: c = 34 MN/m (secant to 2.52 MN at 74 mm), stroke
82.5 mm, solid 200 MN/m, dashpot 0.5 MN·s/m, series springs 400 MN/m each — because the
study's gear parameters are not recorded. The Kelvin-Voigt coupler is that gear's spring and
dashpot alone (c = 34 MN/m, μ = 0.5 MN·s/m, damping ratio 0.18), so the two figures differ
only by the stroke and the series compliance.

Headline (one variant, about a second after the imports):

* Kelvin-Voigt: peak force per unit closing speed 1.125 MN·s/m at 2, 4 and 6 m/s alike
  (linear coupler: peaks 2.25, 4.50, 6.75 MN), equal to the damped closed form above to
  1e-8; the undamped √(c m*) = 1.360 MN·s/m.
* Draft gear: open at 2 m/s (peak 2.18 MN), solid at 4 and 6 m/s (peaks 6.55 and 11.5 MN,
  gear closed 30 and 19 ms after contact); it first goes solid at 2.74 m/s, above the
  2.23 m/s below which the quasi-static energy cannot close it; peaks within 1e-6 of
  femref's impact solver with rigid cars (case/scene API, generalized-α, dt = 10 µs) and
  below the no-dissipation estimates 2.51, 8.23, 13.3 MN.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from femref.case.loader import parse_case
from femref.run.runner import run_scene
from femref.scene.build import scene_from_case
from reduced.couplers import Coupling, StandardLinearDraftGear
from reduced.nonlinear import ImpactSimulation, simulate_impact
from reduced.rigid import ImpactPair, kelvin_voigt_impact

SPEEDS = (2.0, 4.0, 6.0)  # m/s: the source's figures
GEAR = StandardLinearDraftGear.m901e_like()
COUPLER_STIFFNESS = GEAR.gear_stiffness  # N/m
COUPLER_DAMPING = GEAR.gear_damping  # N·s/m
TIME = np.linspace(0.0, 0.3, 30001)  # s: 10 µs samples resolve the closed-form peak to ~1e-8
GEAR_TIME = np.linspace(0.0, 0.3, 3001)  # s: 100 µs samples, peaks to ~1e-5 (the ODE output costs per sample)
CAR_LENGTH = 17.0  # m: only for the scene cross-check, where the cars are rigid


def kelvin_voigt_peak_per_speed(pair: ImpactPair, stiffness: float, damping: float) -> float:
    """Damped closed-form peak ``P_max/v`` (N·s/m) of ``P = v e^{αt}(A sin βt/β + μ cos βt)``.

    ``dP/dt = 0`` where ``(αA − μβ²) sin βt/β + (αμ + A) cos βt = 0``, i.e.
    ``βt_p = atan2(β(c + 2μα), μβ² − αA)`` (underdamped couplers, ``c > μ²/m*``).
    """
    m, c, mu = pair.reduced_mass, stiffness, damping
    alpha = -mu / (2.0 * m)
    beta = math.sqrt(c / m - alpha * alpha)
    a = c + mu * alpha
    t_peak = math.atan2(beta * (c + 2.0 * mu * alpha), mu * beta * beta - alpha * a) / beta
    return math.exp(alpha * t_peak) * (a * math.sin(beta * t_peak) / beta + mu * math.cos(beta * t_peak))


def quasi_static_closing_speed(pair: ImpactPair, gear: StandardLinearDraftGear) -> float:
    """Lowest speed (m/s) at which the gear can close: ``m* v²/2 = c s²/2 + D (c s)²/2``."""
    c, s = gear.gear_stiffness, gear.stroke
    return math.sqrt(2.0 * (0.5 * c * s * s + 0.5 * gear.series_compliance * (c * s) ** 2) / pair.reduced_mass)


def no_dissipation_peak(pair: ImpactPair, gear: StandardLinearDraftGear) -> float:
    """Peak force (N) if all of ``m* v²/2`` were stored at gear equilibrium ``P = F_g(x_g)``."""
    energy = pair.relative_kinetic_energy
    c, s, cs, d = gear.gear_stiffness, gear.stroke, gear.solid_stiffness, gear.series_compliance
    if energy <= 0.5 * c * s * s + 0.5 * d * (c * s) ** 2:
        return math.sqrt(2.0 * energy / (d + 1.0 / c))
    return math.sqrt((energy - 0.5 * c * s * s + (c * s) ** 2 / (2.0 * cs)) / (0.5 * d + 0.5 / cs))


def gear_impact(speed: float, time: NDArray[np.float64] = GEAR_TIME) -> ImpactSimulation:
    """The source pair through the gear, free to roll (event-driven LSODA, closure events)."""
    return simulate_impact(ImpactPair.source_study(speed), Coupling(GEAR, "compression_only"), time)


def first_closing_speed(low: float = 2.0, high: float = 6.0, tolerance: float = 1e-3) -> float:
    """Bisection (m/s) on whether the gear closes (a ``gear_closed`` event) within 80 ms."""
    short = np.linspace(0.0, 0.08, 81)
    while high - low > tolerance:
        middle = 0.5 * (low + high)
        if gear_impact(middle, short).closure_time is None:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


def rigid_scene_peak(speed: float, dt: float = 1e-5) -> float:
    """Peak coupler force (N) of the same impact through femref's case/scene API with rigid cars
    (generalized-α impact solver at ``dt``): an integrator independent of :func:`gear_impact`."""
    pair = ImpactPair.source_study(speed)

    def car(name: str, mass: float, velocity: float) -> dict:
        body = {"type": "rod", "length": CAR_LENGTH, "mass_per_length": mass / CAR_LENGTH,
                "axial_stiffness": 3.0e9, "axial_viscosity": 2.0e6}
        return {"name": name, "body": body, "velocity": velocity, "sensors": {"center": 0.0}}

    law = {name: getattr(GEAR, name) for name in ("series_stiffness_1", "series_stiffness_2", "gear_stiffness",
                                                   "gear_damping", "stroke", "solid_stiffness")}
    case = {
        "kind": "impact",
        "cars": [car("hammer", pair.hammer_mass, speed), car("anvil", pair.anvil_mass, 0.0)],
        "couplers": [{"name": "c1", "between": ["hammer", "anvil"], "law": {"draft_gear": law}, "contact": "compression_only"}],
        "time": {"end": 0.15, "dt": dt},
        "models": ["rigid"],
    }
    result = run_scene(scene_from_case(parse_case(case))).results[0]
    if not result.ok:
        raise RuntimeError(f"rigid scene run failed: {result.message}")
    return float(np.max(result.couplers["c1"]["force"]))


# --- Fig. 3.5: Kelvin-Voigt coupler ------------------------------------------------------------
kelvin_voigt = {v: kelvin_voigt_impact(ImpactPair.source_study(v), COUPLER_STIFFNESS, COUPLER_DAMPING, TIME,
                                       contact="compression_only") for v in SPEEDS}
kelvin_voigt_peak = {v: float(np.max(h.coupler_force)) for v, h in kelvin_voigt.items()}  # N
peak_force_per_speed = kelvin_voigt_peak[SPEEDS[0]] / SPEEDS[0]  # N·s/m: the headline
damping_ratio = COUPLER_DAMPING / (2.0 * math.sqrt(COUPLER_STIFFNESS * ImpactPair.source_study().reduced_mass))
undamped_peak_per_speed = math.sqrt(COUPLER_STIFFNESS * ImpactPair.source_study().reduced_mass)  # √(c m*)

# --- Fig. 3.8: standard-linear draft gear with stroke -------------------------------------------
gear = {v: gear_impact(v) for v in SPEEDS}
gear_peak = {v: float(np.max(run.coupler_force)) for v, run in gear.items()}  # N
gear_closure_time = {v: run.closure_time for v, run in gear.items()}  # s, None: never solid
solid_speeds = tuple(v for v in SPEEDS if gear_closure_time[v] is not None)
closing_speed = first_closing_speed()  # m/s
energy_closing_speed = quasi_static_closing_speed(ImpactPair.source_study(), GEAR)  # m/s

scene_peak_difference = {v: abs(rigid_scene_peak(v) - gear_peak[v]) / gear_peak[v] for v in SPEEDS}  # relative

headline = {
    "kelvin_voigt_peak_per_speed_MN_s_per_m": peak_force_per_speed / 1e6,
    "kelvin_voigt_damping_ratio": damping_ratio,
    "gear_first_solid_speed_m_s": closing_speed,
    **{f"gear_peak_{v:g}_m_s_MN": gear_peak[v] / 1e6 for v in SPEEDS},
}


if __name__ == "__main__":
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), sharey=False)
    for v in SPEEDS:
        t_ms = 1e3 * TIME
        left.plot(t_ms, kelvin_voigt[v].coupler_force / 1e6, label=f"{v:g} m/s")
        (line,) = right.plot(1e3 * GEAR_TIME, gear[v].coupler_force / 1e6, label=f"{v:g} m/s")
        if gear_closure_time[v] is not None:
            tc = gear_closure_time[v]
            right.plot(1e3 * tc, np.interp(tc, GEAR_TIME, gear[v].coupler_force) / 1e6, "o", color=line.get_color())
    left.set(title=f"Fig. 3.5: Kelvin-Voigt coupler (ζ = {damping_ratio:.2f})\n"
                   f"peak/speed {peak_force_per_speed / 1e6:.3f} MN·s/m",
             xlabel="t (ms)", ylabel="coupler force P (MN)", xlim=(0, 250))
    right.set(title=f"Fig. 3.8: standard-linear gear, stroke {1e3 * GEAR.stroke:g} mm\n"
                    f"solid (●) from {closing_speed:.2f} m/s",
              xlabel="t (ms)", xlim=(0, 150))
    for ax in (left, right):
        ax.legend()
        ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(__file__).with_name("figures") / "rigid_impacts.png"
    out.parent.mkdir(exist_ok=True)
    fig.savefig(out, dpi=110)
    for key, value in headline.items():
        print(f"{key}: {value:.4g}")
