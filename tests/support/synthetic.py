"""The synthetic recordings of benchmarks/synthetic (a yard day, a fleet's month), importable by tests.

benchmarks/ is not a package of the project; its ``synthetic`` generators are put on the path here.
"""

from __future__ import annotations

import sys

from support.paths import REPO

if str(REPO / "benchmarks") not in sys.path:
    sys.path.insert(0, str(REPO / "benchmarks"))

from synthetic import day, impacts, writers  # noqa: E402

__all__ = ["day", "impacts", "writers"]
