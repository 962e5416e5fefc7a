"""The compiled coupler kernels against their Python references, law by law and step by step.

* law level: :func:`kernels.couplers.evaluate` (force, mode, state rate, every tangent entry)
  and the stored energy and dissipation rate equal :meth:`reduced.couplers.Coupling.evaluate`
  and the laws' methods at a few hundred points per law and contact, guard boundaries
  included (closure at the slack, gear at its stroke, zero closure and rate, rate at the
  switch velocity);
* iteration level: the reference :class:`support.reference_engine.CouplerSolve` and the compiled
  :func:`start`/:func:`solve` step the same coupler-and-point-mass scenes (Newmark
  average-acceleration cars stepped here, fed by the Python side's forces), and forces,
  states, closures, rates, modes, energies and iteration counts agree over the whole run —
  contacts that open and reclose, and the Gauss–Seidel fallback of a friction gear;
* failure: where the Python iteration raises :class:`CouplerConvergenceError`, the compiled
  one reports the same coupler and :func:`failure_detail` the same text, state untouched.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.optimize

from femref.impact.couplers import NEWTON_ITERATIONS, CouplerConvergenceError, force_tolerance
from femref.impact.kernels import couplers as K
from femref.impact.kernels import coupling as C
from femref.impact.kernels import laws as L
from support.reference_engine import CouplerSolve, EndPrediction
from reduced.couplers import Coupling, HystereticTable, KelvinVoigt, PowerLawGear, StandardLinearDraftGear, draft_gear, power_law, table

RELATIVE = 1e-12  # law level
RUN_RELATIVE = 1e-9  # iteration level, of each quantity's largest magnitude over the run

LAWS = {
    "kelvin_voigt": KelvinVoigt(4e7, 3e5),
    "power_law": PowerLawGear.m901e_like(),
    "power_law_preload": PowerLawGear(2.52e6 / 0.074**2, 1.5, 1.5e5, (1e5, 2e6)),
    "draft_gear": StandardLinearDraftGear.m901e_like(),
    "table": HystereticTable.friction_gear_envelope(),
    "table_shifted": HystereticTable.friction_gear_envelope(slack_in_table=False),
}
CONTACTS = {
    "compression_only": ("compression_only", 0.0, 0.0),
    "compression_only_slack": ("compression_only", 0.0119, 0.0),
    "bilateral": ("bilateral", 0.0, 0.0),
    "bilateral_slack": ("bilateral", 0.01, 0.02),
}
COUPLINGS = {f"{law}-{contact}": Coupling(LAWS[law], *CONTACTS[contact]) for law in LAWS for contact in CONTACTS}
PACKED = L.pack_laws(list(COUPLINGS.values()))


def close(a: float, b: float, relative: float = RELATIVE) -> bool:
    return abs(a - b) <= relative * max(abs(a), abs(b))


def points(coupling: Coupling, seed: int) -> list[tuple[float, float, float]]:
    """(closure, rate, law state) at the guard boundaries and their neighbours, and at random."""
    law, slack, tension = coupling.law, coupling.slack, coupling.tension_slack
    closures = [0.0, slack, -tension, slack + 1e-3, -tension - 1e-3, 0.05, -0.05, 0.2, -0.2]
    closures += [np.nextafter(slack, 1.0), np.nextafter(slack, -1.0), np.nextafter(-tension, -1.0)]
    rates = [0.0, 1.0, -1.0, 1e-3, -1e-3]
    states = [0.0]
    if isinstance(law, HystereticTable):
        vs = law.switch_velocity
        rates += [vs, -vs, 0.5 * vs, -0.5 * vs, np.nextafter(vs, 0.0)]
        closures += [slack + x for x in law.closure] + [-tension - x for x in law.closure[1:3]]
    if isinstance(law, StandardLinearDraftGear):
        stroke = law.stroke
        states = [0.0, stroke, -stroke, np.nextafter(stroke, 1.0), np.nextafter(-stroke, -1.0), 0.03, -0.03, 0.12, -0.12]
        closures += [slack + 0.03, -tension - 0.03, slack + stroke, -tension - stroke]  # the law force at zero
    found = [(c, r, s) for c in closures for r in rates for s in states]
    rng = np.random.default_rng(seed)
    for _ in range(200):
        c = rng.uniform(-0.16, 0.16)
        r = rates[rng.integers(len(rates))] if rng.random() < 0.3 else rng.uniform(-3.0, 3.0)
        s = rng.uniform(-0.12, 0.12) if law.state_size else 0.0
        found.append((c, r, s))
    return found


def python_response(coupling: Coupling, closure: float, rate: float, state: float) -> tuple:
    s = np.full(coupling.law.state_size, state)
    r = coupling.evaluate(closure, rate, s)
    t = r.tangent
    first = lambda a: float(np.ravel(a)[0]) if np.size(a) else 0.0  # noqa: E731
    return (
        r.force, r.mode, first(r.state_rate),
        t.force_closure, t.force_rate, first(t.force_state),
        first(t.rate_closure), first(t.rate_rate), first(t.rate_state), first(t.rate_force),
    )  # fmt: skip


@pytest.mark.parametrize("name", list(COUPLINGS))
def test_law_response_matches_coupling_evaluate(name: str):
    j = list(COUPLINGS).index(name)
    coupling = COUPLINGS[name]
    modes = set()
    for closure, rate, state in points(coupling, seed=j):
        expected = python_response(coupling, closure, rate, state)
        got = C.evaluate(PACKED, j, closure, rate, state)
        assert got[1] == expected[1], (closure, rate, state)
        modes.add(got[1])
        for k in (0, 2, 3, 4, 5, 6, 7, 8, 9):
            assert close(got[k], expected[k]), (k, closure, rate, state, got, expected)
    assert {0, 1} <= modes or coupling.always_engaged
    if coupling.contact == "bilateral" and not coupling.always_engaged:
        assert -1 in modes


@pytest.mark.parametrize("name", list(COUPLINGS))
def test_law_energies_match(name: str):
    j = list(COUPLINGS).index(name)
    law = COUPLINGS[name].law
    rng = np.random.default_rng(100 + j)
    for closure, rate, state in points(COUPLINGS[name], seed=j):
        s = np.full(law.state_size, state)
        force = rng.uniform(-3e6, 3e6)
        for engaged in (True, False):
            assert close(C.stored_energy_of(PACKED, j, closure, state, engaged), law.stored_energy(closure, s, engaged))
            assert close(
                C.dissipation_rate_of(PACKED, j, closure, rate, state, force, engaged),
                law.dissipation_rate(closure, rate, s, force, engaged),
            )


def test_strict_and_branch_none_sign_rules_differ_where_they_should():
    """The two sign rules at a guard's zero: a bilateral power law with preload at δ = 0 is on
    its tensile side in Coupling.evaluate (strict), on its compressive side for branch=None."""
    j = list(COUPLINGS).index("power_law_preload-bilateral")
    coupling = COUPLINGS["power_law_preload-bilateral"]
    force = C.evaluate(PACKED, j, 0.0, 0.0, 0.0)[0]
    assert force == coupling.evaluate(0.0, 0.0).force == -coupling.law.preload
    assert C.force_of(PACKED, j, 0.0, 0.0, 0.0, C.piece_of(PACKED, j, 0.0, 0.0, False)) == coupling.law.force(0.0, 0.0, np.zeros(0))
    assert C.piece_of(PACKED, j, 0.0, 0.0, False) == 1
    gear = list(COUPLINGS).index("draft_gear-bilateral")
    stroke = LAWS["draft_gear"].stroke
    assert C.piece_of(PACKED, gear, 0.0, stroke, True) == 0  # open by the strict rule
    assert C.piece_of(PACKED, gear, 0.0, stroke, False) == 1  # closed by >= 0
    assert C.piece_of(PACKED, gear, 0.0, -stroke, True) == -1
    assert C.piece_of(PACKED, gear, 0.0, -stroke, False) == 0


# --- the iteration -------------------------------------------------------------------------


class PointMasses:
    """Rigid cars stepped by Newmark's average acceleration; end loads ``(F1, F2)`` tension positive."""

    GAIN = np.array([[-1.0, 1.0], [-1.0, 1.0]])  # both ends move with the car; a = (F2 − F1)/m

    def __init__(self, masses, velocities, dt: float) -> None:
        self.m = np.asarray(masses, dtype=float)
        self.v = np.asarray(velocities, dtype=float).copy()
        self.u = np.zeros_like(self.m)
        self.a = np.zeros_like(self.m)
        self.dt = dt

    def set_loads(self, loads) -> None:
        self.a = (loads[:, 1] - loads[:, 0]) / self.m

    def predictions(self) -> list[EndPrediction]:
        dt = self.dt
        return [
            EndPrediction(
                np.full(2, u + dt * v + 0.25 * dt * dt * a), 0.25 * dt * dt / m * self.GAIN, np.full(2, v + 0.5 * dt * a), 0.5 * dt / m * self.GAIN
            )
            for m, u, v, a in zip(self.m, self.u, self.v, self.a)
        ]

    def advance(self, loads) -> None:
        dt = self.dt
        a = (loads[:, 1] - loads[:, 0]) / self.m
        self.u = self.u + dt * self.v + 0.25 * dt * dt * (self.a + a)
        self.v = self.v + 0.5 * dt * (self.a + a)
        self.a = a


