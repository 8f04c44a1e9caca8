"""Batches side by side in threads of one process, taking turns on one device
(``mpmdem.study.cluster.side_by_side``, ``mpmdem.sim.device_turns``)."""

import contextlib
import io
import sys
import threading

import h5py
import numpy as np
import pytest

from mpmdem.io.background import thread_switch_interval
from mpmdem.sim import device_turns
from mpmdem.study import cluster as study_cluster
from mpmdem.study.batch_worker import group_runs
from mpmdem.study.signals import deferred_stop
from mpmdem.study.study import Study, plan_runs
from mpmdem.study.thread_stderr import captured_stderr, routed_stderr

STARTS = Study("starts", "sand-blocks", grid={"--ensemble-seed": [1, 2, 3, 4]},
               fixed={"--cell-size": 0.02, "--end-time": 0.004, "--frames": 2})


def _datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def test_two_batches_side_by_side_write_the_files_of_one_after_the_other(tmp_path, monkeypatch):
    """Four starts in two batches of two, run one batch after the other and then in two threads
    taking turns on the CPU: the threads interleave (each gives its turn up before it reads the
    device clock), and every dataset of every run's file is the same bit for bit, as every row's
    status and batch."""
    runs = plan_runs(STARTS, "cpu")
    groups = group_runs(runs, 2)
    serial = list(study_cluster._execute_groups(groups, STARTS.case, tmp_path / "serial", "cpu", 0, 0, 1, None))

    order = []
    real_wait = device_turns.DeviceTurns.wait

    def logged(self):
        order.append(threading.current_thread().name)
        return real_wait(self)

    monkeypatch.setattr(device_turns.DeviceTurns, "wait", logged)
    side = list(study_cluster._groups_side_by_side(groups, STARTS.case, tmp_path / "side", "cpu", threads=2))
    threads = sorted(set(order))
    assert len(threads) == 2
    first_end = max(i for i, name in enumerate(order) if name == order[0])
    assert any(name != order[0] for name in order[:first_end]), "the two batches did not interleave"
    key = {r["id"]: (r["status"], r["batch"], r["batch_world"]) for r in serial}
    assert {r["id"]: (r["status"], r["batch"], r["batch_world"]) for r in side} == key
    assert {s for s, _, _ in key.values()} == {"completed"}
    for run in runs:
        a = _datasets(tmp_path / "serial" / "runs" / run.id / "sand_blocks.h5")
        b = _datasets(tmp_path / "side" / "runs" / run.id / "sand_blocks.h5")
        assert a.keys() == b.keys()
        for name in a:
            if name.endswith(("wall_time", "/wall_seconds", "diagnostic_values")):  # (the table's columns: the views)
                continue
            assert np.array_equal(a[name], b[name]), (run.id, name)


@pytest.mark.parametrize("tasks, gpus, per_gpu, scheduler, threads", [
    (3, 1, 3, None, 3),
    (2, 1, 4, None, 2),  # (at most one thread a batch)
    (1, 1, 4, None, 0),  # one batch: no threads
    (3, 1, 1, None, 0),
    (3, 2, 3, None, 0),  # several GPUs: worker processes
    (3, 1, 3, "tcp://elsewhere:8786", 0),
])
def test_batches_go_side_by_side_on_one_local_gpu(tasks, gpus, per_gpu, scheduler, threads):
    assert study_cluster.side_by_side(tasks, gpus, per_gpu, scheduler) == threads


def test_a_batched_study_on_one_gpu_runs_in_this_process():
    assert study_cluster.runs_here(None, 3, 1, 3, None, batched=True)
    assert not study_cluster.runs_here(None, 3, 1, 3, None)
    assert not study_cluster.runs_here(None, 3, 2, 1, None, batched=True)


def test_each_thread_captures_its_own_stderr():
    """Two threads inside ``routed_stderr`` write to their own buffers at once; writes of a thread
    with none go where sys.stderr went before, which comes back after."""
    before = sys.stderr
    buffers = [io.StringIO(), io.StringIO()]
    barrier = threading.Barrier(2)

    def write(k):
        with captured_stderr(buffers[k]):
            barrier.wait()
            for _ in range(50):
                print(f"run {k}", file=sys.stderr)
            barrier.wait()

    outside = io.StringIO()
    with contextlib.redirect_stderr(outside):
        with routed_stderr():
            threads = [threading.Thread(target=write, args=(k,)) for k in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            print("lead", file=sys.stderr)
        assert sys.stderr is outside
    assert sys.stderr is before
    for k in range(2):
        assert buffers[k].getvalue() == f"run {k}\n" * 50
    assert outside.getvalue() == "lead\n"


def test_a_thread_stops_on_the_signals_the_main_thread_receives():
    """``deferred_stop`` in another thread yields the main thread's list (signals reach only it)."""
    seen = []
    with deferred_stop() as received:
        def worker():
            with deferred_stop() as theirs:
                seen.append(theirs is received)

        t = threading.Thread(target=worker)
        t.start()
        t.join()
    assert seen == [True]


def test_switch_intervals_of_threads_that_overlap_come_back_in_any_order():
    before = sys.getswitchinterval()
    a = thread_switch_interval(before / 10)
    b = thread_switch_interval(before / 4)
    a.__enter__()
    b.__enter__()
    assert sys.getswitchinterval() == pytest.approx(before / 10)
    a.__exit__(None, None, None)
    assert sys.getswitchinterval() == pytest.approx(before / 4)
    b.__exit__(None, None, None)
    assert sys.getswitchinterval() == pytest.approx(before)


def test_a_run_used_after_its_turn_waits_without_taking_a_turn_it_does_not_hold():
    """``wait`` outside the thread's turn (a Simulation built in a turn, stepped after it) gives
    no turn up: another thread's turn is not broken."""
    turns = device_turns.DeviceTurns("cpu")
    with turns.turn():
        pass
    held = threading.Event()
    done = threading.Event()

    def other():
        with turns.turn():
            held.set()
            done.wait(5)

    t = threading.Thread(target=other)
    t.start()
    assert held.wait(5)
    turns.wait()  # (not in a turn here: must not release the other thread's)
    assert turns._lock._held
    done.set()
    t.join()
