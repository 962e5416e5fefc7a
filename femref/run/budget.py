"""The work budget: what a scene will cost, predicted before any work, and refused when too much.

For every model run the prediction counts its work and the memory it holds — its histories (every output sample
of every probe, coupler and energy), its fields and its matrices — without assembling anything: the degrees of
freedom from the element count and order, the automatic step from the profiles' wave speed sampled at a few
hundred points (:func:`approximate_step`). Work is in *work units*, seconds on the reference machine (2 cores,
loaded). An impact run's cars cost what their fidelities' one cost model says
(:meth:`femref.models.base.CarFidelity.cost`, the ladder's too), its coupler line :func:`coupler_line_cost`;
the rest are measured costs, rounded up:

    single-body fem step   5e-4 s + 5e-7 s per DOF
    harmonic fem           5e-3 s + 1.1e-5 s per DOF, per frequency
    exact transient        6e-5 s per output time and probe; a CSV record of n > 64 samples adds
                           n × 385 transform values × (log2 Nt + 1) windows × 5e-8 s

Everything a command will run is counted, before any of it runs: the scene's model runs, the fem reference's
**self-check** (:func:`self_check_levels`, both levels always) and, for ``femref run --tolerance``, every rung of the
model ladder (priced by :func:`impact_run_cost`, :func:`femref.choice.ladder.check_ladder_budget`).

A scene over the limits is refused by the rule of :mod:`femref.run.costs` (:func:`check_costs`: the limits,
``FEMREF_BUDGET``, the message naming the key that drives the largest part, one of ``fem.elements``, ``time.end``,
``time.dt``, ``frequency.num``, ``loads.<name>.csv.path``, ``cars``). A measured scene is priced by
:mod:`femref.run.event_budget`. The budget is checked once per command: ``femref run`` checks before its output
check and tells :func:`femref.run.run_scene` (or :func:`femref.choice.choose_model`) so; every other caller of
those (sweeps, studies, :func:`femref.api.run_case`) is checked by them.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import TYPE_CHECKING

import numpy as np

from femref.case.errors import CaseError
from femref.core.body import Body
from femref.core.signals import Tabulated
from femref.models import CAR_FIDELITIES
from femref.models.base import CarCost
from femref.models.fem import MATRIX_BYTES_PER_DOF, loaded_bending, mesh_nodes, rod_dofs, transit_time
from femref.run.costs import BUDGET_VARIABLE, MEMORY_BUDGET, WORK_BUDGET, Cost, budget_factor, bytes_text, check_costs
from femref.run.timestep import impact_candidates, single_body_candidates, smallest_candidate

if TYPE_CHECKING:
    from femref.scene import ImpactScene, ModelRun, Scene

#: Set to 1 to check the fem reference's discretisation on every run (:func:`self_check_levels`).
SELF_CHECK_VARIABLE = "FEMREF_SELF_CHECK"

_BYTES = 8.0
_DEFAULT_ELEMENTS = 64
_TYPICAL_END = 1.0  # s: an impact or a load history
_TYPICAL_FREQUENCIES = 200
_TYPICAL_ROWS = 1e4
_LAPLACE_VALUES = 385  # 2M + 1 with de Hoog's M at most 192
_TYPICAL_CARS = 10  # a consist; the coupler line's cost grows as the cube of its cars (coupler_line_cost)


def check_budget(scene: Scene | ImpactScene, source: str = "<case>") -> list[Cost]:
    """Refuse ``scene`` when its runs (:func:`predict`) exceed the budget (:func:`check_costs`); return the prediction
    otherwise."""
    try:
        costs = predict(scene)
    except CaseError as error:  # a record the prediction could not size
        raise CaseError(error.problems, source) from None
    return check_costs(costs, source, "the scene" if len(costs) == 1 else f"the scene's {len(costs)} runs")


def predict(scene: Scene | ImpactScene) -> list[Cost]:
    """The cost of every run ``femref run`` makes of ``scene``: its model runs (impact, transient or harmonic) and the
    fem reference's self-check runs (:func:`self_check_levels`); of a measured scene, its largest event
    (:func:`femref.run.event_budget.measured_costs`)."""
    kind = getattr(scene, "kind", None)
    if kind == "impact":
        return [impact_run_cost(scene, run) for run in scene.runs] + _self_check_costs(scene)
    if kind == "transient":
        return [_transient(scene, model) for model in scene.models] + _self_check_costs(scene)
    if kind == "harmonic":
        return [_harmonic(scene, model) for model in scene.models]
    if kind == "measured":
        from femref.run.event_budget import measured_costs  # it builds on this module's costs

        return measured_costs(scene)
    return []


def wave_speed(body: Body) -> float:
    """``max √(stiffness/m)`` over ~500 points and both sides of every jump (m/s rod, m²/s beam)."""
    l = body.half_length
    jumps = np.asarray(body.jumps, dtype=float)
    x = np.concatenate([np.linspace(-l, l, 513), jumps - 1e-9 * l, jumps + 1e-9 * l])
    x = np.clip(x, -l, l)
    return float(np.max(np.sqrt(body.stiffness(x) / body.mass_per_length(x))))


def _steps(end: float, dt: float) -> float:
    return math.ceil(end / dt - 1e-9)


def _time_factors(scene, dt: float, auto_dt_default: float) -> dict[str, tuple[float, object]]:
    factors: dict[str, tuple[float, object]] = {"time.end": (scene.end / _TYPICAL_END, scene.end)}
    if scene.dt is not None:
        factors["time.dt"] = (auto_dt_default / scene.dt, scene.dt)
    return factors


def approximate_step(scene, run, elements: int | None = None) -> float:
    """The automatic step of an impact run (:func:`femref.run.timestep.impact_time_step`'s rule) without a mesh:
    the wave speeds sampled (:func:`wave_speed`); the case's ``time.dt`` when it gives one and ``elements`` is None."""
    if scene.dt is not None and elements is None:
        return scene.dt
    return smallest_candidate(impact_candidates(scene, run, elements or scene.fem.elements, wave_speed))[0]


def _car_costs(scene: ImpactScene, run: ModelRun) -> list[CarCost]:
    return [CAR_FIDELITIES[fidelity].cost(car, scene) for car, fidelity in zip(scene.cars, run.fidelity)]


def _cars_us(costs: list[CarCost], steps: float) -> float:
    return sum(c.setup for c in costs) + steps * sum(c.step for c in costs)


def run_cost_us(scene: ImpactScene, run: ModelRun, steps: int) -> float:
    """``Σ_cars (setup + steps · step)``: the µs of the run's cars at their fidelities (one cost model,
    :meth:`femref.models.base.CarFidelity.cost`; the model choice orders its ladder by it)."""
    return _cars_us(_car_costs(scene, run), steps)


def impact_run_cost(scene: ImpactScene, run: ModelRun, dt: float | None = None) -> Cost:
    """One impact run of ``scene`` at ``dt`` (None: the step the runner would take, :func:`approximate_step`): its cars'
    cost (:func:`run_cost_us`, in seconds) and their matrices, its coupler line's (:func:`coupler_line_cost`) and
    its histories (module docstring)."""
    dt = approximate_step(scene, run) if dt is None else dt
    steps = _steps(scene.end, dt)
    outputs = steps / scene.output_stride + 1
    cars = _car_costs(scene, run)
    line_step, line_setup, line_memory = coupler_line_cost(scene)
    work = 1e-6 * _cars_us(cars, steps) + steps * line_step + line_setup
    matrices = sum(c.memory for c in cars) + line_memory
    dofs_total = sum(c.dofs for c in cars)
    channels = len(scene.channels)
    histories = outputs * (3 * channels + 2 * len(scene.couplers) + 6) * _BYTES
    factors = _time_factors(scene, dt, approximate_step(scene, run, _DEFAULT_ELEMENTS) if scene.dt is not None else dt)
    if any(c.meshed for c in cars):
        factors["fem.elements"] = (scene.fem.elements / _DEFAULT_ELEMENTS, scene.fem.elements)
    factors["cars"] = ((len(scene.cars) / _TYPICAL_CARS) ** 3, f"{len(scene.cars)} cars")
    size = f"{steps:.3g} steps × {dofs_total:.3g} DOFs = {steps * max(dofs_total, 1):.3g} DOF-steps" if dofs_total else f"{steps:.3g} steps"
    if line_memory > histories + matrices - line_memory:
        n_c = len(scene.couplers)
        size += f" on {len(scene.cars)} cars, each holding two dense {n_c} × {n_c} coupler gains ({bytes_text(line_memory)} of line matrices)"
    return Cost(run.name, work, histories + matrices, size, factors)


def coupler_line_cost(scene: ImpactScene) -> tuple[float, float, float]:
    """``(work per step, set-up work, bytes)`` of the coupler line of ``N`` cars, ``n_c`` couplers and ``m = n_c + s``
    Newton unknowns (``s`` the couplers whose law carries a state), every matrix counted at its true, dense size::

        bytes    = 8 [N (2 n_c² + 12 n_c) + 2 n_c² + 2 m²]
        per step = 6e-10 s × m³,   set-up = 1e-8 s × N n_c²

    Each car keeps its share ``Cc G Bc`` of the gains ``∂δ/∂P`` and ``∂δ̇/∂P`` as two dense ``n_c × n_c`` matrices,
    the line their sum; each car's coupler maps are held three times (line plan, prepared car, packed pool); the
    Newton Jacobian (m × m) twice, solved by dense LU (about three iterations a step). Measured on rigid consists of
    100, 200 and 400 cars (docs/design.md §3.5, "Consists"; tests/run/test_budget.py)."""
    cars, n_c = len(scene.cars), len(scene.couplers)
    m = n_c + sum(int(c.coupling.law.state_size) for c in scene.couplers)
    memory = _BYTES * (cars * (2.0 * n_c**2 + 12.0 * n_c) + 2.0 * n_c**2 + 2.0 * m**2)
    return 6e-10 * float(m) ** 3, 1e-8 * cars * float(n_c) ** 2, memory


def _single_step(scene, elements: int | None = None) -> float:
    """The transient scene's step (:func:`femref.run.timestep.single_body_time_step`'s rule) without a mesh; the
    case's ``time.dt`` when it gives one and ``elements`` is None."""
    if scene.dt is not None and elements is None:
        return scene.dt
    return smallest_candidate(single_body_candidates(scene, elements or scene.fem.elements, wave_speed))[0]


def _single_dofs(scene) -> int:
    if scene.body.kind == "rod":
        return rod_dofs(scene.body, scene.fem.elements, scene.fem.order)
    return 2 * mesh_nodes(scene.body, scene.fem.elements)


def _transient(scene, model: str) -> Cost:
    dt = _single_step(scene)
    steps = _steps(scene.end, dt)
    outputs = steps / scene.output_stride + 1
    probes = len(scene.probes)
    histories = outputs * (3 * probes + 5) * _BYTES
    factors = _time_factors(scene, dt, _single_step(scene, _DEFAULT_ELEMENTS))
    records = {name: int(s.times.size) for name, s in scene.loads.items() if isinstance(s, Tabulated)}  # CSV loads' samples
    memory = histories + sum(2 * _BYTES * n for n in records.values())
    size = f"{steps:.3g} steps"
    if model == "fem":
        dofs = _single_dofs(scene)
        work = steps * (5e-4 + 5e-7 * dofs) + 1e-4 * scene.fem.elements
        memory += MATRIX_BYTES_PER_DOF * dofs + steps * 4 * _BYTES
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
        return Cost(model, num * (5e-3 + 1.1e-5 * dofs), memory + 3 * MATRIX_BYTES_PER_DOF * dofs,
                    f"{num:.3g} frequencies × {dofs:.3g} DOFs", factors)
    return Cost(model, 1e-5 * num, memory, f"{num:.3g} frequencies", factors)


#: A step above this fraction of the shortest wave travel time, or of the coupler contact time (impact) or the
#: loads' shortest time scale (transient), under-resolves the fem reference; so does an element longer than this
#: fraction of the pulse's wavelength.
STEP_PER_WAVE_TIME, STEP_PER_CONTACT_TIME, ELEMENT_PER_WAVELENGTH = 0.1, 0.05, 0.05
STEP_PER_LOAD_TIME = STEP_PER_CONTACT_TIME


def resolution_warnings(scene) -> list[str]:
    """Why the case's own ``time.dt`` or ``fem.elements`` under-resolves the fem reference (empty when they resolve
    it, or when the runner chooses the step); each text starts with the key. Impact: a step above a tenth of the
    shortest wave travel time ``l√(m/EA)`` of the cars or a twentieth of the coupler contact time, or on cars that
    bend above the shortest bending mesh transit time ``h²/c_b,max`` (docs/formulas.md §X8), or fewer elements than
    twenty per wavelength of the contact pulse, ``2l/h < 40 T_wave/T_contact``. Transient:
    :func:`transient_resolution_warnings`."""
    kind = getattr(scene, "kind", None)
    if kind == "transient":
        return transient_resolution_warnings(scene)
    if kind != "impact":
        return []
    contact = scene.contact_time()
    wave = [car.body.wave_travel_time for car in scene.cars]
    bending = [transit_time(beam, scene.fem.elements, wave_speed(beam)) for beam in map(loaded_bending, scene.cars) if beam is not None]
    warnings = []
    if scene.dt is not None:
        if scene.dt > STEP_PER_WAVE_TIME * min(wave):
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a tenth of the shortest wave travel time of the cars "
                            f"({min(wave):.3g} s): the fem reference under-resolves its waves")
        elif math.isfinite(contact) and scene.dt > STEP_PER_CONTACT_TIME * contact:
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a twentieth of the coupler contact time ({contact:.3g} s): "
                            "the fem reference under-resolves the pulse")
        elif bending and scene.dt > min(bending):
            warnings.append(f"time.dt = {scene.dt:.3g} s is above the bending mesh transit time h²√(m/EI) of the cars that bend "
                            f"({min(bending):.3g} s on {scene.fem.elements} elements): the fem reference under-resolves the bending "
                            "the couplers excite")
    needed = 2.0 * max(wave) / (ELEMENT_PER_WAVELENGTH * contact) if math.isfinite(contact) else 0.0
    if scene.fem.elements < needed:
        warnings.append(f"fem.elements = {scene.fem.elements} is below the {math.ceil(needed)} elements that resolve the contact pulse "
                        "(twenty per wavelength)")
    return warnings


