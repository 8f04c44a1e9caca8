"""Where a study's runs execute: a Dask cluster (local CPU processes, one process per GPU, or any
running cluster by its scheduler address), or this process one run after another (``--workers 0``,
or where a local cluster would be one worker: ``runs_here``).

Every worker is a process with one thread, so Warp's per-process state is never shared by two runs
at once. GPU workers are Nannies whose environment pins ``CUDA_VISIBLE_DEVICES`` to one card
(``workers_per_gpu`` of them per card); that needs no dask-cuda.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path

from .batch_worker import execute_batch
from .worker import execute_run, failed_row

__all__ = ["DASK_MISSING", "dask_available", "execute_runs", "local_workers", "map_tasks", "runs_here",
           "side_by_side", "wait_for_clusters"]

DASK_MISSING = 'the study runner needs Dask: pip install "mpmdem[study]" (or run serially with --workers 0)'


def dask_available() -> bool:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def gpu_worker_specs(gpus: int, workers_per_gpu: int) -> dict:
    """SpecCluster worker specs: ``workers_per_gpu`` one-thread Nannies per card, each seeing one card
    (the cards of an existing ``CUDA_VISIBLE_DEVICES`` list, else 0..gpus-1)."""
    from distributed import Nanny

    visible = [c.strip() for c in os.environ.get("CUDA_VISIBLE_DEVICES", "").split(",") if c.strip()]
    cards = visible[:gpus] if len(visible) >= gpus else [str(i) for i in range(gpus)]
    return {f"gpu{card}-{k}": {"cls": Nanny, "options": {"nthreads": 1, "env": {"CUDA_VISIBLE_DEVICES": card}}}
            for card in cards for k in range(workers_per_gpu)}


#: the threads closing the local clusters of studies whose runs all returned (``wait_for_clusters``)
_CLOSING: list[threading.Thread] = []


@contextlib.contextmanager
def study_client(workers: int, gpus: int = 0, workers_per_gpu: int = 1, scheduler: str | None = None,
                 close_later: bool = False):
    """A Dask client: of the cluster at ``scheduler``, else of a local cluster started here (and
    closed on exit) with ``gpus × workers_per_gpu`` GPU workers or ``workers`` CPU processes.
    ``close_later``: a local cluster left without an error is closed in a thread (its worker
    processes take a while to end) that ``wait_for_clusters`` waits for."""
    from distributed import Client, LocalCluster, Scheduler, SpecCluster

    if scheduler:
        with Client(scheduler) as client:
            yield client
        return
    quiet = {"silence_logs": logging.ERROR}
    if gpus > 0:
        cluster = SpecCluster(workers=gpu_worker_specs(gpus, workers_per_gpu),
                              scheduler={"cls": Scheduler, "options": {"dashboard_address": None}}, **quiet)
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               **quiet)
    if not close_later:
        with cluster, Client(cluster) as client:
            yield client
        return
    with contextlib.ExitStack() as now:  # (unwound at once on an error, or when the caller stops early)
        now.enter_context(cluster)
        with Client(cluster) as client:  # (closed here: a client leaves its context in its own thread)
            yield client
        later = now.pop_all()
    thread = threading.Thread(target=later.close, name="mpmdem-cluster-close")
    thread.start()
    _CLOSING.append(thread)


def wait_for_clusters() -> None:
    """Return once the clusters ``study_client(close_later=True)`` left closing are closed."""
    while _CLOSING:
        _CLOSING.pop().join()


def local_workers(workers: int | None, tasks: int) -> int:
    """CPU worker processes of a local cluster for ``tasks`` tasks: ``workers``, else one per core,
    at most one per task."""
    return workers if workers else min(tasks, os.cpu_count() or 1)


def runs_here(workers: int | None, tasks: int, gpus: int = 0, workers_per_gpu: int = 1,
              scheduler: str | None = None, batched: bool = False) -> bool:
    """Whether a study's ``tasks`` (runs, or groups of runs) execute in this process, one after
    another: ``workers == 0``, or a local cluster that would be one worker (one CPU worker; one GPU
    with one worker on it), which would run them in that order too, after starting a scheduler and
    a worker process that imports Warp and loads its modules again. Never with ``scheduler``. A run
    that ends its process (a crash) then ends the study; its finished rows stay (a rerun resumes).
    ``batched`` (the tasks are groups of runs): one GPU runs them here whatever ``workers_per_gpu``,
    that many side by side (``side_by_side``)."""
    if scheduler:
        return False
    if gpus:
        return gpus == 1 and (workers_per_gpu == 1 or batched)
    return workers == 0 or local_workers(workers, tasks) == 1


def side_by_side(tasks: int, gpus: int = 0, workers_per_gpu: int = 1, scheduler: str | None = None) -> int:
    """Threads of this process that run ``tasks`` groups of runs side by side on one GPU, each group
    on its own CUDA stream (``mpmdem.sim.device_turns``): ``workers_per_gpu``, at most one a group,
    with one local GPU; 0 otherwise (and for 1: one group after another). Separate processes would
    time-slice the GPU (no MPS): their small steps would not overlap."""
    if scheduler or gpus != 1:
        return 0
    threads = min(workers_per_gpu, tasks)
    return threads if threads > 1 else 0


def execute_runs(runs, case: str, out: Path, device: str | None, workers: int | None, gpus: int = 0,
                 workers_per_gpu: int = 1, scheduler: str | None = None, groups: list | None = None) -> Iterator[dict]:
    """The row of every run, in the order they finish; in this process, in order, where
    ``runs_here`` says so. ``groups`` (``batch_worker.group_runs``): each group one task that
    batches what it can."""
    def args(run):
        return case, run.id, run.values, list(run.argv), str(out / "runs" / run.id), device

    if not runs:
        return
    if groups is not None:
        yield from _execute_groups(groups, case, out, device, workers, gpus, workers_per_gpu, scheduler)
        return
    if runs_here(workers, len(runs), gpus, workers_per_gpu, scheduler):
        for run in runs:
            row = execute_run(*args(run))
            yield row
            if row["status"] == "interrupted":  # Ctrl-C reached run_case: stop the study, keep its row
                raise KeyboardInterrupt
        return
    from distributed import as_completed

    with study_client(local_workers(workers, len(runs)), gpus, workers_per_gpu, scheduler, close_later=True) as client:
        token = uuid.uuid4().hex[:8]  # keys unique on a shared scheduler
        futures = {client.submit(execute_run, *args(run), key=f"{run.id}-{token}", pure=False): run for run in runs}
        for future in as_completed(futures):
            run = futures[future]
            try:
                yield future.result()
            except Exception as e:  # the worker itself died (a crash, killed for memory, ...)
                yield failed_row(run.id, run.values, f"worker lost: {type(e).__name__}: {e}", device=device)


def _execute_groups(groups, case, out, device, workers, gpus, workers_per_gpu, scheduler) -> Iterator[dict]:
    """The rows of every group of runs (``execute_batch``), a group's rows when it finishes."""
    threads = side_by_side(len(groups), gpus, workers_per_gpu, scheduler)
    if threads:
        yield from _groups_side_by_side(groups, case, out, device, threads)
        return
    if runs_here(workers, len(groups), gpus, workers_per_gpu, scheduler, batched=True):
        for group in groups:
            rows = execute_batch(case, group, str(out), device)
            yield from rows
            if any(row["status"] == "interrupted" for row in rows):
                raise KeyboardInterrupt
        return
    from distributed import as_completed

    with study_client(local_workers(workers, len(groups)), gpus, workers_per_gpu, scheduler,
                      close_later=True) as client:
        token = uuid.uuid4().hex[:8]
        futures = {client.submit(execute_batch, case, group, str(out), device, key=f"{group[0].id}-batch-{token}",
                                 pure=False): group for group in groups}
        for future in as_completed(futures):
            group = futures[future]
            try:
                yield from future.result()
            except Exception as e:  # the worker itself died
                for run in group:
                    yield failed_row(run.id, run.values, f"worker lost: {type(e).__name__}: {e}", device=device)


