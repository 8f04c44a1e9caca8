"""``mpmdem`` command line: run | list | info | plot — a thin layer over the Python API."""

from __future__ import annotations

import sys

__all__ = ["main"]

USAGE = """usage: mpmdem COMMAND ...

commands:
  run CASE [flags]     run a case (mpmdem run CASE --help lists its flags)
  list                 the cases, with a line each
  info FILE            summary of a result file (.h5)
  plot FILE [--out DIR] [--field NAME]
                       PNGs: energy and momentum vs time, snapshots coloured by a field
"""


def _list() -> int:
    from .cases import CASES
    from .runner import case_module

    width = max(len(n) for n in CASES)
    for name in CASES:
        print(f"{name:<{width}}  {case_module(name).DESCRIPTION}")
    return 0


def _info(argv: list[str]) -> int:
    from pathlib import Path

    if len(argv) != 1:
        print("usage: mpmdem info FILE", file=sys.stderr)
        return 2
    path = Path(argv[0])
    if not path.is_file():
        print(f"mpmdem: error: FILE={str(path)!r} does not exist", file=sys.stderr)
        return 2
    from .io import RunFile

    try:
        with RunFile(path) as run:
            print(run.summary())
    except OSError as e:
        print(f"mpmdem: error: FILE={str(path)!r} is not a readable mpmdem HDF5 file ({e})", file=sys.stderr)
        return 2
    return 0


def _plot(argv: list[str]) -> int:
    from pathlib import Path

    from .runner import OneLineParser

    p = OneLineParser(prog="mpmdem plot")
    p.add_argument("file")
    p.add_argument("--out", default=None, help="folder for the PNGs (default: next to the file)")
    p.add_argument("--field", default="speed", help="colour of the snapshots (speed, pressure, stress_yy, ...)")
    p.add_argument("--frames", default=None, help="comma-separated frame numbers (default first, middle, last)")
    args = p.parse_args(argv)
    path = Path(args.file)
    if not path.is_file():
        print(f"mpmdem: error: FILE={str(path)!r} does not exist", file=sys.stderr)
        return 2
    from .plotting import plot_run

    frames = [int(f) for f in args.frames.split(",")] if args.frames else None
    try:
        written = plot_run(path, Path(args.out) if args.out else path.parent / "plots", field=args.field, frames=frames)
    except ValueError as e:
        print(f"mpmdem: error: {e}", file=sys.stderr)
        return 2
    for w in written:
        print(w)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mpmdem`` console script."""
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE)
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd == "list":
        return _list()
    if cmd == "info":
        return _info(rest)
    if cmd == "plot":
        return _plot(rest)
    if cmd == "run":
        from .cases import DEFAULT_CASE
        from .errors import InputError
        from .runner import case_module, run_case

        name = rest[0] if rest and not rest[0].startswith("-") else DEFAULT_CASE
        flags = rest[1:] if rest and not rest[0].startswith("-") else rest
        try:
            module = case_module(name)
        except InputError as e:
            print(f"mpmdem: error: {e}", file=sys.stderr)
            return 2
        return run_case(module, flags, prog=f"mpmdem run {name}")
    print(f"mpmdem: error: unknown command {cmd!r}; allowed: run, list, info, plot", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
