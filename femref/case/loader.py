"""Case files: YAML text → validated :data:`~femref.case.kinds.Case`, and back.

Bad input raises :class:`~femref.case.errors.CaseError` and nothing else. YAML dialect: safe YAML, with
duplicate keys refused (PyYAML keeps the last) and ``1e9`` read as a number (YAML 1.2; 1.1 reads text).

Limits, so that a small hostile file cannot exhaust memory, time or the stack (every case, sweep and study
file goes through :func:`read_yaml_file`): a regular file only (a FIFO would block the open), at most
:data:`MAX_YAML_BYTES` bytes, collections nested at most :data:`MAX_YAML_DEPTH` levels and at most
:data:`MAX_YAML_NODES` values — both counted through aliases, so nested aliases ("billion laughs") cannot
stand for 10⁹ values — and no alias inside its own anchor (a recursive structure).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml
from pydantic import TypeAdapter, ValidationError

from femref.case.errors import CaseError, Problem, problems_from
from femref.case.kinds import CASE_KINDS, Case
from femref.core.files import NotRegularFile, regular_file

__all__ = ["MAX_YAML_BYTES", "MAX_YAML_DEPTH", "MAX_YAML_NODES", "load_case", "load_yaml_text", "parse_case", "read_yaml_file", "resolved_yaml"]

#: Largest YAML file read (bytes); case, sweep and study files are a few kB.
MAX_YAML_BYTES = 16 * 2**20
#: Deepest nesting of collections, aliases expanded (a case nests about 8 levels).
MAX_YAML_DEPTH = 64
#: Most values (scalars and collections) in a document, every alias counting its anchor's values again.
MAX_YAML_NODES = 1_000_000


_RESOLVED_HEADER = "# femref resolved case: every default filled in\n"


class _YamlLimitError(yaml.YAMLError):
    """A document beyond one of the module's limits (module docstring): the rule and where."""

    def __init__(self, rule: str, mark: yaml.Mark | None) -> None:
        where = f" (at line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        super().__init__(rule + where)


