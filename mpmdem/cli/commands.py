"""``mpmdem`` command line: run | list | study | info | plot | animate — a thin layer over the Python API."""

from __future__ import annotations

import argparse
import sys

__all__ = ["main"]

USAGE = """usage: mpmdem COMMAND ...   (mpmdem --version: its version and Warp's)

commands:
  run CASE [flags]     run a case (mpmdem run CASE --help lists its flags)
  list                 the cases, with a line each
  study NAME|FILE [--out DIR] [--workers N] [--gpus N] [--workers-per-gpu K] [--scheduler ADDR]
        [--device cpu|cuda] [--rerun-failed] [--set FLAG=VALUE ...]
                       run a case over a grid of flag values on a Dask cluster (mpmdem study --help)
  validate [--device D] [--out DIR] [--quick] [--cases A,B]
                       every case that declares checks, against its references: validation.md/.json
  info FILE            summary of a result file (.h5)
  plot FILE [--out DIR] [--field NAME]
                       PNGs: energy and momentum vs time, snapshots coloured by a field
  animate FILE [--out FILE.mp4|FILE.gif] [--field NAME] [--fps N] [--frames START:STOP:STEP|I,J,...]
                       a movie of the run: points coloured by a field, body outlines, the time
                       (MP4 with ffmpeg, else GIF)
"""


def _version() -> int:
    """Print mpmdem's version and that of the Warp installed beside it (read from the package
    metadata: Warp is not initialised for it)."""
    from importlib import metadata

    from .. import __version__

    try:
        warp = metadata.version("warp-lang")
    except metadata.PackageNotFoundError:
        warp = "not installed"
    print(f"mpmdem {__version__} (warp {warp})")
    return 0


def _list() -> int:
    from ..study.case import case_module, case_names

    width = max(len(n) for n in case_names())
    for name in case_names():
        print(f"{name:<{width}}  {case_module(name).DESCRIPTION}")
    return 0


def _run_help() -> int:
    """``mpmdem run --help``: the cases (``mpmdem run CASE --help`` gives a case's flags)."""
    from ..study.case import case_module, case_names, default_case

    width = max(len(n) for n in case_names())
    print("usage: mpmdem run [CASE] [flags]\n\nRun a case (default: " + default_case() + "); mpmdem run CASE --help "
          "lists its flags.\n\ncases:")
    for name in case_names():
        print(f"  {name:<{width}}  {case_module(name).DESCRIPTION}")
    return 0


def _run_file_problem(path) -> str | None:
    """The one-line error for a FILE argument that is not a file (None when it is one): a folder
    gets the run files in it named, a missing path says so."""
    if path.is_file():
        return None
    if path.is_dir():
        runs = sorted(p.name for p in path.glob("*.h5"))
        inside = f"; in it: {', '.join(runs[:3])}" + (" ..." if len(runs) > 3 else "") if runs else ""
        return f"FILE={str(path)!r} is invalid: a run file (.h5), not a folder{inside}"
    return f"FILE={str(path)!r} does not exist"


def _info(argv: list[str]) -> int:
    from pathlib import Path

    if len(argv) != 1:
        print("usage: mpmdem info FILE", file=sys.stderr)
        return 2
    path = Path(argv[0])
    problem = _run_file_problem(path)
    if problem:
        print(f"mpmdem: error: {problem}", file=sys.stderr)
        return 2
    from ..io import RunFile

    try:
        with RunFile(path) as run:
            print(run.summary())
    except OSError as e:
        print(f"mpmdem: error: FILE={str(path)!r} is not a readable mpmdem HDF5 file ({e})", file=sys.stderr)
        return 2
    return 0


