"""Command-line front of the cases: common flags, config overrides, summary.json, exit codes.

Exit codes: 0 done, 2 bad input (one line on stderr, no traceback), 3 blow-up (the file keeps
the frames written before it), 130 interrupted.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import sys
import time
import typing
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from .config import SolverConfig
from .errors import BlowUpError, InputError
from .progress import Progress, deferred_sigint, run_callback
from .scene import Scene
from .warp_init import cpu_only

__all__ = ["CaseSetup", "case_module", "make_case_parser", "run_case"]


@dataclass
class CaseSetup:
    """What a case's ``build`` returns: the scene, the run length and frame count."""

    scene: Scene
    end_time: float
    frames: int = 20
    config: dict = field(default_factory=dict)


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad flag in one line and exits with code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _positive(name):
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text!r}") from None
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text!r}")
        return v

    return parse


def count_at_least(least: int):
    """argparse type: an integer >= least (a one-line error otherwise)."""
    def parse(text):
        try:
            n = int(text)
        except ValueError:
            n = least - 1
        if n < least:
            raise argparse.ArgumentTypeError(f"expected an integer >= {least}, got {text!r}")
        return n

    return parse


def _choice(name, allowed):
    lower = {a.lower(): a for a in allowed}

    def parse(text):
        if text.lower() not in lower:
            raise argparse.ArgumentTypeError(f"unknown {name} {text!r}; allowed: {', '.join(allowed)}")
        return lower[text.lower()]

    return parse


def config_flags() -> list[tuple[str, dataclasses.Field, object]]:
    """(flag, field, type) of every SolverConfig field that is a flag of ``mpmdem run`` (those
    made with ``mpmdem.config.flag``), in the order of the fields."""
    hints = typing.get_type_hints(SolverConfig)
    return [("--" + f.name.replace("_", "-"), f, hints[f.name]) for f in dataclasses.fields(SolverConfig)
            if "flag" in f.metadata]


def add_config_flags(parser: argparse.ArgumentParser, *, skip: tuple[str, ...] = ()) -> None:
    """A flag per SolverConfig flag field (default None: the case's choice stands): Literal
    fields take one of their values (any case), booleans --x/--no-x, numbers a number."""
    for name, f, tp in config_flags():
        if f.name in skip:
            continue
        spec = f.metadata["flag"]
        choices = typing.get_args(tp) if typing.get_origin(tp) is typing.Literal else ()
        text = spec["help"].format(choices=", ".join(choices))
        if choices:
            parser.add_argument(name, type=_choice(f.name.replace("_", " "), choices), choices=choices,
                                metavar=f.name.upper(), default=None, help=text)
        elif tp is bool:
            parser.add_argument(name, action=argparse.BooleanOptionalAction, default=None, help=text)
        else:
            kind = int if tp is int else _positive(name) if spec["positive"] else float
            parser.add_argument(name, type=kind, default=None, help=text)


def make_case_parser(module: ModuleType, prog: str | None = None) -> argparse.ArgumentParser:
    """The flags every case takes, plus the case's own (``add_arguments``)."""
    p = OneLineParser(prog=prog or f"mpmdem run {module.NAME}", description=module.DESCRIPTION)
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: the GPU if there is one)")
    p.add_argument("--out", default=None, help=f"output folder (default results/{module.NAME})")
    p.add_argument("--quick", action="store_true", help="a coarse, short run (for tests and a first look)")
    p.add_argument("--end-time", type=_positive("--end-time"), default=None, help="simulated time [s]")
    p.add_argument("--frames", type=count_at_least(1), default=None, help="output frames (an integer >= 1)")
    add_config_flags(p, skip=("coupling",) if getattr(module, "OWN_COUPLING_FLAG", False) else ())
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    if hasattr(module, "add_arguments"):
        module.add_arguments(p)
    return p


def case_module(name: str) -> ModuleType:
    """Import the module of a case by its CLI name (e.g. "sulsky-disks")."""
    from .cases import CASES

    if name not in CASES:
        raise InputError("case", name, "one of " + ", ".join(CASES))
    return importlib.import_module(f"mpmdem.cases.{CASES[name]}")


def config_from_args(setup: CaseSetup, module: ModuleType, args) -> SolverConfig:
    """Case defaults, then the case's build-time choices, then the flags the user gave."""
    fields = dict(getattr(module, "DEFAULTS", {}))
    fields.update(setup.config)
    for _, f, _ in config_flags():
        v = getattr(args, f.name, None)
        if v is not None:
            fields[f.name] = v
    return SolverConfig(**fields)


def written_since(folder: Path, since: float) -> list[str]:
    """Names of the files in ``folder`` written at or after ``since`` (time.time() [s]), sorted
    (a second of slack for file systems with coarse modification times)."""
    return sorted(p.name for p in folder.iterdir() if p.is_file() and p.stat().st_mtime >= since - 1.0)


def run_case(module: ModuleType, argv: list[str] | None = None, prog: str | None = None) -> int:
    """Parse flags, run the case, write OUT/summary.json; returns the exit code."""
    from .simulation import Simulation

    args = make_case_parser(module, prog).parse_args(argv)
    out = Path(args.out or Path("results") / module.NAME)
    summary = {"case": module.NAME, "status": "error"}
    try:
        setup = module.build(args)
        config = config_from_args(setup, module, args)
        end_time = args.end_time or setup.end_time
        frames = args.frames or setup.frames
        sim = Simulation(setup.scene, config, device=args.device)
    except InputError as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        print(f"mpmdem: error: --out={str(out)!r} is invalid: a folder that can be created ({e.strerror})",
              file=sys.stderr)
        return 2
    if not args.quiet and sim.device == "cpu" and cpu_only():
        print("mpmdem: no NVIDIA CUDA driver found: running on the CPU", file=sys.stderr)
    summary.update(device=sim.device, particles=sim.particle_count, bodies=sim.body_count, config=config.to_dict(),
                   end_time=end_time)
    t0 = time.perf_counter()
    started = time.time()
    code = 0
    try:
        with deferred_sigint() as interrupted:
            bar = None if args.quiet else Progress(end_time)
            try:
                result = sim.run(end_time, out=out, frames=frames, progress=run_callback(bar, interrupted),
                                 name=module.NAME.replace("-", "_"))
            finally:
                if bar is not None:
                    bar.close()
        summary.update(status=result.status, steps=result.steps, wall_seconds=time.perf_counter() - t0,
                       output=str(result.path))
        measures = module.summarize(sim, result, args)
        summary.update(measures)
        if hasattr(module, "VARIANTS"):  # further runs, each into OUT/<variant>/, and their comparison
            from .variants import VariantRun, compare_variants

            main = VariantRun("main", result.path, summary, measures, args, is_main=True)
            summary.update(compare_variants(module, args, sim, main, out, end_time, frames, config_from_args))
    except InputError as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    except BlowUpError as e:
        summary.update(status="blown-up", reason=e.reason, message=str(e), time=e.time)
        print(f"mpmdem: {e}", file=sys.stderr)
        code = 3
    except KeyboardInterrupt:
        summary.update(status="interrupted")
        print("mpmdem: interrupted; frames written so far are kept", file=sys.stderr)
        code = 130
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if code == 0 and not args.quiet:
        print(f"wrote in {out}: " + ", ".join(written_since(out, started)))
    return code

