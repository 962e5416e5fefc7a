"""The one runner, and what every caller of it shares.

* :mod:`.runner` — :func:`run_scene` (every model of a scene, estimators, scores) and
  :func:`run_model` (one impact run at a given step);
* :mod:`.measured` — a measured case, event by event: its estimators, closure, wear and alarm;
* :mod:`.capture` — the never-raising call that times a model and records its failure;
* :mod:`.timestep` — every automatic time-step rule;
* :mod:`.scoring` — every score against the reference, one naming.
"""

from femref.run.runner import RunOutcome, load_compiled_loop, run_model, run_scene

__all__ = ["RunOutcome", "load_compiled_loop", "run_model", "run_scene"]
