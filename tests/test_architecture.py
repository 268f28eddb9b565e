"""The house rules ARCHITECTURE.md states, checked on the package's source: no import cycle
(relative and absolute imports, inside functions included, type-checking-only imports left
out), every top-level module in a layer and none importing a later layer, no module over the
size limit."""
from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "synthcompose"
MAX_LINES = 400  # "when a module grows past ~400 lines, split it by its steps"
#: the layers in pipeline order (a top-level module or package of synthcompose -> its layer):
#: a module imports only from its own layer or earlier ones; every top-level module has one
STAGE_OF = {
    # what every stage reads: errors, colours, the label table, the camera, files and image sets
    "errors": 0, "colour": 0, "labels": 0, "camera": 0, "io": 0, "builtin": 0,
    "geometry": 1,
    "placement": 2, "models": 2, "cast": 2,
    "look": 3,
    "lighting": 4, "manifest": 4,
    "render": 5,
    "compose": 6,
    "write": 7, "record": 7,
    # running the stages: one image set (stages/, run/pipeline), a batch and its engines (run/)
    "stages": 8, "run": 8,
    # the tools around the batch, the generator, the command line
    "tools": 9, "preview": 9, "synthetic": 9, "cli": 9, "__main__": 9,
}
MAX_TOP_LEVEL_MODULES = 12  # modules beside the packages, __init__ and __main__ included


def _modules(package: Path = PACKAGE) -> dict[str, Path]:
    out = {}
    for f in package.rglob("*.py"):
        parts = list(f.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = f
    return out


def _imports(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The package modules ``name`` imports (relative and absolute imports, at any depth of its
    code)."""
    found: set[str] = set()
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]

    def add(target: str, names: list[str], itself: bool = True) -> None:
        for candidate in ([target] if itself else []) + [f"{target}.{n}" for n in names]:
            if candidate in known and candidate != name:
                found.add(candidate)

    def visit(tree: ast.AST) -> None:
        for node in ast.iter_child_nodes(tree):
            if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
                continue
            if isinstance(node, ast.ImportFrom) and node.level > 0:
                base = package.split(".")
                if node.level > 1:
                    base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
                add(target, [a.name for a in node.names], itself=node.module is not None)  # from . import x: x
            elif isinstance(node, ast.ImportFrom) and node.module:  # from synthcompose.x import y
                add(node.module, [a.name for a in node.names])
            elif isinstance(node, ast.Import):  # import synthcompose.x.y
                for a in node.names:
                    add(a.name, [])
            visit(node)

    visit(ast.parse(path.read_text()))
    return found


def _graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    known = _modules(package)
    return {name: _imports(name, path, known) for name, path in known.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of ``graph`` (Tarjan's strongly connected components of more than one
    module)."""
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10000))
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def strong(v: str) -> None:
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
    return cycles


def test_no_import_cycle():
    assert not _cycles(_graph())


def test_a_planted_absolute_import_cycle_is_found(tmp_path):
    """The check reads absolute imports too: ``synthcompose.b`` importing ``synthcompose.a``
    back by its full name (at run time, inside a function) closes a cycle it must see."""
    pkg = tmp_path / "synthcompose"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from .sub import b\n")
    (pkg / "sub" / "b.py").write_text("def f():\n    from synthcompose.a import g\n")
    assert _cycles(_graph(pkg)) == [["synthcompose.a", "synthcompose.sub.b"]]
    (pkg / "sub" / "b.py").write_text("def f():\n    import synthcompose.a\n")
    assert _cycles(_graph(pkg)) == [["synthcompose.a", "synthcompose.sub.b"]]
    (pkg / "sub" / "b.py").write_text("def f():\n    import os\n")
    assert not _cycles(_graph(pkg))


def test_every_top_level_module_has_a_layer():
    top = {f.stem if f.suffix else f.name for f in PACKAGE.iterdir()
           if (f.suffix == ".py" and f.stem != "__init__") or (f / "__init__.py").is_file()}
    assert not top - set(STAGE_OF), sorted(top - set(STAGE_OF))
    assert not set(STAGE_OF) - top, sorted(set(STAGE_OF) - top)


def test_few_modules_at_the_top_level():
    modules = sorted(f.name for f in PACKAGE.glob("*.py"))
    assert len(modules) <= MAX_TOP_LEVEL_MODULES, modules


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


def test_no_private_name_is_imported_across_modules():
    """A name with a leading underscore stays in its module: ``from .x import _y`` is refused."""
    private = sorted(f"{f.relative_to(PACKAGE)}: {a.name}" for f in PACKAGE.rglob("*.py")
                     for node in ast.walk(ast.parse(f.read_text())) if isinstance(node, ast.ImportFrom)
                     for a in node.names if a.name.startswith("_") and not a.name.startswith("__"))
    assert not private, private
