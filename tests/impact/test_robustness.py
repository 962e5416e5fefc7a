"""Robustness of the impact solver: the coupler root, the draft gear at a contact jump, field output, energy balance.

* the Gauss–Seidel scalar root (``CouplerSolve._scalar_root`` and its compiled twin): its
  bracket ``[P − f(P), P]`` has no sign change where a table's unloading curve falls
  steeply or where ``T`` hardly depends on ``P`` (round-off); brentq then raised
  ``ValueError: f(a) and f(b) must have different signs`` out of ``solve_impact``. The
  bracket is widened until ``f`` changes sign, in both engines alike;
* a bilateral draft gear with slack: where the tension contact engaged with the gear still
  compressed from buff, the law force jumped from 0 to ``−x_g/D`` (2.1 MN) and Newton on force
  and gear state cycled between open and engaged, ending the run at 0.137 s; then the scalar
  root in the force alone held the contact at its boundary (a set-valued force) and the run
  went on, with about ``x_g²/(2D)`` from nothing booked as negative dissipation. Now the gear
  state is sided (:meth:`reduced.couplers.Coupling.state_mirrored`): mirrored where the ends
  pass into the tension slack, the pack's residual compression is extra free play and the
  tension side engages from zero force, in both engines alike and as the ODE driver does. The
  held contact stays the safeguard for a law that jumps (kept under test on a stale state);
* ``fem.fields`` in an impact case: refused at validation (exit code 2, key path named)
  instead of silently writing no field files;
* the energy balance: one rule, ``ΔE = W`` (:func:`femref.core.energy.energy_balance_error`),
  checked on two-mass impacts with known energies.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from femref.case import parse_case
from femref.case.errors import CaseError
from femref.cli import main
from femref.core.body import Body
from femref.core.profiles import Piecewise, Uniform
from femref.fem.build import FemSettings
from femref.impact import solve_impact
from femref.impact.couplers import CouplerConvergenceError, bracket_detail, coupler_newton_detail, force_tolerance
from femref.impact.kernels import couplers as K
from femref.impact.kernels import coupling as C
from femref.impact.kernels import laws as L
from femref.core.energy import energy_balance_error
from femref.models import model_form
from femref.scene.impact import Car, Coupler, ImpactScene, ModelRun
from reduced.couplers import Coupling, HystereticTable, KelvinVoigt, StandardLinearDraftGear
from reduced.nonlinear import simulate_impact
from reduced.rigid import ImpactPair, kelvin_voigt_impact
from support.reference_engine import couplers as reference
from support.reference_engine import CouplerSolve, EndPrediction, solve_reference

RTOL = 1e-9  # compiled against reference, of each history's peak (as tests/impact/test_compiled.py)

#: A friction-gear-like table whose unloading curve drops 0.89 MN within 10 μm at 10 mm: T rises
#: as P pushes the ends apart (slope −8.9e10 N/m), so f = P − T is not monotone there.
STEEP = HystereticTable((0.0, 0.01, 0.01001, 0.05), (0.0, 1.0e6, 1.1e6, 2.0e6), (0.0, 9.0e5, 1.0e4, 5.0e5))
GEAR = StandardLinearDraftGear(4.0e8, 4.0e8, 1.7e7, 2.5e5, 0.05, 1.0e8)  # the draft gear of tests/impact/test_compiled.py


def rod(mass: float, length: float = 17.0) -> Body:
    """A uniform 17 m rod car of ``mass`` (kg), EA 3 GN, cA 2 MN·s."""
    m = mass / length
    return Body("rod", length / 2, Uniform(m), Uniform(3.0e9), Uniform(2.0e6), length / 2 * math.sqrt(m / 3.0e9))


def hopper(gross: float) -> Body:
    """A 17 m car, 3500 kg/m over each 2 m end and the rest of ``gross`` between the bolsters."""
    inner = (gross - 14000.0) / 13.0
    mass = Piecewise((-6.5, 6.5), (3500.0, inner, 3500.0))
    return Body("rod", 8.5, mass, Uniform(3.0e9), Uniform(2.0e6), 8.5 * math.sqrt(gross / 17.0 / 3.0e9))


def two_cars(coupling: Coupling, masses: tuple[float, float], speed: float, fidelity: str, end: float, *,
             body=rod, integrator: str = "newmark") -> ImpactScene:
    """Two cars, the rear one moving at ``speed``, one coupler, one uniform run of ``fidelity``."""
    cars = (Car("rear", body(masses[0]), speed, {"center": 0.0}), Car("front", body(masses[1]), 0.0, {"center": 0.0}))
    return ImpactScene(
        cars, (Coupler("c1", 0, coupling),), (ModelRun("run", (fidelity, fidelity)),), end=end, integrator=integrator,
        rho_inf=1.0 if integrator == "newmark" else 0.8, fem=FemSettings(elements=12, order=2), modal_modes=3,
    )


def both(scene: ImpactScene, dt: float):
    """(compiled, reference) runs of the scene's first run from the same car systems."""
    systems = [model_form(f, "impact")(car, scene, dt) for car, f in zip(scene.cars, scene.runs[0].fidelity)]
    return solve_impact(scene, systems, dt), solve_reference(scene, systems, dt)


