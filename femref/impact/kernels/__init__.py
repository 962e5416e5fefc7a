"""The compiled stepping kernels of an impact (numba ``@njit``): the readable Python steppers' twins.

Each module here is held by the tests to the readable reference engine
(``tests/support/reference_engine``), to round-off, with no Python per step. Import the module you need.

**The on-disk cache is kept true here.** numba's cache (``cache=True``) checks only the
file that defines a function, so after an edit of ``couplers.py`` the cached loop of
``loop.py``, which calls it, would run the old coupler code (it happened), and the compiled
laws are the law modules' functions, outside this package. Importing this package compares a
stamp — a hash of this package's sources and of every source file the compiled laws are made
of (:func:`.laws.engine_sources`: the registered law modules and what they call) — with the one
the cache was written with and, if it differs (a module or a law edited, a law added), removes
this package's cached machine code so that everything compiles afresh.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba


def cache_directory() -> Path:
    """Where numba caches this package's kernels: ``__pycache__`` beside them, or under ``NUMBA_CACHE_DIR``."""
    here = Path(__file__).parent
    if not numba.config.CACHE_DIR:
        return here / "__pycache__"
    from numba.core.caching import _CacheLocator  # noqa: PLC0415 (numba's own rule for the subdirectory)

    return Path(numba.config.CACHE_DIR).absolute() / _CacheLocator.get_suitable_cache_subpath(str(here / "laws.py"))


def engine_stamp() -> str:
    """A hash of this package's sources and of the compiled laws' source files (module docstring)."""
    from femref.impact.kernels.laws import engine_sources  # noqa: PLC0415 (the package is initialising)

    here = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted(set(here.glob("*.py")) | set(engine_sources())):
        digest.update(str(path).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def _discard_stale_cache() -> None:
    """Remove the cached ``*.nbi|*.nbc`` of this package when its stamp (:func:`engine_stamp`) changed since they were written."""
    cache = cache_directory()
    stamp = engine_stamp()
    recorded = cache / "kernels.stamp"
    try:
        if recorded.read_text() == stamp:
            return
    except OSError:
        pass
    try:
        cache.mkdir(parents=True, exist_ok=True)
        for path in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            path.unlink(missing_ok=True)
        recorded.write_text(stamp)
    except OSError:  # a read-only install: numba caches elsewhere, and the sources do not change
        pass


_discard_stale_cache()

__all__ = ["cache_directory", "engine_stamp"]
