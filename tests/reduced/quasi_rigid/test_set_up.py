"""The quasi-rigid set-up against the previous build's answer (issue 31: vectorised, not re-derived).

``data/set_up_tables.npz`` holds every table of :func:`support.quasi_rigid_tables.tables` as the build before issue 31
computed them (a Gauss rule per node mapped onto its partial panel, numpy's Gauss–Legendre rule) for bodies with
profile jumps: exactly grouped and interpolated time constants, a rod and a beam, the undeformed stepper's step
matrices, a harmonic and a transient response. The build now integrates the interpolant of ψ through each panel's
nodes and takes the Golub–Welsch rule: the same numbers to rounding.
"""

import numpy as np
import pytest

from support.quasi_rigid_tables import STORED, tables

STORED_TABLES = np.load(STORED)


@pytest.fixture(scope="module")
def built():
    return tables()


@pytest.mark.parametrize("name", STORED_TABLES.files)
def test_set_up_tables_equal_the_previous_build_to_rounding(built, name):
    stored = STORED_TABLES[name]
    scale = np.max(np.abs(stored[np.isfinite(stored)]))
    assert built[name].shape == stored.shape
    np.testing.assert_array_equal(np.isfinite(built[name]), np.isfinite(stored))
    finite = np.isfinite(stored)
    np.testing.assert_allclose(built[name][finite], stored[finite], rtol=0.0, atol=1e-13 * scale)
