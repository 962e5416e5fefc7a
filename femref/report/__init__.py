"""The ``femref report`` page (docs/design.md §5): one self-contained HTML file of a result file.

:mod:`~femref.report.read` reads the HDF5 file into dataclasses,
:mod:`~femref.report.figures` draws the matplotlib plots, :mod:`~femref.report.field_map`
renders the FEM field off-screen with pyvista, :mod:`~femref.report.html` assembles the
page and :mod:`~femref.report.build` ties them together; the command is :mod:`femref.cli.report`.
"""

from femref.report.build import build_report
from femref.report.read import ReportInputError, read_result_file

__all__ = ["ReportInputError", "build_report", "read_result_file"]