class _CaseYamlLoader(yaml.SafeLoader):
    """Safe YAML that refuses duplicate keys, reads ``1e9`` as a number and keeps to the size limits.

    The limits are checked while the document is composed, before any Python value is made: each finished
    node records its nesting height and value count with aliases expanded (an alias is its anchor's node).
    The open collections are counted too, which bounds the composer's own recursion.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._open_depth = 0
        self._height: dict[yaml.Node, int] = {}  # finished node → collection levels, aliases expanded
        self._count: dict[yaml.Node, int] = {}  # finished node → values, aliases expanded

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            node = super().compose_node(parent, index)
            if node not in self._height:  # its anchor's collection is still open
                raise _YamlLimitError(f"YAML alias *{event.anchor} is used inside its own anchor's value (a recursive structure)", event.start_mark)
            if self._open_depth + self._height[node] > MAX_YAML_DEPTH:
                raise _YamlLimitError(self._depth_rule(f"the alias *{event.anchor} nests"), event.start_mark)
            return node
        if not isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            node = super().compose_node(parent, index)
            self._height[node], self._count[node] = 0, 1
            return node
        self._open_depth += 1
        if self._open_depth > MAX_YAML_DEPTH:
            raise _YamlLimitError(self._depth_rule("collections nest"), event.start_mark)
        try:
            node = super().compose_node(parent, index)
        finally:
            self._open_depth -= 1
        children = [child for pair in node.value for child in pair] if isinstance(node, yaml.MappingNode) else node.value
        height = 1 + max((self._height[child] for child in children), default=0)
        count = 1 + sum(self._count[child] for child in children)
        if height > MAX_YAML_DEPTH:
            raise _YamlLimitError(self._depth_rule("collections nest (aliases expanded)"), node.start_mark)
        if count > MAX_YAML_NODES:
            raise _YamlLimitError(
                f"YAML document too large: more than {MAX_YAML_NODES} values, aliases counted every time they are used "
                f"(nested aliases, a 'billion laughs'?); the limit is {MAX_YAML_NODES}",
                node.start_mark,
            )
        self._height[node], self._count[node] = height, count
        return node

    @staticmethod
    def _depth_rule(what: str) -> str:
        return f"YAML nested too deeply: {what} more than {MAX_YAML_DEPTH} levels deep; the limit is {MAX_YAML_DEPTH}"

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
    if isinstance(error, _YamlLimitError):
        return str(error)
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        context = f" ({error.context})" if error.context else ""
        return f"YAML syntax error{where}: {error.problem}{context}"
    return f"YAML syntax error: {error}"


def load_case(path: str | Path) -> Case:
    """Read, parse and validate the case file at ``path`` (relative file paths inside it: from its directory)."""
    path = Path(path)
    return parse_case(read_yaml_file(path, "case"), source=str(path), base_dir=path.parent)


def read_yaml_file(path: str | Path, what: str) -> Any:
    """The YAML document of a ``what`` file (case, sweep, study) in this module's dialect and limits."""
    source = str(path)
    try:
        regular_file(path)  # before opening: a FIFO would block the open until a writer came
        with open(path, "rb") as handle:
            data = handle.read(MAX_YAML_BYTES + 1)
    except FileNotFoundError:
        raise CaseError(Problem((), f"{what} file not found"), source) from None
    except NotRegularFile as error:
        raise CaseError(Problem((), f"cannot read the {what} file: it {error}"), source) from None
    except OSError as error:
        raise CaseError(Problem((), f"cannot read the {what} file: {error.strerror or error}"), source) from None
    if len(data) > MAX_YAML_BYTES:
        raise CaseError(Problem((), f"the {what} file is larger than {MAX_YAML_BYTES // 2**20} MiB, the limit of a YAML file"), source)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise CaseError(Problem((), "not a text (UTF-8) file"), source) from None
    return load_yaml_text(text, source)


def load_yaml_text(text: str, source: str = "<yaml>") -> Any:
    """The YAML document in ``text``, in this module's dialect and limits; ``source`` names it in errors."""
    try:
        return yaml.load(text, Loader=_CaseYamlLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as error:
        raise CaseError(Problem((), _yaml_problem(error)), source) from None


def parse_case(data: Any, *, source: str = "<case>", base_dir: Path | None = None) -> Case:
    """Validate parsed YAML (or any mapping) into a case; ``source`` names it in errors, ``base_dir`` resolves
    relative file paths (default: the working directory)."""
    if data is None:
        raise CaseError(Problem((), "the case is empty; a case needs at least kind, body, loads"), source)
    if not isinstance(data, Mapping):
        what = "list" if isinstance(data, list) else f"single {type(data).__name__} value"
        rule = f"a case must be a mapping of keys (kind, body, loads, ...), not a {what}"
        raise CaseError(Problem((), rule, data), source)
    if "kind" not in data:
        raise CaseError(Problem(("kind",), f"required key is missing; one of: {', '.join(CASE_KINDS)}"), source)
    context = {"base_dir": Path(base_dir) if base_dir is not None else Path.cwd()}
    kind = data["kind"]
    try:
        if isinstance(kind, str) and kind in CASE_KINDS:
            return CASE_KINDS[kind].model_validate(data, context=context)
        return _case_adapter().validate_python(data, context=context)  # the rule for a kind that is none of them
    except ValidationError as error:
        raise CaseError(problems_from(error, data), source) from None


@functools.cache
def _case_adapter() -> TypeAdapter[Case]:
    return TypeAdapter(Case)


def resolved_yaml(case: Case) -> str:
    """The case as YAML with every default filled in; ``load_case`` of it gives an equal case."""
    data = case.model_dump(mode="json")
    return _RESOLVED_HEADER + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, allow_unicode=True, width=100)
