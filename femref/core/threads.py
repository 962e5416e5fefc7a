"""One BLAS thread around the stepping.

A run steps small operators many times; OpenBLAS's default of one thread per core makes
each small product pay a thread hand-off, and the workers of a sweep, one per core, would
contend for the same cores. :func:`one_blas_thread` limits BLAS to one thread for a ``with``
block. The libraries are found once per process (threadpoolctl); each limit then sets and
restores their thread counts directly (threadpoolctl's own ``limit`` inspects every library
again, ~60 µs, a tenth of a rigid run).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

_blas: list | None = None


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """A context in which BLAS runs on one thread (each library's count restored on exit)."""
    global _blas
    if _blas is None:
        _blas = ThreadpoolController().select(user_api="blas").lib_controllers
    previous = [library.num_threads for library in _blas]
    for library, threads in zip(_blas, previous):
        if threads != 1:
            library.set_num_threads(1)
    try:
        yield
    finally:
        for library, threads in zip(_blas, previous):
            if threads != 1:
                library.set_num_threads(threads)


__all__ = ["one_blas_thread"]
