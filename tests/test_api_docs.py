"""The public Python API documents itself in numpydoc form, and the documentation names the real parameters.

Every function :mod:`femref.api` exports has a summary line, a ``Parameters`` section listing exactly its
signature's parameters (``self`` and ``*``/``**`` collectors aside) and a ``Returns`` or ``Raises`` section, so
``help()``, IDEs and Sphinx's numpydoc render it; a parameter renamed or added without its entry fails here.
"""

from __future__ import annotations

import inspect
import re

import pytest

import femref.api as api

FUNCTIONS = [name for name in api.__all__ if inspect.isfunction(getattr(api, name))]


def _sections(doc: str) -> dict[str, list[str]]:
    """numpydoc sections: a title line followed by a line of dashes of its length → the lines below it."""
    lines = inspect.cleandoc(doc).splitlines()
    sections: dict[str, list[str]] = {"": []}
    current = ""
    for k, line in enumerate(lines):
        if k + 1 < len(lines) and re.fullmatch(r"-{3,}", lines[k + 1].strip()) and len(lines[k + 1].strip()) == len(line.strip()):
            current = line.strip()
            sections[current] = []
        elif not re.fullmatch(r"-{3,}", line.strip()):
            sections[current].append(line)
    return sections


def test_the_api_exports_functions():
    assert {"run_case", "open_result", "open_frames", "result_models", "check_run_output", "run_scene"} <= set(FUNCTIONS)


@pytest.mark.parametrize("name", FUNCTIONS)
def test_numpydoc_sections_match_the_signature(name: str):
    function = getattr(api, name)
    doc = function.__doc__ or ""
    assert doc.strip(), f"{name} has no docstring"
    sections = _sections(doc)
    assert sections[""] and sections[""][0].strip(), f"{name}: no summary line"
    assert "Parameters" in sections, f"{name}: no Parameters section"
    assert {"Returns", "Raises", "Yields"} & set(sections), f"{name}: neither Returns nor Raises"
    documented = [re.match(r"(\*{0,2}\w+)\s*:", line).group(1) for line in sections["Parameters"]
                  if re.match(r"\*{0,2}\w+\s*:", line)]
    parameters = [p for p in inspect.signature(function).parameters.values()
                  if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    assert documented == [p.name for p in parameters], f"{name}: documents {documented}"
