"""The sided state of a bilateral draft gear with slack (reduced.couplers.Coupling.state_mirrored, reduced.nonlinear).

The gear pack is compressed in buff and in draft alike; the signed state ``x_g`` says which
side compressed it last. A pack still compressed from buff when the cars run through the
free play into draft is picked up by the yoke as a free pack: its residual compression is
extra free play, and the force rises from zero. In the signed model this is the mirror
``x_g → −x_g`` where the open contact passes into the other side's slack boundary
(``x_g > 0`` and ``δ + s_t < 0``, or ``x_g < 0`` and ``δ − s_c > 0``). Before, the tension
contact engaged with a force jump from 0 to ``−x_g/D`` (−2.04 MN in the scene below) and
``x_g²/(2D)`` appeared from nothing, booked as negative dissipation (−6.8 kJ).

Independent check: with the pack compression ``a = |x_g|`` the same physics is the
memoryless-in-sign system ``P = max(0, (δ − s_c − a)/D) + min(0, (δ + s_t + a)/D)``,
``μ ȧ = |P| − F_g(a)``, integrated here by brute force without events.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from reduced.couplers import Coupling, KelvinVoigt, StandardLinearDraftGear
from reduced.nonlinear import simulate_impact
from reduced.rigid import ImpactPair

GEAR = StandardLinearDraftGear(4.0e8, 4.0e8, 1.7e7, 2.5e5, 0.05, 1.0e8)  # the gear of tests/impact/test_robustness.py
PAIR = ImpactPair(119.0e3, 100.0e3, 3.0)
SLACK = 0.005
BILATERAL = Coupling(GEAR, "bilateral", SLACK, SLACK)
T = np.linspace(0.0, 0.35, 3501)


@pytest.fixture(scope="module")
def run():
    result = simulate_impact(PAIR, BILATERAL, T)
    assert result.status == "ok", result.message
    return result


# --- the rule ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "closure, state, mirrored",
    [
        (-0.0051, 0.01, True),  # buff compression beyond the tension boundary
        (-0.3, 1e-9, True),
        (0.0051, -0.01, True),  # draft compression beyond the compression boundary
        (-0.0051, -0.01, False),  # already of the side's sign
        (0.0051, 0.01, False),
        (-0.0051, 0.0, False),  # nothing to mirror
        (0.0051, -0.0, False),
        (0.0, 0.01, False),  # in the free play
        (-0.004, 0.01, False),
        (0.004, -0.01, False),
        (-0.005, 0.01, False),  # on the boundary itself (the contact is open on both sides of it)
        (0.005, -0.01, False),
    ],
)
def test_the_state_is_mirrored_only_beyond_the_other_sides_boundary(closure: float, state: float, mirrored: bool):
    s = np.array([state])
    assert BILATERAL.mirrors_state
    assert BILATERAL.state_mirrored(closure, s) is mirrored
    np.testing.assert_array_equal(BILATERAL.sided_state(closure, s), -s if mirrored else s)


@pytest.mark.parametrize(
    "coupling",
    [
        Coupling(GEAR),  # compression only: no other side
        Coupling(GEAR, slack=0.005),
        Coupling(GEAR, "bilateral"),  # no slack: the signed law passes through zero under load
        Coupling(KelvinVoigt(4e7, 3e5), "bilateral", 0.005, 0.005),  # no state
    ],
    ids=["compression_only", "compression_only_slack", "bilateral_no_slack", "stateless"],
)
def test_the_rule_is_void_without_a_second_side_without_slack_and_without_a_signed_state(coupling: Coupling):
    assert not coupling.mirrors_state
    for closure in (-0.2, -0.0051, 0.0, 0.0051, 0.2):
        for state in (-0.06, -0.01, 0.0, 0.01, 0.06):
            s = np.full(coupling.law.state_size, state)
            assert not coupling.state_mirrored(closure, s)
            np.testing.assert_array_equal(coupling.sided_state(closure, s), s)


def test_one_sided_slack_mirrors_at_the_side_with_slack_and_at_zero_on_the_other():
    coupling = Coupling(GEAR, "bilateral", 0.0, 0.01)
    assert coupling.mirrors_state
    assert coupling.state_mirrored(1e-6, np.array([-0.01])) and not coupling.state_mirrored(0.0, np.array([-0.01]))
    assert coupling.state_mirrored(-0.0101, np.array([0.01])) and not coupling.state_mirrored(-0.0099, np.array([0.01]))


@pytest.mark.parametrize("state", [0.0, 0.01, 0.05, 0.07, 0.12])
def test_the_mirror_keeps_the_gear_energy_and_commutes_with_the_open_relaxation(state: float):
    """``F_g`` odd (open and solid pieces): the open contact's ``ẋ_g = −F_g/μ`` is odd, the gear energy and the
    dissipation rate even, to rounding."""
    s = np.array([state])
    m = GEAR.mirror_state(s)
    np.testing.assert_array_equal(m, -s)
    assert GEAR.gear_spring(float(m[0]))[0] == -GEAR.gear_spring(state)[0]
    assert GEAR.state_rate(0.0, 0.0, m, 0.0)[0] == -GEAR.state_rate(0.0, 0.0, s, 0.0)[0]
    assert GEAR.stored_energy(0.0, m, False) == pytest.approx(GEAR.stored_energy(0.0, s, False), rel=1e-15, abs=0.0)
    assert GEAR.dissipation_rate(0.0, 0.0, m, 0.0, False) == GEAR.dissipation_rate(0.0, 0.0, s, 0.0, False)


def test_the_sided_state_engages_from_zero_where_the_stale_one_jumps():
    """Along the tension side with a 10 mm buff compression: the stale state engages at once with
    ``(δ_e − x_g)/D`` ≈ −2 MN; the mirrored one stays open for another |x_g| of travel and then
    loads from zero along ``(δ_e + |x_g|)/D`` — continuous, the residual compression as free play."""
    x = 0.01
    d = GEAR.series_compliance
    stale = BILATERAL.evaluate(-SLACK - 1e-9, -2.5, np.array([x]))
    assert stale.mode == -1 and stale.force == pytest.approx(-(1e-9 + x) / d, rel=1e-12)
    forces = []
    closures = -SLACK - np.linspace(1e-9, 2.0 * x, 2001)
    for closure in closures:
        state = BILATERAL.sided_state(closure, np.array([x]))
        assert state[0] == -x
        forces.append(BILATERAL.evaluate(closure, -2.5, state).force)
    forces = np.array(forces)
    expected = np.minimum(0.0, (closures + SLACK + x) / d)
    np.testing.assert_allclose(forces, expected, rtol=0.0, atol=1e-6 * x / d)
    assert np.max(np.abs(np.diff(forces))) <= 1.0001 * (closures[0] - closures[1]) / d  # no step beyond the spring's


# --- the ODE driver --------------------------------------------------------------------------


def test_the_ode_mirrors_at_the_boundary_and_engages_from_zero_force(run):
    """The events: buff contact, gear solid, separation with the gear still compressed 33.7 mm; the
    mirror exactly at the tension boundary (no force, the gear energy kept); the tension contact
    where ``δ + s_t = x_g`` (mirrored), i.e. after another |x_g| = 8.16 mm of travel, with zero force;
    the same on the way back into buff."""
    kinds = [e.kind for e in run.events]
    assert kinds[:4] == ["contact", "gear_closed", "gear_reopened", "separation"]
    assert kinds.count("gear_mirrored") == 2
    for k, event in enumerate(run.events):
        if event.kind != "gear_mirrored":
            continue
        after = run.events[k + 1]
        assert after.kind in ("tension_contact", "contact")
        if after.kind == "tension_contact":
            assert event.closure == pytest.approx(-SLACK, abs=1e-12) and event.coupler_state[0] < -1e-3
            assert after.closure + SLACK - after.coupler_state[0] == pytest.approx(0.0, abs=1e-12)  # (δ_e − x_g)/D = 0
        else:
            assert event.closure == pytest.approx(SLACK, abs=1e-12) and event.coupler_state[0] > 1e-3
            assert after.closure - SLACK - after.coupler_state[0] == pytest.approx(0.0, abs=1e-12)
        assert event.coupler_force == 0.0 and abs(after.coupler_force) < 1e-3
    tension = next(e for e in run.events if e.kind == "tension_contact")
    assert tension.time == pytest.approx(0.129574, abs=1e-6) and tension.coupler_state[0] == pytest.approx(-0.0081553, abs=1e-7)


def test_the_ode_force_is_continuous_and_its_energy_books_close(run):
    """At 0.1 ms samples the force never steps by more than the series springs' (|δ̇| + |ẋ_g|)·dt/D
    (1.1e5 N; measured 5.7e4 N, before: a 2.04 MN jump at the tension contact); dissipation never
    decreases (before: −6.8 kJ at each engagement); the energy balance closes to 1e-8 of the impact energy."""
    dt = T[1] - T[0]
    gear_rate = [(p - GEAR.gear_spring(float(x))[0]) / GEAR.gear_damping for p, x in zip(run.coupler_force, run.coupler_state[:, 0])]
    bound = (np.max(np.abs(run.relative_velocity)) + np.max(np.abs(gear_rate))) * dt / GEAR.series_compliance
    assert np.max(np.abs(np.diff(run.coupler_force))) < bound
    assert np.min(run.coupler_force) < -3.5e6 and np.max(run.coupler_force) > 4.9e6  # draft and buff
    assert np.all(np.diff(run.dissipated_energy) >= -1e-9 * PAIR.kinetic_energy)
    assert np.max(np.abs(run.energy_residual)) <= 1e-8 * PAIR.kinetic_energy


def test_the_ode_is_the_pack_model_integrated_by_brute_force(run):
    """``a = |x_g|``: ``P = max(0, (δ − s_c − a)/D) + min(0, (δ + s_t + a)/D)``, ``μ ȧ = |P| − F_g(a)``,
    by LSODA at rtol 1e-11 with 20 μs steps and no events: force within 1e-7 of its peak (measured 3e-9),
    |x_g| and the closure within 1e-9 m (measured 1e-10)."""
    d, mu, m = GEAR.series_compliance, GEAR.gear_damping, PAIR.reduced_mass

    def pack(y) -> float:
        return max(0.0, (y[0] - SLACK - y[2]) / d) + min(0.0, (y[0] + SLACK + y[2]) / d)

    def rhs(_t, y):
        p = pack(y)
        return [y[1], -p / m, (abs(p) - GEAR.gear_spring(float(y[2]))[0]) / mu]

    sol = solve_ivp(rhs, (0.0, T[-1]), [0.0, PAIR.closing_speed, 0.0], method="LSODA", rtol=1e-11,
                    atol=[1e-14, 1e-12, 1e-14], max_step=2e-5, dense_output=True)
    y = sol.sol(T)
    force = np.array([pack(y[:, k]) for k in range(T.size)])
    assert np.max(np.abs(force - run.coupler_force)) <= 1e-7 * np.max(np.abs(force))
    assert np.max(np.abs(y[2] - np.abs(run.coupler_state[:, 0]))) <= 1e-9
    assert np.max(np.abs(y[0] + run.relative_displacement)) <= 1e-9


def test_the_draft_side_is_the_mirror_image_of_the_buff_side():
    """The cars opening at 3 m/s through slack (s_c, s_t) = (3, 7) mm against closing through (7, 3) mm:
    closure, force and gear state are each other's negatives (the rule is the same on both sides)."""
    t = np.linspace(0.0, 0.3, 601)
    closing = simulate_impact(PAIR, Coupling(GEAR, "bilateral", 0.007, 0.003), t)
    opening = simulate_impact(ImpactPair(119.0e3, 100.0e3, 0.0, 3.0), Coupling(GEAR, "bilateral", 0.003, 0.007), t)
    assert closing.status == opening.status == "ok"
    assert [e.kind for e in closing.events].count("gear_mirrored") >= 1
    flipped = {"contact": "tension_contact", "tension_contact": "contact", "separation": "tension_separation",
               "tension_separation": "separation", "gear_closed": "gear_closed_tension", "gear_closed_tension": "gear_closed",
               "gear_reopened": "gear_reopened_tension", "gear_reopened_tension": "gear_reopened", "gear_mirrored": "gear_mirrored"}
    assert [flipped[e.kind] for e in opening.events] == [e.kind for e in closing.events]
    peak = np.max(np.abs(closing.coupler_force))
    np.testing.assert_allclose(opening.coupler_force, -closing.coupler_force, rtol=0.0, atol=1e-7 * peak)
    np.testing.assert_allclose(opening.relative_displacement, -closing.relative_displacement, rtol=0.0, atol=1e-10)
    np.testing.assert_allclose(opening.coupler_state, -closing.coupler_state, rtol=0.0, atol=1e-10)


@pytest.mark.parametrize(
    "coupling, external",
    [
        (Coupling(GEAR, "compression_only", 0.005), None),
        (Coupling(GEAR, "bilateral"), lambda t: (1.0e5 * (t < 0.3), 0.0)),
    ],
    ids=["compression_only_slack", "bilateral_no_slack"],
)
def test_where_the_state_keeps_its_sides_sign_nothing_is_mirrored(coupling: Coupling, external):
    """Compression only (x_g ≥ 0 throughout) and bilateral without slack (x_g from +91 to −78 mm through
    zero under load, the signed law): no mirror event, and the rule holds false at every sample."""
    run = simulate_impact(PAIR, coupling, T, external_force=external)
    assert run.status == "ok"
    assert "gear_mirrored" not in [e.kind for e in run.events]
    assert not any(coupling.state_mirrored(-x, s) for x, s in zip(run.relative_displacement, run.coupler_state))
