"""The house rules ARCHITECTURE.md states, checked on the package's source: no import cycle
(imports inside functions included, type-checking-only imports left out), no stage importing a
stage after it, no module over the size limit."""
from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "synthcompose"
MAX_LINES = 400  # "when a module grows past ~400 lines, split it by its steps"
#: the stages in order (a top-level module or package of synthcompose -> its stage); modules not
#: named here (pipeline, batch, engines, cli, preview, compare, stages, ...) run the stages
STAGE_OF = {
    "errors": 0, "fileio": 0, "labels": 0, "colour": 0, "camera": 0, "dataset": 0,
    "geometry": 1, "right_view": 1,
    "placement": 2, "placements": 2, "surfaces": 2, "frequency": 2, "models": 2, "cast": 2,
    "lighting": 3, "appearance": 3,
    "gl": 4, "render": 4,
    "compose": 5,
    "writer": 6, "annotations": 6, "polygons": 6, "record": 6,
}


def _modules() -> dict[str, Path]:
    out = {}
    for f in PACKAGE.rglob("*.py"):
        parts = list(f.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def _imports(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package modules ``name`` imports (relative imports, at any depth of its code)."""
    found: set[str] = set()
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]

    def visit(tree: ast.AST) -> None:
        for node in ast.iter_child_nodes(tree):
            if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
                continue
            if isinstance(node, ast.ImportFrom) and node.level > 0:
                base = package.split(".")
                if node.level > 1:
                    base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
                for candidate in ([target] if node.module else []) + [f"{target}.{a.name}" for a in node.names]:
                    if candidate in known and candidate != name:
                        found.add(candidate)
            visit(node)

    visit(ast.parse(path.read_text()))
    return found


def _graph() -> dict[str, set[str]]:
    known = _modules()
    return {name: _imports(name, path, known) for name, path in known.items()}


def test_no_import_cycle():
    graph = _graph()
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10000))
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def strong(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in graph:
        if v not in index:
            strong(v)
    assert not cycles, cycles


def test_no_stage_imports_a_later_stage():
    def stage(name: str) -> int | None:
        parts = name.split(".")
        return STAGE_OF.get(parts[1]) if len(parts) > 1 else None

    late = [(a, b) for a, targets in _graph().items() for b in targets
            if stage(a) is not None and stage(b) is not None and stage(b) > stage(a)]
    assert not late, late


def test_no_module_over_the_size_limit():
    long = {str(f.relative_to(PACKAGE)): n for f in PACKAGE.rglob("*.py")
            if (n := len(f.read_text().splitlines())) > MAX_LINES}
    assert not long, long
