"""Import cycles between the modules of a package (stdlib only).

Usage: ``python tools/import_cycles.py [PACKAGE_DIR]`` (default: ``reach_addon`` beside
this folder). Prints each cycle with the lines that make it and exits 1, or prints
"no import cycles" and exits 0.

Every ``.py`` file under PACKAGE_DIR is a module (a package is its ``__init__.py``). Every
``import`` and ``from ... import`` in a module counts, wherever it is written: at module
level, inside a function or class, under ``if`` or ``try``. Relative imports are resolved
against the importing module. Imports of anything outside the package are ignored.

What an import is an edge to:

* ``import p.a.b`` is an edge to ``p.a.b``; ``from p.a import b`` (or ``from .a import b``,
  ``from . import b``) is an edge to the module ``p.a.b`` when there is one (a submodule
  imported by name) and otherwise to ``p.a`` (``b`` is a name defined there).
* Importing ``p.a.b`` also runs the ``__init__`` of every package on the way (``p.a``), so
  the importer has an edge to each of those packages too — except to its own ancestor
  packages, which Python has already started before the importer's code runs.
* A package's imports of its own submodules are edges like any other.
* A module's import *from its own ancestor package* (``from . import __version__`` in
  ``p/cli.py``, or ``from .. import x`` deeper down) is an edge only when that package's
  ``__init__`` imports the module at module level, directly or through other module-level
  imports (imports inside functions do not count for this test). Python runs a package's
  ``__init__`` before any of its submodules: unless the ``__init__``'s own module-level
  imports lead to the module, the package has finished running when the module reads from
  it, so the import can neither start an import nor see a half-made package. When they do
  lead to it, the module can read the package half-made, and the edge counts (and closes
  a cycle through the package like any other edge).

A cycle is a strongly connected component of more than one module (Tarjan's algorithm); an
import of a module by itself is ignored. ``if TYPE_CHECKING:`` imports count like the rest.
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Edge:
    source: str
    target: str
    line: int
    top_level: bool          # the import runs when the source module is imported


def modules_of(package_dir: Path) -> dict[str, Path]:
    """{dotted module name: file} of every module under ``package_dir``."""
    package_dir = package_dir.resolve()
    base = package_dir.name
    out = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = list(path.relative_to(package_dir).with_suffix("").parts)
        if any(not p.isidentifier() for p in parts):
            continue
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join([base, *parts])] = path
    return out


def _is_package(path: Path) -> bool:
    return path.name == "__init__.py"


def _ancestors(name: str) -> list[str]:
    """``a.b.c`` → [``a``, ``a.b``]."""
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _imports(tree: ast.Module):
    """(node, runs at import time?) for every import statement in the module."""
    def walk(node, top):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, top
            inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                   ast.Lambda))
            yield from walk(child, inner)
    yield from walk(tree, True)


def _targets(node, name: str, is_package: bool, modules) -> list[str]:
    """The package modules one import statement in module ``name`` names."""
    if isinstance(node, ast.Import):
        out = []
        for alias in node.names:
            parts = alias.name.split(".")
            # ``import p.a.b`` imports p.a.b; the longest prefix that is a module of ours.
            found = next((".".join(parts[:i]) for i in range(len(parts), 0, -1)
                          if ".".join(parts[:i]) in modules), None)
            if found is not None:
                out.append(found)
        return out
    if node.level:
        here = name.split(".") if is_package else name.split(".")[:-1]
        if node.level - 1 > len(here):
            return []
        base = here[:len(here) - (node.level - 1)]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    out = []
    for alias in node.names:
        sub = f"{source}.{alias.name}"
        if alias.name != "*" and sub in modules:
            out.append(sub)
        elif source in modules:
            out.append(source)
    return out


def import_edges(package_dir: Path) -> tuple[dict[str, Path], list[Edge]]:
    """The modules and the edges between them, by the rules of the module docstring."""
    modules = modules_of(package_dir)
    raw = []
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        own = set(_ancestors(name))
        for node, top in _imports(tree):
            for target in _targets(node, name, _is_package(path), modules):
                for t in [*_ancestors(target), target]:
                    if t not in modules or t == name:
                        continue
                    if t in own and t != target:
                        continue          # an ancestor run on the way: already started
                    raw.append(Edge(name, t, node.lineno, top))
    # Imports from an own ancestor count only when the ancestor's module-level imports
    # (not counting such imports themselves) lead to the importing module.
    plain = [e for e in raw if e.target not in _ancestors(e.source)]
    top_graph: dict[str, set[str]] = {}
    for e in plain:
        if e.top_level:
            top_graph.setdefault(e.source, set()).add(e.target)
    edges = plain + [e for e in raw if e.target in _ancestors(e.source)
                     and e.source in _reachable(top_graph, e.target)]
    return modules, edges


def _reachable(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        for nxt in graph.get(todo.pop(), ()):
            if nxt not in seen:
                seen.add(nxt)
                todo.append(nxt)
    return seen


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components (iterative), those of more than one node."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        out.append(sorted(component))
    return sorted(out)


def find_cycles(package_dir: Path) -> list[list[str]]:
    """Each cycle as lines of text: its modules, then every import between them."""
    modules, edges = import_edges(package_dir)
    graph: dict[str, set[str]] = {}
    where: dict[tuple[str, str], list[int]] = {}
    for e in edges:
        graph.setdefault(e.source, set()).add(e.target)
        where.setdefault((e.source, e.target), []).append(e.line)
    reports = []
    for component in strongly_connected(graph):
        lines = ["import cycle: " + ", ".join(component)]
        inside = set(component)
        for a in component:
            rel = modules[a].relative_to(package_dir.resolve().parent)
            for b in sorted(graph[a] & inside):
                at = ", ".join(str(n) for n in sorted(set(where[(a, b)])))
                lines.append(f"  {a} imports {b}  ({rel}: line {at})")
        reports.append(lines)
    return reports


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    package_dir = Path(argv[0]) if argv else ROOT / "reach_addon"
    if not (package_dir / "__init__.py").is_file():
        print(f"import_cycles: {package_dir} is not a package", file=sys.stderr)
        return 2
    reports = find_cycles(package_dir)
    for lines in reports:
        print("\n".join(lines))
    if reports:
        print(f"{len(reports)} import cycle(s) in {package_dir.name}")
        return 1
    print("no import cycles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