def scene_of(couplings, masses, velocities) -> SimpleNamespace:
    """What CouplerSolve reads of an ImpactScene: the cars' masses and velocities, the couplers."""
    return SimpleNamespace(
        cars=[SimpleNamespace(mass=m, velocity=v) for m, v in zip(masses, velocities)],
        couplers=[SimpleNamespace(coupling=c, rear=k, front=k + 1) for k, c in enumerate(couplings)],
    )


FIELDS = ("force", "state", "closure", "rate", "state_rate", "stored", "dissipated")


def python_values(py: CouplerSolve, name: str) -> np.ndarray:
    if name in ("state", "state_rate"):  # one value per coupler, 0 for a stateless law
        values = getattr(py, name)
        return np.array([values[sl][0] if sl.stop > sl.start else 0.0 for sl in py.state_slices])
    return np.array(getattr(py, name), dtype=float)


def run_both(couplings, masses, velocities, dt: float, steps: int, tolerance: float | None = None) -> dict:
    """Step the Python and the compiled coupler iteration side by side; the cars follow the Python forces."""
    scene = scene_of(couplings, masses, velocities)
    py = CouplerSolve(scene, dt)
    assert force_tolerance(scene) == py.force_tolerance
    if tolerance is not None:
        py.force_tolerance = tolerance
    tol = py.force_tolerance
    laws = L.pack_laws(couplings)
    st = K.new_state(laws)
    velocity = np.asarray(velocities, dtype=float)
    rates = velocity[py.rear] - velocity[py.front]
    py.start(rates)
    K.start(laws, st, rates)
    cars = PointMasses(masses, velocities, dt)
    cars.set_loads(py.loads(py.force))
    record: dict = {key: [] for key in (*FIELDS, *(f"c_{f}" for f in FIELDS), "mode", "c_mode", "iterations", "c_iterations")}

    def keep() -> None:
        for f in FIELDS:
            record[f].append(python_values(py, f))
            record[f"c_{f}"].append(getattr(st, f).copy())
        record["mode"].append(np.array(py.modes))
        record["c_mode"].append(st.mode.copy())

    keep()
    record["failure"] = None
    for step in range(steps):
        predictions = cars.predictions()
        if py.gain_u is None:
            py.assemble_gains(predictions)
        closure_free = np.array([predictions[r].displacement[1] - predictions[r + 1].displacement[0] for r in py.rear])
        rate_free = np.array([predictions[r].velocity[1] - predictions[r + 1].velocity[0] for r in py.rear])
        before = tuple(a.copy() for a in st)
        try:
            iterations, error = py.solve(predictions), None
        except CouplerConvergenceError as e:
            iterations, error = None, e
        compiled = K.solve(laws, st, dt, tol, closure_free, rate_free, py.gain_u, py.gain_v)
        if error is not None or compiled[2] != 0:
            record["failure"] = (step, error, compiled, before, st)
            break
        record["iterations"].append(iterations)
        record["c_iterations"].append(compiled[0])
        assert compiled[1:] == (-1, 0, 0.0)
        keep()
        cars.advance(py.loads(py.force))
    return {k: (np.array(v) if isinstance(v, list) else v) for k, v in record.items()}


