"""Running one case: its flags (the common ones, the config's and its own), its SolverConfig (case
defaults, then its build, then the flags), the run, its variants and its summary.json.

The library's "run one case": ``mpmdem run``, a case script's ``__main__``, ``mpmdem validate`` and
the study workers all run a case through ``run_case`` (the case protocol: ``mpmdem.study.case``).

Exit codes: 0 done, 2 bad input (one line on stderr, no traceback), 3 blow-up (the file keeps
the frames written before it), 130 interrupted by Ctrl-C, 143 stopped by SIGTERM (the file is
marked "interrupted" and summary.json written either way, ``mpmdem.study.signals``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import typing
from pathlib import Path
from types import ModuleType

from ..errors import BlowUpError, InputError
from ..model.config import SolverConfig
from ..sim.warp_init import check_device, cpu_only
from .case import CaseSetup, case_module
from .flag_types import choice, count_at_least, given, non_negative, positive
from .run_plan import (
    DISK_FRACTION,
    check_frame_interval,
    check_output_size,
    estimate_output_bytes,
    long_run_warning,
    parse_size,
)
from .run_progress import Progress, run_callback
from .signals import deferred_stop, exit_code, sigterm_raises

__all__ = ["CaseSetup", "OneLineParser", "case_module", "count_at_least", "make_case_parser", "out_folder", "run_case"]


def _join_dash_values(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """``--flag -1e-5`` as ``--flag=-1e-5``: argparse takes a token that starts with one "-" and is
    not a plain negative number (-1, -0.5) for a flag (-1e-5, -inf, -1,5), and then says "expected
    one argument"; joined, the value reaches the flag's type, which refuses it with the real rule
    or takes it. A token that is one of the parser's options (-h) is left as it is."""
    out: list[str] = []
    options = parser._option_string_actions
    for tok in argv:
        prev = out[-1] if out else ""
        action = options.get(prev) if prev.startswith("--") else None
        if (action is not None and action.nargs is None and tok.startswith("-") and not tok.startswith("--")
                and tok not in options):
            out[-1] = f"{prev}={tok}"
        else:
            out.append(tok)
    return out


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad flag in one line and exits with code 2, and that passes a
    negative number (-1e-5, -inf) to a flag as its value."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")

    def parse_known_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        return super().parse_known_args(_join_dash_values(self, args), namespace)


def config_flags() -> list[tuple[str, dataclasses.Field, object]]:
    """(flag, field, type) of every SolverConfig field that is a flag of ``mpmdem run`` (those
    made with ``mpmdem.model.config.flag``), in the order of the fields."""
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
            parser.add_argument(name, type=choice(f.name.replace("_", " "), choices), choices=choices,
                                metavar=f.name.upper(), default=None, help=text)
        elif tp is bool:
            parser.add_argument(name, action=argparse.BooleanOptionalAction, default=None, help=text)
        else:
            # (no flag of the config takes a negative number; "positive" ones not 0 either)
            if tp is int:
                kind = count_at_least(1 if spec["positive"] else 0)
            else:
                kind = positive() if spec["positive"] else non_negative()
            parser.add_argument(name, type=kind, default=None, help=text)


def make_case_parser(module: ModuleType, prog: str | None = None) -> argparse.ArgumentParser:
    """The flags every case takes, plus the case's own (``add_arguments``)."""
    p = OneLineParser(prog=prog or f"mpmdem run {module.NAME}", description=module.DESCRIPTION)
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: the GPU if there is one)")
    p.add_argument("--out", default=None, help=f"output folder (default results/{module.NAME})")
    p.add_argument("--quick", action="store_true", help="a coarse, short run (for tests and a first look)")
    p.add_argument("--end-time", type=positive("s"), default=None, help="simulated time [s]")
    p.add_argument("--frames", type=count_at_least(1), default=None, help="output frames (an integer >= 1)")
    p.add_argument("--max-output", type=parse_size, default=None, metavar="SIZE",
                   help="refuse a run whose output would exceed SIZE (bytes, or 500M, 2G; default: "
                        f"{100 * DISK_FRACTION:g} %% of the free disk)")
    add_config_flags(p, skip=("coupling",) if getattr(module, "OWN_COUPLING_FLAG", False) else ())
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    if hasattr(module, "add_arguments"):
        module.add_arguments(p)
    return p


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


def out_folder(path: str | Path, flag: str = "--out") -> Path:
    """The output folder ``path``, created if needed; InputError naming ``flag`` when it cannot be
    (a file of that name, no permission)."""
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        reason = "a file of that name exists" if folder.is_file() else e.strerror
        raise InputError(flag, str(folder), f"a folder that can be created ({reason})") from None
    return folder


def plan_run(sim, args, out: Path, end_time: float, frames: int) -> tuple[int, str | None]:
    """The checks of ``mpmdem.study.run_plan`` for a built Simulation: InputError for a frame interval
    below the first step (given with --frames) or an output above the limit; returns the frame count
    (a case's own count, when no --frames was given, capped at one frame a step: a flag such as
    --dem-kappa or --end-time may have lengthened the step) and the long-run warning line (or None)."""
    dt, _ = sim.initial_step()
    if args.frames is None:
        frames = min(frames, max(1, int(end_time / dt)))
    check_frame_interval(end_time, frames, dt)
    estimate = estimate_output_bytes(sim.particle_count, sim.body_count, frames, sim.config.precision,
                                     coupled=sim.coupling is not None,
                                     grains=sum(len(s) for s in sim.model.grains))
    check_output_size(estimate, out, frames, args.max_output)
    return frames, long_run_warning(end_time, dt, sim.particle_count, sim.device)


def run_case(module: ModuleType, argv: list[str] | None = None, prog: str | None = None) -> int:
    """Parse flags, run the case, write OUT/summary.json; returns the exit code (0 done, 2 bad
    input, 3 blow-up, 128 + the signal's number when stopped by Ctrl-C or SIGTERM)."""
    from ..sim.simulation import Simulation

    args = make_case_parser(module, prog).parse_args(argv)
    summary = {"case": module.NAME, "status": "error"}
    try:
        check_device(args.device)
        setup = module.build(args)
        config = config_from_args(setup, module, args)
        end_time = given(args.end_time, setup.end_time)
        frames = given(args.frames, setup.frames)
        sim = Simulation(setup.scene, config, device=args.device)
        out = Path(args.out or Path("results") / module.NAME)
        frames, warning = plan_run(sim, args, out, end_time, frames)
        out = out_folder(out)
    except InputError as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    if warning:
        print(warning, file=sys.stderr)
    if not args.quiet and sim.device == "cpu" and cpu_only():
        print("mpmdem: no NVIDIA CUDA driver found: running on the CPU", file=sys.stderr)
    summary.update(device=sim.device, particles=sim.particle_count, bodies=sim.body_count, config=config.to_dict(),
                   end_time=end_time)
    t0 = time.perf_counter()
    started = time.time()
    code = 0
    try:
        with sigterm_raises():
            with deferred_stop() as received:
                bar = None if args.quiet else Progress(end_time)
                try:
                    result = sim.run(end_time, out=out, frames=frames, progress=run_callback(bar, received),
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
    except KeyboardInterrupt as e:
        code = exit_code(e)
        summary.update(status="interrupted", message=str(e) or "stopped by Ctrl-C")
        print(f"mpmdem: interrupted ({summary['message']}); frames written so far are kept", file=sys.stderr)
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    if code == 0 and not args.quiet:
        print(f"wrote in {out}: " + ", ".join(written_since(out, started)))
    return code
