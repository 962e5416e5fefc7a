"""The one never-raising call: run a model's work, time it, and turn any exception into a failed result.

Every caller — ``femref run``, the choice ladder, the bench, sweep workers — runs models
through :func:`capture`, so a failing model is recorded with its message and wall time
and the other models still run.
"""

from __future__ import annotations

import time
from typing import Callable

from femref.results import ModelResult


def capture(name: str, work: Callable[[], ModelResult]) -> ModelResult:
    """``work()`` with its wall time (s) in ``wall_time_s``; an exception becomes ``ModelResult.failed(name, …)``."""
    started = time.perf_counter()
    try:
        result = work()
    except Exception as error:  # recorded as the model's status, never swallowed silently
        return ModelResult.failed(name, f"{type(error).__name__}: {error}", time.perf_counter() - started)
    result.wall_time_s = time.perf_counter() - started
    return result


__all__ = ["capture"]
