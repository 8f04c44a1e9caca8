"""Where a study's time goes outside its simulations (issue 46: 16 block-impact starts in at most
twice one run's wall time).

Runs a built-in study (default ``block-impact-ensemble``) through ``mpmdem.study.study.run_study``
as ``mpmdem study`` does, at a size where the steps are small on a CPU (``--set`` flags: a coarse
grid, a short end time, few frames), into a fresh folder, and times its phases by wrapping the
functions that make them (nothing in the library changes):

- ``import_s``: importing the study layer in this process (``mpmdem.study.study``; Warp and mpmdem
  with it: what ``mpmdem study`` pays before its first run);
- ``plan_s``: ``load_study`` + ``plan_runs`` (every run's flags parsed by the case's parser);
- ``keys_s``: ``batch_worker.run_keys`` (every run's scene built on this host, for the batch keys);
- ``cluster_start_s``, ``cluster_close_s``: entering and leaving ``cluster.study_client`` (a local
  Dask cluster's scheduler and worker processes; 0 when the runs go in this process);
- per group (``groups``: one entry each, in the order they finished): ``queued_s`` (from the first
  submit to the group's start in its worker: the workers' start and their share of waiting),
  ``worker_import_s`` (the worker's first import of the batch layer and Warp; 0 after the first),
  ``prepare_s`` (``BatchedSimulation`` and the scenes, from ``execute_batch``'s start to the batch's
  run), ``run_s`` (``BatchedSimulation.run``: steps and frames), ``summaries_s`` (every world's
  ``summarize`` and summary.json), ``total_s``;
- ``runs_s``: from the first submit to the last row (the groups side by side);
- ``csv_s``: ``ResultsTable.write_csv``; ``analysis_s``: the study's ``analyze`` (``load_runs_s``:
  reading every run's summary.json; ``matplotlib_import_s``; the rest is the tables and charts);
- ``study_s``: ``run_study`` from its call to its return; ``wall_s``: this process from its start
  (the interpreter's own start not included: ``cli_wall_s`` with ``--cli``, the same study run again
  as ``python -m mpmdem.cli study ...`` in a fresh folder, wall time of the whole command).

One JSON line. Nothing is asserted.

    python bench/study_overhead.py --device cpu                   # 16 starts, 2 cm grid, 2 frames, batches of 8
    python bench/study_overhead.py --device cpu --workers 0 --cli
    python bench/study_overhead.py --gpus 1 --set=--cell-size=0.003125 --keep-sizes --cli   # the GPU study itself
"""

from __future__ import annotations

import time

_START = time.perf_counter()

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

#: the flags that make the block-impact study small on a CPU (a 2 cm grid: 200 points a world)
TINY = ("--cell-size=0.02", "--end-time=0.02", "--frames=2")


def timed_batch(case, runs, out, device):
    """``batch_worker.execute_batch`` with its phases timed; the times go to OUT/_timings/<pid>-<first id>.json.
    (A function of this script: Dask's cloudpickle sends it to the workers by value.)"""
    begin = time.perf_counter()
    wall_begin = time.time()
    fresh = "mpmdem.study.batch_worker" not in sys.modules
    import warp  # noqa: F401

    from mpmdem.sim import batch_run
    from mpmdem.study import batch_worker

    imported = time.perf_counter()
    marks = {}
    original_run = batch_run.BatchedSimulation.run

    def run(self, *args, **kwargs):
        marks["run_start"] = time.perf_counter()
        try:
            return original_run(self, *args, **kwargs)
        finally:
            marks["run_end"] = time.perf_counter()

    batch_run.BatchedSimulation.run = run
    try:
        rows = batch_worker.execute_batch(case, runs, out, device)
    finally:
        batch_run.BatchedSimulation.run = original_run
    end = time.perf_counter()
    timing = {"wall_begin": wall_begin, "worker_import_s": imported - begin if fresh else 0.0,
              "prepare_s": marks.get("run_start", end) - imported,
              "run_s": marks.get("run_end", end) - marks.get("run_start", end),
              "summaries_s": end - marks.get("run_end", end), "total_s": end - begin, "pid": os.getpid(),
              "worlds": len(runs)}
    folder = Path(out) / "_timings"
    folder.mkdir(exist_ok=True)
    (folder / f"{os.getpid()}-{runs[0].id}.json").write_text(json.dumps(timing))
    return rows


