"""Where the compiled kernels are cached, and the rule that keeps that cache true.

**Where.** numba caches a kernel beside its source by default, which a read-only
site-packages refuses (numba then falls back to a folder of its own choosing). femref
chooses: the kernels of this package are cached in :func:`cache_directory`, a folder named
after the package's folder (its name and a hash of its path: two installs never share one)
under :func:`cache_root` — ``NUMBA_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/femref``,
else ``~/.cache/femref``. A folder that cannot be written leaves the kernels to numba's own
fallback.

**True.** numba stamps a cached function with its own file only (its mtime and size, or in
recent numba its content), so after an edit of ``couplers.py`` the cached loop of ``loop.py``, which calls
it, would run the old coupler code (it happened), and the compiled laws live outside this
package. Every kernel's entry is stamped instead with :func:`~femref.impact.kernels.sources.engine_stamp`
— a hash of this package's sources and of every source the compiled laws are made of, not of
file times, which an install does not keep — so an entry of other sources is never loaded;
:func:`refresh_cache` removes such entries' files when the package is imported.

**Ahead of time.** A wheel built by ``pip install .`` carries the kernels compiled at its build
(:data:`COMPILED`, stamped as above: the stamp names sources relative to the install, so a build
folder's stamp is the installed package's); :func:`refresh_cache` copies them into a cache
folder that holds none of these sources, and numba loads the entries of this machine's CPU (its
index is keyed on the signature and the CPU's name and features: a wheel built on another CPU
compiles on the first run, with the notice).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numba
from numba.core import caching

from femref.impact.kernels.sources import PACKAGE, engine_stamp

COMPILE_SECONDS = 60.0
"""The expected compile time of the loop before one was measured on this machine (s; 28–77 s measured on 2 cores)."""

STAMP_FILE, SECONDS_FILE = "kernels.stamp", "compile.seconds"

COMPILED = PACKAGE / "_compiled"
"""The kernels compiled when the wheel was built (``scripts/femref_build.py``), with their stamp; absent from a
checkout. :func:`refresh_cache` copies them into the cache folder, where numba loads those of this machine's CPU."""


def cache_root() -> Path:
    """``NUMBA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/femref``, else ``~/.cache/femref``."""
    if numba.config.CACHE_DIR:
        return Path(numba.config.CACHE_DIR).absolute()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).absolute() / "femref"


def cache_directory() -> Path:
    """The folder of this package's cached kernels: numba's name for the package's folder under :func:`cache_root`."""
    return cache_root() / caching._CacheLocator.get_suitable_cache_subpath(str(PACKAGE / "laws.py"))


class KernelCacheLocator(caching._CacheLocator):
    """numba's cache locator for the functions of this package: :func:`cache_directory`, stamp :func:`engine_stamp`."""

    def __init__(self, py_func, py_file) -> None:
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(cache_directory())

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> str:
        return engine_stamp()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        """A locator for a function of this package whose cache folder can be written, else None (numba's next)."""
        if Path(py_file).resolve().parent != PACKAGE.resolve():
            return None
        locator = cls(py_func, py_file)
        try:
            locator.ensure_cache_path()
        except OSError:
            return None
        return locator


def install_locator() -> None:
    """Put :class:`KernelCacheLocator` first among numba's cache locators (once)."""
    locators = (getattr(caching, "CacheImpl", None) or caching._CacheImpl)._locator_classes  # numba < 0.62: _CacheImpl
    if KernelCacheLocator not in locators:
        locators.insert(0, KernelCacheLocator)


def refresh_cache() -> None:
    """Keep :func:`cache_directory` to entries of these sources: when its recorded stamp is not :func:`engine_stamp`,
    remove its ``*.nbi|*.nbc`` and copy in the kernels compiled when the wheel was built (:data:`COMPILED`) if they
    carry the same stamp."""
    cache = cache_directory()
    stamp = engine_stamp()
    recorded = cache / STAMP_FILE
    try:
        if recorded.read_text() == stamp:
            return
    except OSError:
        pass
    try:
        cache.mkdir(parents=True, exist_ok=True)
        for path in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
            path.unlink(missing_ok=True)
        if compiled_stamp() == stamp:
            for path in [*COMPILED.glob("*.nbc"), *COMPILED.glob("*.nbi"), *COMPILED.glob(SECONDS_FILE)]:  # indexes after their data
                copy_whole(path, cache / path.name)
        recorded.write_text(stamp)
    except OSError:  # a folder that cannot be written: numba caches elsewhere
        pass


def compiled_stamp() -> str | None:
    """The stamp of the kernels the wheel ships in :data:`COMPILED`, None without them."""
    try:
        return (COMPILED / STAMP_FILE).read_text()
    except OSError:
        return None


def copy_whole(source: Path, target: Path) -> None:
    """Copy ``source`` to ``target`` under a temporary name, then rename: a process reading ``target`` sees it whole."""
    partial = target.with_name(f"{target.name}.{os.getpid()}.partial")
    shutil.copyfile(source, partial)
    os.replace(partial, target)


def cached(dispatchers) -> bool:
    """Whether numba's cache holds an entry of every one of ``dispatchers`` for this machine's CPU (fresh: its index's
    stamp is :func:`engine_stamp`), so that calling them loads rather than compiles."""
    for dispatcher in dispatchers:
        machine = dispatcher.targetctx.codegen().magic_tuple()
        index = dispatcher._cache._cache_file._load_index()  # {(signature, machine, code hashes): data file}; {} if stale
        if not any(key[1] == machine for key in index):
            return False
    return True


def compile_seconds() -> float:
    """The loop's last compile time on this machine (recorded in :func:`cache_directory`), else :data:`COMPILE_SECONDS`."""
    try:
        return float((cache_directory() / SECONDS_FILE).read_text())
    except (OSError, ValueError):
        return COMPILE_SECONDS


def record_compile_seconds(seconds: float) -> None:
    """Record the loop's compile time for :func:`compile_seconds` (nothing if the folder cannot be written)."""
    try:
        (cache_directory() / SECONDS_FILE).write_text(f"{seconds:.1f}")
    except OSError:
        pass


__all__ = [
    "COMPILE_SECONDS",
    "KernelCacheLocator",
    "cached",
    "cache_directory",
    "cache_root",
    "COMPILED",
    "compile_seconds",
    "compiled_stamp",
    "copy_whole",
    "install_locator",
    "record_compile_seconds",
    "refresh_cache",
]
