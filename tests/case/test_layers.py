"""The case package is a layer: it imports only the layers below it, at the top of each module, without a circle."""

import ast
from graphlib import CycleError, TopologicalSorter
from pathlib import Path

import femref.case
from femref.case import CASE_KINDS
from femref.case.base import case_classes

CASE_DIR = Path(femref.case.__file__).parent
#: What femref.case may import from femref (besides itself).
BELOW = ("femref.core", "femref.sensing")


def _imports(path: Path) -> tuple[list[str], list[int]]:
    """Modules imported at the top of ``path``, and the lines of any import below the top level."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    top = []
    for node in tree.body:
        if isinstance(node, ast.Import):
            top += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module is not None:
            top += [f"{node.module}.{alias.name}" if node.module == "femref.case" else node.module for alias in node.names]
    nested = [node.lineno for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))]
    return top, sorted(set(nested) - {n.lineno for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))})


def test_case_modules_import_only_lower_layers_at_the_top_without_a_circle() -> None:
    graph: dict[str, set[str]] = {}
    for path in sorted(CASE_DIR.glob("*.py")):
        name = "femref.case" if path.stem == "__init__" else f"femref.case.{path.stem}"
        top, nested = _imports(path)
        assert not nested, f"{name}: imports below the top level at lines {nested}"
        femref_imports = [m for m in top if m == "femref" or m.startswith("femref.")]
        outside = [m for m in femref_imports if not m.startswith(("femref.case", *BELOW))]
        assert not outside, f"{name} imports {outside}; the case layer may import {', '.join(BELOW)} only"
        graph[name] = {m for m in femref_imports if m.startswith("femref.case.")}
    try:
        tuple(TopologicalSorter(graph).static_order())
    except CycleError as error:
        raise AssertionError(f"import circle in femref.case: {error.args[1]}") from None


def test_the_foreign_key_hint_walks_every_case_kind() -> None:
    """``SceneCase`` finds the kinds by walking its subclasses; they are the registry, in its order."""
    assert case_classes() == dict(CASE_KINDS)