def assert_same_run(compiled, reference_run) -> None:
    """Status, counters and every coupler and energy history (coupler work included) agree."""
    assert (compiled.status, compiled.message, compiled.steps) == (reference_run.status, reference_run.message, reference_run.steps)
    assert (compiled.newton_iterations, compiled.newton_iterations_max, compiled.contact_changes) == (
        reference_run.newton_iterations, reference_run.newton_iterations_max, reference_run.contact_changes)
    for key in ("force", "closure"):
        value = reference_run.couplers["c1"][key]
        np.testing.assert_allclose(compiled.couplers["c1"][key], value, rtol=0, atol=RTOL * np.nanmax(np.abs(value)), err_msg=key)
    scale = np.nanmax(reference_run.energy["total"])
    for key, value in reference_run.energy.items():
        np.testing.assert_allclose(compiled.energy[key], value, rtol=0, atol=RTOL * scale, err_msg=key)
    np.testing.assert_allclose(compiled.coupler_work, reference_run.coupler_work, rtol=0, atol=RTOL * scale)


def one_coupler_solve(coupling: Coupling, masses=(5.0e4, 5.0e4), speeds=(2.0, 0.0), dt: float = 1e-3) -> CouplerSolve:
    """A CouplerSolve of one coupler between two cars of ``masses`` moving at ``speeds`` (what it reads of a scene)."""
    scene = SimpleNamespace(
        cars=[SimpleNamespace(mass=m, velocity=v) for m, v in zip(masses, speeds)],
        couplers=[SimpleNamespace(coupling=coupling, rear=0, front=1)],
    )
    return CouplerSolve(scene, dt)


def old_bracket_has_a_sign_change(solve: CouplerSolve, closure_free, rate_free, start: float) -> bool:
    """Whether ``[P − f(P), P]``, the bracket brentq was given before it could be widened, changes sign."""
    P, s = np.array([start]), solve.state.copy()
    f0 = solve._excess(0, closure_free, rate_free, P, s, start)
    f1 = solve._excess(0, closure_free, rate_free, P, s, start - f0)
    return not reference.same_sign(f0, f1)


# --- 1. the scalar root's bracket -----------------------------------------------------------


def test_a_steep_unloading_drop_leaves_the_first_bracket_without_sign_change_and_both_engines_widen_it():
    """``f(P) = P − U(δ_f + D_u P)`` with the 10 μm drop: from P = 1 MN the bracket [P − f(P), P] lies on
    one side of the root (brentq raised ValueError); widened, it finds the root, the same in both engines."""
    coupling = Coupling(STEEP)
    solve = one_coupler_solve(coupling)
    solve.gain_u, solve.gain_v = np.array([[-1.0e-9]]), np.array([[-1.0e-6]])
    closure_free, rate_free = np.array([0.011]), np.array([-1.0])
    assert not old_bracket_has_a_sign_change(solve, closure_free, rate_free, 1.0e6)

    root = solve._scalar_root(0, closure_free, rate_free, np.array([1.0e6]), np.zeros(0))
    f = lambda p: p - coupling.evaluate(0.011 - 1.0e-9 * p, -1.0 - 1.0e-6 * p).force  # noqa: E731
    tolerance = solve.force_tolerance
    assert f(root) == 0.0 or not reference.same_sign(f(root - 2 * tolerance), f(root + 2 * tolerance))  # a root (or the jump)

    laws = L.pack_laws([coupling])
    compiled, kind = K._scalar_root(laws, K.new_state(laws), 1e-3, 0, tolerance, closure_free, rate_free,
                                    solve.gain_u, solve.gain_v, np.array([1.0e6]), np.zeros(1))
    assert kind == 0 and compiled == root