def assert_same_run(run: dict) -> None:
    assert run["failure"] is None, run["failure"][:3]
    np.testing.assert_array_equal(run["c_mode"], run["mode"])
    np.testing.assert_array_equal(run["c_iterations"], run["iterations"])
    for f in FIELDS:
        scale = np.max(np.abs(run[f]))
        assert np.max(np.abs(run[f"c_{f}"] - run[f])) <= RUN_RELATIVE * scale, f


def reclosures(modes: np.ndarray) -> int:
    """How often a coupler engages again after having been engaged and opened."""
    count = 0
    for column in modes.T:
        engaged_before, opened = False, False
        for mode in column:
            if mode != 0 and opened:
                count += 1
                opened = False
            engaged_before |= mode != 0
            opened |= engaged_before and mode == 0
    return count


TABLE = HystereticTable.friction_gear_envelope()
SHIFTED = HystereticTable.friction_gear_envelope(slack_in_table=False)
SLACK = HystereticTable.FRICTION_GEAR_SLACK
GEAR = StandardLinearDraftGear.m901e_like()
THREE = (60e3, 50e3, 70e3)
LIGHT = (500.0, 400.0, 450.0)  # light cars: a narrow switch band in force, where Newton cycles

RUNS = {
    "kelvin_voigt": ([Coupling(KelvinVoigt(4e7, 3e5)), Coupling(KelvinVoigt(4e7, 3e5), slack=0.005)], THREE, (2.0, 0, 0), 1e-3, 300),
    "kelvin_voigt_bilateral_slack": ([Coupling(KelvinVoigt(4e7, 3e5), "bilateral", 0.01, 0.02)], THREE[:2], (2.0, 0), 1e-3, 500),
    "power_law": ([Coupling(PowerLawGear.m901e_like(), slack=0.0119), Coupling(PowerLawGear.m901e_like())], THREE, (2.0, 0, 0), 1e-3, 400),
    "power_law_preload": ([Coupling(LAWS["power_law_preload"], "bilateral")], THREE[:2], (2.0, 0), 1e-3, 400),
    "draft_gear_bilateral_slack": ([Coupling(GEAR, "bilateral", 0.01, 0.02)], THREE[:2], (3.0, 0), 1e-3, 500),
    "draft_gear": ([Coupling(GEAR), Coupling(GEAR, slack=0.005)], THREE, (4.0, 0, 0), 1e-3, 400),
    "table": ([Coupling(TABLE)], THREE[:2], (2.0, 0), 1e-3, 400),
    "table_shifted": ([Coupling(SHIFTED, slack=SLACK), Coupling(SHIFTED, "bilateral", 0.01, 0.01)], THREE, (2.0, 0, 0), 1e-3, 400),
    "table_gauss_seidel_with_gear": ([Coupling(TABLE), Coupling(GEAR)], LIGHT, (3.0, 0, 0), 1e-3, 250),
    "table_gauss_seidel": ([Coupling(TABLE), Coupling(SHIFTED, slack=SLACK)], LIGHT, (3.0, 0, 0), 2e-3, 250),
}


