"""The package's import graph has no cycles: every module can be read knowing only the modules
below it.

Every import counts, at module level or inside a function (a lazy import still ties two modules
together), except imports under ``if TYPE_CHECKING:``, which exist only for the type checker.
Importing ``a.b.c`` runs ``a/__init__.py`` and ``a/b/__init__.py`` first, so a module also
depends on the ``__init__`` of every package above what it imports, except the packages it sits
in itself (those are already being loaded when it runs).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import resilient_tracking

PACKAGE = Path(resilient_tracking.__file__).parent
ROOT_NAME = PACKAGE.name


def module_name(path: Path) -> str:
    """``resilient_tracking.belief.ekf`` for ``.../belief/ekf.py`` (packages by their name)."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, hints: bool = False) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement of a tree, without those under ``if TYPE_CHECKING:`` unless
    ``hints``."""
    found: list[ast.Import | ast.ImportFrom] = []
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if not hints and isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append(node)
        stack.extend(ast.iter_child_nodes(node))
    return found


def imported(path: Path, modules: set[str], hints: bool = False) -> set[str]:
    """The package's modules that the file at ``path`` imports (and the packages above them)."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets: set[str] = set()
    for node in _imports(ast.parse(path.read_text()), hints):
        if isinstance(node, ast.Import):
            targets |= {a.name for a in node.names}
            continue
        base = node.module or ""
        if node.level:
            up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
            base = ".".join([*up, base] if base else up)
        targets.add(base)
        targets |= {f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in modules}
    own_packages = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
    out: set[str] = set()
    for target in targets:
        parts = target.split(".")
        above = {".".join(parts[:i]) for i in range(1, len(parts))}
        out |= {target} | (above - own_packages)  # a package being loaded is not run again
    return {m for m in out if m in modules and m != name and m != ROOT_NAME}


def import_graph(hints: bool = False) -> dict[str, set[str]]:
    """Each module's imports; ``hints``: with those under ``if TYPE_CHECKING:`` too."""
    files = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    return {name: imported(path, set(files), hints) for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
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
    return found


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert len(graph) > 80  # the scan found the package's modules
    assert cycles(graph) == []


def test_type_hints_close_no_import_cycle_either():
    # a cycle through type hints alone still means two modules cannot be read apart
    assert cycles(import_graph(hints=True)) == []


def test_the_scan_finds_a_cycle_and_ignores_type_checking(tmp_path, monkeypatch):
    pkg = tmp_path / "resilient_tracking"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from resilient_tracking.sub import b\n")
    (pkg / "sub" / "b.py").write_text("from .. import c\n")
    (pkg / "c.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from resilient_tracking import a\n"
    )
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", pkg)
    graph = import_graph()
    assert graph["resilient_tracking.a"] == {"resilient_tracking.sub", "resilient_tracking.sub.b"}
    assert cycles(graph) == []
    assert len(cycles(import_graph(hints=True))) == 1
    (pkg / "c.py").write_text("import resilient_tracking.a\n")
    assert cycles(import_graph()) == [
        ["resilient_tracking.a", "resilient_tracking.c", "resilient_tracking.sub.b"]
    ]