def test_round_off_no_longer_breaks_the_bracket_where_T_hardly_depends_on_P():
    """A soft bilateral spring between very heavy cars (|∂T/∂P| ≈ 1e-17): P − f(P) lands on the root
    to round-off, on either side. 72 of these 300 seeded configurations raised ValueError before."""
    solve = one_coupler_solve(Coupling(KelvinVoigt(1.0e3), "bilateral"))
    solve.force_tolerance = 1e-6
    rng = np.random.default_rng(3)
    for _ in range(300):
        solve.gain_u, solve.gain_v = np.array([[-(10 ** rng.uniform(-21, -18))]]), np.array([[0.0]])
        closure_free, P = np.array([rng.uniform(-0.08, 0.08)]), np.array([rng.uniform(-3e6, 3e6)])
        for _ in range(3):  # the sweeps: the second and third start on the root, f(P) at round-off
            P[0] = solve._scalar_root(0, closure_free, np.zeros(1), P, np.zeros(0))
        assert abs(P[0] - 1.0e3 * (closure_free[0] + solve.gain_u[0, 0] * P[0])) <= 1e-6


def test_a_steep_table_with_bilateral_slack_runs_to_the_end_in_both_engines():
    """Found by a random search of table laws: two rigid cars (56 t, 38 t) at 1.63 m/s, bilateral with 10 mm
    of slack each way, a table whose unloading falls 0.75 MN within 0.7 μm. Before: ValueError out of
    solve_impact (both engines) at the fallback's scalar root; now the run ends, the engines agree."""
    x1, lo1, un1, un2 = 0.010869608066192658, 879240.714729476, 748182.6200879595, 2403.537814305866
    table = HystereticTable(
        (0.0, x1, x1 + 6.799407954758472e-07, 0.08), (0.0, lo1, 1.1 * lo1, 2.0 * lo1), (0.0, un1, un2, un2 + 0.5 * 0.9 * lo1),
        switch_velocity=0.07570162133893613,
    )
    scene = two_cars(Coupling(table, "bilateral", 0.01, 0.01), (55982.07954336476, 38145.39970126394), 1.6300863187991994, "rigid", 0.4)
    compiled, reference_run = both(scene, 1e-3)
    assert reference_run.ok and reference_run.newton_iterations_max > reference.NEWTON_ITERATIONS  # the fallback ran
    assert_same_run(compiled, reference_run)
    assert reference_run.energy_balance_error < 2e-3 and reference_run.car_energy_balance_error < 1e-12


def test_a_bracket_that_never_changes_sign_fails_alike_in_both_engines():
    """No widening allowed (0 doublings): the steep configuration has no sign change to offer. The reference
    raises CouplerConvergenceError, the kernel returns BRACKET_NOT_FOUND, with one detail text."""
    coupling = Coupling(STEEP)
    solve = one_coupler_solve(coupling)
    solve.gain_u, solve.gain_v = np.array([[-1.0e-9]]), np.array([[-1.0e-6]])
    solve.bracket_expansions = 0
    with pytest.raises(CouplerConvergenceError) as raised:
        solve._scalar_root(0, np.array([0.011]), np.array([-1.0]), np.array([1.0e6]), np.zeros(0))
    assert raised.value.coupler == 0 and raised.value.detail == bracket_detail()
    laws = L.pack_laws([coupling])
    laws = laws._replace(limits=np.array([*laws.limits[:3], 0], dtype=np.int64))
    _, kind = K._scalar_root(laws, K.new_state(laws), 1e-3, 0, solve.force_tolerance, np.array([0.011]), np.array([-1.0]),
                             solve.gain_u, solve.gain_v, np.array([1.0e6]), np.zeros(1))
    assert kind == K.BRACKET_NOT_FOUND and K.failure_detail(kind, 0.0) == bracket_detail()


# --- 2. the draft gear at the other side's slack boundary --------------------------------------

