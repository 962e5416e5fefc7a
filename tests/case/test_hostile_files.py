"""Hostile YAML files (issue 18): refused within the loader's limits, exit 2, nothing written.

A 1 kB YAML of nested aliases ("billion laughs") stands for 10⁹ values, and a line of a thousand
brackets nests deeper than Python's stack; before the limits the first ran for minutes past
800 MB and the second crashed with a RecursionError. Every case, sweep and study file goes through
:func:`femref.case.loader.read_yaml_file`, so each probe runs through ``femref run``, ``femref
sweep`` or ``femref study`` and must exit 2 with the file and the rule; anchors, aliases and merge
keys used within the limits still work.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from femref.case import CaseError, load_case
from femref.case import loader
from femref.case.loader import MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES, load_yaml_text
from femref.cli import main
from support.paths import CASES


def billion_laughs(levels: int = 9) -> str:
    """``a0`` holds ten strings and every ``a<k>`` ten aliases of ``a<k-1>``: 10^(levels+1) strings in about 1 kB."""
    lines = ["kind: impact", 'a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 10)}]" for k in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


def deep_brackets(depth: int = 1000) -> str:
    return "kind: impact\nx: " + "[" * depth + "]" * depth + "\n"


def alias_tower(anchors: int = 7) -> str:
    """Anchor ``b<k>`` nests ten levels around ``*b<k-1>``: 11 levels deep as text, 10(k + 1) expanded.

    ``b6`` puts ``*b5`` (60 levels) inside 11 open ones (the document's mapping and its own ten).
    """
    lines = ["kind: impact", "b0: &b0 [[[[[[[[[[1]]]]]]]]]]"]
    lines += [f"b{k}: &b{k} [[[[[[[[[[*b{k - 1}]]]]]]]]]]" for k in range(1, anchors)]
    return "\n".join(lines) + "\n"


AT = r" \(at line \d+, column \d+\)"
SIZE = rf"YAML document too large: more than {MAX_YAML_NODES} values, aliases counted every time they are used \(nested aliases, a 'billion laughs'\?\); the limit is {MAX_YAML_NODES}{AT}"
DEPTH = rf"YAML nested too deeply: collections nest more than {MAX_YAML_DEPTH} levels deep; the limit is {MAX_YAML_DEPTH}{AT}"

#: id → (file text (or bytes), message after "<file>: " (a regex)).
HOSTILE_YAML: dict[str, tuple[str | bytes, str]] = {
    "billion laughs": (billion_laughs(), SIZE),
    "1000 nested brackets": (deep_brackets(), DEPTH),
    "1000 nested mappings": ("kind: impact\nx: " + "{a: " * 1000 + "1" + "}" * 1000 + "\n", DEPTH),
    "aliases nesting past the limit": (alias_tower(), rf"YAML nested too deeply: the alias \*b5 nests more than {MAX_YAML_DEPTH} levels deep; the limit is {MAX_YAML_DEPTH}{AT}"),
    "recursive alias": ("kind: impact\nx: &x [1, *x]\n", r"YAML alias \*x is used inside its own anchor's value \(a recursive structure\)" + AT),
    "recursive merge": ("kind: impact\nx: &x {a: 1, <<: *x}\n", r"YAML alias \*x is used inside its own anchor's value \(a recursive structure\)" + AT),
    "file over 16 MiB": (b"kind: impact\n" + b"#" * MAX_YAML_BYTES, rf"the (case|sweep|study) file is larger than {MAX_YAML_BYTES // 2**20} MiB, the limit of a YAML file"),
}


def _write(path: Path, text: str | bytes) -> Path:
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "rule"), list(HOSTILE_YAML.values()), ids=list(HOSTILE_YAML))
def test_hostile_case_exits_2_naming_the_file_and_the_rule(tmp_path: Path, text: str | bytes, rule: str) -> None:
    path = _write(tmp_path / "case.yaml", text)
    output = tmp_path / "out.h5"
    result = CliRunner().invoke(main, ["run", str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and "RecursionError" not in result.output
    assert re.search(rf"^error: {re.escape(str(path))}: {rule}$", result.output, re.MULTILINE), result.output
    assert [p.name for p in tmp_path.iterdir()] == ["case.yaml"]


@pytest.mark.parametrize("command", ["sweep", "study"])
@pytest.mark.parametrize(("text", "rule"), [HOSTILE_YAML["billion laughs"], HOSTILE_YAML["1000 nested brackets"]], ids=["billion laughs", "1000 nested brackets"])
def test_hostile_sweep_and_study_files_exit_2(tmp_path: Path, command: str, text: str, rule: str) -> None:
    path = _write(tmp_path / f"{command}.yaml", text)
    output = tmp_path / "out"
    result = CliRunner().invoke(main, [command, str(path), "-o", str(output)])
    assert result.exit_code == 2, result.output
    assert re.search(rf"^error: {re.escape(str(path))}: {rule}$", result.output, re.MULTILINE), result.output
    assert [p.name for p in tmp_path.iterdir()] == [f"{command}.yaml"]


# The limits, at their edges


def test_nesting_up_to_the_limit_reads() -> None:
    """``[[…[]…]]``: 64 levels are a list nested 64 deep; 65 are refused, naming where the 65th opens."""
    value = load_yaml_text("[" * MAX_YAML_DEPTH + "]" * MAX_YAML_DEPTH)
    for _ in range(MAX_YAML_DEPTH - 1):
        (value,) = value
    assert value == []
    with pytest.raises(CaseError, match=rf"^f\.yaml: {DEPTH}$") as error:
        load_yaml_text("[" * (MAX_YAML_DEPTH + 1) + "]" * (MAX_YAML_DEPTH + 1), "f.yaml")
    assert error.value.rule.endswith(f"(at line 1, column {MAX_YAML_DEPTH + 1})")


def test_every_alias_counts_its_anchors_values(monkeypatch) -> None:
    """With a limit of 20 values: ``a`` (a list of 4: 5 values) used three times in ``b`` (1 + 15) and
    itself (5) make 1 + 1 + 5 + 1 + 1 + 16 = 25 values — refused — while two uses make 20."""
    monkeypatch.setattr(loader, "MAX_YAML_NODES", 20)
    assert load_yaml_text("a: &a [1, 2, 3, 4]\nb: [*a, *a]") == {"a": [1, 2, 3, 4], "b": [[1, 2, 3, 4]] * 2}
    with pytest.raises(CaseError, match="YAML document too large: more than 20 values"):
        load_yaml_text("a: &a [1, 2, 3, 4]\nb: [*a, *a, *a]")


# Normal anchors, aliases and merge keys still work


ANCHORED_FREE_ROLL = """\
kind: impact
cars:
  - name: hammer
    body: &hopper
      type: rod
      length: 17.0
      mass_per_length: {piecewise: {breaks: &bolsters [-6.5, 6.5], values: [3500.0, 8076.923, 3500.0]}}
      axial_stiffness: 3.0e9
      axial_viscosity: 2.0e6
    velocity: 2.2
    sensors: {center: 0.0, front: &front 8.3}
  - name: anvil
    body:
      <<: *hopper
      mass_per_length: {piecewise: {breaks: *bolsters, values: [3500.0, 6615.385, 3500.0]}}
    velocity: 0.0
    sensors: {rear: -8.3, center: 0.0, front: *front}
couplers:
  - name: c1
    between: [hammer, anvil]
    law:
      draft_gear: {gear_stiffness: 1.7e7, gear_damping: 2.5e5, stroke: 0.165, solid_stiffness: 1.0e8,
                   series_stiffness_1: &series 4.0e8, series_stiffness_2: *series}
    contact: compression_only
time: {end: 0.5}
models: [fem, modal, quasi_rigid, rigid]
fem: {elements: 64, order: 2}
measurement: {rate: 1000.0, lowpass: 100.0, noise: 0.05, seed: 1}
estimators: [inverse_rigid, inverse_quasi_rigid]
"""


def test_anchors_aliases_and_merge_keys_read_as_the_written_out_case(tmp_path: Path) -> None:
    """The default free-roll case written with an anchored body merged into the second car (``<<: *hopper``,
    one key overridden) and aliased values is the same case as cases/impact_free_roll.yaml."""
    path = _write(tmp_path / "anchored.yaml", ANCHORED_FREE_ROLL)
    assert load_case(path) == load_case(CASES / "impact_free_roll.yaml")
    result = CliRunner().invoke(main, ["validate", str(path)])
    assert result.exit_code == 0, result.output
