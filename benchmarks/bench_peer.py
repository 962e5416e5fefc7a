"""femref against OpenSeesPy on one linear two-car impact: cost of 1 % and 0.1 % peak coupler force.

    python benchmarks/bench_peer.py [--quick] [--repeat 3] [--json PATH]
    python benchmarks/bench_peer.py --parts [--elements 1] [--runs 100]

**Scene** (linear, so both tools solve the same problem). Two identical homogeneous
freight cars as axial rods: length 17 m, mass 119 t (7000 kg/m), EA = 3 GN, Voigt
viscosity cA = 2 MN·s (the default scene's stiffness and viscosity, a uniform 119 t car:
c = √(EA/m) ≈ 655 m/s, first free-free axial mode ≈ 19 Hz). The hammer rolls at 2.2 m/s
into the anvil at rest; they are joined by a linear Kelvin–Voigt coupler,
P = k δ + μ δ̇ with k = 40 MN/m and μ = 0.3 MN·s/m, bilateral with zero slack (it carries
tension too, so there is no contact switching and the problem is linear). End time 0.3 s:
the compression peak (≈ 2.90 MN) is at ≈ 0.053 s, followed by the tension swing; the
script checks that the largest force is not at the end of the run.

**femref**: the case as a dict (``kind: impact``, model ``fem`` only, P2 rod elements,
``integrator: newmark`` = average acceleration, ``time.dt`` given) through
``parse_case`` -> ``scene_from_case`` -> ``run_model``; consistent mass, Voigt damping
assembled from cA, coupler forces solved each step; time = ``ModelResult.wall_time_s``
(building the cars + stepping + the result), every run cold: femref's builds kept per
geometry are dropped first (:func:`femref.models.base.forget_built`), since OpenSees
builds its model every run.

**OpenSeesPy**: ``ndm = ndf = 1``; each car a chain of ``n`` 1-D ``Truss`` elements
(``Elastic`` material E = EA, A = 1) with lumped nodal masses (m h, m h/2 at the ends);
Rayleigh damping β K with β = cA/EA (a homogeneous Voigt rod's viscosity), switched on for
the trusses only (``-doRayleigh 1``); the coupler a ``zeroLength`` element between the
hammer's front node and the anvil's rear node with a ``Parallel`` of ``Elastic`` (k) and
``Viscous`` (μ, exponent 1) materials, no Rayleigh damping. Every hammer node starts at
2.2 m/s (``setNodeVel``). OpenSees' ``Newmark`` starts from the committed acceleration
(zero unless set), not from equilibrium, which costs a first-order error in dt; the
script sets the consistent initial acceleration a0 = M⁻¹(−C v0 − K u0): only the two
coupler nodes accelerate, ∓μ v0 / (m h/2) (βK v0 = 0 on a uniformly moving car).
``Newmark 0.5 0.25``, ``Linear -factorOnce`` (the problem is linear with a fixed step:
factorise once, as femref does), ``RCM`` numbering, ``BandSPD`` system; the coupler's
basic force is recorded every step by an element recorder (17 digits) and read back.
Time = model build + analysis + reading the record. Needs Debian's ``libblas3`` and
``liblapack3`` (``apt-get install -y libblas3 liblapack3``) and
``.venv/bin/python -m pip install openseespy`` (or ``pip install -e '.[peer]'``).

**Resolutions**: one ladder for both tools, elements per car n = 1, 2, 3, 4, 6, 8, 11,
16, … (steps of √2, rounded; 256 at the top, 64 with ``--quick``) with the step tied to
the element's wave transit time, dt = h/c, h = 17 m / n (femref's own automatic mesh
rule). A separate dt sweep on a fixed mesh is not used: with dt ≫ h/c the average
acceleration rule, A-stable but not L-stable, keeps the mesh's stiff, overdamped Voigt
modes (kicked by the dashpot's force jump at contact) ringing with alternating sign, and
the peak gets worse as the mesh is refined. On this ladder femref's error is dominated
by the step (P2 space error ~ h⁴, time ~ dt²), OpenSees' by both (lumped P1 ~ h², ~ dt²):
both converge at order 2. The same A-stable ringing stays in femref's force as a small
sawtooth: P2 with a consistent mass has higher top frequencies than lumped P1, so its
stiffest Voigt modes, which the rule damps only by a factor ≈ 1 − 4/(βω²dt) a step, still
ring at the peak (±10 N at 64 elements, ±2.4 N at 256, ±0.6 N at 1024; OpenSees's below
1e-5 N from 64 elements on). The tables show it ("ringing"). Beyond 256 elements the
level-to-level change of femref's peak falls to a few times its ringing and its observed
order wanders (2.5, 3.5, 1.0 at 512, 724, 1024 elements), so the ladder stops at 256,
where the two references already agree to ~1e-7, far below the targets.

**Peak force** of a run: the vertex of the parabola through the largest sample of the
coupler force and its two neighbours. (The largest sample alone carries an O(dt²) error
whose constant depends on where the grid falls on the peak, which spoils the observed
order; the vertex's own error is of higher order.) The ringing of a run is the amplitude
of the alternating (−1)^j component of the force at the peak, read from the sixth
difference of the second differences over the seven samples around it,
|Σ (−1)^j C(6, j) Δ²F_{k−3+j}| / 256 (exact for a sawtooth on a polynomial of degree < 8;
on coarse levels, a few steps per pulse, it also picks up the pulse itself).

**Reference** (Richardson): for each tool, from the peaks F1, F2, F3 of the three finest
levels (n/4, n/2, n; h and dt halved each time), the observed order and the extrapolation

    p = log2((F1 − F2) / (F2 − F3)),    F∞ = F3 + (F3 − F2) / (2^p − 1).

Ringing shifts a peak by up to about its amplitude, so the script warns when |F2 − F3|
is less than five times the ringing of those two levels (the observed order then reads
noise). The two tools' F∞ must agree (relative difference
≤ ``--agree``, 1e-4); the reference is their mean, and the error of a run is
|F − F_ref| / F_ref.

**Cost of a target**: the coarsest level from which on every finer level of the ladder
has an error below the target (coarse levels can hit the reference by cancelling errors;
that is luck, not accuracy). Its wall time is the median of ``--repeat`` runs (after one
warm-up run of each tool, which also takes any just-in-time compilation; the repeats go
round-robin over both tools' selected levels); other times in the convergence tables are
single runs. Times are wall-clock on this machine: only their ratios within one run mean
something, and only on an otherwise idle machine.
Exit 2 when openseespy cannot be imported; exit 1 when the two references disagree.

**Parts** (``--parts``, femref alone, no OpenSees needed): ``--runs`` cold runs at ``--elements`` per car
(default 1, the 1 % rung) — each run's wall time split by what femref records, building the cars plus the line
plan and packing (``setup_time_s``), stepping plus the response (``stepping_time_s``) and the rest (the result),
medians — then the same runs again under cProfile, the functions with the most own time.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from femref.case import parse_case
from femref.models.base import forget_built
from femref.run.runner import run_model
from femref.scene.build import scene_from_case

# --- the scene -------------------------------------------------------------------------
LENGTH = 17.0  # m, each car
MASS_PER_LENGTH = 119.0e3 / LENGTH  # kg/m: a 119 t car
AXIAL_STIFFNESS = 3.0e9  # N, EA
AXIAL_VISCOSITY = 2.0e6  # N·s, cA (Voigt)
VELOCITY = 2.2  # m/s, the hammer; the anvil is at rest
COUPLER_STIFFNESS = 4.0e7  # N/m, k
COUPLER_DAMPING = 3.0e5  # N·s/m, μ
END_TIME = 0.3  # s
WAVE_SPEED = math.sqrt(AXIAL_STIFFNESS / MASS_PER_LENGTH)  # m/s

TARGETS = (1e-2, 1e-3)
FULL_TOP, QUICK_TOP = 256, 64
RINGING_MARGIN = 5.0  # |F2 − F3| / ringing of those two levels below which the observed order reads noise


@dataclass
class Level:
    """One resolution of one tool: elements per car, step (s), steps, peak force (N) and its time (s),
    wall time (s: the median of ``wall_runs_s``), ringing at the peak (N), error against the reference."""

    elements: int
    dt: float
    steps: int
    peak: float
    peak_time: float
    wall_s: float
    ringing: float = math.nan
    wall_runs_s: list[float] = field(default_factory=list)
    error: float = math.nan


@dataclass
class Extrapolation:
    """Richardson extrapolation of one tool's peak force on its three finest levels."""

    elements: tuple[int, int, int]
    peaks: tuple[float, float, float]
    order: float
    value: float
    ringing: float = math.nan  # N, the larger of the two finest levels'