def _shortest_load(scene: Scene) -> tuple[str, float]:
    """The load with the shortest time scale (``loads.<name>``) and that scale ``T_load`` (s; ∞ for steps)."""
    scales = {name: float(s.time_scale) for name, s in scene.loads.items() if hasattr(s, "time_scale")}
    if not scales:
        return "", math.inf
    name = min(scales, key=scales.get)
    return name, scales[name]


def load_wavelength(body: Body, load_time: float) -> float:
    """``λ = 2π/k(ω)`` at ``ω = 2π/T_load``: ``λ = c T_load = l T_load/T_wave`` on a rod, and by the bending
    dispersion ``k⁴ = ω² m/EI`` with ``√(m/EI) = T_wave/l²``, ``λ = l √(2π T_load/T_wave)`` on a beam (m)."""
    wave, l = body.wave_travel_time, body.half_length
    if body.kind == "rod":
        return l * load_time / wave
    return l * math.sqrt(2.0 * math.pi * load_time / wave)


def transient_resolution_warnings(scene: Scene) -> list[str]:
    """Why the case's own ``time.dt`` or ``fem.elements`` under-resolves the fem run of a transient scene: a step
    above a tenth of the body's wave travel time ``T_wave`` (``l√(m/EA)``, ``l²√(m/EI)`` for a beam) or a twentieth
    of the loads' shortest time scale ``T_load`` (a half-sine's duration, a ramp's rise time, ten samples of a
    CSV record), or fewer than twenty elements per wavelength of that load, ``2l/h < 40 l/λ``
    (:func:`load_wavelength`: ``40 T_wave/T_load`` on a rod, ``40 √(T_wave/(2π T_load))`` on a beam). Empty when
    they resolve it, or when the runner chooses the step and the mesh suffices. Each text starts with the key."""
    wave = scene.body.wave_travel_time
    name, load = _shortest_load(scene)
    warnings = []
    if scene.dt is not None:
        if scene.dt > STEP_PER_WAVE_TIME * wave:
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a tenth of the body's wave travel time ({wave:.3g} s): "
                            "the fem run under-resolves its waves")
        elif math.isfinite(load) and scene.dt > STEP_PER_LOAD_TIME * load:
            warnings.append(f"time.dt = {scene.dt:.3g} s is above a twentieth of the time scale of loads.{name} ({load:.3g} s): "
                            "the fem run under-resolves the load")
    if math.isfinite(load):
        needed = 2.0 * scene.body.half_length / (ELEMENT_PER_WAVELENGTH * load_wavelength(scene.body, load))
        if scene.fem.elements < needed:
            warnings.append(f"fem.elements = {scene.fem.elements} is below the {math.ceil(needed)} elements that resolve "
                            f"loads.{name} ({load:.3g} s; twenty per wavelength)")
    return warnings


