"""The case protocol: what a case module (``cases/<name>.py``, or a user's own) provides, and what
its ``build`` returns. Library code: cases depend on it, not on the command line.

A case module defines ``NAME``, ``DESCRIPTION``, ``add_arguments(parser)`` (its own flags),
``build(args) -> CaseSetup`` and, optionally, ``DEFAULTS`` (SolverConfig fields), ``VALIDATION``
(``mpmdem.study.validation.Check`` rows), ``summarize(sim, result, args) -> dict`` and
``costly_build(args) -> bool`` (True when ``build`` itself simulates: a study then groups the runs
for batching without building them first, ``mpmdem.study.batch_worker``);
``mpmdem.study.runner.run_case`` parses the flags, runs it and writes its summary.

The built-in cases are plug-ins on top of the library: ``mpmdem.cases`` lists them by name
(``CASES``, ``DEFAULT_CASE``) and each imports what it uses of the library. The library finds them
by that name when a run asks for one (``case_module``), never by a static import, so the import
graph keeps its layers (tests/project/test_layers.py).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from types import ModuleType

from ..errors import InputError
from ..model.scene import Scene

__all__ = ["CASES_PACKAGE", "CaseSetup", "case_module", "case_names", "default_case", "load_case"]

#: the package of the built-in cases (``cases/`` in a checkout, installed as mpmdem.cases)
CASES_PACKAGE = "mpmdem.cases"


@dataclass
class CaseSetup:
    """What a case's ``build`` returns: the scene, the run length [s], the frame count and the
    SolverConfig fields the case sets (the user's flags override them)."""

    scene: Scene
    end_time: float
    frames: int = 20
    config: dict = field(default_factory=dict)


def case_names() -> dict[str, str]:
    """The built-in cases: command-line name (e.g. "sulsky-disks") → module name, in the order
    ``mpmdem list`` shows them (``mpmdem.cases.CASES``)."""
    return importlib.import_module(CASES_PACKAGE).CASES


def default_case() -> str:
    """The case ``mpmdem run`` runs without a name (``mpmdem.cases.DEFAULT_CASE``)."""
    return importlib.import_module(CASES_PACKAGE).DEFAULT_CASE


def case_module(name: str) -> ModuleType:
    """Import the module of a case by its CLI name (e.g. "sulsky-disks")."""
    cases = case_names()
    if name not in cases:
        raise InputError("case", name, "one of " + ", ".join(cases))
    return importlib.import_module(f"{CASES_PACKAGE}.{cases[name]}")


def load_case(case: str) -> ModuleType:
    """The case module: a name of ``mpmdem list`` or an importable module (``my_package.my_case``)."""
    if case in case_names() or not all(part.isidentifier() for part in case.split(".")):
        return case_module(case)
    try:
        return importlib.import_module(case)
    except ImportError as e:
        raise InputError("case", case, f"a case of mpmdem list or an importable case module ({e})") from None