# --- resolutions and peaks -------------------------------------------------------------
def ladder(top: int) -> list[int]:
    """Elements per car 1, 2, 3, 4, 6, 8, 11, 16, … up to ``top`` (a power of 2): steps of √2, rounded."""
    levels = 2 * int(round(math.log2(top)))
    return sorted({int(round(2.0 ** (k / 2.0))) for k in range(levels + 1)})


def time_step(elements: int) -> float:
    """The element's wave transit time ``h/c`` (s), ``h = LENGTH/elements``."""
    return LENGTH / elements / WAVE_SPEED


def peak_of(t: NDArray[np.float64], force: NDArray[np.float64]) -> tuple[float, float]:
    """Peak (N) and its time (s): the vertex of the parabola through the largest sample and its neighbours
    (the sample itself at either end of the history); raises if the peak is the last sample."""
    k = int(np.argmax(force))
    if k == len(force) - 1:
        raise RuntimeError(f"the coupler force is largest at the end of the run (t = {t[k]:.3f} s): lengthen END_TIME")
    if k == 0:
        return float(force[0]), float(t[0])
    y0, y1, y2 = force[k - 1 : k + 2]
    curvature = y0 - 2.0 * y1 + y2
    if curvature >= 0.0:
        return float(y1), float(t[k])
    shift = -(y2 - y0) / (2.0 * curvature)  # in steps, within [-1/2, 1/2]
    return float(y1 - (y2 - y0) ** 2 / (8.0 * curvature)), float(t[k] + shift * (t[k + 1] - t[k]))


