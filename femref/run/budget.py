"""The work budget: what a scene will cost, predicted before any work, and refused when too much.

For every model run of a scene the prediction counts the work the run does — steps × degrees
of freedom for a time-stepped model, frequencies × degrees of freedom for a harmonic one,
output times × probes × de Hoog terms for the exact transient, load-record samples × transform
values for a long CSV load under ``exact``, and a dense eigenproblem for the modal bending of a
car — and the memory it holds: its histories (every output sample of every probe, coupler and
energy), its fields, and its matrices. Nothing is assembled to predict: the degrees of freedom
come from the element count and order, the automatic step from the profiles' wave speed sampled
at a few hundred points (:func:`approximate_step`).

Work is counted in *work units*, calibrated to seconds on the reference machine (2 cores, a
loaded one: the constants below are the measured per-step and per-DOF costs, rounded up):

    impact car step        fem 3e-7 s per DOF + 5e-6 s; modal, quasi-rigid, rigid 5e-6 s (4e-5 s bending)
    single-body fem step   5e-4 s + 5e-7 s per DOF
    harmonic fem           5e-3 s + 1.1e-5 s per DOF, per frequency
    exact transient        6e-5 s per output time and probe; a CSV record of n > 64 samples adds
                           n × 385 transform values × (log2 Nt + 1) windows × 5e-8 s
    modal bending car      3e-10 s × n³ (dense eigenproblem of the beam's n DOFs)

A scene is refused (:class:`~femref.case.CaseError`, exit 2) when its total work exceeds
:data:`WORK_BUDGET` work units or the memory it holds exceeds :data:`MEMORY_BUDGET` bytes; the
message names the key that drives the largest part (``fem.elements``, ``time.end``, ``time.dt``,
``frequency.num``, ``loads.<name>.csv.path``) and the predicted size. The environment variable
``FEMREF_BUDGET=<factor>`` multiplies both limits, on purpose (``FEMREF_BUDGET=10`` allows ten
times as much).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from femref.case.errors import CaseError, Problem
from femref.core.body import Body
from femref.core.signals import Tabulated
from femref.run.timestep import impact_candidates, single_body_candidates, smallest_candidate

#: Work units (≈ seconds on the reference machine) a scene may take.
WORK_BUDGET = 3600.0
#: Bytes of histories, fields and matrices a scene may hold.
MEMORY_BUDGET = 8e9
#: The environment variable that multiplies both limits.
BUDGET_VARIABLE = "FEMREF_BUDGET"

_BYTES = 8.0
_MATRIX_BYTES_PER_DOF = 600.0  # sparse M, C, K, banded factors, dense load and output maps
_DEFAULT_ELEMENTS = 64
_TYPICAL_END = 1.0  # s: an impact or a load history
_TYPICAL_FREQUENCIES = 200
_TYPICAL_ROWS = 1e4
_LAPLACE_VALUES = 385  # 2M + 1 with de Hoog's M at most 192


@dataclass
class Cost:
    """One model run's predicted work (work units) and memory (bytes), the size that drives it, and how far
    each case key it depends on lies beyond a typical run (``factors``: key → (ratio, value))."""

    model: str
    work: float
    memory: float
    size: str
    factors: dict[str, tuple[float, object]] = field(default_factory=dict)

    def driver(self) -> tuple[str, object]:
        """The key lying furthest beyond a typical run, and its value."""
        key = max(self.factors, key=lambda k: self.factors[k][0])
        return key, self.factors[key][1]


def budget_factor() -> float:
    """``FEMREF_BUDGET`` (default 1); a CaseError when it is not a positive number."""
    text = os.environ.get(BUDGET_VARIABLE, "").strip()
    if not text:
        return 1.0
    try:
        factor = float(text)
    except ValueError:
        factor = math.nan
    if not (math.isfinite(factor) and factor > 0.0):
        raise CaseError(Problem((), f"environment variable {BUDGET_VARIABLE} must be a positive number (a factor on the work budget)", text))
    return factor


def check_budget(scene, source: str = "<case>") -> list[Cost]:
    """Raise :class:`CaseError` when ``scene`` is predicted to cost more than the budget (module docstring);
    return the prediction otherwise. Measured scenes (no model runs) pass."""
    costs = predict(scene)
    if not costs:
        return costs
    factor = budget_factor()
    work = sum(c.work for c in costs)
    memory = sum(c.memory for c in costs)
    if work <= WORK_BUDGET * factor and memory <= MEMORY_BUDGET * factor:
        return costs
    worst = max(costs, key=lambda c: max(c.work / WORK_BUDGET, c.memory / MEMORY_BUDGET))
    key, value = worst.driver()
    rule = (f"the {worst.model} run is predicted at {worst.size} ≈ {_duration(worst.work)} of work and {_bytes(worst.memory)} of histories "
            f"and matrices (the scene: {_duration(work)}, {_bytes(memory)}); the budget is {_duration(WORK_BUDGET * factor)} and "
            f"{_bytes(MEMORY_BUDGET * factor)}: reduce {key}, or raise the budget on purpose with the environment variable "
            f"{BUDGET_VARIABLE}=<factor> (now {factor:g})")
    raise CaseError(Problem(tuple(key.split(".")), rule, value), source)


def predict(scene) -> list[Cost]:
    """The cost of every model run of ``scene`` (impact, transient or harmonic; nothing else is predicted)."""
    kind = getattr(scene, "kind", None)
    if kind == "impact":
        return [_impact_run(scene, run) for run in scene.runs]
    if kind == "transient":
        return [_transient(scene, model) for model in scene.models]
    if kind == "harmonic":
        return [_harmonic(scene, model) for model in scene.models]
    return []


# ---------------------------------------------------------------------------------------------
# Sizes without assembly


def wave_speed(body: Body) -> float:
    """``max √(stiffness/m)`` over ~500 points and both sides of every jump (m/s rod, m²/s beam)."""
    l = body.half_length
    jumps = np.asarray(body.jumps, dtype=float)
    x = np.concatenate([np.linspace(-l, l, 513), jumps - 1e-9 * l, jumps + 1e-9 * l])
    x = np.clip(x, -l, l)
    return float(np.max(np.sqrt(body.stiffness(x) / body.mass_per_length(x))))


def _nodes(body: Body, elements: int) -> int:
    return int(elements) + 1 + len(body.jumps)


def rod_dofs(body: Body, elements: int, order: int) -> int:
    return order * (_nodes(body, elements) - 1) + 1


def _steps(end: float, dt: float) -> float:
    return math.ceil(end / dt - 1e-9)


def _time_factors(scene, dt: float, auto_dt_default: float) -> dict[str, tuple[float, object]]:
    factors: dict[str, tuple[float, object]] = {"time.end": (scene.end / _TYPICAL_END, scene.end)}
    if scene.dt is not None:
        factors["time.dt"] = (auto_dt_default / scene.dt, scene.dt)
    return factors


# ---------------------------------------------------------------------------------------------
# Impact runs


def approximate_step(scene, run, elements: int | None = None) -> float:
    """The automatic step of an impact run (:func:`femref.run.timestep.impact_time_step`'s rule) without a mesh:
    the wave speeds sampled (:func:`wave_speed`); the case's ``time.dt`` when it gives one and ``elements`` is None."""
    if scene.dt is not None and elements is None:
        return scene.dt
    return smallest_candidate(impact_candidates(scene, run, elements or scene.fem.elements, wave_speed))[0]


def _impact_run(scene, run) -> Cost:
    dt = approximate_step(scene, run)
    steps = _steps(scene.end, dt)
    outputs = steps / scene.output_stride + 1
    per_step, setup, matrices, dofs_total = 0.0, 0.0, 0.0, 0
    for car, fidelity in zip(scene.cars, run.fidelity):
        if fidelity in ("fem", "modal"):
            dofs = rod_dofs(car.body, scene.fem.elements, scene.fem.order)
            beam = 2 * _nodes(car.body, scene.fem.elements) if car.bending is not None else 0
            setup += 1e-4 * scene.fem.elements * (2 if beam else 1)
            matrices += _MATRIX_BYTES_PER_DOF * (dofs + beam)
            if fidelity == "fem":
                per_step += 3e-7 * (dofs + beam) + 5e-6
                dofs_total += dofs + beam
            else:
                per_step += 4e-5 if beam else 5e-6
                setup += 3e-6 * dofs * (scene.modal_modes + 1) + 3e-10 * float(beam) ** 3
                matrices += 4 * _BYTES * float(beam) ** 2
        else:
            per_step += 4e-5 if car.bending is not None else 5e-6
    channels = len(scene.channels)
    histories = outputs * (3 * channels + 2 * len(scene.couplers) + 6) * _BYTES
    factors = _time_factors(scene, dt, approximate_step(scene, run, _DEFAULT_ELEMENTS) if scene.dt is not None else dt)
    if any(f in ("fem", "modal") for f in run.fidelity):
        factors["fem.elements"] = (scene.fem.elements / _DEFAULT_ELEMENTS, scene.fem.elements)
    size = f"{steps:.3g} steps × {dofs_total:.3g} DOFs = {steps * max(dofs_total, 1):.3g} DOF-steps" if dofs_total else f"{steps:.3g} steps"
    return Cost(run.name, steps * per_step + setup, histories + matrices, size, factors)


# ---------------------------------------------------------------------------------------------
# Single body


def _single_step(scene, elements: int | None = None) -> float:
    """The transient scene's step (:func:`femref.run.timestep.single_body_time_step`'s rule) without a mesh; the
    case's ``time.dt`` when it gives one and ``elements`` is None."""
    if scene.dt is not None and elements is None:
        return scene.dt
    return smallest_candidate(single_body_candidates(scene, elements or scene.fem.elements, wave_speed))[0]


def _single_dofs(scene) -> int:
    if scene.body.kind == "rod":
        return rod_dofs(scene.body, scene.fem.elements, scene.fem.order)
    return 2 * _nodes(scene.body, scene.fem.elements)


def _records(scene) -> dict[str, int]:
    """Samples of each tabulated (CSV) load."""
    return {name: int(s.times.size) for name, s in scene.loads.items() if isinstance(s, Tabulated)}


def _transient(scene, model: str) -> Cost:
    dt = _single_step(scene)
    steps = _steps(scene.end, dt)
    outputs = steps / scene.output_stride + 1
    probes = len(scene.probes)
    histories = outputs * (3 * probes + 5) * _BYTES
    factors = _time_factors(scene, dt, _single_step(scene, _DEFAULT_ELEMENTS))
    records = _records(scene)
    memory = histories + sum(2 * _BYTES * n for n in records.values())
    size = f"{steps:.3g} steps"
    if model == "fem":
        dofs = _single_dofs(scene)
        work = steps * (5e-4 + 5e-7 * dofs) + 1e-4 * scene.fem.elements
        memory += _MATRIX_BYTES_PER_DOF * dofs + steps * 4 * _BYTES
        if scene.fem.fields:
            memory += outputs / scene.fem.field_stride * dofs * _BYTES
        factors["fem.elements"] = (scene.fem.elements / _DEFAULT_ELEMENTS, scene.fem.elements)
        size = f"{steps:.3g} steps × {dofs:.3g} DOFs = {steps * dofs:.3g} DOF-steps"
    elif model == "exact":
        work = 6e-5 * outputs * probes
        memory += 4 * outputs * 3 * probes * 2 * _BYTES
        windows = math.log2(max(outputs, 2.0)) + 1
        for name, n in records.items():
            if n > 64:  # a long record is transformed whole (femref.exact.transient.MAX_TABULATED_CORNERS)
                work += n * _LAPLACE_VALUES * windows * 5e-8
                memory = max(memory, 6 * n * _LAPLACE_VALUES * 2 * _BYTES)
                factors[f"loads.{name}.csv.path"] = (n / _TYPICAL_ROWS, f"{n} samples")
        size = f"{outputs:.3g} output times × {probes} probes" + (f", {max(records.values()):.3g} load samples" if records else "")
    else:
        work = 5e-6 * steps
    return Cost(model, work, memory, size, factors)


def _harmonic(scene, model: str) -> Cost:
    num = int(np.size(scene.omega))
    factors: dict[str, tuple[float, object]] = {"frequency.num": (num / _TYPICAL_FREQUENCIES, num)}
    memory = num * (3 * len(scene.probes) + 2) * 2 * _BYTES
    if model == "fem":
        dofs = _single_dofs(scene)
        factors["fem.elements"] = (scene.fem.elements / _DEFAULT_ELEMENTS, scene.fem.elements)
        return Cost(model, num * (5e-3 + 1.1e-5 * dofs), memory + 3 * _MATRIX_BYTES_PER_DOF * dofs,
                    f"{num:.3g} frequencies × {dofs:.3g} DOFs", factors)
    return Cost(model, 1e-5 * num, memory, f"{num:.3g} frequencies", factors)


# ---------------------------------------------------------------------------------------------
# Does the case's discretisation resolve the reference?

#: A step above this fraction of the shortest wave travel time, or of the coupler contact time, under-resolves
#: the fem reference; so does an element longer than this fraction of the pulse's wavelength.
STEP_PER_WAVE_TIME, STEP_PER_CONTACT_TIME, ELEMENT_PER_WAVELENGTH = 0.1, 0.05, 0.05


def resolution_warnings(scene) -> list[str]:
    """Why the case's own ``time.dt`` or ``fem.elements`` under-resolves the fem reference of an impact scene
    (empty when they resolve it, or when the runner chooses the step): a step above a tenth of the shortest
    wave travel time ``l√(m/EA)`` of the cars or a twentieth of the coupler contact time, or fewer elements
    than twenty per wavelength of the contact pulse, ``2l/h ≥ 40 T_wave/T_contact``. Each text starts with the key."""
    if getattr(scene, "kind", None) != "impact":
        return []
    contact = scene.contact_time()
    wave = [car.body.wave_travel_time for car in scene.cars]
    warnings = []
    if scene.dt is not None:
        if scene.dt > STEP_PER_WAVE_TIME * min(wave):
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a tenth of the shortest wave travel time of the cars "
                            f"({min(wave):.3g} s): the fem reference under-resolves its waves")
        elif math.isfinite(contact) and scene.dt > STEP_PER_CONTACT_TIME * contact:
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a twentieth of the coupler contact time ({contact:.3g} s): "
                            "the fem reference under-resolves the pulse")
    needed = 2.0 * max(wave) / (ELEMENT_PER_WAVELENGTH * contact) if math.isfinite(contact) else 0.0
    if scene.fem.elements < needed:
        warnings.append(f"fem.elements = {scene.fem.elements} is below the {math.ceil(needed)} elements that resolve the contact pulse "
                        "(twenty per wavelength)")
    return warnings


# ---------------------------------------------------------------------------------------------
# Messages


def _duration(seconds: float) -> str:
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.3g} B"


__all__ = ["BUDGET_VARIABLE", "MEMORY_BUDGET", "WORK_BUDGET", "Cost", "approximate_step", "budget_factor", "check_budget", "predict", "resolution_warnings",
           "wave_speed"]
