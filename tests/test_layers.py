"""The layer rule of docs/design.md §9: every femref import points down (or within its own package).

Every import statement of every module is read with ``ast`` — at module level and inside
functions alike, so an import cannot hide a circle or an upward arrow behind a function
— and mapped to the layer of the package it names. ``reduced`` and ``ann`` import
nothing of femref (nor ``ann`` of ``reduced``).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

from support.paths import REPO

#: Layer of each femref package (docs/design.md §9.1); the package root holds only the version.
LAYERS = {
    "__init__": 0,
    "core": 0,
    "fem": 1,
    "exact": 1,
    "sensing": 1,
    "results": 1,
    "events": 1,
    "case": 2,
    "report": 2,
    "scene": 3,
    "impact": 4,
    "models": 5,
    "estimators": 5,
    "run": 6,
    "choice": 7,
    "api": 7,
    "flow": 7,
    "bench": 7,
    "sweep": 7,
    "study": 7,
    "fleet": 7,
    "verification": 7,
    "cli": 8,
    # a module placed apart from its package: the gears' wear trend computes on the event store's rows alone (numpy,
    # scipy, pandas), so the report reads it without reaching up to the fleet's runner
    "fleet.wear": 1,
}


def _modules(package: str) -> list[Path]:
    return sorted((REPO / package).rglob("*.py"))


def _imports(path: Path) -> list[tuple[str, int]]:
    """Every imported module name with its line, at any depth (``from . import`` resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = ".".join(path.relative_to(REPO).with_suffix("").parts[:-1])
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.extend((alias.name, node.lineno) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            found.append((name, node.lineno))
            found.extend((f"{name}.{alias.name}", node.lineno) for alias in node.names)
    return found


def _package_of(module: str) -> str | None:
    """``femref.<package>`` of a dotted femref module name (``__init__`` for the root)."""
    parts = module.split(".")
    if parts[0] != "femref":
        return None
    if len(parts) == 1 or parts[1] == "__version__":
        return "__init__"
    if ".".join(parts[1:3]) in LAYERS:
        return ".".join(parts[1:3])
    return parts[1] if parts[1] in LAYERS else None


def _own_package(path: Path) -> str:
    parts = path.relative_to(REPO / "femref").with_suffix("").parts
    return ".".join(parts[:2]) if ".".join(parts[:2]) in LAYERS else parts[0]


def test_every_femref_package_has_a_layer():
    packages = {_own_package(p) for p in _modules("femref")}
    assert packages <= set(LAYERS), sorted(packages - set(LAYERS))


@pytest.mark.parametrize("path", _modules("femref"), ids=lambda p: str(p.relative_to(REPO)))
def test_imports_point_down(path: Path):
    own = _own_package(path)
    upward = []
    for name, line in _imports(path):
        target = _package_of(name)
        if target is None or target == own:
            continue
        if LAYERS[target] > LAYERS[own]:
            upward.append(f"line {line}: {name} (layer {LAYERS[target]}) from {own} (layer {LAYERS[own]})")
    assert not upward, "\n".join(upward)


def test_no_circle_between_packages():
    """Same-layer packages may import each other (study uses sweep) but never both ways round."""
    edges: dict[str, set[str]] = defaultdict(set)
    for path in _modules("femref"):
        own = _own_package(path)
        for name, _ in _imports(path):
            target = _package_of(name)
            if target not in (None, own):
                edges[own].add(target)

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        return any(n == goal or (n not in seen and reaches(n, goal, seen | {n})) for n in edges.get(start, ()))

    circles = sorted(p for p in list(edges) if reaches(p, p, {p}))
    assert not circles, circles


def test_no_circle_between_modules():
    """Within a package too, no module reaches itself through femref imports (at any depth)."""
    graph: dict[str, set[str]] = {}
    for path in _modules("femref"):
        name = ".".join(path.relative_to(REPO).with_suffix("").parts)
        graph[name.removesuffix(".__init__")] = {n for n, _ in _imports(path) if n.startswith("femref")}
    modules = set(graph)
    for name in graph:
        # an imported name may be a module or a name inside one: keep the longest module prefix
        graph[name] = {next((m for m in (".".join(t.split(".")[:k]) for k in range(t.count(".") + 1, 0, -1)) if m in modules), t) for t in graph[name]}
        graph[name] = {t for t in graph[name] if t in modules and t != name}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            pytest.fail(" -> ".join(cycle))


@pytest.mark.parametrize("package, forbidden", [("reduced", ("femref", "ann")), ("ann", ("femref", "reduced"))])
def test_reduced_and_ann_stand_alone(package: str, forbidden: tuple[str, ...]):
    bad = [
        f"{path.relative_to(REPO)}:{line}: {name}"
        for path in _modules(package)
        for name, line in _imports(path)
        if name.split(".")[0] in forbidden
    ]
    assert not bad, "\n".join(bad)