@pytest.mark.parametrize("name", list(RUNS))
def test_compiled_iteration_steps_like_coupler_solve(name: str):
    run = run_both(*RUNS[name])
    assert_same_run(run)
    if name == "power_law_preload":  # always engaged: the preload's jump at δ = 0 instead
        assert np.any(run["closure"] > 0.0) and np.any(run["closure"] < 0.0)
    else:  # contact changes: the other branch of the energy bookkeeping
        assert np.count_nonzero(np.diff(run["mode"], axis=0)) >= 2
    if name.startswith("table_gauss_seidel"):
        assert np.max(run["iterations"]) > NEWTON_ITERATIONS  # the fallback was taken (identically, above)
    if name in ("kelvin_voigt_bilateral_slack", "draft_gear_bilateral_slack"):
        assert reclosures(run["mode"]) >= 2
        assert {-1, 0, 1} <= set(np.unique(run["mode"]))


def test_brent_root_is_scipy_brentq():
    """The transcription of Brent's method returns scipy's root (same evaluations) to a few ulps: the compiled
    table law may round its last bit differently from the Python one on another CPU (1 ulp seen), and Brent's
    iterates then part by that much."""
    laws = L.pack_laws([Coupling(TABLE), Coupling(TABLE)])
    gain_u = np.array([[-2e-9, 1e-9], [1e-9, -2e-9]])
    gain_v = 2e3 * gain_u
    rng = np.random.default_rng(7)
    for _ in range(40):
        closure_free = rng.uniform(0.0, 0.06, 2)
        rate_free = rng.uniform(-0.05, 0.05, 2)
        P = rng.uniform(0.0, 1e6, 2)

        def excess(force: float) -> float:
            Q = P.copy()
            Q[0] = force
            response = Coupling(TABLE).evaluate(closure_free[0] + gain_u[0] @ Q, rate_free[0] + gain_v[0] @ Q)
            return force - response.force

        f0 = excess(P[0])
        low, high = sorted((P[0], P[0] - f0))
        expected = scipy.optimize.brentq(excess, low, high, xtol=1e-4)
        got = K.brent_root(laws, K.new_state(laws), 1e-3, 0, closure_free, rate_free, gain_u, gain_v, P.copy(), np.zeros(2), low, high, 1e-4)
        assert abs(got - expected) <= 4.0 * np.spacing(abs(expected))