#: The step at t = 0.137 s of the bilateral gear below between quasi-rigid cars (dt = 5e-4 s) as the engines
#: stepped it before the sided gear state: contact open, the gear still compressed 10.65 mm from buff, the ends
#: separating at 2.55 m/s into the tension slack (−5 mm), which the step's free closure passes by 0.43 mm.
JUMP_STEP = dict(
    closure_free=-0.005426425842334742, rate_free=-2.5484153782633148, gain_u=-1.1766568340797213e-09,
    gain_v=-4.1898452110652926e-06, state=0.010654487899804194, closure=-0.0041522181532035185,
    rate=-2.548415378261111, state_rate=-0.7245051771866852, stored=964.9039554601287, dt=5e-4,
)
#: JUMP_STEP mirrored onto a compression-only contact with 5 mm of slack: a gear compressed 10.65 mm in *draft*
#: (a state no engine reaches: a compression-only gear is never pulled) meets its compression boundary. Its law
#: jumps there, from 0 to (δ_e − x_g)/D ≈ +2.1 MN — what the bilateral gear did before its state was sided.
STALE_STEP = {**JUMP_STEP, **{k: -JUMP_STEP[k] for k in ("closure_free", "rate_free", "state", "closure", "rate", "state_rate")}}


def gear_step_solves(coupling: Coupling, d: dict) -> tuple[CouplerSolve, L.CouplerLaws, K.CouplerState]:
    """The reference and the compiled couplers at the start of step ``d`` (same scene tolerance)."""
    solve = one_coupler_solve(coupling, (119.0e3, 100.0e3), (3.0, 0.0), d["dt"])
    solve.gain_u, solve.gain_v = np.array([[d["gain_u"]]]), np.array([[d["gain_v"]]])
    solve.state, solve.closure, solve.rate = np.array([d["state"]]), np.array([d["closure"]]), np.array([d["rate"]])
    solve.state_rate, solve.stored = np.array([d["state_rate"]]), np.array([d["stored"]])
    laws = L.pack_laws([coupling])
    st = K.new_state(laws)
    st.state[0], st.closure[0], st.rate[0], st.state_rate[0], st.stored[0] = d["state"], d["closure"], d["rate"], d["state_rate"], d["stored"]
    return solve, laws, st


def step_both(solve: CouplerSolve, laws: L.CouplerLaws, st: K.CouplerState, d: dict) -> int:
    """One step of step ``d`` in both engines; they agree (values to 1e-12, iterations, mode, held flag)."""
    prediction = lambda u, v: EndPrediction(np.array([0.0, u]), np.zeros((2, 2)), np.array([0.0, v]), np.zeros((2, 2)))  # noqa: E731
    iterations = solve.solve([prediction(d["closure_free"], d["rate_free"]), prediction(0.0, 0.0)])
    tol = force_tolerance(SimpleNamespace(cars=[SimpleNamespace(mass=119.0e3, velocity=3.0), SimpleNamespace(mass=100.0e3, velocity=0.0)],
                                          couplers=[SimpleNamespace(coupling=solve.couplings[0], rear=0, front=1)]))
    assert tol == solve.force_tolerance
    result = K.solve(laws, st, d["dt"], tol, np.array([d["closure_free"]]), np.array([d["rate_free"]]), solve.gain_u, solve.gain_v)
    assert result == (iterations, -1, 0, 0.0)
    for name in ("force", "state", "closure", "rate", "state_rate", "stored", "dissipated", "work"):
        assert getattr(st, name)[0] == pytest.approx(float(getattr(solve, name)[0]), rel=1e-12, abs=1e-12), name
    assert st.mode[0] == solve.modes[0] and st.held[0] == int(solve.held[0])
    return iterations


def test_the_step_into_the_tension_slack_starts_from_the_mirrored_gear():
    """At JUMP_STEP the law force of the buff-compressed gear would jump from 0 (open) to (δ_e − x_g)/D ≈ −2.1 MN
    (engaged), and no force satisfies P = T: Newton cycled, and the contact was held at its boundary (a set-
    valued force) by the fallback. The step now starts from the mirrored gear, σ (s_n, ṡ_n) with σ = −1: the
    pack is 10.65 mm of extra free play, the contact stays open (P = 0), the gear relaxes — exactly the mirror
    of the trapezoidal relaxation — and Newton converges in 3 iterations, in both engines alike."""
    d = JUMP_STEP
    solve, laws, st = gear_step_solves(Coupling(GEAR, "bilateral", 0.005, 0.005), d)
    assert solve.couplings[0].state_mirrored(d["closure_free"], solve.state)
    iterations = step_both(solve, laws, st, d)
    assert iterations <= 3 and not solve.held[0]
    assert solve.force[0] == 0.0 and solve.modes[0] == 0 and solve.closure[0] == d["closure_free"]
    r = 0.5 * d["dt"] * GEAR.gear_stiffness / GEAR.gear_damping
    relaxed = (d["state"] + 0.5 * d["dt"] * d["state_rate"]) / (1.0 + r)  # s = s_n + dt/2 (ṡ_n − c s/μ)
    assert solve.state[0] == pytest.approx(-relaxed, rel=1e-13)
    assert solve.stored[0] == pytest.approx(0.5 * GEAR.gear_stiffness * relaxed**2, rel=1e-13)  # the gear's, kept
    # dissipation: the midpoint rule on the mirrored start, (c x̄)²/μ with x̄ = (s − s_n)/2 (not ≈ 0)
    mid = 0.5 * (solve.state[0] - d["state"])
    assert solve.dissipated[0] == pytest.approx(d["dt"] * (GEAR.gear_stiffness * mid) ** 2 / GEAR.gear_damping, rel=1e-13)