def ringing_of(force: NDArray[np.float64]) -> float:
    """Amplitude (N) of the alternating component ``a (−1)^j`` of ``force`` at its largest sample:
    ``|Σ (−1)^j C(6, j) Δ²F_{k−3+j}| / 256`` (NaN when the peak is within four samples of either end)."""
    k = int(np.argmax(force))
    if k < 4 or k > len(force) - 5:
        return math.nan
    second = np.diff(force[k - 4 : k + 5], 2)  # Δ²F at k−3 … k+3
    weights = np.array([1.0, -6.0, 15.0, -20.0, 15.0, -6.0, 1.0])
    return float(abs(weights @ second) / 256.0)


def richardson(elements: list[int], peaks: list[float]) -> Extrapolation:
    """``p = log2((F1 − F2)/(F2 − F3))``, ``F∞ = F3 + (F3 − F2)/(2^p − 1)`` on the last three levels
    (each halving h and dt); raises when the three peaks do not converge monotonically."""
    f1, f2, f3 = peaks[-3:]
    ratio = (f1 - f2) / (f2 - f3) if f2 != f3 else math.inf
    if not 1.0 < ratio < math.inf:
        raise RuntimeError(f"no monotone convergence on the finest levels {elements[-3:]}: peaks {f1:.3f}, {f2:.3f}, {f3:.3f} N")
    order = math.log2(ratio)
    return Extrapolation(tuple(elements[-3:]), (f1, f2, f3), order, f3 + (f3 - f2) / (2.0**order - 1.0))


# --- femref ----------------------------------------------------------------------------
def femref_case(elements: int, dt: float) -> dict[str, Any]:
    """The impact case as a dict: two uniform P2 rod cars, the Kelvin–Voigt coupler, fem with average acceleration."""
    body = {
        "type": "rod",
        "length": LENGTH,
        "mass_per_length": MASS_PER_LENGTH,
        "axial_stiffness": AXIAL_STIFFNESS,
        "axial_viscosity": AXIAL_VISCOSITY,
    }
    return {
        "kind": "impact",
        "cars": [
            {"name": "hammer", "body": body, "velocity": VELOCITY},
            {"name": "anvil", "body": body, "velocity": 0.0},
        ],
        "couplers": [
            {
                "name": "c1",
                "between": ["hammer", "anvil"],
                "law": {"kelvin_voigt": {"stiffness": COUPLER_STIFFNESS, "damping": COUPLER_DAMPING}},
                "contact": "bilateral",
                "slack": 0.0,
            }
        ],
        "time": {"end": END_TIME, "dt": dt},
        "integrator": {"scheme": "newmark"},
        "models": ["fem"],
        "fem": {"elements": elements, "order": 2},
    }


