"""The fleet tests' impacts, simulated once per session (tests/support/fleet.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from support.fleet import simulate_records


@pytest.fixture(scope="session")
def fleet_records(tmp_path_factory) -> dict[str, Path]:
    """``"low"``/``"high"`` → the folder of that impact's recorders' files (support.fleet.simulate_records)."""
    return simulate_records(tmp_path_factory.mktemp("impacts"))
