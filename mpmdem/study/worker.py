"""One run of a study, as a worker executes it: ``run_case`` into the run's folder, then its table row.

``execute_run`` never raises: a run that fails (bad input found by the case, a blow-up, an exception
anywhere) is a row with its status and message. Each call builds a fresh ``Simulation``, and a
process runs one at a time, so runs on the same worker share nothing but Warp's loaded kernels.
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import os
import socket
import sys
import threading
import time
import traceback
from pathlib import Path

from .case import load_case
from .thread_stderr import captured_stderr

__all__ = ["FINAL_STATUSES", "execute_run", "failed_row", "run_lock", "scalar_summary"]

#: statuses a resumed study does not run again (unless --rerun-failed: then only "completed")
FINAL_STATUSES = ("completed", "blown-up", "bad-input")
#: summary.json keys the row takes from elsewhere (or, for config, keeps only in the run folder)
SUMMARY_SKIPPED = ("case", "status", "message", "device", "config", "output")
STATUS_OF_EXIT_CODE = {0: "completed", 2: "bad-input", 3: "blown-up", 130: "interrupted", 143: "interrupted"}
#: one run at a time per process, also on a worker of several threads (Warp's state and sys.stderr are per
#: process), except runs that take turns on one GPU (``run_lock``)
RUN_LOCK = threading.Lock()


def run_lock():
    """``RUN_LOCK``, or nothing for a thread that holds turns on its device beside other runs of this
    process (``mpmdem.sim.device_turns``: the turns order their launches, and a run waiting for its
    stream must not hold a lock the others need)."""
    from ..sim.device_turns import current

    return contextlib.nullcontext() if current() is not None else RUN_LOCK


def worker_name() -> str:
    """The Dask worker's name, or host:pid outside a worker (a process without Dask imported is not
    one: a study run in its own process does not import it for this)."""
    if "distributed" in sys.modules:
        try:
            from distributed import get_worker

            return str(get_worker().name)
        except (ImportError, ValueError):
            pass
    return f"{socket.gethostname()}:{os.getpid()}"


def scalar_summary(summary: dict, row: dict) -> dict:
    """The summary's numbers, strings, booleans and nulls; lists and tables stay in summary.json. A
    key the row already has (a flag of the same name) is kept as ``case_<key>`` when it differs."""
    out = {}
    for key, value in summary.items():
        if key in SUMMARY_SKIPPED or not (value is None or isinstance(value, bool | int | float | str)):
            continue
        if key == "wall_seconds":
            out["sim_seconds"] = value  # Simulation.run alone; the row's wall_seconds is the whole run
        elif key not in row:
            out[key] = value
        elif value != row[key]:
            out[f"case_{key}"] = value
    return out


def failed_row(run_id: str, values: dict, message: str, **extra) -> dict:
    """The row of a run that ended in an exception (in the worker or of the worker itself)."""
    return {"id": run_id, **values, "status": "error", "message": message, **extra}


def execute_run(case: str, run_id: str, values: dict, argv: list[str], run_dir: str, device: str | None) -> dict:
    """Run the case with ``argv`` + ``--out run_dir --quiet``; the row: id, grid values, status,
    message, wall seconds, device, worker and the summary's scalars."""
    from .runner import run_case

    start = time.perf_counter()
    folder = Path(run_dir)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "summary.json").unlink(missing_ok=True)  # a stale one from an earlier attempt
    stderr = io.StringIO()
    row = {"id": run_id, **values}
    try:
        with run_lock(), captured_stderr(stderr):
            code = run_case(load_case(case), [*argv, "--out", str(folder), "--quiet"], prog=f"mpmdem run {case}")
        summary = _read_summary(folder)
        lines = [ln.removeprefix("mpmdem: ").removeprefix("error: ") for ln in stderr.getvalue().splitlines()
                 if ln.strip()]
        row["status"] = STATUS_OF_EXIT_CODE.get(code, summary.get("status", "error"))
        row["message"] = summary.get("message") or (lines[-1] if code != 0 and lines else "")
    except Exception as e:  # a bug or a case's own failure: a row, never the end of the study
        (folder / "error.txt").write_text(traceback.format_exc())
        row = failed_row(run_id, values, f"{type(e).__name__}: {e}")
        summary = _read_summary(folder)
    finally:
        gc.collect()  # the Simulation's arrays (GPU memory) go now, before the next run on this worker
    row.update(wall_seconds=time.perf_counter() - start, device=summary.get("device", device),
               worker=worker_name())
    row.update(scalar_summary(summary, row))
    return row


def _read_summary(folder: Path) -> dict:
    try:
        return json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return {}
