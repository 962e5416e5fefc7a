"""Result file → page: read, draw, render the field maps, assemble (an event file: :mod:`femref.report.events`;
a network study's ``study.h5``: :mod:`femref.report.study`)."""

from __future__ import annotations

from pathlib import Path

import h5py

from femref.report.events import event_report, is_event_file
from femref.report.field_map import field_map_picture
from femref.report.figures import Picture, figures_for
from femref.report.html import render_page
from femref.report.read import read_result_file
from femref.report.study import is_study_file, study_report


def build_report(results: str | Path) -> str:
    """The HTML page of the result file ``results`` (or a measured case's event file, or a network
    study's ``study.h5``); raises ReportInputError for bad input."""
    if (page := _event_page(Path(results))) is not None:
        return page
    result = read_result_file(results)
    field_maps: list[Picture] = [p for m in result.ok_models if (p := field_map_picture(m)) is not None]
    return render_page(result, figures_for(result), field_maps)


def _event_page(path: Path) -> str | None:
    """The page of an event file or a study file, or None when ``path`` is neither (read_result_file then judges it)."""
    if not (path.is_file() and h5py.is_hdf5(path)):
        return None
    try:
        with h5py.File(path, "r") as h5:
            if is_study_file(h5):
                return study_report(path, h5)
            return event_report(path, h5) if is_event_file(h5) else None
    except OSError:
        return None