def _plot(argv: list[str]) -> int:
    from pathlib import Path

    from ..study.runner import OneLineParser

    p = OneLineParser(prog="mpmdem plot")
    p.add_argument("file")
    p.add_argument("--out", default=None, help="folder for the PNGs (default: next to the file)")
    p.add_argument("--field", default="speed", help="colour of the snapshots (speed, pressure, stress_yy, ...)")
    p.add_argument("--frames", default=None, help="comma-separated frame numbers (default first, middle, last)")
    args = p.parse_args(argv)
    path = Path(args.file)
    problem = _run_file_problem(path)
    if problem:
        print(f"mpmdem: error: {problem}", file=sys.stderr)
        return 2
    from ..errors import InputError
    from ..io.plotting import plot_run
    from ..study.runner import out_folder

    try:
        try:
            frames = [int(f) for f in args.frames.split(",")] if args.frames else None
        except ValueError:
            raise InputError("--frames", args.frames, "comma-separated frame numbers (0,10,-1)") from None
        out = out_folder(args.out if args.out else path.parent / "plots")
        written = plot_run(path, out, field=args.field, frames=frames)
    except ValueError as e:  # (InputError too: a bad --out, --field or --frames)
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"mpmdem: error: FILE={str(path)!r} is not a readable mpmdem HDF5 file ({e})", file=sys.stderr)
        return 2
    for w in written:
        print(w)
    return 0


def _animate(argv: list[str]) -> int:
    from ..study.runner import OneLineParser

    p = OneLineParser(prog="mpmdem animate")
    p.add_argument("file")
    p.add_argument("--out", default=None, help="FILE.mp4 (needs ffmpeg) or FILE.gif (default: RUN_FIELD.mp4 beside "
                   "the run with ffmpeg, else .gif)")
    p.add_argument("--field", default="speed", help="colour (speed, pressure, stress_yy, J, body, omega, ...)")
    p.add_argument("--fps", type=float, default=10.0, help="frames per second (default 10)")
    p.add_argument("--frames", default=None, help="START:STOP:STEP (::5 every fifth) or comma-separated frames "
                   "(default all)")
    args = p.parse_args(argv)
    from ..errors import InputError
    from ..io.animation import animate_run

    try:
        written = animate_run(args.file, args.out, field=args.field, fps=args.fps, frames=args.frames)
    except (InputError, OSError) as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    print(written)
    return 0


def _setting(text: str) -> tuple[str, str]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected FLAG=VALUE, got {text!r}")
    flag, value = text.split("=", 1)
    return flag.strip(), value


def _study(argv: list[str]) -> int:
    from ..study.builtin import STUDIES
    from ..study.flag_types import count_at_least as _count
    from ..study.runner import OneLineParser

    p = OneLineParser(prog="mpmdem study", description="Run a case over a grid of flag values; one row per run in "
                      "OUT/results.jsonl (streamed) and OUT/results.csv. Re-running resumes.",
                      epilog="built-in studies: " + ", ".join(STUDIES))
    p.add_argument("study", help="a built-in study's name or a .toml study file")
    p.add_argument("--out", default=None, help="output folder (default results/study-NAME)")
    p.add_argument("--workers", type=_count(0), default=None,
                   help="CPU worker processes of a local Dask cluster (default: one per core; 0 or 1: one run "
                        "after another, in this process)")
    p.add_argument("--gpus", type=_count(0), default=0, help="a local cluster of workers pinned one GPU each instead")
    p.add_argument("--workers-per-gpu", type=_count(1), default=None,
                   help="workers sharing each GPU (default: on several GPUs one per batch, up to 4, when "
                        "batched; else 1); on one GPU the study runs in this process, K batches side by side in "
                        "threads, a CUDA stream each")
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler to use instead")
    p.add_argument("--device", default=None, help="passed to every run: cpu, cuda (default: cuda with --gpus)")
    p.add_argument("--rerun-failed", action="store_true", help="run again every run not completed")
    p.add_argument("--batch", type=_count(1), default=None, metavar="N",
                   help="up to N runs of one batch key as one batched simulation on one device (default: 16 on a "
                        "GPU, none on a CPU; docs/studies/running.md)")
    p.add_argument("--no-batch", dest="batch", action="store_const", const=1, help="run every run alone")
    p.add_argument("--set", type=_setting, action="append", default=[], metavar="FLAG=VALUE",
                   help="a fixed flag (true/false for switches), or a grid flag's comma-separated values")
    try:
        args = p.parse_args(argv)
    except SystemExit as e:  # a bad flag (one line on stderr) or --help
        return e.code
    from ..errors import InputError
    from ..study.study import load_study, run_study

    try:
        study = load_study(args.study).with_settings(dict(args.set))
        rows = run_study(study, args.out, workers=args.workers, gpus=args.gpus, workers_per_gpu=args.workers_per_gpu,
                         scheduler=args.scheduler, device=args.device, rerun_failed=args.rerun_failed,
                         batch=args.batch)
    except (InputError, ImportError) as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mpmdem: interrupted; the finished runs are in the table (run the same command to resume)",
              file=sys.stderr)
        return 130
    counts = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    print(f"study {study.name}: " + ", ".join(f"{n} {s}" for s, n in counts.items()))
    return 0


