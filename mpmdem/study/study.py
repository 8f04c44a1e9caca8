"""Studies: one case run over a grid of flag values, on a Dask cluster, into one streamed table.

A study is a case name × the Cartesian product of a grid of flag values, plus fixed flags. It is
declared in Python (``Study``, with an optional ``analyze(rows, out_dir)`` for fits and charts) or
in a TOML file (``case = "..."``, ``[grid]``, ``[fixed]``). ``run_study`` checks every run's flags
with the case's own parser before any run starts, skips the runs the output folder already holds
(resume), runs the rest with ``mpmdem.study.runner.run_case`` on Dask workers (or in this process),
appends one row per run to ``OUT/results.jsonl`` as each finishes, and writes ``OUT/results.csv``.
"""

from __future__ import annotations

import itertools
import math
import sys
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from ..errors import InputError
from .case import load_case

__all__ = ["Run", "Study", "load_study", "plan_runs", "run_study"]

#: flags the study runner sets itself (every run also gets --quiet; a study may name it, to no effect)
RESERVED_FLAGS = ("--out", "--help")


def flag_name(key: str) -> str:
    """``"orifice"`` or ``"--orifice"`` → ``"--orifice"``."""
    return key if key.startswith("--") else f"--{key}"


def format_value(value) -> str:
    """A flag value as the command line (and the run id) spell it."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def toml_value(text: str):
    """``"0.5"`` → 0.5, ``"true"`` → True, ``"APIC"`` → "APIC": a TOML value, else the text itself."""
    try:
        return tomllib.loads(f"v = {text.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        return text.strip()


@dataclass(frozen=True)
class Study:
    """A sweep: ``case`` run at every combination of ``grid`` values, with the ``fixed`` flags.

    ``grid`` maps a flag (``"--orifice"`` or ``"orifice"``) to its values; ``fixed`` maps a flag to
    one value (``True``: a switch given, ``False``: left out, or ``--no-X`` for a ``--X/--no-X`` flag).
    ``analyze(rows, out_dir)`` runs after the last run, on every row of the table.
    """

    name: str
    case: str
    grid: Mapping[str, Sequence] = field(default_factory=dict)
    fixed: Mapping[str, object] = field(default_factory=dict)
    description: str = ""
    analyze: Callable[[list[dict], Path], object] | None = None

    def __post_init__(self):
        grid = {flag_name(k): (v,) if isinstance(v, str | bytes) or not hasattr(v, "__iter__") else tuple(v)
                for k, v in self.grid.items()}
        fixed = {flag_name(k): v for k, v in self.fixed.items()}
        object.__setattr__(self, "grid", MappingProxyType(grid))
        object.__setattr__(self, "fixed", MappingProxyType(fixed))

    def with_settings(self, settings: Mapping[str, str]) -> Study:
        """A copy with ``--set FLAG=VALUE`` applied: a grid flag takes the comma-separated values, any
        other flag becomes fixed; values read as in a study file (``0.5``, ``true``), else as text."""
        grid, fixed = dict(self.grid), dict(self.fixed)
        for key, text in settings.items():
            flag = flag_name(key)
            if flag in grid:
                grid[flag] = [toml_value(v) for v in text.split(",") if v.strip()]
            else:
                fixed[flag] = toml_value(text)
        return Study(self.name, self.case, grid, fixed, self.description, self.analyze)


@dataclass(frozen=True)
class Run:
    """One run of a study: its id (from the grid values), the grid values and the case's argv."""

    id: str
    values: dict
    argv: tuple[str, ...]


def study_from_toml(path: Path) -> Study:
    """A study from a TOML file: ``case``, optional ``name`` (default: the file's stem),
    ``description`` and ``analyze = "module:function"``, a ``[grid]`` table of value lists and a
    ``[fixed]`` table."""
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise InputError("study file", str(path), f"a readable TOML file ({e})") from None
    unknown = sorted(set(data) - {"name", "case", "description", "analyze", "grid", "fixed"})
    if unknown:
        raise InputError("study file key", unknown[0], "name, case, description, analyze, [grid], [fixed]")
    if not isinstance(data.get("case"), str):
        raise InputError("case", data.get("case"), f"a case name in {path} (mpmdem list shows them)")
    for table in ("grid", "fixed"):
        if not isinstance(data.get(table, {}), dict):
            raise InputError(f"[{table}]", data[table], f"a TOML table in {path}")
    analyze = imported_function(data["analyze"]) if "analyze" in data else None
    return Study(data.get("name", path.stem), data["case"], data.get("grid", {}), data.get("fixed", {}),
                 data.get("description", ""), analyze)


def imported_function(spec: str) -> Callable:
    """``"package.module:function"`` → that function."""
    import importlib

    module, _, name = str(spec).partition(":")
    try:
        function = getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError, ValueError) as e:
        raise InputError("analyze", spec, f"an importable 'module:function' ({e})") from None
    if not callable(function):
        raise InputError("analyze", spec, "a function analyze(rows, out_dir)")
    return function


