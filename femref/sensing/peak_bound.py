"""The largest coupler force a closing speed allows: an estimate far beyond it is no impact of these cars.

Two groups of cars meet at closing speed ``v`` (m/s): the cars behind the coupler and those ahead
of it, of masses ``M_r`` and ``M_f`` (kg), each moving as one before contact. In their centre of
mass frame they carry the kinetic energy ``½ m* v²``, ``m* = M_r M_f/(M_r + M_f)``, and nothing adds
to it during the impact. A coupler whose force is ``P = f(x) + g(ẋ)`` — a spring part of the stroke
``x`` with ``0 ≤ f′ ≤ k_max`` and a rate part ``0 ≤ g(ẋ) ≤ c_max ẋ`` (friction and viscous gears,
series springs: the gear's loading curve is ``f``) — stores at least ``f²/(2 k_max)`` at stroke
``x``, which the energy bounds, and closes at no more than ``v`` (the force only slows the closing),
so

    P_max ≤ v (√(k_max m*) + c_max)                (N)

with equality for a linear spring of stiffness ``k_max`` and no damping. ``k_max`` =
:data:`STIFFEST_COUPLER` and ``c_max`` = :data:`MOST_DAMPED_COUPLER` are the top of the typical
ranges of :mod:`femref.case.plausibility` (draft gears and couplers 1e6–1e9 N/m, 1e4–1e6 N·s/m),
ten times the default scene's stiffest series element (``4e8`` N/m) and four times its gear
damping: on the yard's two cars (``m* = 54.5`` t) the bound is ``8.4`` MN per m/s. Elastic cars
store some of the energy in their bodies and lower the force: the bound holds for them too.
Checked in tests/measured/test_phantom_impacts.py against rigid two-mass impacts through
Kelvin–Voigt couplers (the bound reached within 0.1 % by the undamped stiffest one) and fem
impacts of the default scene through the measurement chain (every estimate far below it).

An estimate whose peak exceeds the bound at the upper end of the event's closing speed interval
is ``implausible`` (:func:`implausible`): a bias, a glitch or a wrong unit made it, not the cars.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

STIFFEST_COUPLER = 1.0e9
"""``k_max`` (N/m): the largest plausible coupler or draft-gear stiffness."""
MOST_DAMPED_COUPLER = 1.0e6
"""``c_max`` (N·s/m): the largest plausible draft-gear damping."""


def peak_force_bound(closing_speed: float, reduced_mass: float, stiffness: float = STIFFEST_COUPLER,
                     damping: float = MOST_DAMPED_COUPLER) -> float:
    """``P_max = v (√(k_max m*) + c_max)`` (N): the largest coupler force closing speed ``v`` (m/s) allows between
    groups of reduced mass ``m*`` (kg) (module docstring)."""
    return closing_speed * (math.sqrt(stiffness * reduced_mass) + damping)


def line_reduced_mass(masses: Sequence[float], coupler: int) -> float:
    """``m* = M_r M_f/(M_r + M_f)`` (kg): the cars behind coupler ``coupler`` (0-based, between cars ``coupler`` and
    ``coupler + 1``) against those ahead of it, masses in line order (kg)."""
    behind, ahead = sum(masses[: coupler + 1]), sum(masses[coupler + 1 :])
    return behind * ahead / (behind + ahead)


def implausible(peak: float, closing_speed_upper: float, reduced_mass: float) -> str | None:
    """Why a peak force ``peak`` (N) cannot come from cars of reduced mass ``m*`` (kg) closing at no more than
    ``closing_speed_upper`` (m/s), or None when it can (or without a finite speed to check it by)."""
    if not (math.isfinite(peak) and math.isfinite(closing_speed_upper) and closing_speed_upper > 0.0):
        return None
    bound = peak_force_bound(closing_speed_upper, reduced_mass)
    if peak <= bound:
        return None
    return (f"implausible: peak {peak / 1e3:.6g} kN exceeds the {bound / 1e3:.6g} kN that a closing speed of at most "
            f"{closing_speed_upper:.3g} m/s allows between m* = {reduced_mass / 1e3:.4g} t through the stiffest plausible coupler "
            f"(P ≤ v (√(k m*) + c), k = {STIFFEST_COUPLER:.0e} N/m, c = {MOST_DAMPED_COUPLER:.0e} N·s/m)")


__all__ = ["MOST_DAMPED_COUPLER", "STIFFEST_COUPLER", "implausible", "line_reduced_mass", "peak_force_bound"]
