"""Result file → page: read, draw, render the field maps, assemble (an event file: :mod:`femref.report.measured`;
a network study's ``study.h5``: :mod:`femref.report.study`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import h5py

from femref.events import is_event_file
from femref.report.measured import event_pages, event_report
from femref.report.field_map import field_map_picture
from femref.report.figures import Picture, figures_for
from femref.report.html import render_page
from femref.report.read import read_result_file
from femref.report.study import is_study_file, study_report


def build_report(results: str | Path, output: str | None = None) -> str:
    """The HTML page of the result file ``results`` (or a measured case's event file, or a network
    study's ``study.h5``); raises ReportInputError for bad input. An event file of many events gives the index
    of the report written to the file ``output`` (its pages: :func:`build_event_pages`)."""
    if (page := _event_page(Path(results), output)) is not None:
        return page
    result = read_result_file(results)
    field_maps: list[Picture] = [p for m in result.ok_models if (p := field_map_picture(m)) is not None]
    return render_page(result, figures_for(result), field_maps)


def build_event_pages(results: str | Path, output: str, progress_for: Callable[[str], Callable[[int, int], None] | None] | None = None
                      ) -> Iterator[tuple[str, str]]:
    """``(file name, page)`` of each page of events beside the index ``output`` of an event file of many events
    (:func:`femref.report.measured.event_pages`, with its progress); nothing for any other file."""
    path = Path(results)
    if not (path.is_file() and h5py.is_hdf5(path)):
        return
    with h5py.File(path, "r") as h5:
        if is_event_file(h5):
            yield from event_pages(path, h5, output, progress_for)


def _event_page(path: Path, output: str | None = None) -> str | None:
    """The page of an event file or a study file, or None when ``path`` is neither (read_result_file then judges it)."""
    if not (path.is_file() and h5py.is_hdf5(path)):
        return None
    try:
        with h5py.File(path, "r") as h5:
            if is_study_file(h5):
                return study_report(path, h5)
            return event_report(path, h5, output) if is_event_file(h5) else None
    except OSError:
        return None