def _in_turn(turns, group, case, out, device) -> list[dict]:
    with turns.turn():
        return execute_batch(case, group, out, device)


def _groups_side_by_side(groups, case, out, device, threads: int) -> Iterator[dict]:
    """The rows of every group, ``threads`` groups at a time in threads of this process taking turns
    on the device (``mpmdem.sim.device_turns``); a stop signal stops them all between two batches of
    steps (``signals.deferred_stop``), and the groups not begun are not begun."""
    import concurrent.futures as cf

    from ..sim.device_turns import DeviceTurns
    from ..sim.warp_init import init_warp
    from .signals import deferred_stop
    from .thread_stderr import routed_stderr

    init_warp()
    turns = DeviceTurns(device or "cuda")
    interrupted = False
    with deferred_stop() as received, routed_stderr(), cf.ThreadPoolExecutor(
            threads, thread_name_prefix="mpmdem-batch") as pool:
        futures = {pool.submit(_in_turn, turns, group, case, str(out), device): group for group in groups}
        pending = set(futures)
        while pending:
            done, pending = cf.wait(pending, timeout=0.5, return_when=cf.FIRST_COMPLETED)
            if received:
                for future in pending:
                    future.cancel()
            for future in done:
                if future.cancelled():
                    continue
                group = futures[future]
                try:
                    rows = future.result()
                except Exception as e:  # (execute_batch makes rows of its failures; this is a bug)
                    rows = [failed_row(run.id, run.values, f"{type(e).__name__}: {e}", device=device)
                            for run in group]
                interrupted |= any(row["status"] == "interrupted" for row in rows)
                yield from rows
    if interrupted or received:
        raise KeyboardInterrupt


def map_tasks(fn, tasks: list, workers: int = 1, gpus: int = 0, workers_per_gpu: int = 1,
              scheduler: str | None = None) -> Iterator:
    """``fn(task)`` of every task, in the order they finish, on the same clusters as a study's runs:
    in this process (``workers`` ≤ 1, no GPUs, no scheduler), on ``workers`` local CPU processes, on
    ``gpus × workers_per_gpu`` pinned GPU workers, or on the cluster at ``scheduler``. For sweeps
    that are not a case × flags (the benches' own scenes); ``fn`` must be picklable (Dask's
    cloudpickle also takes a script's own functions)."""
    if workers <= 1 and gpus == 0 and not scheduler:
        for task in tasks:
            yield fn(task)
        return
    if not dask_available():
        raise ImportError(DASK_MISSING)
    from distributed import as_completed

    with study_client(workers, gpus, workers_per_gpu, scheduler) as client:
        futures = client.map(fn, tasks, pure=False)
        for future in as_completed(futures):
            yield future.result()
