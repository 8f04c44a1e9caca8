"""A test-only case for the study runner: one DEM disk at rest; ``--fail`` makes ``build`` raise,
``--crash`` end its process. ``count_rows`` is an ``analyze`` for a study file's test."""

from mpmdem import ContactLaw, Scene, sphero_disk
from mpmdem.study.case import CaseSetup

NAME = "study-raising-case"
DESCRIPTION = "one resting DEM disk; --fail raises inside build (a bug, not bad input)"
DEFAULTS = {}


def add_arguments(parser):
    parser.add_argument("--fail", action="store_true", help="raise RuntimeError in build")
    parser.add_argument("--crash", action="store_true", help="end the process in build (a lost worker)")


def build(args) -> CaseSetup:
    if args.crash:
        import os

        os._exit(1)
    if args.fail:
        raise RuntimeError("this case was told to fail")
    scene = Scene(domain=((-1.0, -1.0), (1.0, 1.0)), contact=ContactLaw(1e6))
    scene.add_rigid_body(sphero_disk(0.1), density=1000.0, position=(0.0, 0.0))
    return CaseSetup(scene, end_time=0.01, frames=2)


def summarize(sim, result, args) -> dict:
    return {"steps_run": result.steps, "a_list": [1, 2, 3]}


def count_rows(rows, out):
    """An ``analyze``: writes the number of rows to OUT/rows.txt."""
    (out / "rows.txt").write_text(f"{len(rows)}\n")
