"""Shared helpers of the case tests: edit a valid case, write it, load one that must fail, match its message."""

from __future__ import annotations

import copy
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


DELETE = object()
"""Edit value that removes the key."""


def edited_copy(base: dict[str, Any], edits: dict[str, Any]) -> dict[str, Any]:
    """A copy of ``base`` with ``edits``: dotted key path (list indices as numbers; missing
    mappings on the way are created) → new value, or :data:`DELETE`."""
    data = copy.deepcopy(base)
    for dotted, value in edits.items():
        *parents, last = [int(k) if k.isdigit() else k for k in dotted.split(".")]
        node = data
        for key in parents:
            node = node[key] if isinstance(node, list) else node.setdefault(key, {})
        if value is DELETE:
            del node[last]
        else:
            node[last] = value
    return data


def write_case(directory: Path, text: str, name: str = "case.yaml") -> Path:
    """Write case text to ``directory/name`` and return the path."""
    path = directory / name
    path.write_text(text)
    return path
