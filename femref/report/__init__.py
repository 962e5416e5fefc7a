"""The ``femref report`` page (docs/design.md §5): one self-contained HTML file of a result file.

:mod:`~femref.report.read` reads the HDF5 file into dataclasses,
:mod:`~femref.report.figures` draws the matplotlib plots, :mod:`~femref.report.field_map`
renders the FEM field off-screen with pyvista, :mod:`~femref.report.html` assembles the
page, :mod:`~femref.report.build` ties them together and
:mod:`~femref.report.command` is the click command.
"""

from femref.report.build import build_report
from femref.report.command import report_command
from femref.report.read import ReportInputError, read_result_file

__all__ = ["ReportInputError", "build_report", "read_result_file", "report_command"]
