"""A group of a study's runs executed as batches (``mpmdem.sim.batch_run``) in one worker.

``group_runs`` cuts the study's runs into groups of at most N, in grid order; ``execute_batch``
builds each run of a group (its case's ``build`` and flags, as ``run_case`` does), gathers the
runs that share a batch key, an end time and a frame count into one ``BatchedSimulation``, and
runs any run left alone (another key, a case with variants, a build that fails) as
``execute_run`` does. Each run still gets its own folder, HDF5 file, summary.json and table row;
a row says which batch it ran in (``batch``: the group's first run id, ``batch_world``,
``batch_worlds``). Like ``execute_run`` it never raises: a failure is a row.
"""

from __future__ import annotations

import gc
import io
import json
import time
import traceback
from pathlib import Path

from ..errors import InputError
from .case import load_case
from .run_progress import run_callback
from .signals import deferred_stop, sigterm_raises
from .thread_stderr import captured_stderr
from .worker import execute_run, failed_row, run_lock, scalar_summary, worker_name

__all__ = ["execute_batch", "group_runs", "run_keys"]


def group_runs(runs: list, size: int, keys: list | None = None) -> list[list]:
    """The runs in groups of at most ``size``: runs of equal ``keys`` together (in the order each key
    first comes, a key of None alone), else in grid order; size <= 1: one run a group."""
    size = max(1, int(size))
    if keys is None:
        return [list(runs[k:k + size]) for k in range(0, len(runs), size)]
    by_key: dict = {}
    for n, (run, key) in enumerate(zip(runs, keys, strict=True)):
        by_key.setdefault(("alone", n) if key is None else key, []).append(run)
    return [same[k:k + size] for same in by_key.values() for k in range(0, len(same), size)]


def run_keys(case: str, runs: list, out: str, budget: float = 20.0) -> list | None:
    """The batch key (with the end time and frame count) of each run, from its case's ``build``, on
    the host that plans the study; None for a run whose build fails; None for all when a run's
    build itself simulates (the case's optional ``costly_build(args)`` says so: grains settled behind
    a gate) or building them takes longer than ``budget`` [s]: the groups are then cut in grid order
    and the workers find the keys."""
    from ..sim.batch_scene import group_key

    module = load_case(case)
    if hasattr(module, "VARIANTS"):
        return [None] * len(runs)
    from .runner import make_case_parser

    keys, start = [], time.perf_counter()
    parser = make_case_parser(module)
    for run in runs:
        if time.perf_counter() - start > budget:
            return None
        costly = getattr(module, "costly_build", None)
        try:
            if costly is not None and costly(parser.parse_args([*run.argv, "--quiet"])):
                return None
        except SystemExit:  # (plan_runs checked the flags; a case's own check may still refuse)
            keys.append(None)
            continue
        try:
            with captured_stderr(io.StringIO()):
                _, setup, config, end, frames = _prepare(module, run, str(Path(out) / "runs" / run.id))
            key = group_key(setup.scene, config)
            keys.append(None if key is None else (key, end, frames))
        except Exception:  # (the run's own path reports it)
            keys.append(None)
    return keys


def _prepare(module, run, run_dir: str):
    """(args, setup, config, end_time, frames) of one run, as ``run_case`` builds them."""
    from .flag_types import given
    from .runner import config_from_args, make_case_parser

    args = make_case_parser(module).parse_args([*run.argv, "--out", run_dir, "--quiet"])
    setup = module.build(args)
    config = config_from_args(setup, module, args)
    return args, setup, config, given(args.end_time, setup.end_time), given(args.frames, setup.frames)


