"""The import graph of mpmdem (mpmdem/**) and mpmdem.kernels (kernels/**) has no cycle.

Built from the source by AST (no import runs): every ``import`` and ``from ... import``, relative
ones resolved and those inside functions included. Importing ``a.b.c`` also runs the packages
``a.b`` and ``a``: an edge goes to each of them too, except the importer's own packages (a module
inside a package runs after that package started)."""

import ast
from pathlib import Path

from helpers import ROOT

#: package name → its directory (as pyproject's package-dir installs them)
PACKAGES = {"mpmdem": ROOT / "mpmdem", "mpmdem.kernels": ROOT / "kernels"}


def _modules() -> dict[str, tuple[Path, bool]]:
    """Module name → (file, whether it is a package's __init__)."""
    out = {}
    for package, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            init = parts[-1] == "__init__"
            if init:
                parts = parts[:-1]
            out[".".join([package, *parts])] = (path, init)
    return out


def _targets(tree: ast.AST, name: str, init: bool, known) -> set[str]:
    """The modules of ``known`` that module ``name`` imports directly."""
    here = name if init else name.rpartition(".")[0]  # the package relative imports start from
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = here
            for _ in range(node.level - 1):
                base = base.rpartition(".")[0]
            module = node.module or ""
            if node.level:
                module = f"{base}.{module}" if module else base
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)  # (submodules: ``from . import x``)
    edges = set()
    for target in found:
        parts = target.split(".")
        for k in range(1, len(parts) + 1):  # the module and the packages it runs on the way
            prefix = ".".join(parts[:k])
            if prefix in known and prefix != name and not name.startswith(prefix + "."):
                edges.add(prefix)
    return edges


def import_graph() -> dict[str, set[str]]:
    """Module → the modules of mpmdem and mpmdem.kernels it imports."""
    modules = _modules()
    return {name: _targets(ast.parse(path.read_text()), name, init, modules)
            for name, (path, init) in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a list of modules (the first repeated at the end), or None."""
    colour = dict.fromkeys(graph, 0)  # 0 unvisited, 1 on the current path, 2 done
    path: list[str] = []

    def visit(node):
        colour[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if colour[nxt] == 1:
                return path[path.index(nxt):] + [nxt]
            if colour[nxt] == 0:
                cycle = visit(nxt)
                if cycle:
                    return cycle
        path.pop()
        colour[node] = 2
        return None

    for node in sorted(graph):
        if colour[node] == 0:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def test_graph_sees_relative_and_local_imports():
    graph = import_graph()
    assert "mpmdem.kernels.types" in graph["mpmdem.kernels.state"]  # a relative import
    assert "mpmdem.kernels.plasticity" in graph["mpmdem.kernels.constitutive"]  # one inside a function
    assert "mpmdem.kernels" in graph["mpmdem.sim.mpm"]  # a package on the way


def test_no_import_cycle():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_find_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
