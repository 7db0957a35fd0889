"""No import circles in rigid_body_sim/, not even through imports made only for type checking;
no test module importing another.

The graph is read from the sources (AST), so it sees every kind of import at once: top-level
ones, lazy ones inside functions, and those under ``if TYPE_CHECKING:``. A circle of lazy or
type-only imports does not fail at run time, but it still means two modules each need the
other to be read: one of them holds something that belongs elsewhere. An edge goes to the
module an import names (``from .a import b`` is an edge to ``a.b`` when that is a module, else
to ``a``); importing a module also runs its packages' ``__init__``, which is not counted as an
edge, so a package may re-export what its modules define.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "rigid_body_sim"


def _module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules(root: Path) -> dict[str, Path]:
    return {_module_name(p, root): p for p in sorted(root.rglob("*.py")) if "__pycache__" not in p.parts}


def _edges(name: str, path: Path, known: set[str]) -> dict[str, list[tuple[int, str]]]:
    """{imported module: [(line, kind)]} for module ``name`` at ``path``; kind is top-level, lazy or TYPE_CHECKING."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    package = name if is_package else name.rpartition(".")[0]
    kinds: dict[int, str] = {}

    def mark(node: ast.AST, kind: str) -> None:
        for child in ast.walk(node):
            kinds.setdefault(id(child), kind)

    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for stmt in node.body:
                mark(stmt, "TYPE_CHECKING")
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for stmt in node.body:
                mark(stmt, "lazy")

    def resolve(module: str) -> str | None:
        while module and module not in known:
            module = module.rpartition(".")[0]
        return module or None

    found: dict[str, list[tuple[int, str]]] = {}
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            targets = [f"{module}.{alias.name}" if f"{module}.{alias.name}" in known else module for alias in node.names]
        for target in targets:
            resolved = resolve(target)
            if resolved is not None and resolved != name:
                found.setdefault(resolved, []).append((node.lineno, kinds.get(id(node), "top-level")))
    return found


def import_graph(root: Path = PACKAGE) -> dict[str, dict[str, list[tuple[int, str]]]]:
    modules = _modules(root)
    known = set(modules)
    return {name: _edges(name, path, known) for name, path in modules.items()}


def cycles(graph: dict[str, dict[str, list]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted; sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
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
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def _describe(graph: dict[str, dict[str, list]], component: list[str]) -> str:
    members = set(component)
    lines = [f"  {a} -> {b} ({', '.join(f'line {line} {kind}' for line, kind in graph[a][b])})"
             for a in component for b in sorted(graph[a]) if b in members]
    return "\n".join(lines)


def test_no_import_cycles_in_the_package() -> None:
    graph = import_graph()
    assert len(graph) > 50 and "rigid_body_sim.core.simulator" in graph
    found = cycles(graph)
    report = "\n".join(f"cycle of {len(c)} modules:\n{_describe(graph, c)}" for c in found)
    assert not found, f"import cycles in rigid_body_sim/ (top-level, lazy and TYPE_CHECKING imports):\n{report}"


def test_the_graph_sees_lazy_and_type_checking_imports(tmp_path: Path) -> None:
    """The checker itself, on a small package: a circle closed only by TYPE_CHECKING or a lazy import is found."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .b import B\n")
    (package / "b.py").write_text("from . import c\n")
    (package / "c.py").write_text("def f():\n    from .a import A\n")
    (package / "d.py").write_text("import pkg.c\n")
    modules = _modules(package)
    known = set(modules)
    assert known == {"pkg", "pkg.a", "pkg.b", "pkg.c", "pkg.d"}

    graph = {m: _edges(m, p, known) for m, p in modules.items()}
    assert graph["pkg.a"] == {"pkg.b": [(3, "TYPE_CHECKING")]}
    assert graph["pkg.b"] == {"pkg.c": [(1, "top-level")]}
    assert graph["pkg.c"] == {"pkg.a": [(2, "lazy")]}
    assert graph["pkg.d"] == {"pkg.c": [(1, "top-level")]}
    assert cycles(graph) == [["pkg.a", "pkg.b", "pkg.c"]]


def test_no_test_module_imports_another() -> None:
    """What tests share lives in support modules (helpers.py, foxglove_support.py,
    session_support.py): a test module imported by another would run its collection-time code
    twice and tie one file's tests to another's."""
    offenders = []
    for path in sorted((REPO / "test").glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
            offenders += [f"{path.name}:{node.lineno} imports {name}" for name in names
                          if name.split(".")[0].startswith("test_")]
    assert not offenders, offenders