def run_femref(elements: int, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64], int, float]:
    """One femref run: time axis, coupler force (N, compression positive), steps, wall time (s). Cold:
    the cars are built afresh (femref keeps builds per geometry; OpenSees builds its model every run)."""
    forget_built()
    scene = scene_from_case(parse_case(femref_case(elements, dt), source="<bench_peer>"))
    result = run_model(scene, scene.runs[0])
    if not result.ok:
        raise RuntimeError(f"femref failed at {elements} elements, dt = {dt:.3e} s: {result.message}")
    return result.axes["time"], result.couplers["c1"]["force"], int(result.settings["steps"]), float(result.wall_time_s)


# --- OpenSeesPy ------------------------------------------------------------------------
def run_opensees(elements: int, dt: float) -> tuple[NDArray[np.float64], NDArray[np.float64], int, float]:
    """One OpenSeesPy run: time axis, coupler force (N, compression positive), steps, wall time (s):
    model build, analysis and reading the recorded force."""
    import openseespy.opensees as ops

    steps = math.ceil(END_TIME / dt - 1e-9)
    with tempfile.TemporaryDirectory() as folder:
        record = os.path.join(folder, "coupler.out")
        started = time.perf_counter()
        ops.wipe()
        ops.model("basic", "-ndm", 1, "-ndf", 1)
        ops.uniaxialMaterial("Elastic", 1, AXIAL_STIFFNESS)  # the rod, A = 1
        ops.uniaxialMaterial("Elastic", 2, COUPLER_STIFFNESS)
        ops.uniaxialMaterial("Viscous", 3, COUPLER_DAMPING, 1.0)
        ops.uniaxialMaterial("Parallel", 4, 2, 3)  # P = k δ + μ δ̇
        h = LENGTH / elements
        element = 0
        for car in range(2):  # nodes 1 … n+1 the hammer (rear to front), n+2 … 2n+2 the anvil
            first = car * (elements + 1) + 1
            for i in range(elements + 1):
                ops.node(first + i, car * LENGTH + i * h)
                ops.mass(first + i, MASS_PER_LENGTH * h * (0.5 if i in (0, elements) else 1.0))
            for i in range(elements):
                element += 1
                ops.element("Truss", element, first + i, first + i + 1, 1.0, 1, "-doRayleigh", 1)
        front, rear = elements + 1, elements + 2  # the hammer's front node, the anvil's rear node
        coupler = element + 1
        ops.element("zeroLength", coupler, front, rear, "-mat", 4, "-dir", 1, "-doRayleigh", 0)
        ops.rayleigh(0.0, AXIAL_VISCOSITY / AXIAL_STIFFNESS, 0.0, 0.0)
        for node in range(1, elements + 2):
            ops.setNodeVel(node, 1, VELOCITY, "-commit")
        end_mass = MASS_PER_LENGTH * h / 2.0
        kick = COUPLER_DAMPING * VELOCITY  # the dashpot's force at contact
        ops.setNodeAccel(front, 1, -kick / end_mass, "-commit")
        ops.setNodeAccel(rear, 1, kick / end_mass, "-commit")
        ops.constraints("Plain")
        ops.numberer("RCM")
        ops.system("BandSPD")
        ops.algorithm("Linear", "-factorOnce")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")
        ops.recorder("Element", "-file", record, "-precision", 17, "-ele", coupler, "basicForce")
        status = ops.analyze(steps, dt)
        ops.wipe()  # closes the recorder
        basic = np.loadtxt(record, ndmin=1)
        wall = time.perf_counter() - started
    if status != 0 or len(basic) != steps:
        raise RuntimeError(f"OpenSees failed at {elements} elements, dt = {dt:.3e} s (analyze returned {status}, {len(basic)} of {steps} steps)")
    # the basic force is tension positive (deformation = u_anvil − u_hammer); t = 0 carries the dashpot's kick
    force = np.concatenate(([kick], -basic))
    return dt * np.arange(steps + 1), force, steps, wall


