"""Parameter sweeps (docs/design.md §6): sweep files, their samples, runs on Dask, the HDF5 sweep file.

>>> from femref.sweep import load_sweep, run_sweep, read_sweep
>>> sweep = load_sweep("cases/sweeps/free_roll_speeds.yaml")               # doctest: +SKIP
>>> run_sweep(sweep, "speeds.h5", workers=2).runs_per_second              # doctest: +SKIP
>>> data = read_sweep("speeds.h5"); data.records["fem"][data.ok].shape     # doctest: +SKIP

The file and its samples (:mod:`~femref.sweep.spec`, :mod:`~femref.sweep.distributions`,
:mod:`~femref.sweep.keypaths`), one sample on a worker (:mod:`~femref.sweep.worker`), the HDF5 file
(:mod:`~femref.sweep.store`), the Dask orchestration (:mod:`~femref.sweep.run`).
dask.distributed is imported when a sweep runs, not when a sweep file is read.
"""

from femref.sweep.run import SweepInterrupted, SweepSummary, run_sweep
from femref.sweep.distributions import DISTRIBUTIONS
from femref.sweep.spec import Sample, Sweep, load_sweep, parse_sweep
from femref.sweep.store import SweepData, read_sweep

__all__ = [
    "DISTRIBUTIONS",
    "Sample",
    "Sweep",
    "SweepData",
    "SweepInterrupted",
    "SweepSummary",
    "load_sweep",
    "parse_sweep",
    "read_sweep",
    "run_sweep",
]
