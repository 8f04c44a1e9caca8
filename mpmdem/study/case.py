"""The case protocol: what a case module (``cases/<name>.py``, or a user's own) provides, and what
its ``build`` returns. Library code: cases depend on it, not on the command line.

A case module defines ``NAME``, ``DESCRIPTION``, ``add_arguments(parser)`` (its own flags),
``build(args) -> CaseSetup`` and, optionally, ``DEFAULTS`` (SolverConfig fields), ``VALIDATION``
(``mpmdem.study.validation.Check`` rows) and ``summarize(sim, result, args) -> dict``;
``mpmdem.study.runner.run_case`` parses the flags, runs it and writes its summary.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..model.scene import Scene

__all__ = ["CaseSetup"]


@dataclass
class CaseSetup:
    """What a case's ``build`` returns: the scene, the run length [s], the frame count and the
    SolverConfig fields the case sets (the user's flags override them)."""

    scene: Scene
    end_time: float
    frames: int = 20
    config: dict = field(default_factory=dict)