def test_a_law_that_jumps_at_its_contact_is_still_held_at_its_boundary():
    """The safeguard for a jump of the law (STALE_STEP: a compression-only gear holding a draft compression at
    its compression boundary, the law force 0 open and ≈ +2.1 MN engaged): no force satisfies P = T, Newton
    cycles and the scalar root in P, the gear state following it, holds the ends at the slack boundary with a
    force between the two sides of the jump, in both engines alike (as the bilateral gear was held before)."""
    d = STALE_STEP
    solve, laws, st = gear_step_solves(Coupling(GEAR, slack=0.005), d)
    assert not solve.couplings[0].state_mirrored(d["closure_free"], solve.state)  # compression only: never mirrored
    iterations = step_both(solve, laws, st, d)
    assert iterations > reference.NEWTON_ITERATIONS  # Newton cycled; the fallback solved it
    P, x = float(solve.force[0]), float(solve.state[0])
    assert abs(solve.closure[0] - 0.005) <= 1e-9  # the ends at the slack boundary
    law_force = (solve.closure[0] - 0.005 - x) / GEAR.series_compliance
    assert law_force > 1.9e6 > P > 0.0  # inside the jump
    rate = (P - GEAR.gear_stiffness * x) / GEAR.gear_damping  # the gear driven by the force it carries
    assert abs(x - d["state"] - 0.5 * d["dt"] * (d["state_rate"] + rate)) <= reference.STATE_TOLERANCE
    assert solve.state_rate[0] == pytest.approx(rate, rel=1e-12) and solve.held[0]


def test_a_gear_state_that_does_not_settle_fails_alike_in_both_engines(monkeypatch):
    """With no Newton iterations allowed the gear's state cannot settle (STALE_STEP, where Newton cycles): the
    reference raises, the kernel returns COUPLER_NEWTON_FAILED, with one detail text; the compiled state is left
    untouched."""
    d = STALE_STEP
    solve, laws, st = gear_step_solves(Coupling(GEAR, slack=0.005), d)
    monkeypatch.setattr(reference, "MAX_NEWTON_ITERATIONS", 0)
    with pytest.raises(CouplerConvergenceError) as raised:
        solve._gauss_seidel(np.array([d["closure_free"]]), np.array([d["rate_free"]]))
    assert raised.value.detail == coupler_newton_detail()
    laws = laws._replace(limits=np.array([laws.limits[0], 0, *laws.limits[2:]], dtype=np.int64))
    before = [a.copy() for a in st]
    _, worst, kind, _ = K.solve(laws, st, d["dt"], solve.force_tolerance, np.array([d["closure_free"]]), np.array([d["rate_free"]]),
                                solve.gain_u, solve.gain_v)
    assert (worst, kind) == (0, K.COUPLER_NEWTON_FAILED) and K.failure_detail(kind, 0.0) == coupler_newton_detail()
    for name, old, new in zip(K.CouplerState._fields, before, st):
        if not name.startswith("work_"):
            np.testing.assert_array_equal(new, old, err_msg=name)