def wrap(owner, name: str, into: dict, key: str):
    """Replace ``owner.name`` by a version that adds its call's seconds to ``into[key]``."""
    original = getattr(owner, name)

    @functools.wraps(original)
    def timed(*args, **kwargs):
        start = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            into[key] = into.get(key, 0.0) + time.perf_counter() - start

    setattr(owner, name, timed)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study", nargs="?", default="block-impact-ensemble")
    p.add_argument("--set", action="append", default=[], metavar="FLAG=VALUE",
                   help="as mpmdem study's --set (after the tiny flags, which they override)")
    p.add_argument("--keep-sizes", action="store_true", help="no tiny flags: the study at its own (or --set) sizes")
    p.add_argument("--device", default=None)
    p.add_argument("--workers", type=int, default=None)
    p.add_argument("--gpus", type=int, default=0)
    p.add_argument("--workers-per-gpu", type=int, default=None, help="(default: run_study's)")
    p.add_argument("--batch", type=int, default=None, help="(default: 8, as on a GPU, also on a CPU)")
    p.add_argument("--cli", action="store_true", help="also time the same study as one `mpmdem study` command")
    p.add_argument("--label", default="")
    p.add_argument("--out", type=Path, default=None, help="append the JSON line here")
    args = p.parse_args(argv)

    from mpmdem.study import study as study_module

    import_s = time.perf_counter() - _START
    from mpmdem.study import batch_worker, cluster, table
    from mpmdem.study.builtin import block_impact_analysis, run_summaries

    times: dict = {}
    settings = [] if args.keep_sizes else list(TINY)
    settings += args.set
    pairs = dict(s.split("=", 1) for s in settings)
    batch = 8 if args.batch is None else args.batch
    start = time.perf_counter()
    study = study_module.load_study(args.study).with_settings(pairs)
    study_module.plan_runs(study, args.device or ("cuda" if args.gpus else None))
    plan_s = time.perf_counter() - start

    wrap(batch_worker, "run_keys", times, "keys_s")
    wrap(table.ResultsTable, "write_csv", times, "csv_s")
    wrap(run_summaries, "load_runs", times, "load_runs_s")
    wrap(block_impact_analysis, "analyze", times, "analyze_s")
    cluster.execute_batch = timed_batch
    original_client = cluster.study_client

    def study_client(*a, **k):
        class Timed:
            def __enter__(self):
                t = time.perf_counter()
                self.inner = original_client(*a, **k)
                client = self.inner.__enter__()
                times["cluster_start_s"] = time.perf_counter() - t
                times["submit_wall"] = time.time()
                return client

            def __exit__(self, *exc):
                t = time.perf_counter()
                try:
                    return self.inner.__exit__(*exc)
                finally:
                    times["cluster_close_s"] = time.perf_counter() - t
        return Timed()

    cluster.study_client = study_client
    if study.analyze is not None:
        analyze = study.analyze

        def timed_analyze(rows, out):
            t = time.perf_counter()
            import matplotlib.pyplot  # noqa: F401

            times["matplotlib_import_s"] = time.perf_counter() - t
            try:
                return analyze(rows, out)
            finally:
                times["analysis_s"] = time.perf_counter() - t

        study = study_module.Study(study.name, study.case, study.grid, study.fixed, study.description, timed_analyze)
    original_execute = cluster.execute_runs

    def execute_runs(*a, **k):
        t = time.perf_counter()
        times.setdefault("submit_wall", time.time())
        yield from original_execute(*a, **k)
        times["runs_s"] = time.perf_counter() - t

    cluster.execute_runs = execute_runs
    with tempfile.TemporaryDirectory(prefix="study-overhead-") as tmp:
        out = Path(tmp) / "study"
        t = time.perf_counter()
        rows = study_module.run_study(study, out, workers=args.workers, gpus=args.gpus, device=args.device,
                                      batch=batch, progress=False, workers_per_gpu=args.workers_per_gpu)
        study_s = time.perf_counter() - t
        groups = []
        for path in sorted((out / "_timings").glob("*.json")):
            g = json.loads(path.read_text())
            g["queued_s"] = g.pop("wall_begin") - times.get("submit_wall", g.get("wall_begin", 0.0))
            groups.append({k: round(v, 3) if isinstance(v, float) else v for k, v in g.items()})
        groups.sort(key=lambda g: g["queued_s"])
        cli_wall_s = None
        if args.cli:
            cmd = [sys.executable, "-m", "mpmdem.cli", "study", args.study, "--out", str(Path(tmp) / "cli"),
                   "--batch", str(batch), *(f"--set={s}" for s in settings)]
            cmd += ["--device", args.device] if args.device else []
            cmd += ["--gpus", str(args.gpus)] if args.gpus else []
            cmd += ["--workers", str(args.workers)] if args.workers is not None else []
            cmd += ["--workers-per-gpu", str(args.workers_per_gpu)] if args.workers_per_gpu else []
            t = time.perf_counter()
            # (from the folder above the package this process imported: `python -m` puts its folder first)
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           cwd=Path(study_module.__file__).resolve().parents[2])
            cli_wall_s = time.perf_counter() - t
    statuses = {}
    for row in rows:
        statuses[row["status"]] = statuses.get(row["status"], 0) + 1
    times.pop("submit_wall", None)
    line = {"bench": "study_overhead", "label": args.label, "study": args.study, "settings": settings,
            "device": args.device or ("cuda" if args.gpus else "default"), "gpus": args.gpus, "workers": args.workers,
            "workers_per_gpu": args.workers_per_gpu,
            "batch": batch, "runs": len(rows), "statuses": statuses, "import_s": round(import_s, 3),
            "plan_s": round(plan_s, 3), **{k: round(v, 3) for k, v in times.items()}, "groups": groups,
            "study_s": round(study_s, 3), "wall_s": round(time.perf_counter() - _START, 3),
            "cli_wall_s": None if cli_wall_s is None else round(cli_wall_s, 3), "commit": _commit(),
            "package": str(Path(study_module.__file__).resolve().parents[2]),
            "cpus": os.cpu_count()}
    text = json.dumps(line)
    print(text, flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "a") as f:
            f.write(text + "\n")
    return 0


def _commit() -> str | None:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).parent, check=True).stdout.strip() or None
    except (OSError, subprocess.CalledProcessError):
        return None


if __name__ == "__main__":
    sys.exit(main())
