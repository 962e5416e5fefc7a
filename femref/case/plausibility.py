"""Physical plausibility bounds: values no rail vehicle can have are refused at validation.

A number can be finite and of the right sign and still describe nothing a railroad owns: an axial
stiffness of 1e308 N overflows inside the models, a density contrast of 1e12 makes the automatic time
step follow the wave speed of a few nanograms per metre. Each bound lies about a factor 1e3 beyond what
rail vehicles have on each side (the ``typical`` range in the message), so that parameter studies — the
test suite's extremes — still pass::

    case.yaml: body.axial_stiffness: 1e+308 N is beyond any rail vehicle (car bodies 1e8–1e11 N);
        the plausible range is 1e5–1e14 N; got 1e+308

Some quantities have a high bound only (``low`` 0, zero allowed): end loads and harmonic frequencies.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from pydantic import AfterValidator

from femref.case.errors import Problem, problems_error

__all__ = ["BOUNDS", "MAX_CONTRAST", "Bound", "format_number", "plausible", "profile_problems"]


@dataclass(frozen=True)
class Bound:
    """``low ≤ |value| ≤ high`` (``low`` applies to nonzero values only when ``zero_ok``)."""

    what: str
    unit: str
    low: float
    high: float
    typical: str
    zero_ok: bool = False

    def rule(self, value: float) -> str | None:
        """Why ``value`` cannot describe a rail vehicle, or None when it can."""
        size = abs(value)
        if size == 0.0 and self.zero_ok:
            return None
        if self.low <= size <= self.high:
            return None
        side = "beyond" if size > self.high else "below"
        return (f"{self.what} {format_number(value)} {self.unit} is {side} any rail vehicle ({self.typical}); "
                f"the plausible range is {format_number(self.low)}–{format_number(self.high)} {self.unit}")


def format_number(x: float) -> str:
    """``1e+14`` as ``1e14``, ``100000`` as ``1e5``, ``0.5`` as ``0.5``."""
    if x == 0.0 or 1e-3 <= abs(x) < 1e4:
        return f"{x:g}"
    mantissa, exponent = f"{x:.3e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


#: Plausible magnitudes by quantity: a factor ≈ 1e3 beyond rail vehicles on each side (module docstring).
BOUNDS: dict[str, Bound] = {
    "length": Bound("a body length of", "m", 1e-2, 1e4, "car bodies 10–30 m"),
    "mass_per_length": Bound("a mass per length of", "kg/m", 1.0, 1e7, "car bodies 1e3–1e4 kg/m"),
    "axial_stiffness": Bound("an axial stiffness EA of", "N", 1e5, 1e14, "car bodies 1e8–1e11 N"),
    "axial_viscosity": Bound("an axial viscosity cA of", "N·s", 0.0, 1e14, "car bodies 1e5–1e8 N·s", zero_ok=True),
    "bending_stiffness": Bound("a bending stiffness EI of", "N·m²", 1e5, 1e15, "car bodies 1e8–1e11 N·m²"),
    "bending_viscosity": Bound("a bending viscosity cI of", "N·m²·s", 0.0, 1e17, "car bodies 1e5–1e9 N·m²·s", zero_ok=True),
    "velocity": Bound("a speed of", "m/s", 0.0, 1e3, "yard impacts 1–4 m/s, collisions below 50 m/s", zero_ok=True),
    "coupler_stiffness": Bound("a coupler stiffness of", "N/m", 1e3, 1e12, "draft gears and couplers 1e6–1e9 N/m"),
    "coupler_damping": Bound("a coupler damping of", "N·s/m", 0.0, 1e10, "draft gears 1e4–1e6 N·s/m", zero_ok=True),
    "coupler_travel": Bound("a coupler travel of", "m", 1e-5, 10.0, "draft gear strokes 0.05–0.2 m", zero_ok=True),
    "coupler_force": Bound("a coupler force of", "N", 0.0, 1e10, "couplers fail near 4e6 N", zero_ok=True),
    # Gear curves (femref.case.couplers: friction_gear, power_law).
    "gear_linear_stiffness": Bound("a linear stiffness k1 of", "N/m", 1e3, 1e12, "friction gears 1e6–1e8 N/m", zero_ok=True),
    "gear_cubic_stiffness": Bound("a cubic stiffness k3 of", "N/m³", 1e5, 1e13, "friction gears 1e8–1e10 N/m³", zero_ok=True),
    "gear_curve_amplitude": Bound("a loading-curve amplitude of", "N", 10.0, 1e9, "friction gears 1e4–1e6 N"),
    "gear_curve_exponent": Bound("a loading-curve exponent b·δ_c of", "(dimensionless)", 1e-3, 40.0, "friction gears 1–5"),
    "gear_exponent": Bound("a power-law exponent n of", "(dimensionless)", 1.0, 10.0, "gear curves n = 1–3"),
    "end_time": Bound("a simulated time of", "s", 0.0, 1e4, "impacts last 0.1–10 s", zero_ok=True),
    "time_step": Bound("a time step of", "s", 1e-10, 1e4, "fem steps of car bodies 1e-6–1e-3 s"),
    # End loads of single-body cases (femref.case.single, femref.case.signals): only a high bound, small loads are fine.
    "end_force": Bound("an end force of", "N", 0.0, 1e10, "coupler and end forces 1e4–1e7 N", zero_ok=True),
    "end_moment": Bound("an end moment of", "N·m", 0.0, 1e11, "end moments of car bodies 1e4–1e8 N·m", zero_ok=True),
    "load_time": Bound("a load pulse or rise time of", "s", 1e-7, 1e5, "impact pulses and load rises 1e-4–100 s", zero_ok=True),
    # Harmonic axes (femref.case.single.HarmonicCase): a frequency no car body responds at is a typo or a unit slip.
    "frequency": Bound("a frequency of", "Hz", 0.0, 1e6, "structural modes of car bodies 1–200 Hz", zero_ok=True),
    "circular_frequency": Bound("a circular frequency ω of", "rad/s", 0.0, 2e6 * math.pi,
                                "structural modes of car bodies 6–1300 rad/s, 1–200 Hz", zero_ok=True),
}

#: Largest ratio of the largest to the smallest value of a mass or stiffness profile along one body
#: (a loaded hopper's lading section against its end structure: 2–10).
MAX_CONTRAST = 1e6

#: Profiles whose values must not span more than :data:`MAX_CONTRAST` (positive profiles).
_CONTRAST_KEYS = ("mass_per_length", "axial_stiffness", "bending_stiffness")


def plausible(quantity: str) -> Any:
    """A pydantic validator for a scalar field (None passes): refuses values outside ``BOUNDS[quantity]``."""
    bound = BOUNDS[quantity]

    def check(value: Any) -> Any:
        if value is not None:
            rule = bound.rule(float(value))
            if rule is not None:
                raise problems_error([Problem((), rule, value)])
        return value

    return AfterValidator(check)


def sequence_check(quantity: str) -> Callable[[tuple[float, ...]], tuple[float, ...]]:
    """A validator for a tuple of values (table-law closures and forces): each within ``BOUNDS[quantity]``."""
    bound = BOUNDS[quantity]

    def check(values: tuple[float, ...]) -> tuple[float, ...]:
        problems = [Problem((i,), rule, v) for i, v in enumerate(values) if (rule := bound.rule(v)) is not None]
        if problems:
            raise problems_error(problems)
        return values

    return check


def profile_problems(key: str, items: Iterable[tuple[tuple[str | int, ...], float]]) -> list[Problem]:
    """Problems of the profile under ``key`` (``mass_per_length``, ``axial_stiffness``, …), paths below the
    body: values outside ``BOUNDS[key]``, and a contrast ``max/min`` above :data:`MAX_CONTRAST`."""
    items = list(items)
    bound = BOUNDS.get(key)
    problems = [Problem((key, *path), rule, v) for path, v in items if bound is not None and (rule := bound.rule(v)) is not None]
    values = [v for _, v in items if v > 0.0]
    if not problems and key in _CONTRAST_KEYS and len(values) > 1 and max(values) > MAX_CONTRAST * min(values):
        rule = (f"the values span a factor {max(values) / min(values):.3g}, beyond any rail vehicle (a car body's segments differ "
                f"by a factor 2–10; at most {MAX_CONTRAST:g}): the automatic time step would follow the extreme segment's wave speed")
        problems.append(Problem((key,), rule, [v for _, v in items]))
    return problems
