"""The compiled stepping kernels of an impact (numba ``@njit``): the readable Python steppers' twins.

Each module here is held by the tests to the readable reference engine
(``tests/support/reference_engine``), to round-off, with no Python per step. Import the module you need.

Importing this package puts femref's cache locator first among numba's (the kernels' cache
folder and the stamp that keeps it true: :mod:`femref.impact.kernels.cache`) and removes
cached machine code of other sources (copying in what the wheel compiled at its build), before
any kernel is decorated.
"""

from __future__ import annotations

from femref.impact.kernels.cache import cache_directory, install_locator, refresh_cache
from femref.impact.kernels.sources import engine_stamp

install_locator()
refresh_cache()

__all__ = ["cache_directory", "engine_stamp"]