def _validate(argv: list[str]) -> int:
    from pathlib import Path

    from ..errors import InputError
    from ..study.runner import OneLineParser
    from ..study.validation import collect_checks, run_validation

    p = OneLineParser(prog="mpmdem validate", description="every case with a reference, against it: one table")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: the GPU if there is one)")
    p.add_argument("--out", default="results/validation", help="folder of validation.md/.json and the runs")
    p.add_argument("--quick", action="store_true", help="the cases' quick sizes (a smoke table, not a validation)")
    p.add_argument("--cases", default=None, help="comma-separated cases (default: every case that declares checks)")
    p.add_argument("--resume", action="store_true", help="reuse the completed runs already in OUT/runs (a call cut "
                                                         "short by a time limit; same code only)")
    args = p.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()] if args.cases else None
    try:
        known = collect_checks(cases)
    except InputError as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    if not known:
        print(f"mpmdem: error: --cases={args.cases!r} is invalid: cases that declare VALIDATION checks",
              file=sys.stderr)
        return 2
    rows = run_validation(Path(args.out), device=args.device, quick=args.quick, cases=list(known),
                          resume=args.resume)
    counts = {}
    for r in rows:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    print(f"wrote {Path(args.out) / 'validation.md'}: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    return 1 if counts.get("fail") else 0  # a fail (beyond a known gap's range, or no value) fails the command


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mpmdem`` console script. Output cut short by its reader
    (``mpmdem list | head``) ends the command quietly with 141 (128 + SIGPIPE), as ``ls | head`` does."""
    try:
        return _dispatch(sys.argv[1:] if argv is None else argv)
    except BrokenPipeError:
        # the reader is gone: point stdout at /dev/null so that Python's flush at exit stays quiet
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def _dispatch(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE)
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd in ("--version", "-V"):
        return _version()
    if cmd == "list":
        return _list()
    if cmd == "info":
        return _info(rest)
    if cmd == "plot":
        return _plot(rest)
    if cmd == "study":
        return _study(rest)
    if cmd == "animate":
        return _animate(rest)
    if cmd == "validate":
        return _validate(rest)
    if cmd == "run":
        from ..errors import InputError
        from ..study.case import case_module, default_case
        from ..study.runner import run_case

        if rest and rest[0] in ("-h", "--help"):
            return _run_help()
        name = rest[0] if rest and not rest[0].startswith("-") else default_case()
        flags = rest[1:] if rest and not rest[0].startswith("-") else rest
        try:
            module = case_module(name)
        except InputError as e:
            print(f"mpmdem: error: {e}", file=sys.stderr)
            return 2
        return run_case(module, flags, prog=f"mpmdem run {name}")
    print(f"mpmdem: error: unknown command {cmd!r}; allowed: run, list, study, validate, info, plot, animate",
          file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
