"""Shared helpers of the bad-input tests: load a case that must fail, and match its message line."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from femref.case import CaseError, load_case


def load_bad(tmp_path: Path, data: Any) -> CaseError:
    """Write ``data`` as ``case.yaml`` and return the CaseError loading it raises."""
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    with pytest.raises(CaseError) as caught:
        load_case(path)
    assert caught.value.source == str(path)
    return caught.value


def expect(key_path: str, rule: str) -> str:
    """Regex for the message line of ``key_path`` (literal) with ``rule`` (a regex)."""
    return rf"case\.yaml: {re.escape(key_path)}: {rule}"
