"""The library's imports run one way: concepts below, the layers that judge, record or present above.

An AST scan of ``src/motionlab`` reads every import, also those inside functions (a deferred import is still a
dependency), resolves relative imports, and checks two rules:

- a concept package or a ground-floor module imports nothing from the upper layers;
- the graph between top-level packages has no circle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = "motionlab"

# The papers' concepts and the foundations they stand on.
CONCEPTS = {
    "representation",
    "data",
    "text",
    "io",
    "train",
    "tokenizers",
    "metrics",
    "flow",
    "diffusion",
    "multimotion",
}
# Modules every layer may use; they import nothing above themselves.
GROUND = {"estimate", "comparison", "paths", "profiles", "precision", "settings", "sizes", "checks", "interrupts"}
# What judges, records, presents or assembles the concepts.
UPPER = {
    "report",
    "evaluation",
    "studies",
    "models",
    "pretrained",
    "build",
    "book",
    "results",
    "cli",
    "__main__",
    "viz",
    "try_it",
}


def _module_name(path: Path) -> str:
    """``src/motionlab/flow/toy.py`` -> ``motionlab.flow.toy``; a package's ``__init__`` names the package."""
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imported_modules(path: Path) -> list[tuple[str, int]]:
    """Every ``motionlab`` module ``path`` imports, with the line, counting imports at any depth."""
    module = _module_name(path)
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[tuple[str, int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                # A relative import counts from the package holding the module (the module itself for __init__).
                base = module.split(".")
                if not is_package:
                    base = base[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            # ``from motionlab import viz`` imports the subpackage ``viz``, not just the package.
            found += [(f"{target}.{alias.name}", node.lineno) for alias in node.names]
    return [(name, line) for name, line in found if name == PACKAGE or name.startswith(PACKAGE + ".")]


def _top(name: str) -> str | None:
    """The top-level package or module of ``motionlab.x.y`` (``x``), or None for ``motionlab`` itself."""
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else None


def _known_tops() -> set[str]:
    root = SRC / PACKAGE
    return {p.stem for p in root.glob("*.py")} | {p.name for p in root.iterdir() if (p / "__init__.py").exists()}


def scan() -> list[tuple[str, str, str, int]]:
    """Edges ``(from_top, to_top, file, line)`` between distinct top-level parts of the package."""
    tops = _known_tops()
    edges = []
    for path in sorted((SRC / PACKAGE).rglob("*.py")):
        here = _top(_module_name(path))
        for name, line in _imported_modules(path):
            there = _top(name)
            # ``from motionlab import __version__`` and the like name an attribute, not a part.
            if here is None or there is None or there not in tops or there == here:
                continue
            edges.append((here, there, str(path.relative_to(SRC)), line))
    return edges


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One circle in ``graph`` as a path ``[a, b, ..., a]``, or None when the graph has none."""
    state: dict[str, int] = {}  # 1 = on the current path, 2 = finished
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt) :] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def test_the_layers_cover_the_package():
    """Every listed name exists and every top-level part is listed, so a rename or a new module cannot silently fall
    outside the rules."""
    tops = _known_tops() - {"__init__"}
    listed = CONCEPTS | GROUND | UPPER
    assert not listed - tops, f"layer lists name parts that do not exist: {sorted(listed - tops)}"
    assert not tops - listed, f"top-level parts in no layer (add them to a list above): {sorted(tops - listed)}"


def test_concepts_and_ground_import_nothing_above():
    upward = [
        f"{file}:{line}: {here} -> {there}"
        for here, there, file, line in scan()
        if here in CONCEPTS | GROUND and there in UPPER
    ]
    assert not upward, "imports from a concept or ground-floor module up into a layer above:\n" + "\n".join(upward)


def test_ground_floor_imports_no_concept():
    upward = [
        f"{file}:{line}: {here} -> {there}"
        for here, there, file, line in scan()
        if here in GROUND and there in CONCEPTS
    ]
    assert not upward, "ground-floor modules import a concept package:\n" + "\n".join(upward)


def test_no_circle_between_top_level_parts():
    graph: dict[str, set[str]] = {}
    where: dict[tuple[str, str], str] = {}
    for here, there, file, line in scan():
        graph.setdefault(here, set()).add(there)
        where.setdefault((here, there), f"{file}:{line}")
    cycle = find_cycle(graph)
    if cycle:
        steps = "\n".join(f"  {a} -> {b}  ({where[a, b]})" for a, b in zip(cycle, cycle[1:]))
        pytest.fail(f"circle between top-level parts of motionlab: {' -> '.join(cycle)}\n{steps}")


@pytest.mark.parametrize(
    ("graph", "has_cycle"),
    [({"a": {"b"}, "b": {"c"}}, False), ({"a": {"b"}, "b": {"c"}, "c": {"a"}}, True), ({"a": {"a"}}, True)],
)
def test_find_cycle(graph, has_cycle):
    cycle = find_cycle(graph)
    assert (cycle is not None) == has_cycle
    if cycle:
        assert cycle[0] == cycle[-1]
        assert all(b in graph[a] for a, b in zip(cycle, cycle[1:]))