def opensees_available() -> bool:
    try:
        import openseespy.opensees  # noqa: F401
    except Exception:  # ImportError, or a missing libblas3 / liblapack3 (OSError inside the import)
        return False
    return True


# --- the ladders -----------------------------------------------------------------------
Runner = Callable[[int, float], tuple[NDArray[np.float64], NDArray[np.float64], int, float]]
TOOLS: dict[str, Runner] = {"femref": run_femref, "opensees": run_opensees}


def level(runner: Runner, elements: int) -> Level:
    """One run of ``runner`` at ``elements`` per car and ``dt = h/c``, with its peak."""
    dt = time_step(elements)
    t, force, steps, wall = runner(elements, dt)
    peak, peak_time = peak_of(t, force)
    return Level(elements, dt, steps, peak, peak_time, wall, ringing_of(force), [wall])


def climb(runner: Runner, counts: list[int], say: Callable[[str], None]) -> list[Level]:
    """Every level of the ladder, coarse to fine (one warm-up run first, not kept)."""
    runner(counts[0], time_step(counts[0]))
    levels = []
    for n in counts:
        levels.append(level(runner, n))
        say(f"  {n:5d} el.  {levels[-1].steps:6d} steps  {levels[-1].wall_s:8.3f} s")
    return levels


def extrapolate(levels: list[Level]) -> Extrapolation:
    """Richardson on the three finest levels that each halve h (and dt)."""
    top = levels[-1].elements
    chosen = [next(lv for lv in levels if lv.elements == top // d) for d in (4, 2, 1)]
    result = richardson([lv.elements for lv in chosen], [lv.peak for lv in chosen])
    result.ringing = max(lv.ringing for lv in chosen[1:])
    return result


def cheapest(levels: list[Level], target: float) -> Level | None:
    """The coarsest level from which on every level's error is below ``target`` (None if not even the finest)."""
    found = None
    for lv in reversed(levels):
        if not lv.error < target:
            break
        found = lv
    return found


def retime(selected: list[tuple[Runner, Level]], repeat: int) -> None:
    """Time each selected level up to ``repeat`` times, round-robin over the levels of both tools (so a
    change in the machine's load hits both alike); each level's time becomes the median of its runs."""
    for _ in range(repeat - 1):
        for runner, lv in selected:
            if len(lv.wall_runs_s) < repeat:
                lv.wall_runs_s.append(runner(lv.elements, lv.dt)[3])
    for _, lv in selected:
        lv.wall_s = statistics.median(lv.wall_runs_s)


def local_order(levels: list[Level], lv: Level) -> float:
    """Observed order at ``lv`` from its peak and those at n/2 and n/4 (NaN if not on the ladder)."""
    by_n = {x.elements: x for x in levels}
    n = lv.elements
    if n % 4 or n // 2 not in by_n or n // 4 not in by_n:
        return math.nan
    f1, f2, f3 = by_n[n // 4].peak, by_n[n // 2].peak, lv.peak
    ratio = (f1 - f2) / (f2 - f3) if f2 != f3 else math.nan
    return math.log2(ratio) if ratio > 0 else math.nan


# --- output ----------------------------------------------------------------------------
def convergence_table(tool: str, levels: list[Level]) -> str:
    """Every level of one tool's ladder: resolution, peak, ringing, error, observed order, wall time."""
    lines = [
        f"{tool}: convergence (dt = h/c; error against the common reference; order from n/4, n/2, n)",
        f"{'el./car':>8} {'dt s':>10} {'steps':>6} {'peak force N':>16} {'t peak s':>9} {'ringing N':>10} {'error':>9} {'order':>6} {'wall s':>9}",
    ]
    for lv in levels:
        order = local_order(levels, lv)
        lines.append(
            f"{lv.elements:8d} {lv.dt:10.3e} {lv.steps:6d} {lv.peak:16.3f} {lv.peak_time:9.5f} {lv.ringing:10.3g} {lv.error:9.2e} "
            f"{'' if math.isnan(order) else f'{order:6.2f}':>6} {lv.wall_s:9.4f}"
        )
    return "\n".join(lines)


def cost_table(choices: dict[str, dict[float, Level | None]], levels: dict[str, list[Level]], repeat: int) -> str:
    """Per target, each tool's cheapest level and its median wall time, and the femref / OpenSees ratio."""
    lines = [
        f"cheapest resolution per target (error below it from there on; wall time: median of {repeat} runs)",
        f"{'target':>7} {'tool':>9} {'el./car':>8} {'dt s':>10} {'steps':>6} {'error':>9} {'wall s':>9} {'femref / OpenSees':>18}",
    ]
    for target in TARGETS:
        f, o = choices["femref"][target], choices["opensees"][target]
        ratio = f"{f.wall_s / o.wall_s:18.2f}" if f and o else f"{'n/a':>18}"
        for tool, lv in (("femref", f), ("opensees", o)):
            head = f"{target:7.1%} {tool:>9}"
            if lv is None:
                lines.append(f"{head} {'not reached on this ladder':>45}")
            else:
                line = f"{head} {lv.elements:8d} {lv.dt:10.3e} {lv.steps:6d} {lv.error:9.2e} {lv.wall_s:9.4f}" + (ratio if tool == "femref" else f"{'':18}")
                lines.append((line + ("  (the ladder's coarsest level)" if lv is levels[tool][0] else "")).rstrip())
    return "\n".join(lines)


def _finite(value: Any) -> Any:
    """``value`` with NaN replaced by None (strict JSON), through dicts, lists and tuples."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def parts(elements: int, runs: int, top: int = 20) -> None:
    """Print the medians of ``runs`` cold femref runs at ``elements`` per car, part by part (module docstring), and
    cProfile's ``top`` functions by own time over as many more."""
    import cProfile  # noqa: PLC0415 (only here)
    import pstats  # noqa: PLC0415

    dt = time_step(elements)
    cases = [femref_case(elements, dt) for _ in range(2 * runs + 5)]

    def cold(case: dict[str, Any]) -> dict[str, float]:
        forget_built()
        scene = scene_from_case(parse_case(case, source="<bench_peer>"))
        result = run_model(scene, scene.runs[0])
        setup, stepping = float(result.settings["setup_time_s"]), float(result.settings["stepping_time_s"])
        return {"wall": result.wall_time_s, "cars + line plan + packing": setup, "stepping + response": stepping,
                "result": result.wall_time_s - setup - stepping}

    for case in cases[:5]:
        cold(case)
    split = [cold(case) for case in cases[5 : 5 + runs]]
    print(f"femref, {elements} element(s) per car, dt = h/c ({math.ceil(END_TIME / dt - 1e-9)} steps), {runs} cold runs, medians:")
    for part in split[0]:
        print(f"  {part:28} {statistics.median(run[part] for run in split) * 1e3:8.3f} ms")
    profile = cProfile.Profile()
    profile.enable()
    for case in cases[5 + runs :]:
        cold(case)
    profile.disable()
    print(f"cProfile over {runs} more cold runs (case parsing and the scene included), by own time:")
    pstats.Stats(profile, stream=sys.stdout).sort_stats("tottime").print_stats(top)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", action="store_true", help="femref's cold run part by part and profiled (no OpenSees)")
    parser.add_argument("--elements", type=int, default=1, help="with --parts: elements per car (default 1, the 1 %% rung)")
    parser.add_argument("--runs", type=int, default=100, help="with --parts: cold runs (default 100)")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs of each selected resolution (median; default 3)")
    parser.add_argument("--json", metavar="PATH", help="also write the numbers as JSON")
    parser.add_argument("--quick", action="store_true", help=f"short ladder (up to {QUICK_TOP} elements per car), a smoke run")
    parser.add_argument("--agree", type=float, default=1e-4, help="largest relative difference of the two references (default 1e-4)")
    args = parser.parse_args()
    if args.parts:
        parts(args.elements, args.runs)
        return 0
    if not opensees_available():
        print(
            "error: openseespy cannot be imported. Install it into this environment with\n"
            "  apt-get install -y libblas3 liblapack3   # Debian; OpenSees links them\n"
            "  .venv/bin/python -m pip install openseespy   # or: pip install -e '.[peer]'",
            file=sys.stderr,
        )
        return 2
    started = time.perf_counter()
    counts = ladder(QUICK_TOP if args.quick else FULL_TOP)
    print(
        f"two {LENGTH:g} m cars of {MASS_PER_LENGTH * LENGTH / 1e3:g} t, EA = {AXIAL_STIFFNESS:.3g} N, cA = {AXIAL_VISCOSITY:.3g} N·s "
        f"(c = {WAVE_SPEED:.1f} m/s); {VELOCITY} m/s; Kelvin–Voigt coupler k = {COUPLER_STIFFNESS:.3g} N/m, "
        f"μ = {COUPLER_DAMPING:.3g} N·s/m, bilateral; end {END_TIME} s; average acceleration, dt = h/c"
    )
    print(f"ladder, elements per car: {counts}")
    levels: dict[str, list[Level]] = {}
    for tool, runner in TOOLS.items():
        print(f"{tool}:", flush=True)
        levels[tool] = climb(runner, counts, lambda s: print(s, flush=True))

    try:
        references = {tool: extrapolate(lv) for tool, lv in levels.items()}
    except RuntimeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    reference = statistics.mean(r.value for r in references.values())
    difference = abs(references["femref"].value - references["opensees"].value) / reference
    agree = difference <= args.agree
    for lvs in levels.values():
        for lv in lvs:
            lv.error = abs(lv.peak - reference) / reference

    choices: dict[str, dict[float, Level | None]] = {tool: {t: cheapest(levels[tool], t) for t in TARGETS} for tool in TOOLS}
    selected = {id(lv): (TOOLS[tool], lv) for tool, by_target in choices.items() for lv in by_target.values() if lv is not None}
    retime(list(selected.values()), args.repeat)

    print()
    print("Richardson references (three finest levels, h and dt halved each time):")
    for tool, r in references.items():
        print(
            f"  {tool:9} levels {r.elements}: peaks {', '.join(f'{p:.3f}' for p in r.peaks)} N, "
            f"observed order {r.order:.3f}, F∞ = {r.value:.3f} N (ringing ≤ {r.ringing:.2g} N)"
        )
        if abs(r.peaks[1] - r.peaks[2]) < RINGING_MARGIN * r.ringing:
            print(f"  warning: {tool}'s last change, {abs(r.peaks[1] - r.peaks[2]):.3g} N, is less than {RINGING_MARGIN:g} × its ringing: the observed order reads noise")
    print(f"  relative difference {difference:.2e} ({'agree' if agree else 'DISAGREE'}: limit {args.agree:g}); reference = mean = {reference:.3f} N")
    print()
    for tool, lvs in levels.items():
        print(convergence_table(tool, lvs))
        print()
    print(cost_table(choices, levels, args.repeat))
    total = time.perf_counter() - started
    print()
    print("Times are wall-clock on this machine (femref: building the cars + stepping + the result; OpenSees: model build +")
    print("analysis + reading the record); only their ratios within one run are meaningful, and only on an otherwise idle machine.")
    print(f"script time {total:.1f} s")

    if args.json:
        data = {
            "scene": {
                "length_m": LENGTH,
                "mass_per_length_kg_m": MASS_PER_LENGTH,
                "axial_stiffness_N": AXIAL_STIFFNESS,
                "axial_viscosity_Ns": AXIAL_VISCOSITY,
                "velocity_m_s": VELOCITY,
                "coupler_stiffness_N_m": COUPLER_STIFFNESS,
                "coupler_damping_Ns_m": COUPLER_DAMPING,
                "end_s": END_TIME,
                "dt_rule": "h/c",
            },
            "references": {tool: asdict(r) for tool, r in references.items()},
            "reference_N": reference,
            "relative_difference": difference,
            "agree": agree,
            "levels": {tool: [asdict(lv) for lv in lvs] for tool, lvs in levels.items()},
            "targets": {
                f"{target:g}": {
                    **{tool: (asdict(choices[tool][target]) if choices[tool][target] else None) for tool in TOOLS},
                    "ratio_femref_over_opensees": (
                        choices["femref"][target].wall_s / choices["opensees"][target].wall_s
                        if choices["femref"][target] and choices["opensees"][target]
                        else None
                    ),
                }
                for target in TARGETS
            },
            "repeat": args.repeat,
            "script_time_s": total,
            "note": "wall-clock times on one machine; only ratios within one run are meaningful",
        }
        with open(args.json, "w", encoding="utf-8") as out:
            json.dump(_finite(data), out, indent=2, allow_nan=False)
    if not agree:
        print(f"error: the two references differ by {difference:.2e} > {args.agree:g}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