def load_study(name_or_path: str) -> Study:
    """A built-in study by name (``mpmdem.study.builtin.STUDIES``) or a study from a ``.toml`` file."""
    from .builtin import STUDIES, study_by_name

    path = Path(name_or_path)
    if path.suffix == ".toml" or path.is_file():
        if not path.is_file():
            raise InputError("study file", name_or_path, "an existing .toml file")
        return study_from_toml(path)
    if name_or_path not in STUDIES:
        raise InputError("study", name_or_path, "a .toml file or one of " + ", ".join(STUDIES))
    return study_by_name(name_or_path)


def _argv_of(flags: Mapping[str, object], parser) -> list[str]:
    """Command-line words of ``{flag: value}``; booleans switch flags on or off."""
    negatable = {o for a in parser._actions for o in a.option_strings if o.startswith("--no-")}
    words = []
    for flag, value in flags.items():
        if value is True:
            words.append(flag)
        elif value is False or value is None:
            if f"--no-{flag[2:]}" in negatable:
                words.append(f"--no-{flag[2:]}")
        else:
            words += [flag, format_value(value)]
    return words


def _check_parses(parser, argv: list[str], flag: str, value) -> None:
    """Parse ``argv`` with the case's parser; its complaint becomes an InputError."""
    def complain(message):
        raise InputError(flag, value, message)

    parser.error = complain
    try:
        parser.parse_args(argv)
    except SystemExit:  # --help or an action that exits
        raise InputError(flag, value, "a value the case's parser accepts") from None


def fixed_flags(study: Study, device: str | None) -> dict:
    """The study's fixed flags, with ``--device`` set to ``device`` unless the grid sweeps devices."""
    fixed = dict(study.fixed)
    if device is not None and "--device" not in study.grid:
        fixed["--device"] = device
    return fixed


def plan_runs(study: Study, device: str | None = None) -> list[Run]:
    """Every run of the study in grid order, each argv checked by the case's parser first.

    Raises InputError for an unknown case, an empty grid, a flag the case does not take, or a
    value its parser rejects; nothing has run then.
    """
    from .runner import make_case_parser

    module = load_case(study.case)
    parser = make_case_parser(module)
    if not study.grid or any(len(v) == 0 for v in study.grid.values()):
        empty = next((k for k, v in study.grid.items() if len(v) == 0), "grid")
        raise InputError(empty, [], "at least one value (a study needs a non-empty grid)")
    known = set(parser._option_string_actions)
    for flag in [*study.grid, *study.fixed]:
        if flag in RESERVED_FLAGS:
            raise InputError(flag, study.grid.get(flag, study.fixed.get(flag)), "set by the study runner, not a study")
        if flag not in known:
            raise InputError("flag", flag, f"a flag of case {study.case} (mpmdem run {study.case} --help)")
    fixed = fixed_flags(study, device)
    fixed_argv = _argv_of(fixed, parser)
    for flag, value in fixed.items():
        _check_parses(parser, _argv_of({flag: value}, parser), flag, value)
    for flag, values in study.grid.items():
        for value in values:
            _check_parses(parser, _argv_of({flag: value}, parser), flag, value)
    runs = []
    for combo in itertools.product(*study.grid.values()):
        values = dict(zip(study.grid, combo, strict=True))
        argv = _argv_of(values, parser) + fixed_argv
        _check_parses(parser, argv, "run", " ".join(argv))
        run_id = ",".join(f"{flag[2:]}={format_value(v)}" for flag, v in values.items())
        runs.append(Run(safe_id(run_id), {flag[2:]: v for flag, v in values.items()}, tuple(argv)))
    ids = [r.id for r in runs]
    if len(set(ids)) != len(ids):
        raise InputError("grid", dict(study.grid), "distinct values (two runs would share an id)")
    return runs


def safe_id(text: str) -> str:
    """A run id usable as a folder name: characters other than letters, digits and ``.=,+-_`` → ``_``."""
    return "".join(c if c.isalnum() or c in ".=,+-_" else "_" for c in text)


#: runs per batch on a GPU by default: the silo at the study's sizes is launch-bound below ~8 worlds,
#: and the 16 block-impact starts ran faster as one batch than as two (docs/benchmarks.md)
GPU_BATCH = 16


#: batches sharing one GPU at a time by default on a machine of several GPUs: worker processes per
#: GPU, whose steps time-slice it but fill it while another batch's host reads and writes its frames
GPU_SIDE_BY_SIDE = 4


def default_workers_per_gpu(groups: list | None, gpus: int = 1) -> int:
    """Workers per GPU when none is asked: the batches shared out over the ``gpus``, up to
    ``GPU_SIDE_BY_SIDE`` side by side on each, when the study is batched on several GPUs; else 1.
    On one GPU a batched study runs its batches one after another in this process: side by side
    in threads (``--workers-per-gpu K``, ``cluster.side_by_side``) they were measured no faster
    yet (docs/studies/running.md)."""
    if not groups or gpus <= 1:
        return 1
    return min(math.ceil(len(groups) / gpus), GPU_SIDE_BY_SIDE)


def default_batch(device: str | None, gpus: int) -> int:
    """Runs per batch when none is asked: ``GPU_BATCH`` on a GPU, 1 (no batching) on a CPU."""
    return GPU_BATCH if gpus or (device or "").startswith("cuda") else 1