#: Most levels the self-check refines to: the fem run again at dt/2, then at dt/4.
SELF_CHECK_LEVELS = 2


def self_check_asked() -> bool:
    """``FEMREF_SELF_CHECK`` is 1 (or true, yes): check the reference on every run."""
    return os.environ.get(SELF_CHECK_VARIABLE, "").strip().lower() in ("1", "true", "yes")


def self_check_levels(scene: Scene | ImpactScene, warnings: list[str] | None = None) -> list[tuple[int, int]]:
    """The finer fem runs the reference's self-check may make, as ``(d, e)``: step ``dt/d``, ``e ×`` the elements —
    ``d = 2^k`` for ``k = 1 … SELF_CHECK_LEVELS`` and ``e = d`` when a warning names ``fem.elements`` (the mesh is the
    coarse part), else 1. Empty without a fem reference, or when neither ``warnings`` (default
    :func:`resolution_warnings`) nor ``FEMREF_SELF_CHECK`` asks. The budget counts both levels."""
    kind = getattr(scene, "kind", None)
    if kind == "impact":
        has_fem = any(run.name == "fem" for run in scene.runs)
    elif kind == "transient":
        has_fem = "fem" in scene.models
    else:
        return []
    warnings = resolution_warnings(scene) if warnings is None else warnings
    if not has_fem or not (warnings or self_check_asked()):
        return []
    mesh = any(w.startswith("fem.elements") for w in warnings)
    return [(2**k, 2**k if mesh else 1) for k in range(1, SELF_CHECK_LEVELS + 1)]


