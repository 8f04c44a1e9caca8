"""The import graph reads in layers: cli → cases → study → sim → io → model → base → kernels, with no
arrow up (issue 47).

The graph is the one tests/project/test_imports.py checks for cycles (built by AST from the source: every
import, those inside functions too), over mpmdem/**, kernels/** (mpmdem.kernels) and cases/**
(mpmdem.cases). A module may import its own layer and any layer below it. The package ``mpmdem``
itself (the public API: ``Scene``, ``Simulation``, materials, ...) re-exports the model and the
simulation, so it counts as the simulation layer: cases import it, the model may not.

The library finds the cases by name (``mpmdem.study.case.case_module``), never by an import, so
the cases can build on the study layer (``CaseSetup``, ``Check``, ``Variant``, flag types).
"""

import ast

from helpers import ROOT
from test_imports import _targets

#: (layer, the module prefixes in it), bottom first
LAYERS = [
    ("kernels", ("mpmdem.kernels",)),
    ("base", ("mpmdem.errors", "mpmdem.checks")),
    ("model", ("mpmdem.model",)),
    ("io", ("mpmdem.io",)),
    ("sim", ("mpmdem.sim",)),
    ("study", ("mpmdem.study",)),
    ("cases", ("mpmdem.cases",)),
    ("cli", ("mpmdem.cli",)),
]
#: modules that are their package's public face: the layer whose names they re-export
FACADES = {"mpmdem": "sim"}
PACKAGES = {"mpmdem": ROOT / "mpmdem", "mpmdem.kernels": ROOT / "kernels", "mpmdem.cases": ROOT / "cases"}


def layer_of(module: str) -> int | None:
    """The index in LAYERS of the layer a module belongs to (None: no layer)."""
    if module in FACADES:
        return [name for name, _ in LAYERS].index(FACADES[module])
    for k, (_, prefixes) in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return k
    return None


def graph() -> dict[str, set[str]]:
    """Module → the modules of mpmdem, mpmdem.kernels and mpmdem.cases it imports."""
    modules = {}
    for package, folder in PACKAGES.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            init = parts[-1] == "__init__"
            modules[".".join([package, *(parts[:-1] if init else parts)])] = (path, init)
    return {name: _targets(ast.parse(path.read_text()), name, init, modules)
            for name, (path, init) in modules.items()}


def upward_arrows(g: dict[str, set[str]]) -> list[str]:
    """Every import of a module from a higher layer, as "a (layer) -> b (layer)"."""
    names = [name for name, _ in LAYERS]
    out = []
    for a in sorted(g):
        for b in sorted(g[a]):
            la, lb = layer_of(a), layer_of(b)
            if la is not None and lb is not None and lb > la:
                out.append(f"{a} ({names[la]}) -> {b} ({names[lb]})")
    return out


def test_every_module_has_a_layer():
    assert [m for m in graph() if layer_of(m) is None] == []


def test_no_upward_arrow():
    arrows = upward_arrows(graph())
    assert not arrows, "imports from a higher layer:\n" + "\n".join(arrows)


def test_upward_arrow_named():
    g = {"mpmdem.model.scene": {"mpmdem.sim.simulation", "mpmdem.errors"}, "mpmdem.sim.mpm": {"mpmdem.kernels.grid"},
         "mpmdem.study.runner": {"mpmdem.cases.axial_bar"}, "mpmdem.cases.axial_bar": {"mpmdem"}}
    assert upward_arrows(g) == ["mpmdem.model.scene (model) -> mpmdem.sim.simulation (sim)",
                                "mpmdem.study.runner (study) -> mpmdem.cases.axial_bar (cases)"]


def test_graph_sees_the_cases_and_lazy_imports():
    g = graph()
    assert "mpmdem.study.case" in g["mpmdem.cases.axial_bar"]
    assert "mpmdem.study.runner" in g["mpmdem.cases.axial_bar"]  # inside ``if __name__ == "__main__"``
    assert "mpmdem.study.runner" in g["mpmdem.study.worker"]  # inside a function


def test_pyproject_installs_every_subpackage():
    """An install carries every package of the layers (pyproject's explicit list), not only a checkout."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(["mpmdem", *p.parent.relative_to(ROOT / "mpmdem").parts])
             for p in (ROOT / "mpmdem").rglob("__init__.py")}
    assert found <= listed, sorted(found - listed)
