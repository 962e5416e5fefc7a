"""One BLAS thread around the stepping.

A run steps small operators many times; OpenBLAS's default of one thread per core makes
each small product pay a thread hand-off (a 1e4-element car stepped with scipy's products
ran about 7× slower with two threads than with one), and the workers of a sweep, one per
core, would contend for the same cores. :func:`one_blas_thread` limits BLAS to one thread
for a ``with`` block. The libraries are inspected once per process (about a millisecond);
each limit then costs tens of microseconds.
"""

from __future__ import annotations

from contextlib import AbstractContextManager

from threadpoolctl import ThreadpoolController

_controller: ThreadpoolController | None = None


def one_blas_thread() -> AbstractContextManager:
    """A context in which BLAS runs on one thread (restored on exit)."""
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")


__all__ = ["one_blas_thread"]
