"""The automatic time-step rules (femref.run.timestep) on bodies whose wave speeds are known."""

import math

import pytest

from femref.core.body import Body
from femref.core.profiles import Piecewise, Uniform
from femref.core.signals import HalfSine
from femref.fem.build import FemSettings
from femref.run.timestep import GIVEN, MESH_RULE, mesh_transit_time, single_body_time_step
from femref.scene import Scene

L, M, EA = 8.0, 6000.0, 3.0e9


def body(kind: str = "rod", mass=Uniform(M)) -> Body:
    return Body(kind, L, mass, Uniform(EA), Uniform(1.0e6), L * math.sqrt(M / EA))


def test_rod_transit_time_is_the_average_element_over_the_wave_speed():
    """T_h = (2l/N)/√(EA/m) for a uniform rod, whatever the grading (the average element, not the shortest)."""
    expected = 2.0 * L / 32 / math.sqrt(EA / M)
    assert mesh_transit_time(body(), FemSettings(elements=32)) == pytest.approx(expected, rel=1e-14)
    assert mesh_transit_time(body(), FemSettings(elements=32, grading=3.0)) == pytest.approx(expected, rel=1e-14)


def test_beam_transit_time_is_h_squared_over_the_bending_speed():
    """Beam: T_h = h²·√(m/EI) with h = 2l/N."""
    h = 2.0 * L / 20
    assert mesh_transit_time(body("beam"), FemSettings(elements=20)) == pytest.approx(h * h * math.sqrt(M / EA), rel=1e-14)


def test_the_fastest_segment_sets_the_speed():
    """Lading in the middle (5× the mass): the light ends carry the fastest wave, c = √(EA/m_end)."""
    lading = Piecewise((-4.0, 4.0), (M, 5.0 * M, M))
    assert mesh_transit_time(body(mass=lading), FemSettings(elements=16)) == pytest.approx(2.0 * L / 16 / math.sqrt(EA / M), rel=1e-14)


def scene(dt=None, duration=0.1, end=1.0, elements=64) -> Scene:
    return Scene("transient", body(), {"center": 0.0}, {"F2": HalfSine(1.0e6, duration, 0.0)}, ("fem",), FemSettings(elements=elements), end=end, dt=dt)


def test_single_body_step_takes_the_smallest_candidate_and_names_it():
    """min(T_load/100, T_h, end/20): a coarse mesh and a long pulse give the mesh rule, a short pulse the load rule."""
    dt, rule = single_body_time_step(scene(duration=2.0, elements=4))
    assert (dt, rule) == (pytest.approx(mesh_transit_time(body(), FemSettings(elements=4))), f"automatic: {MESH_RULE}")
    short = scene(duration=1e-3, elements=4)
    dt, rule = single_body_time_step(short)
    assert dt == pytest.approx(short.load_time_scale / 100.0) and rule == "automatic: load time scale / 100"
    assert single_body_time_step(scene(dt=2e-4)) == (2e-4, GIVEN)
