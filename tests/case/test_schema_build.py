"""The case schema is built where it is used (femref.case.fields.CaseModel: ``defer_build``): a case is validated by
its kind's model (femref.case.loader.parse_case), the other kinds' validators never built — and it gives what the
union of every kind, discriminated on ``kind`` (femref.case.kinds.Case), gives: the same case, the same problems."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import pytest
from pydantic import TypeAdapter, ValidationError

from femref.case import CaseError, parse_case
from femref.case.defaults import default_scene_data
from femref.case.errors import problems_from
from femref.case.kinds import Case
from femref.case.loader import read_yaml_file

from support.paths import REPO

CASES = sorted((REPO / "cases").glob("*.yaml"))


def union_parse(data: dict, base_dir: Path):
    """The case as the union of every kind validates it (the second path)."""
    try:
        return TypeAdapter(Case).validate_python(data, context={"base_dir": base_dir})
    except ValidationError as error:
        raise CaseError(problems_from(error, data), "<union>") from None


@pytest.mark.parametrize("path", CASES, ids=[p.stem for p in CASES])
def test_a_case_of_every_kind_is_the_unions_case(path: Path) -> None:
    data = read_yaml_file(path, "case")
    assert parse_case(data, base_dir=path.parent) == union_parse(data, path.parent)


def bad(data: dict, *edits: tuple[tuple, object]) -> dict:
    """``data`` with each ``(key path, value)`` set (value ``...``: the key removed)."""
    data = copy.deepcopy(data)
    for path, value in edits:
        node = data
        for key in path[:-1]:
            node = node[key]
        if value is ...:
            node.pop(path[-1])
        else:
            node[path[-1]] = value
    return data


SCENE = default_scene_data()
BAD = {
    "unknown key": bad(SCENE, (("speeds",), 3.0)),
    "key of another kind": bad(SCENE, (("records",), [])),
    "negative mass": bad(SCENE, (("cars", 0, "mass"), -1.0)),
    "missing cars": bad(SCENE, (("cars",), ...)),
    "unknown model": bad(SCENE, (("models",), ["fem", "rigd"])),
    "three problems": bad(SCENE, (("cars", 0, "mass"), "heavy"), (("time", "end"), -1.0), (("wheels",), 4)),
    "unknown kind": bad(SCENE, (("kind",), "impakt")),
    "kind not a string": bad(SCENE, (("kind",), 3)),
}


@pytest.mark.parametrize("name", list(BAD))
def test_a_bad_case_has_the_unions_problems(name: str) -> None:
    data = BAD[name]
    with pytest.raises(CaseError) as by_kind:
        parse_case(data, source="<union>")
    with pytest.raises(CaseError) as by_union:
        union_parse(data, Path.cwd())
    assert str(by_kind.value) == str(by_union.value)


def test_parsing_a_case_builds_its_kinds_validator_only() -> None:
    """In a fresh interpreter, the default scene (an impact) parsed and resolved: ImpactCase's validator is built, the
    other kinds' are not (pydantic's ``__pydantic_complete__``)."""
    script = "\n".join([
        "import json",
        "from femref.case import parse_case, resolved_yaml",
        "from femref.case.defaults import default_scene_data",
        "from femref.case.kinds import CASE_KINDS",
        "resolved_yaml(parse_case(default_scene_data()))",
        "print(json.dumps({kind: cls.__pydantic_complete__ for kind, cls in CASE_KINDS.items()}))",
    ])
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=REPO, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    built = json.loads(done.stdout.splitlines()[-1])
    assert built == {"harmonic": False, "transient": False, "impact": True, "measured": False}
