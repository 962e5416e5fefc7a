"""One run flow for every case: simulate, choose or measure, decided once (docs/design.md §5).

``femref run`` and :func:`femref.api.run_case` both go through here, in two steps with the
output check between them (the caller's: the CLI names ``-o`` and exits 2, the API raises):
:func:`plan_case` decides the flow and checks its work budget, :func:`run_plan` runs it and writes
its result file. Nothing here prints or exits: notes come back in :attr:`CasePlan.notes`, failures
in the outcome or as exceptions, and the caller says them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from femref.models import ProgressFor

#: The flows a case runs by.
Flow = Literal["simulate", "choose", "measure"]


@dataclass(frozen=True)
class CasePlan:
    """A validated case (its tolerance applied), its scene, the flow it runs by and the notes to say before it runs."""

    case: Any
    scene: Any
    flow: Flow
    source: str
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class CaseOutcome:
    """What a case's run gave: exactly one of ``run`` (simulate: :class:`femref.run.RunOutcome`), ``choice``
    (choose: :class:`femref.choice.ModelChoice`) or ``measured`` (measure: :class:`femref.run.measured.MeasuredOutcome`),
    and the files written (empty without an output)."""

    flow: Flow
    written: tuple[Path, ...] = ()
    run: Any = None
    choice: Any = None
    measured: Any = None

    @property
    def failures(self) -> list[tuple[str, str]]:
        """``(what, message)`` of every model that failed (a simulated run's only)."""
        return [(f"model {failed.model}", failed.message) for failed in self.run.failed] if self.run is not None else []


def plan_case(case, base_dir: Path, source: str, tolerance: float | None = None) -> CasePlan:
    """``case`` with ``tolerance`` in its ``tolerance.value``, its scene and its flow, the flow's budget checked.

    Raises :class:`femref.case.CaseError` naming ``source``: a tolerance on a case that is not an impact,
    a scene that cannot be built, runs over the work budget (:func:`femref.run.budget.check_budget`, or for a
    choice every rung of the ladder it may climb: :func:`femref.choice.check_ladder_budget`)."""
    from femref.run.budget import check_budget
    from femref.scene.build import scene_from_case

    case = with_tolerance(case, tolerance, source)
    scene = scene_from_case(case, base_dir)
    flow: Flow = "measure" if case.kind == "measured" else "choose" if case.kind == "impact" and case.tolerance is not None else "simulate"
    if flow == "choose":
        from femref.choice import check_ladder_budget  # the ladder's modules only where a model is chosen

        check_ladder_budget(scene, source)
    else:
        check_budget(scene, source)
    notes = ()
    if flow == "choose" and (scene.estimators or scene.networks):
        notes = ("with a tolerance the estimators are not run (they read the records of the models list's fem run)",)
    return CasePlan(case, scene, flow, source, notes)


def with_tolerance(case, tolerance: float | None, source: str):
    """The case with ``tolerance`` in its ``tolerance.value`` (kept in the resolved case of the result file)."""
    from femref.case import CaseError, Problem
    from femref.case.runs import ToleranceSpec

    if tolerance is None:
        return case
    if case.kind != "impact":
        rule = "--tolerance: model choice serves impact cases (the ladder of impact models)"
        raise CaseError(Problem(("kind",), rule, case.kind), source)
    spec = ToleranceSpec(value=tolerance) if case.tolerance is None else ToleranceSpec(value=tolerance, output=case.tolerance.output)
    return case.model_copy(update={"tolerance": spec})


def run_plan(plan: CasePlan, output: Path | None = None, progress_for: ProgressFor | None = None) -> CaseOutcome:
    """Run ``plan`` by its flow and, with ``output`` (checked by the caller), write its result file atomically.

    A measured case's events go into the output's temporary as they finish and the outcome keeps their
    summaries (without histories); without ``output`` they keep their histories. Raises what the flow
    raises: a RecordError (a record changed since validation) or CaseError (the events over the budget)
    for a measured case, leaving nothing under ``output``; a RuntimeError when no rung of the ladder ran."""
    from femref.case import resolved_yaml

    case, scene = plan.case, plan.scene
    if plan.flow == "measure":
        from femref.events import event_file
        from femref.run.measured import run_measured

        if output is None:
            return CaseOutcome("measure", measured=run_measured(scene, progress_for, source=plan.source))
        with event_file(output, scene.facts(), resolved_yaml(case)) as write:
            measured = run_measured(scene, progress_for, sink=write, source=plan.source)
        return CaseOutcome("measure", (output,), measured=measured)
    from femref.results import write_results

    if plan.flow == "choose":
        from femref.choice import choose_model, run_rung
        from femref.choice.output import write_choice

        def runner(rung):
            return run_rung(rung, progress_for(rung.label) if progress_for else None)

        choice = choose_model(scene, case.tolerance.value, case.tolerance.output, runner=runner, source=plan.source, budget_checked=True)
        written = () if output is None else tuple(
            write_results(output, resolved_yaml(case), choice.results, extra=lambda h5: write_choice(h5, choice), scene=scene.facts()))
        return CaseOutcome("choose", written, choice=choice)
    from femref.run import run_scene

    outcome = run_scene(scene, progress_for, source=plan.source, budget_checked=True)
    written = () if output is None else tuple(write_results(output, resolved_yaml(case), outcome.results, outcome.scores, scene=scene.facts()))
    return CaseOutcome("simulate", written, run=outcome)
