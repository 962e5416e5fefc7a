"""The fleet report's table for maintenance systems: ``events.csv`` (UTF-8 with a byte-order mark, so that Excel reads
it as UTF-8; one row per event and coupler, the event store's columns with their SI unit in the header) and
``events.xlsx`` when openpyxl is installed (``pip install 'femref[report]'``)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd

CSV_NAME = "events.csv"
XLSX_NAME = "events.xlsx"
XLSX_EXTRA = "femref[report]"
UNITS = {
    "time": "UTC",
    "closing_speed": "m/s", "closing_speed_lower": "m/s", "closing_speed_upper": "m/s",
    "peak_force": "N", "peak_force_lower": "N", "peak_force_upper": "N", "alarm_limit": "N",
    "closure_force": "N", "wear_limit": "N",
}
"""The unit each numeric column of the export carries in its header, ``peak_force (N)``."""


def header(column: str) -> str:
    """The export's header of an event-store column: the name with its unit, if it has one."""
    return f"{column} ({UNITS[column]})" if column in UNITS else column


def can_write_xlsx() -> bool:
    """Whether openpyxl is importable (pandas writes .xlsx through it)."""
    return importlib.util.find_spec("openpyxl") is not None


def write_exports(events: pd.DataFrame, folder: Path) -> list[Path]:
    """``events.csv`` and, with openpyxl, ``events.xlsx`` of ``events`` (rows, newest first) in ``folder``."""
    table = events.rename(columns=header)
    csv = folder / CSV_NAME
    table.to_csv(csv, index=False, encoding="utf-8-sig", date_format="%Y-%m-%dT%H:%M:%S.%fZ")
    written = [csv]
    if can_write_xlsx():
        sheet = table.copy()
        sheet[header("time")] = sheet[header("time")].dt.tz_convert("UTC").dt.tz_localize(None)  # Excel has no time zones
        sheet.to_excel(folder / XLSX_NAME, index=False, sheet_name="events", engine="openpyxl")
        written.append(folder / XLSX_NAME)
    return written


__all__ = ["CSV_NAME", "UNITS", "XLSX_EXTRA", "XLSX_NAME", "can_write_xlsx", "header", "write_exports"]