def test_the_compiled_mirror_is_the_couplings_rule():
    """kernels.couplers.state_mirror is −1 exactly where Coupling.state_mirrored holds, for every contact kind,
    at the slack boundaries, their neighbours and zero states."""
    couplings = [Coupling(GEAR, "bilateral", 0.005, 0.005), Coupling(GEAR, "bilateral", 0.0, 0.01), Coupling(GEAR, "bilateral"),
                 Coupling(GEAR), Coupling(GEAR, slack=0.005), Coupling(KelvinVoigt(4e7, 3e5), "bilateral", 0.005, 0.005)]
    laws = L.pack_laws(couplings)
    closures = [0.0, 0.005, -0.005, 0.01, -0.01, 1e-6, -1e-6, 0.2, -0.2]
    closures += [np.nextafter(c, s) for c in (0.005, -0.005, 0.0, -0.01) for s in (-1.0, 1.0)]
    states = [0.0, -0.0, 1e-9, -1e-9, 0.01, -0.01, 0.07, -0.07]
    mirrored = 0
    for j, coupling in enumerate(couplings):
        for closure in closures:
            for state in states:
                expected = coupling.state_mirrored(closure, np.full(coupling.law.state_size, state)) if coupling.law.state_size else False
                assert C.state_mirror(laws, j, closure, state) == (-1.0 if expected else 1.0), (j, closure, state)
                mirrored += expected
    assert mirrored > 0


def gear_scene(end: float = 0.35, fidelity: str = "quasi_rigid") -> ImpactScene:
    """The bilateral draft gear with 5 mm of free play each way between 119 t / 100 t cars at 3 m/s."""
    return two_cars(Coupling(GEAR, "bilateral", 0.005, 0.005), (119.0e3, 100.0e3), 3.0, fidelity, end,
                    body=hopper, integrator="generalized_alpha")


def impulse(response) -> np.ndarray:
    """``∫₀ᵗ P dt`` at the output times (N·s): the momentum the coupler has passed on."""
    force, time = response.couplers["c1"]["force"], response.time
    return np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(time))])


def test_a_bilateral_draft_gear_with_slack_engages_in_draft_from_zero_force(monkeypatch):
    """The scene that stopped at 0.137 s ("Newton on its force and state did not converge in 40 iterations")
    and then ran held at a force jump (−0.36 and −0.99 MN on its first two tension steps, a step of 0.63 MN,
    and the same on the way back into buff; −6.6 kJ and −4.0 kJ of coupler dissipation; up to 14 iterations).
    Now the gear, compressed 10.65 mm when the ends cross into the tension slack, is mirrored there and the
    tension contact engages 3.5 ms later from zero force: the largest step change of the force is that first
    engaged step (0.17 MN), no larger than the series springs' (|δ̇| + |ẋ_g|)·dt/D and within 1.3× of the
    first buff engagement's on a relaxed gear (0.14 MN: the relaxing gear adds its 0.55 m/s to the 2.5 m/s
    closing speed); nothing is held, the coupler dissipation never decreases, Newton takes at most 3
    iterations; the line's energy balances to 1e-4 (generalized-α's own dissipation; 7.3e-5, before
    9.0e-5), the cars balance the coupler forces' work to round-off; the engines agree."""
    held = []
    commit = reference.CouplerSolve._commit

    def recording_commit(self, *args):
        commit(self, *args)
        held.append(bool(self.held[0]))

    monkeypatch.setattr(reference.CouplerSolve, "_commit", recording_commit)
    compiled, reference_run = both(gear_scene(), 5e-4)
    assert reference_run.ok, reference_run.message
    assert_same_run(compiled, reference_run)
    assert len(held) == reference_run.steps and not any(held)
    assert reference_run.newton_iterations_max <= 3
    force, closure, time = reference_run.couplers["c1"]["force"], reference_run.couplers["c1"]["closure"], reference_run.time
    step = np.abs(np.diff(force))
    first_tension = int(np.argmax(force < 0.0))
    assert 0.140 < time[first_tension] < 0.141 and closure[first_tension - 1] < -0.005 - 0.008  # 8 mm past the boundary
    first_buff = int(np.argmax(force > 0.0))
    assert np.max(step) == step[first_tension - 1] <= 1.3 * np.max(step[first_buff - 1 : first_buff + 2])
    bound = (np.max(np.abs(np.diff(closure))) / 5e-4 + 3.0) * 5e-4 / GEAR.series_compliance  # |ẋ_g| < 3 m/s
    assert np.max(step) < bound
    assert np.min(force) < -3.5e6 and np.max(force) > 4.4e6  # draft and buff
    assert np.all(np.diff(reference_run.energy["coupler_dissipated"]) >= 0.0)
    assert reference_run.energy_balance_error < 1e-4
    assert reference_run.car_energy_balance_error < 1e-12