# --- failures ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "couplings, masses, velocities, tolerance, kind",
    [
        # a light middle car between two friction gears: Gauss–Seidel crawls (a real non-convergence)
        ([Coupling(TABLE), Coupling(TABLE)], (2000.0, 20.0, 2000.0), (2.0, 0, 0), None, K.SWEEPS_EXHAUSTED),
    ],
    ids=["sweeps_exhausted"],
)
def test_failure_names_the_same_coupler_and_detail(couplings, masses, velocities, tolerance, kind):
    run = run_both(couplings, masses, velocities, 1e-3, 100, tolerance)
    assert run["failure"] is not None
    step, error, (iterations, worst, failure_kind, change), before, after = run["failure"]
    assert isinstance(error, CouplerConvergenceError)
    assert failure_kind == kind
    assert worst == error.coupler
    assert K.failure_detail(failure_kind, change) == error.detail
    assert iterations > NEWTON_ITERATIONS
    for name, old, new in zip(K.CouplerState._fields, before, after):  # the state is untouched
        if not name.startswith("work_"):  # (solve's scratch, no state: it holds the failed iterate)
            np.testing.assert_array_equal(new, old, err_msg=name)


def test_failure_detail_rejects_an_unknown_kind():
    with pytest.raises(ValueError, match="failure_kind"):
        K.failure_detail(4, 0.0)


# --- packing -------------------------------------------------------------------------------


class Bilinear:
    """A law with the CouplerLaw interface whose module (this one) has no law functions: no compiled form."""

    state_size = 0
    guard_events = ()
    reference_stiffness = 1e7

    def initial_state(self):
        return np.zeros(0)


class TwoStates(Bilinear):
    state_size = 2


def test_pack_laws_rejects_laws_without_a_compiled_form():
    with pytest.raises(ValueError, match=r"coupler 1: law Bilinear has no compiled form: its module \S+ lacks the plain functions piece, force"):
        L.pack_laws([Coupling(TABLE), Coupling(Bilinear())])
    with pytest.raises(ValueError, match="coupler 0: law TwoStates carries 2 state variables"):
        L.pack_laws([Coupling(TwoStates())])


def test_pack_laws_layout():
    laws = L.pack_laws([Coupling(GEAR, "bilateral", 0.01, 0.02), Coupling(LAWS["power_law_preload"]), Coupling(TABLE)])
    np.testing.assert_array_equal(laws.kind, [L.LAW_MODULES.index(m) for m in (draft_gear, power_law, table)])
    np.testing.assert_array_equal(laws.contact, [L.BILATERAL, L.COMPRESSION_ONLY, L.COMPRESSION_ONLY])
    np.testing.assert_array_equal(laws.stateful, [1, 0, 0])
    np.testing.assert_array_equal(laws.params[0, :5], [GEAR.series_compliance, GEAR.gear_stiffness, GEAR.gear_damping, GEAR.stroke, GEAR.solid_stiffness])
    np.testing.assert_array_equal(laws.params[1, :6], [2.52e6 / 0.074**2, 1.5, 1.5e5, 2.0, 1e5, 2e6])
    np.testing.assert_array_equal(laws.table[2, 0, : int(laws.params[2, 2])], TABLE.closure)
    st = K.new_state(laws)
    assert st.mode.dtype == np.int64 and not np.any(st.force) and not np.any(st.state)