def _self_check_costs(scene: Scene | ImpactScene) -> list[Cost]:
    """The self-check's finer fem runs (:func:`self_check_levels`), each predicted like the fem run at its step and
    mesh (without fields); their factors are the fem run's own."""
    warnings = resolution_warnings(scene)
    levels = self_check_levels(scene, warnings)
    if not levels:
        return []
    why = "the fem reference checks itself: " + ("; ".join(warnings) if warnings else f"asked by {SELF_CHECK_VARIABLE}")
    costs = []
    if scene.kind == "impact":
        run = next(r for r in scene.runs if r.name == "fem")
        base, dt = impact_run_cost(scene, run), approximate_step(scene, run)
    else:
        base, dt = _transient(scene, "fem"), _single_step(scene)
    for divisor, factor in levels:
        finer = dataclasses.replace(scene, dt=dt / divisor, fem=dataclasses.replace(scene.fem, elements=scene.fem.elements * factor, fields=False))
        cost = impact_run_cost(finer, run, dt / divisor) if scene.kind == "impact" else _transient(finer, "fem")
        label = f"dt/{divisor}" + (f" and {factor}× fem.elements" if factor > 1 else "")
        costs.append(dataclasses.replace(cost, model=f"fem self-check {label}", factors=base.factors,
                                         what=f"the fem self-check run at {label}", why=why))
    return costs


__all__ = ["BUDGET_VARIABLE", "MEMORY_BUDGET", "SELF_CHECK_LEVELS", "SELF_CHECK_VARIABLE", "WORK_BUDGET", "Cost", "approximate_step", "budget_factor",
           "check_budget", "check_costs", "impact_run_cost", "load_wavelength", "predict", "run_cost_us", "resolution_warnings", "self_check_asked", "self_check_levels",
           "transient_resolution_warnings", "wave_speed"]