def test_the_tension_engagement_converges_with_the_step():
    """Against a four times finer step: the peak buff and draft forces agree to 5e-5 and the impulse ∫P dt
    to 1e-4 of its largest value; the line's energy balance improves with the step."""
    coarse = both(gear_scene(), 5e-4)[0]
    fine_scene = gear_scene()
    systems = [model_form(f, "impact")(car, fine_scene, 1.25e-4) for car, f in zip(fine_scene.cars, fine_scene.runs[0].fidelity)]
    fine = solve_impact(fine_scene, systems, 1.25e-4)
    assert coarse.ok and fine.ok
    for extreme in (np.max, np.min):
        assert extreme(coarse.couplers["c1"]["force"]) == pytest.approx(extreme(fine.couplers["c1"]["force"]), rel=5e-5)
    on_coarse = np.interp(coarse.time, fine.time, impulse(fine))
    assert np.max(np.abs(impulse(coarse) - on_coarse)) < 1e-4 * np.max(np.abs(on_coarse))
    assert fine.energy_balance_error < coarse.energy_balance_error and fine.energy_balance_error < 1e-5


def test_rigid_cars_converge_to_the_ode_through_both_engagements():
    """Rigid cars: the impact engines against reduced.nonlinear.simulate_impact (its own mirror event at the
    boundary, rtol 1e-10) at dt = 0.5, 0.25, 0.125 ms: the force error falls (1.8e-3, 6.3e-4, 1.9e-4 of the
    peak) and the impulse agrees to 1e-4; before, with the held jump against the ODE's booked one, the
    errors did not fall (6.6e-3, 2.5e-2, 6.6e-3)."""
    errors = []
    for dt in (5e-4, 2.5e-4, 1.25e-4):
        scene = gear_scene(fidelity="rigid")
        systems = [model_form(f, "impact")(car, scene, dt) for car, f in zip(scene.cars, scene.runs[0].fidelity)]
        run = solve_impact(scene, systems, dt)
        assert run.ok and np.all(np.diff(run.energy["coupler_dissipated"]) >= 0.0)
        ode = simulate_impact(ImpactPair(119.0e3, 100.0e3, 3.0), scene.couplers[0].coupling, run.time)
        assert ode.status == "ok" and [e.kind for e in ode.events].count("gear_mirrored") == 2
        force, exact = run.couplers["c1"]["force"], ode.coupler_force
        errors.append(np.max(np.abs(force - exact)) / np.max(np.abs(exact)))
        exact_impulse = np.concatenate([[0.0], np.cumsum(0.5 * (exact[1:] + exact[:-1]) * dt)])
        assert np.max(np.abs(impulse(run) - exact_impulse)) < 1e-4 * np.max(np.abs(exact_impulse))
    assert errors[0] < 3e-3 and errors[1] < 0.5 * errors[0] and errors[2] < 0.5 * errors[1]


# --- 3. field output of impact cases -----------------------------------------------------------

IMPACT_CASE = {
    "kind": "impact",
    "cars": [
        {"name": "hammer", "body": {"type": "rod", "length": 17.0, "mass_per_length": 7000.0, "axial_stiffness": 3.0e9},
         "velocity": 2.2, "sensors": {"center": 0.0}},
        {"name": "anvil", "body": {"type": "rod", "length": 17.0, "mass_per_length": 5900.0, "axial_stiffness": 3.0e9},
         "velocity": 0.0, "sensors": {"center": 0.0}},
    ],
    "couplers": [{"between": ["hammer", "anvil"], "law": {"kelvin_voigt": {"stiffness": 4.0e7, "damping": 3.0e5}}}],
    "time": {"end": 0.2},
    "models": ["fem", "rigid"],
}


@pytest.mark.parametrize("fem, key", [({"elements": 8, "fields": True}, "fem.fields"), ({"elements": 8, "field_stride": 5}, "fem.field_stride")])
def test_an_impact_case_asking_for_field_files_is_refused_with_the_key_path(fem, key):
    """Before: accepted, and the run wrote no field file (impact results record sensors only)."""
    with pytest.raises(CaseError) as raised:
        parse_case({**IMPACT_CASE, "fem": fem})
    message = str(raised.value)
    assert f"{key}: field files are written for single-body scenes only; impact results record sensors at the probes" in message
    parse_case({**IMPACT_CASE, "fem": {"elements": 8, "fields": False}})  # the default, said out loud, is fine


def test_cli_validate_refuses_impact_fields_with_exit_code_2(tmp_path):
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump({**IMPACT_CASE, "fem": {"elements": 8, "fields": True}}, sort_keys=False))
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    assert f"{path}: fem.fields: field files are written for single-body scenes only" in result.output
    assert list(tmp_path.iterdir()) == [path]


