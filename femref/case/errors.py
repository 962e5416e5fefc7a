"""One error for every bad case file: :class:`CaseError`, naming the file, key path, rule and value::

    case.yaml: body.mass_per_length.piecewise.breaks: must lie strictly inside the body (-8.0, 8.0); got [-9.0, 4.0]

A validator raises :func:`problems_error` (a pydantic error carrying :class:`Problem` records, key paths
relative to the value validated); :func:`problems_from` turns the ``ValidationError`` back into problems
with full key paths, pydantic's own messages translated into the rules of the case-file language.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError
from pydantic_core import PydanticCustomError

__all__ = ["CaseError", "Problem", "did_you_mean", "format_key_path", "problems_error", "problems_from"]

KeyPath = tuple[str | int, ...]

#: Marks a problem without an offending value (a missing key, an unknown key).
NO_VALUE: Any = type("NoValue", (), {"__repr__": lambda self: "<no value>"})()

_PROBLEMS_ERROR_TYPE = "femref_case_problems"


def format_key_path(path: KeyPath) -> str:
    """``("body", "mass_per_length", "piecewise", "values", 1)`` → ``body.mass_per_length.piecewise.values[1]``."""
    text = ""
    for part in path:
        if isinstance(part, int) and not isinstance(part, bool):
            text += f"[{part}]"
        else:
            text += f".{part}" if text else str(part)
    return text


def _show(value: Any, limit: int = 160) -> str:
    """A short, YAML-like rendering of an offending value (tuples as lists, long values cut)."""

    def plain(v: Any) -> Any:
        if isinstance(v, Mapping):
            return {plain(k): plain(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if hasattr(v, "model_dump"):
            return v.model_dump(mode="json")
        return v

    text = repr(plain(value))
    return text if len(text) <= limit else text[: limit - 3] + "..."


@dataclass(frozen=True)
class Problem:
    """One violated rule: where (``path``), what rule, and the value found there."""

    path: KeyPath
    rule: str
    value: Any = NO_VALUE

    @property
    def key_path(self) -> str:
        return format_key_path(self.path)

    def under(self, prefix: KeyPath) -> "Problem":
        """The same problem seen from a value ``prefix`` levels up."""
        return Problem((*prefix, *self.path), self.rule, self.value)

    def line(self, source: str) -> str:
        where = f"{source}: {self.key_path}: " if self.path else f"{source}: "
        got = "" if self.value is NO_VALUE else f"; got {_show(self.value)}"
        return f"{where}{self.rule}{got}"


class CaseError(ValueError):
    """A case that cannot be run: ``problems`` of file ``source``, one line each; ``key_path``, ``rule`` and
    ``value`` are those of the first."""

    def __init__(self, problems: Sequence[Problem] | Problem, source: str = "<case>") -> None:
        self.problems: tuple[Problem, ...] = (problems,) if isinstance(problems, Problem) else tuple(problems)
        if not self.problems:
            raise ValueError("a CaseError needs at least one problem")  # internal contract
        self.source = source
        super().__init__("\n".join(p.line(source) for p in self.problems))

    @classmethod
    def at(cls, key_path: str, rule: str, value: Any = NO_VALUE, *, source: str = "<case>") -> "CaseError":
        """One problem at a dotted ``key_path`` (e.g. for checks made after validation)."""
        return cls(Problem((key_path,) if key_path else (), rule, value), source)

    @property
    def key_path(self) -> str:
        return self.problems[0].key_path

    @property
    def rule(self) -> str:
        return self.problems[0].rule

    @property
    def value(self) -> Any:
        value = self.problems[0].value
        return None if value is NO_VALUE else value


def did_you_mean(word: Any, choices: Iterable[str]) -> str:
    """`` (did you mean 'length'?)`` when ``word`` is close to one of ``choices``, else ``""``."""
    choices = list(choices)
    text = str(word)
    lowered = {c.lower(): c for c in choices}
    if text.lower() in lowered:
        return f" (did you mean {lowered[text.lower()]!r}?)"
    close = difflib.get_close_matches(text.lower(), list(lowered), n=1, cutoff=0.6)
    return f" (did you mean {lowered[close[0]]!r}?)" if close else ""


def problems_error(problems: Sequence[Problem]) -> PydanticCustomError:
    """A pydantic error carrying ``problems`` (paths relative to the value being validated)."""
    text = "; ".join(f"{p.key_path}: {p.rule}" if p.path else p.rule for p in problems)
    return PydanticCustomError(_PROBLEMS_ERROR_TYPE, "{summary}", {"summary": text, "problems": tuple(problems)})


def _walk(loc: tuple[str | int, ...], raw: Any, missing: bool) -> KeyPath:
    """Translate a pydantic location into the key path of the case file.

    A location part is kept only where the raw input has that key or index, so union tags (``body.rod.length``)
    drop out; the last part of a *missing* key is kept though absent; below a scalar (a number standing for a
    model, like a uniform profile) the path stops.
    """
    path: list[str | int] = []
    node = raw
    for i, part in enumerate(loc):
        if isinstance(node, Mapping):  # mapping keys are names, even when YAML read them as numbers
            if part in node:
                path.append(str(part))
                node = node[part]
            elif missing and i == len(loc) - 1:
                path.append(str(part))
        elif isinstance(node, (list, tuple)):
            if isinstance(part, int) and -len(node) <= part < len(node):
                path.append(part)
                node = node[part]
        else:
            break
    return tuple(path)


def _number(text: Any) -> str:
    """``0`` rather than ``0.0`` in rules; other bounds as given."""
    if isinstance(text, float) and math.isfinite(text) and text == int(text):
        return str(int(text))
    return str(text)


#: pydantic's own error types → the rules of the case-file language (``{…}`` from the error's context).
_RULES: dict[str, str] = {
    "missing": "required key is missing",
    "extra_forbidden": "unknown key",
    "greater_than": "must be > {gt}",
    "greater_than_equal": "must be >= {ge}",
    "less_than": "must be < {lt}",
    "less_than_equal": "must be <= {le}",
    "finite_number": "must be a finite number (not NaN or infinity)",
    **dict.fromkeys(("float_parsing", "float_type"), "must be a number"),
    **dict.fromkeys(("int_parsing", "int_type", "int_from_float"), "must be an integer"),
    **dict.fromkeys(("bool_parsing", "bool_type"), "must be true or false"),
    "string_type": "must be a text string",
    "literal_error": "must be one of {expected}",
    "union_tag_invalid": "must be one of {expected_tags}",
    "union_tag_not_found": "required key is missing",
    **dict.fromkeys(("model_type", "model_attributes_type"), "must be a mapping of keys"),
    "dict_type": "must be a mapping",
    **dict.fromkeys(("list_type", "tuple_type"), "must be a list"),
    "too_short": "must have at least {min_length} entries",
    "too_long": "must have at most {max_length} entries",
    "path_type": "must be a file path",
}


def _rule(error: Mapping[str, Any]) -> str:
    """The case-file rule for one of pydantic's own error records."""
    kind = error["type"]
    if kind in _RULES:
        return _RULES[kind].format(**{key: _number(value) for key, value in (error.get("ctx") or {}).items()})
    return str(error.get("msg", kind)).removeprefix("Value error, ")


def problems_from(error: ValidationError, raw: Any) -> list[Problem]:
    """All problems in a pydantic ``ValidationError`` raised while validating ``raw``."""
    problems: list[Problem] = []
    for record in error.errors(include_url=False):
        kind, ctx = record["type"], record.get("ctx") or {}
        prefix = _walk(record["loc"], raw, missing=kind == "missing")
        if kind == _PROBLEMS_ERROR_TYPE:
            problems.extend(p.under(prefix) for p in ctx["problems"])
            continue
        if kind in ("union_tag_invalid", "union_tag_not_found"):
            # The rule is about the discriminating key itself (body.type, kind).
            prefix = (*prefix, str(ctx["discriminator"]).strip("'\""))
        value = NO_VALUE if kind in ("missing", "union_tag_not_found", "extra_forbidden") else record.get("input", NO_VALUE)
        if kind == "union_tag_invalid":
            value = ctx.get("tag", value)
        problems.append(Problem(prefix, _rule(record), value))
    return problems