def execute_batch(case: str, runs: list, out: str, device: str | None) -> list[dict]:
    """The rows of ``runs`` (``study.Run``s; folders ``out/runs/<id>``), batched where they can be."""
    from ..sim.batch_scene import group_key

    module = load_case(case)
    folders = {r.id: str(Path(out) / "runs" / r.id) for r in runs}
    prepared, alone = {}, []
    for run in runs:
        if hasattr(module, "VARIANTS") or not hasattr(module, "summarize"):
            alone.append(run)
            continue
        try:
            with captured_stderr(io.StringIO()):
                prepared[run.id] = _prepare(module, run, folders[run.id])
        except Exception:  # (bad input and the like: the lone path reports it as its row)
            alone.append(run)
    groups: dict[tuple, list] = {}
    for run in runs:
        if run.id in prepared:
            _, setup, config, end, frames = prepared[run.id]
            key = group_key(setup.scene, config)
            if key is None:
                alone.append(run)
                continue
            groups.setdefault((key, end, frames), []).append(run)
    rows = []
    for group in groups.values():
        if len(group) == 1:
            alone += group
            continue
        for row in _run_group(module, group, prepared, folders, device):
            left_tile, batch_wide = row.pop("left_tile", False), row.pop("batch_wide", False)
            if left_tile or batch_wide:  # (its side: the lone run has the wall; the batch: find the world)
                run = next(r for r in group if r.id == row["id"])
                lone = execute_run(case, run.id, run.values, list(run.argv), folders[run.id], device)
                why = ("it reached its side in the batch" if left_tile else
                       "the batch failed in a check no world could be named for")
                rows.append({**lone, "batch": row["batch"], "batch_note": f"ran alone: {why}"})
            else:
                rows.append(row)
    for run in alone:
        rows.append(execute_run(case, run.id, run.values, list(run.argv), folders[run.id], device))
    return rows


def _run_group(module, group: list, prepared: dict, folders: dict, device: str | None) -> list[dict]:
    """One BatchedSimulation over ``group``; a row and a summary.json per run."""
    from ..sim.batch_run import BatchedSimulation

    start = time.perf_counter()
    first = prepared[group[0].id]
    end_time, frames, config = first[3], first[4], first[2]
    tag = {"batch": group[0].id, "batch_worlds": len(group)}
    for run in group:
        (Path(folders[run.id]) / "summary.json").unlink(missing_ok=True)
    try:
        with run_lock(), sigterm_raises(), deferred_stop() as received:
            batch = BatchedSimulation([prepared[r.id][1].scene for r in group], config, device=device)
            results = batch.run(end_time, outs=[folders[r.id] for r in group], frames=frames,
                                names=module.NAME.replace("-", "_"), progress=run_callback(None, received))
            final = batch.last_batch
    except KeyboardInterrupt as e:  # (the files say "interrupted"; a resumed study runs the group again)
        message = str(e) or "stopped by Ctrl-C"
        for run in group:
            Path(folders[run.id]).mkdir(parents=True, exist_ok=True)
            (Path(folders[run.id]) / "summary.json").write_text(json.dumps(
                {"case": module.NAME, "status": "interrupted", "message": message, **tag}, indent=2) + "\n")
        return [{"id": run.id, **run.values, "status": "interrupted", "message": message, "device": device,
                 "worker": worker_name(), **tag} for run in group]
    except Exception as e:
        rows = []
        for run in group:
            Path(folders[run.id]).mkdir(parents=True, exist_ok=True)
            (Path(folders[run.id]) / "error.txt").write_text(traceback.format_exc())
            rows.append(failed_row(run.id, run.values, f"{type(e).__name__}: {e}", device=device, **tag))
        return rows
    finally:
        gc.collect()
    wall = time.perf_counter() - start
    rows = []
    for k, (run, result) in enumerate(zip(group, results, strict=True)):
        args = prepared[run.id][0]
        summary = {"case": module.NAME, "status": result.status, "device": final.sim.device,
                   "particles": 0, "bodies": 0, "config": config.to_dict(), "end_time": end_time,
                   "steps": result.steps, "wall_seconds": wall, "output": str(result.path), **tag, "batch_world": k}
        if result.status == "completed":
            view = batch.views[k]
            summary.update(particles=view.particle_count, bodies=view.body_count)
            try:
                summary.update(module.summarize(view, result, args))
            except InputError as e:
                summary.update(status="bad-input", message=str(e))
            except Exception as e:  # (a row, as execute_run makes of it)
                (Path(folders[run.id]) / "error.txt").write_text(traceback.format_exc())
                summary.update(status="error", message=f"{type(e).__name__}: {e}")
        else:
            summary.update(message=result.message)
        folder = Path(folders[run.id])
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
        row = {"id": run.id, **run.values, "status": summary["status"], "message": summary.get("message", ""),
               "wall_seconds": wall, "device": summary["device"], "worker": worker_name(), **tag, "batch_world": k}
        row.update(scalar_summary(summary, row))
        for flag in ("left_tile", "batch_wide"):
            if result.extra.get(flag):
                row[flag] = True
        rows.append(row)
    return rows