# --- 5. the energy balance -----------------------------------------------------------------------


def test_energy_balance_error_is_work_against_the_change_of_energy():
    """``max |E − E(0) − W| / max(|E|, |W|)``: a closed system's drift, a driven one's mismatch; NaN left out."""
    assert energy_balance_error([10.0, 10.0, 9.9]) == pytest.approx(0.01)
    assert energy_balance_error([0.0, 1.0, 2.0], [0.0, 1.0, 2.5]) == pytest.approx(0.2)
    assert energy_balance_error([5.0, 4.0, math.nan], [0.0, -1.0, math.nan]) == 0.0
    assert energy_balance_error([0.0, 0.0]) == 0.0
    with pytest.raises(ValueError, match="one length"):
        energy_balance_error([1.0, 2.0], [0.0])


def test_energy_balance_error_of_finite_histories_is_the_masked_formula():
    """A history without NaN (the path that skips the mask) gives the formula over every sample exactly, closed or
    driven; the same history with a NaN tail gives it over the samples before the tail."""
    rng = np.random.default_rng(3)
    energy, work = rng.standard_normal(40), rng.standard_normal(40)

    def formula(e, w):
        return float(np.max(np.abs(e - e[0] - w)) / max(np.max(np.abs(e)), np.max(np.abs(w))))

    assert energy_balance_error(energy) == formula(energy, np.zeros(40))
    assert energy_balance_error(energy, work) == formula(energy, work)
    tailed = np.concatenate([energy[:25], np.full(15, math.nan)])
    assert energy_balance_error(tailed, work) == formula(energy[:25], work[:25])


def test_a_rigid_two_mass_impact_on_a_linear_spring_conserves_energy_to_round_off():
    """Newmark's average acceleration on two rigid cars and a bilateral spring: kinetic + stored stays at the
    initial kinetic energy to round-off, and the spring force's work on the cars is their loss of kinetic energy."""
    compiled, reference_run = both(two_cars(Coupling(KelvinVoigt(4.0e7), "bilateral"), (6.0e4, 5.0e4), 2.0, "rigid", 0.3), 5e-4)
    assert_same_run(compiled, reference_run)
    e = reference_run.energy
    kinetic0 = 0.5 * 6.0e4 * 2.0**2
    assert e["kinetic"][0] == pytest.approx(kinetic0, rel=1e-15)
    np.testing.assert_allclose(e["kinetic"] + e["coupler_stored"], kinetic0, rtol=1e-13)
    assert np.max(e["coupler_stored"]) > 0.5 * 0.5 * 6.0e4 * 5.0e4 / 1.1e5 * 2.0**2  # the spring takes most of the relative energy
    assert reference_run.energy_balance_error < 1e-13 and reference_run.car_energy_balance_error < 1e-13


def test_a_kelvin_voigt_impact_dissipates_the_kinetic_energy_it_takes():
    """Compression only, rigid cars: once the cars have separated the coupler stores nothing and has dissipated
    exactly the kinetic energy lost, which is the closed form's to O(dt²)."""
    scene = two_cars(Coupling(KelvinVoigt(4.0e7, 3.0e5)), (6.0e4, 5.0e4), 2.0, "rigid", 0.3)
    compiled, reference_run = both(scene, 2.5e-4)
    assert_same_run(compiled, reference_run)
    e = reference_run.energy
    lost = e["kinetic"][0] - e["kinetic"][-1]
    assert e["coupler_stored"][-1] == 0.0 and reference_run.couplers["c1"]["force"][-1] == 0.0
    assert e["coupler_dissipated"][-1] == pytest.approx(lost, rel=1e-12)
    assert reference_run.coupler_work[-1] == pytest.approx(lost, rel=1e-12)  # the coupler forces' work on the cars is −lost
    exact = kelvin_voigt_impact(ImpactPair(6.0e4, 5.0e4, 2.0), 4.0e7, 3.0e5, np.array([0.3]), contact="compression_only")
    kinetic_end = 0.5 * 6.0e4 * exact.hammer_velocity[-1] ** 2 + 0.5 * 5.0e4 * exact.anvil_velocity[-1] ** 2
    assert lost == pytest.approx(e["kinetic"][0] - kinetic_end, rel=1e-4)
    assert reference_run.energy_balance_error < 1e-13 and reference_run.car_energy_balance_error < 1e-13