def grouping_line(name: str, runs: int, size: int, groups: list | None = None, keyed: bool = False) -> str:
    """How the study groups its runs, in one line."""
    if size <= 1 or not groups:
        return f"study {name}: {runs} runs, each alone (no batching)"
    sizes = [len(g) for g in groups]
    how = ("grouped by batch key: config, grid, sides, gravity, contact laws" if keyed else
           "in grid order; within a group, runs of one batch key share a grid, the others run alone")
    return (f"study {name}: {runs} runs in {len(groups)} batch(es) of up to {size} ({', '.join(map(str, sizes))} "
            f"runs; {how})")


def study_spec(study: Study, device: str | None) -> dict:
    """What ``OUT/study.json`` records: enough to tell whether a folder's rows belong to this study."""
    fixed = {k: format_value(v) for k, v in fixed_flags(study, device).items()}
    return {"name": study.name, "case": study.case, "fixed": fixed,
            "grid": {k: [format_value(v) for v in vs] for k, vs in study.grid.items()}}


def run_study(study: Study, out: str | Path | None = None, *, workers: int | None = None, gpus: int = 0,
              workers_per_gpu: int | None = None, scheduler: str | None = None, device: str | None = None,
              rerun_failed: bool = False, progress: bool = True, batch: int | None = None) -> list[dict]:
    """Run every run of ``study`` not yet in ``out`` and return the table (one row per run, grid order).

    ``workers``: CPU worker processes of a local Dask cluster (None: one per core, at most one per
    run; 0: in this process); ``gpus``: a local cluster of ``workers_per_gpu`` workers per GPU
    instead (None: ``default_workers_per_gpu``, batches side by side); ``scheduler``: the address
    of a running Dask cluster to use instead. Where the local cluster would be one worker (one CPU
    worker, one GPU with one worker) the runs go in this process instead (``cluster.runs_here``).
    ``device`` is passed to every run (``cuda`` by default with ``gpus``). Runs whose last row is
    completed, blown-up or bad-input are skipped; ``rerun_failed`` runs all but the completed ones
    again. Raises InputError (nothing has run) for
    a study the case cannot take, ImportError when Dask is needed but missing.
    """
    from .cluster import DASK_MISSING, dask_available, execute_runs, runs_here, side_by_side, wait_for_clusters
    from .progress import StudyProgress
    from .table import ResultsTable
    from .worker import FINAL_STATUSES

    device = device or ("cuda" if gpus else None)
    if gpus and not scheduler:
        from ..sim.warp_init import check_gpu_count

        check_gpu_count(gpus)
    runs = plan_runs(study, device)
    out = Path(out or Path("results") / f"study-{study.name}").resolve()
    table = ResultsTable(out)
    spec = study_spec(study, device)
    table.check_spec(spec)
    kept = ("completed",) if rerun_failed else FINAL_STATUSES
    previous = table.latest()
    todo = [r for r in runs if previous.get(r.id, {}).get("status") not in kept]
    size = default_batch(device, gpus) if batch is None else int(batch)
    if size < 1:
        raise InputError("batch", batch, "a number of runs per batch >= 1 (1: no batching)")
    groups = None
    if size > 1 and todo:
        from .batch_worker import group_runs, run_keys

        keys = run_keys(study.case, todo, str(out))
        groups = group_runs(todo, size, keys)
    if workers_per_gpu is None:
        workers_per_gpu = default_workers_per_gpu(groups, gpus) if gpus else 1
    tasks = len(groups) if groups is not None else len(todo)
    if todo and not runs_here(workers, tasks, gpus, workers_per_gpu, scheduler, batched=groups is not None) \
            and not dask_available():
        raise ImportError(DASK_MISSING)
    table.write_spec(spec)
    if progress and todo:
        side = f"; {workers_per_gpu} worker(s) per GPU" if gpus else ""
        threads = side_by_side(tasks, gpus, workers_per_gpu, scheduler) if groups is not None else 0
        if threads:
            side = f"; {threads} batches side by side on the GPU (threads of this process, a CUDA stream each)"
        print(grouping_line(study.name, len(todo), size, groups, keyed=size > 1 and keys is not None) + side,
              file=sys.stderr)
    bar = StudyProgress(study.name, len(todo), skipped=len(runs) - len(todo), enabled=progress)
    try:
        for row in execute_runs(todo, study.case, out, device, workers, gpus, workers_per_gpu, scheduler,
                                groups=groups):
            table.append(row)
            previous[row["id"]] = row
            bar.update(row)
    finally:
        bar.close()
    rows = [previous[r.id] for r in runs if r.id in previous]
    try:  # (while the cluster of the runs closes: cluster.study_client)
        table.write_csv(rows)
        if study.analyze is not None:
            if not any(row.get("status") == "completed" for row in rows):
                print(f"study {study.name}: no run completed, so no analysis (the rows say why: "
                      f"{out / 'results.csv'})", file=sys.stderr)
            else:
                study.analyze(rows, out)
    finally:
        wait_for_clusters()
    return rows
