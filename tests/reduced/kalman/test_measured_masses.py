"""Each car's own mass tolerance in the kalman band (issue 32 item 4): the mass corners per car at per-car tolerances.

Against the closed form: accelerations cannot tell a heavier car under a larger force, so the force the records imply
scales with the mass, and the mass part of the band at the peak is ``m P`` to first order. And against the previous
path: one tolerance for every car through the sequence gives what ``car_mass_corners=True`` gave.
"""

from __future__ import annotations

import numpy as np
import pytest

from reduced.kalman import estimate_forces, estimate_forces_with_variants, forced_response
from tests.reduced.kalman.test_consist import line, line_record
from tests.reduced.test_kalman import NOISE


@pytest.fixture(scope="module")
def two_cars():
    """Two instrumented cars (119 t into 100 t), the record of a smooth coupler-force pulse with sensor noise."""
    model = line((119.0e3, 100.0e3), (True, True))
    t, forces = line_record(model, 300)
    y = forced_response(model, t, forces[:, :1]) + NOISE * np.random.default_rng(5).standard_normal((t.size, 4))
    return model, t, y


def _mass_part(model, t, y, tolerances) -> tuple[float, float, float]:
    """(peak, upper and lower mass parts of the band at the peak) with only the per-car mass corners at ``tolerances``."""
    (band,) = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", car_mass_corners=tolerances)
    nominal = band.nominal
    return nominal.peak_force, band.peak_upper - nominal.peak_upper, nominal.peak_lower - band.peak_lower


@pytest.mark.parametrize("tolerance", [0.001, 0.005, 0.05])
def test_the_mass_part_of_the_band_is_the_tolerance_times_the_peak(two_cars, tolerance):
    """Both cars measured to ±m: the band at the peak widens by ``m P`` each way, the remainder second order
    (``≤ 1.2 m² P``; measured ``≈ m² P``: the corners are taken to first order); each car's own corner widens it (the two
    cars' shifts share their sign, as one scale of both masses needs)."""
    model, t, y = two_cars
    peak, up, down = _mass_part(model, t, y, [tolerance, tolerance])
    assert abs(up - tolerance * peak) <= 1.2 * tolerance**2 * peak
    assert abs(down - tolerance * peak) <= 1.2 * tolerance**2 * peak
    assert all(_mass_part(model, t, y, corners)[1] > 0.3 * up for corners in ([tolerance, 0.0], [0.0, tolerance]))


def test_one_tolerance_per_car_is_the_common_tolerance_path():
    """Three cars, every car at the same tolerance through the sequence: the band equals ``car_mass_corners=True``'s
    bit for bit; a car at 0 is no run; a sequence of the wrong length is refused."""
    model = line((119.0e3, 100.0e3, 90.0e3), (True, True, True))
    t, force = line_record(model, 200)
    y = forced_response(model, t, force) + NOISE * np.random.default_rng(3).standard_normal((t.size, 6))
    common = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", mass_tolerance=0.02, car_mass_corners=True)
    per_car = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", mass_tolerance=0.02,
                                            car_mass_corners=[0.02, 0.02, 0.02])
    for a, b in zip(common, per_car):
        np.testing.assert_array_equal(a.lower, b.lower)
        np.testing.assert_array_equal(a.upper, b.upper)
        assert (a.peak_lower, a.peak_upper) == (b.peak_lower, b.peak_upper)
    one = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", car_mass_corners=[0.0, 0.02, 0.0])
    assert all(len(band.variant_status) == 1 + 2 for band in one)
    with pytest.raises(ValueError, match="one tolerance per car of the model \\(3\\), got 2"):
        estimate_forces_with_variants([model], t, y, NOISE, car_mass_corners=[0.02, 0.02])
    alone = estimate_forces(model, t, y, NOISE, noise_scale="estimated")
    none = estimate_forces_with_variants([model], t, y, NOISE, variant_force_rate="nominal", car_mass_corners=[0.0, 0.0, 0.0])
    for band, nominal in zip(none, alone):
        np.testing.assert_array_equal(band.upper, nominal.upper)
