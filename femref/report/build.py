"""Result file → page: read, draw, render the field maps, assemble."""

from __future__ import annotations

from pathlib import Path

from femref.report.field_map import field_map_picture
from femref.report.figures import Picture, figures_for
from femref.report.html import render_page
from femref.report.read import read_result_file


def build_report(results: str | Path) -> str:
    """The HTML page of the result file ``results``; raises ReportInputError for bad input."""
    result = read_result_file(results)
    field_maps: list[Picture] = [p for m in result.ok_models if (p := field_map_picture(m)) is not None]
    return render_page(result, figures_for(result), field_maps)
