"""The compiled stepping kernels of an impact (numba ``@njit``): the readable Python steppers' twins.

Each module here reproduces a reference of :mod:`femref.impact` to round-off with no Python
per step, and the tests hold it to that reference: :mod:`.couplers` the coupler laws of
:mod:`reduced.couplers` (packed once per scene into arrays) and the coupler iteration of one
step, :class:`femref.impact.couplers.CouplerSolve` (Newton, its Gauss–Seidel fallback, the
energy bookkeeping); :mod:`.cars` the cars' steppers, on the pool of :mod:`.pool` (every car
of a run in two arrays, and the linear algebra on it) that :mod:`.packing` fills; :mod:`.loop`
the time loop that calls both. Import the module you need.

**The on-disk cache is kept true here.** numba's cache (``cache=True``) checks only the
file that defines a function, so after an edit of ``couplers.py`` the cached loop of
``loop.py``, which calls it, would run the old coupler code (it happened). Importing this
package compares a stamp of every module's source (modification time and size) with the one
the cache was written with and, if any changed, removes this package's cached machine code
so that everything compiles afresh.
"""

from __future__ import annotations

from pathlib import Path


def _discard_stale_cache() -> None:
    """Remove ``__pycache__/*.nbi|*.nbc`` of this package when any module's source changed since they were written."""
    here = Path(__file__).parent
    cache = here / "__pycache__"
    stamp = " ".join(f"{p.name}:{p.stat().st_mtime_ns}:{p.stat().st_size}" for p in sorted(here.glob("*.py")))
    recorded = cache / "kernels.stamp"
    try:
        if recorded.read_text() == stamp:
            return
    except OSError:
        pass
    try:
        cache.mkdir(exist_ok=True)
        for path in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            path.unlink(missing_ok=True)
        recorded.write_text(stamp)
    except OSError:  # a read-only install: numba caches elsewhere, and the sources do not change
        pass


_discard_stale_cache()
