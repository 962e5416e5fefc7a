"""Case files: YAML text → validated :data:`~femref.case.kinds.Case`, and back.

``load_case`` and ``parse_case`` raise :class:`~femref.case.errors.CaseError` and
nothing else for bad input (missing or unreadable file, YAML syntax, a document that
is not a mapping, any schema rule). ``resolved_yaml`` writes a case with every
default filled in; loading that text gives an equal case.

YAML dialect: safe YAML, with two corrections of PyYAML's YAML 1.1 reading —
duplicate keys are errors (PyYAML silently keeps the last one), and ``1e9`` is the
number 10⁹ as in YAML 1.2 (YAML 1.1 reads it as text).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import TypeAdapter, ValidationError

from femref.case.errors import CaseError, Problem, problems_from
from femref.case.kinds import CASE_KINDS, Case

__all__ = ["load_case", "parse_case", "read_yaml_file", "resolved_yaml"]

_CASE_ADAPTER: TypeAdapter[Case] = TypeAdapter(Case)

_RESOLVED_HEADER = "# femref resolved case: every default filled in\n"


class _CaseYamlLoader(yaml.SafeLoader):
    """Safe YAML that refuses duplicate keys and reads ``1e9`` as a number."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                duplicate = key in seen
            except TypeError:  # an unhashable key: the base class reports it
                break
            if duplicate:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping", node.start_mark, f"found duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_CaseYamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _yaml_problem(error: yaml.YAMLError) -> str:
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        context = f" ({error.context})" if error.context else ""
        return f"YAML syntax error{where}: {error.problem}{context}"
    return f"YAML syntax error: {error}"


def load_case(path: str | Path) -> Case:
    """Read, parse and validate the case file at ``path``.

    Relative CSV paths inside it are relative to the file's directory. Raises
    :class:`CaseError` for any bad input.
    """
    path = Path(path)
    return parse_case(read_yaml_file(path, "case"), source=str(path), base_dir=path.parent)


def read_yaml_file(path: str | Path, what: str) -> Any:
    """The YAML document of a ``what`` file (case, sweep, study) in this module's dialect.

    Raises :class:`CaseError` (source: the path) for a missing or unreadable file, a
    file that is not UTF-8 text, or a YAML syntax error.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CaseError(Problem((), f"{what} file not found"), source) from None
    except UnicodeDecodeError:
        raise CaseError(Problem((), "not a text (UTF-8) file"), source) from None
    except OSError as error:
        raise CaseError(Problem((), f"cannot read the {what} file: {error.strerror or error}"), source) from None
    try:
        return yaml.load(text, Loader=_CaseYamlLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as error:
        raise CaseError(Problem((), _yaml_problem(error)), source) from None


def parse_case(data: Any, *, source: str = "<case>", base_dir: Path | None = None) -> Case:
    """Validate parsed YAML (or any mapping) into a case.

    ``source`` names the input in error messages; ``base_dir`` resolves relative CSV
    paths (default: the working directory at call time). Raises :class:`CaseError`.
    """
    if data is None:
        raise CaseError(Problem((), "the case is empty; a case needs at least kind, body, loads"), source)
    if not isinstance(data, Mapping):
        what = "list" if isinstance(data, list) else f"single {type(data).__name__} value"
        rule = f"a case must be a mapping of keys (kind, body, loads, ...), not a {what}"
        raise CaseError(Problem((), rule, data), source)
    if "kind" not in data:
        raise CaseError(Problem(("kind",), f"required key is missing; one of: {', '.join(CASE_KINDS)}"), source)
    context = {"base_dir": Path(base_dir) if base_dir is not None else Path.cwd()}
    try:
        return _CASE_ADAPTER.validate_python(data, context=context)
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None


def resolved_yaml(case: Case) -> str:
    """The case as YAML with every default filled in; ``load_case`` of it gives an equal case."""
    data = case.model_dump(mode="json")
    return _RESOLVED_HEADER + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, allow_unicode=True, width=100)
