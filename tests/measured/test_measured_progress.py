"""The progress hook of a measured run (femref.run.measured.run_measured): a stage while the records are read, then
one per event, whose callback counts the event's steps — its classification, each estimator, each network."""

from __future__ import annotations

from femref.case import load_case
from femref.run.measured import READ_LABEL, event_label, run_measured
from femref.scene.build import scene_from_case
from support.measured import yard_case_with_inverse_estimators


def test_run_measured_reports_the_records_and_each_step_of_each_event(tmp_path) -> None:
    """cases/measured_yard.yaml's two events with two inverse estimators: the read stage counting the bytes of the files
    opened up to all of them, each event named by its number and its trigger time as the stream decides it (the count is
    not known then), its callback at 1 + 2 steps of 3; the events as without the hook."""
    scene = scene_from_case(load_case(yard_case_with_inverse_estimators(tmp_path)), tmp_path)

    calls: dict[str, list[tuple[int, int]]] = {}

    def progress_for(stage: str):
        calls[stage] = []
        return lambda done, total: calls[stage].append((done, total))

    outcome = run_measured(scene, progress_for)
    steps = [(1, 3), (2, 3), (3, 3)]
    total = sum(path.stat().st_size for record in scene.records for path in record.paths)
    read = calls.pop(READ_LABEL)
    assert read[-1] == (total, total) and all(done <= total == of for done, of in read) and [d for d, _ in read] == sorted(d for d, _ in read)
    assert calls == {"event 1 at 1.503 s": steps, "event 2 at 3.603 s": steps}
    assert event_label(2, 7, 3.6034) == "event 2/7 at 3.603 s"
    plain = run_measured(scene)
    assert [e.trigger_time for e in outcome.events] == [e.trigger_time for e in plain.events]
    assert [e.peak[0] for e in outcome.events[0].estimates] == [e.peak[0] for e in plain.events[0].estimates]
