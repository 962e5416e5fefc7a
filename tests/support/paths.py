"""Where the repository's own files are, for tests that read them."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CASES = REPO / "cases"
