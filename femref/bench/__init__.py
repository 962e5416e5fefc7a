"""The speed–accuracy trade of the impact models (docs/design.md §7, ``femref bench``).

The folder is the data flow: :mod:`~femref.bench.configurations` decides which runs to
make and the reference, :mod:`~femref.bench.run` times and scores them,
:mod:`~femref.bench.pareto` finds the configurations no other beats on both time and
error, :mod:`~femref.bench.output` writes the HDF5 table and the plot; the command is
:mod:`femref.cli.bench`.
"""

from femref.bench.configurations import BenchPlan, Configuration, bench_plan
from femref.bench.pareto import pareto_mask
from femref.bench.run import BenchOutcome, BenchRow, ReferenceFailed, run_bench

__all__ = ["BenchOutcome", "BenchPlan", "BenchRow", "Configuration", "ReferenceFailed", "bench_plan", "pareto_mask", "run_bench"]
