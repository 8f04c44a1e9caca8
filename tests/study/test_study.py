"""The study runner: sweeps on a two-process Dask cluster, resume, failing runs, bad input."""

import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from mpmdem.cli import main
from mpmdem.errors import InputError
from mpmdem.study import cluster as study_cluster
from mpmdem.study.cluster import study_client
from mpmdem.study.study import Study, load_study, plan_runs, run_study
from mpmdem.study.table import ResultsTable

INCLINE = Study("incline", "block-on-incline", grid={"--angle": [20.0, 30.0]},
                fixed={"quick": True, "friction": 0.2, "--quiet": True})


def jsonl_rows(out):
    return [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]


def count_executions(monkeypatch):
    """Counts the runs executed in this process (serial mode) from now on."""
    executed = []
    real = study_cluster.execute_run

    def counting(*args):
        executed.append(args[1])
        return real(*args)

    monkeypatch.setattr(study_cluster, "execute_run", counting)
    return executed


def test_plan_gives_stable_ids_and_checked_argv():
    study = Study("s", "block-on-incline", grid={"angle": [30, 45.5], "--friction": [0.1]}, fixed={"--quick": True})
    runs = plan_runs(study, "cpu")
    assert [r.id for r in runs] == ["angle=30,friction=0.1", "angle=45.5,friction=0.1"]
    assert runs[1].values == {"angle": 45.5, "friction": 0.1}
    assert runs[0].argv == ("--angle", "30", "--friction", "0.1", "--quick", "--device", "cpu")
    granular = Study("g", "slope-flow", grid={"granular": [True, False]})
    assert [r.argv for r in plan_runs(granular)] == [("--granular",), ("--no-granular",)]


def test_sweep_on_two_cpu_processes(tmp_path):
    rows = run_study(INCLINE, tmp_path, workers=2, device="cpu", progress=False)
    assert [r["id"] for r in rows] == ["angle=20.0", "angle=30.0"]
    for row in rows:
        assert row["status"] == "completed", row
        recorded = row["wall_seconds"]  # the row records the run's duration (its value is not checked)
        assert row["device"] == "cpu" and recorded > 0 and row["worker"] is not None
        assert row["acceleration"] == pytest.approx(row["acceleration_expected"], rel=1e-3)
        assert (tmp_path / "runs" / row["id"] / "summary.json").is_file()
    assert len(jsonl_rows(tmp_path)) == 2
    csv_lines = (tmp_path / "results.csv").read_text().splitlines()
    assert len(csv_lines) == 3 and "acceleration" in csv_lines[0].split(",")


def test_resume_runs_only_the_missing_runs(tmp_path, monkeypatch):
    study = load_study("disk-restitution")
    real_append = ResultsTable.append

    def killed_after_first(self, row):
        real_append(self, row)
        raise KeyboardInterrupt  # as if the study were killed once the first result is in

    monkeypatch.setattr(ResultsTable, "append", killed_after_first)
    with pytest.raises(KeyboardInterrupt):
        run_study(study, tmp_path, workers=0, device="cpu", progress=False)
    monkeypatch.setattr(ResultsTable, "append", real_append)
    (first,) = jsonl_rows(tmp_path)
    first_summary = tmp_path / "runs" / first["id"] / "summary.json"
    mtime = first_summary.stat().st_mtime_ns
    with (tmp_path / "results.jsonl").open("a") as f:
        f.write('{"id": "restitution=0.9", "sta')  # a line cut short by the kill
    executed = count_executions(monkeypatch)
    rows = run_study(study, tmp_path, workers=0, device="cpu", progress=False)
    assert sorted(executed) == ["restitution=0.6", "restitution=0.9"]
    assert first_summary.stat().st_mtime_ns == mtime
    assert [r["status"] for r in rows] == ["completed"] * 3
    assert (tmp_path / "restitution.json").is_file()  # the study's analyze ran
    run_study(study, tmp_path, workers=0, device="cpu", progress=False)
    assert len(executed) == 2  # nothing left to run
    with pytest.raises(InputError, match="--out"):
        run_study(study.with_settings({"end-time": "0.1"}), tmp_path, workers=0, device="cpu", progress=False)


def test_failing_runs_are_rows(tmp_path, monkeypatch):
    study = Study("bad-angle", "block-on-incline", grid={"--angle": [30.0, 90.0]}, fixed={"--quick": True})
    rows = run_study(study, tmp_path, workers=0, device="cpu", progress=False)
    assert [r["status"] for r in rows] == ["completed", "bad-input"]
    assert "--angle" in rows[1]["message"]
    executed = count_executions(monkeypatch)
    run_study(study, tmp_path, workers=0, device="cpu", progress=False)
    assert executed == []  # bad input is a final status
    run_study(study, tmp_path, workers=0, device="cpu", progress=False, rerun_failed=True)
    assert executed == ["angle=90.0"]

    raising = Study("raising", "study_raising_case", grid={"--fail": [True, False]}, fixed={"--end-time": 0.01})
    rows = run_study(raising, tmp_path / "raising", workers=0, device="cpu", progress=False)
    assert [r["status"] for r in rows] == ["error", "completed"]
    assert rows[0]["message"] == "RuntimeError: this case was told to fail"
    assert (tmp_path / "raising" / "runs" / "fail=true" / "error.txt").is_file()
    assert rows[1]["steps_run"] > 0 and "a_list" not in rows[1]  # scalars only


def test_killed_study_resumes_without_losing_a_finished_run(tmp_path, monkeypatch):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "mpmdem.cli", "study", "disk-restitution", "--workers", "1", "--device", "cpu",
               "--out", str(out)]
    study = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while study.poll() is None and not (out / "results.jsonl").is_file():
            time.sleep(0.05)
    finally:
        study.send_signal(signal.SIGKILL)
        study.wait()
    finished = [r["id"] for r in jsonl_rows(out)]
    assert finished  # the first run's row was on disk before the kill
    executed = count_executions(monkeypatch)
    rows = run_study(load_study("disk-restitution"), out, workers=0, device="cpu", progress=False)
    assert len(executed) == 3 - len(finished) and not set(executed) & set(finished)
    assert [r["status"] for r in rows] == ["completed"] * 3


def test_lost_worker_is_a_row(tmp_path):
    crash = Study("crash", "study_raising_case", grid={"--crash": [True, False]}, fixed={"--end-time": 0.01})
    rows = run_study(crash, tmp_path, workers=2, device="cpu", progress=False)
    assert [r["status"] for r in rows] == ["error", "completed"]
    assert rows[0]["message"].startswith("worker lost: KilledWorker")


def test_missing_dask_is_one_line_unless_serial(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(study_cluster, "dask_available", lambda: False)
    assert main(["study", "disk-restitution", "--out", str(tmp_path / "out")]) == 2
    assert 'pip install "mpmdem[study]"' in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


CASE = 'case = "block-on-incline"'


@pytest.mark.parametrize("top, grid, fixed, complaint", [
    (CASE, "angle = [30.0]", "no-such-flag = 1", "flag='--no-such-flag'"),
    (CASE, "angle = [30.0, \"steep\"]", "", "--angle='steep'"),
    (CASE, "angle = []", "", "at least one value"),
    (CASE, "angle = [30.0]", "out = \"elsewhere\"", "set by the study runner"),
    ('case = "no-such-case"', "angle = [30.0]", "", "case='no-such-case'"),
    (CASE + '\nanalyze = "no_such_module:fit"', "angle = [30.0]", "", "analyze='no_such_module:fit'"),
])
def test_bad_study_file_exits_2_and_runs_nothing(tmp_path, capsys, top, grid, fixed, complaint):
    path = tmp_path / "sweep.toml"
    path.write_text(f"{top}\n[grid]\n{grid}\n[fixed]\n{fixed}\n")
    assert main(["study", str(path), "--workers", "0", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert complaint in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv", [
    ["no-such-study"], ["missing.toml"], ["disk-restitution", "--set", "angle=3"],
    ["disk-restitution", "--set", "restitution=0.5,x"], ["disk-restitution", "--gpus", "-1"],
    ["disk-restitution", "--gpus", "64"],  # (more GPUs than the machine has: refused before any worker)
])
def test_bad_command_line_exits_2_and_runs_nothing(tmp_path, capsys, argv):
    assert main(["study", *argv, "--out", str(tmp_path / "out")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_study_file_runs_from_the_command_line(tmp_path, capsys):
    path = tmp_path / "incline.toml"
    path.write_text('case = "block-on-incline"\nanalyze = "study_raising_case:count_rows"\n'
                    '[grid]\nangle = [30.0]\nfriction = [0.1, 0.2]\n[fixed]\nquick = true\n')
    out = tmp_path / "out"
    assert main(["study", str(path), "--workers", "0", "--device", "cpu", "--out", str(out),
                 "--set", "friction=0.25"]) == 0
    assert "1 completed" in capsys.readouterr().out
    assert [r["id"] for r in jsonl_rows(out)] == ["angle=30.0,friction=0.25"]
    assert json.loads((out / "study.json").read_text())["name"] == "incline"
    assert (out / "rows.txt").read_text() == "1\n"


def _visible_devices():
    return os.environ.get("CUDA_VISIBLE_DEVICES")


def test_gpu_workers_are_pinned_one_card_each(monkeypatch):
    monkeypatch.delenv("CUDA_VISIBLE_DEVICES", raising=False)
    with study_client(0, gpus=2, workers_per_gpu=2) as client:
        client.wait_for_workers(4)
        assert sorted(client.run(_visible_devices).values()) == ["0", "0", "1", "1"]


def _square_and_pid(x):
    return x * x, os.getpid()


@pytest.mark.parametrize("workers", [1, 2])
def test_bench_sweeps_map_their_tasks_on_the_study_clusters(workers):
    """map_tasks (the benches' sweeps): every task's result, in this process or on two worker
    processes of a local cluster."""
    out = list(study_cluster.map_tasks(_square_and_pid, [1, 2, 3, 4], workers=workers))
    assert sorted(r for r, _ in out) == [1, 4, 9, 16]
    pids = {p for _, p in out}
    assert (pids == {os.getpid()}) if workers == 1 else (os.getpid() not in pids)


def test_batched_study_runs_its_batches_side_by_side_by_default():
    """Unbatched studies keep one worker per GPU; batched ones on several GPUs get one per batch,
    at most GPU_SIDE_BY_SIDE (a batch's frames leave the GPU idle for the others' steps); on one
    GPU the batches run one after another in the study's process."""
    from mpmdem.study.study import GPU_SIDE_BY_SIDE, default_workers_per_gpu

    assert default_workers_per_gpu(None) == 1
    assert default_workers_per_gpu([]) == 1
    assert default_workers_per_gpu([["a"], ["b"], ["c"]]) == 1
    assert default_workers_per_gpu([[k] for k in range(2 * GPU_SIDE_BY_SIDE + 6)], gpus=2) == GPU_SIDE_BY_SIDE
    assert default_workers_per_gpu([["a"], ["b"], ["c"]], gpus=2) == 2  # (3 batches over 2 GPUs)
    assert default_workers_per_gpu([["a"], ["b"]], gpus=4) == 1


def test_a_study_with_no_completed_run_skips_its_analysis(tmp_path, capsys):
    """Every run failed (the case raises in build): the rows say why, and the analysis, which has
    nothing to read, is not run (it would fail on an empty table) but named on stderr."""
    path = tmp_path / "failing.toml"
    path.write_text('case = "study_raising_case"\nanalyze = "study_raising_case:count_rows"\n'
                    '[grid]\nfail = [true]\n')
    out = tmp_path / "out"
    assert main(["study", str(path), "--workers", "0", "--device", "cpu", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "no run completed, so no analysis" in captured.err
    assert not (out / "rows.txt").exists()  # (count_rows writes it)
    assert [r["status"] for r in jsonl_rows(out)] == ["error"]


@pytest.mark.parametrize("workers, tasks, gpus, per_gpu, scheduler, here", [
    (0, 5, 0, 1, None, True),  # serial, as asked
    (1, 5, 0, 1, None, True),  # one CPU worker: its runs one after another, as here
    (None, 1, 0, 1, None, True),  # one task: one worker at most
    (None, 2, 0, 1, None, (os.cpu_count() or 1) == 1),
    (2, 1, 0, 1, None, False),  # (two workers asked: a cluster, though one task)
    (None, 2, 1, 1, None, True),  # one GPU, one worker on it
    (None, 2, 1, 2, None, False),  # batches side by side: one process each
    (None, 2, 2, 1, None, False),
    (0, 2, 0, 1, "tcp://elsewhere:8786", False),
])
def test_a_cluster_of_one_local_worker_is_this_process(workers, tasks, gpus, per_gpu, scheduler, here):
    """A local cluster of one worker would run its tasks one after another, as this process does,
    after starting a scheduler and a worker process that imports Warp again: the study runs here."""
    assert study_cluster.runs_here(workers, tasks, gpus, per_gpu, scheduler) is here


def test_one_worker_study_starts_no_cluster(tmp_path, monkeypatch):
    """--workers 1, and a batched study of one batch: every row from this process, no Dask cluster
    started; the rows and the table as a cluster's worker writes them."""
    def no_cluster(*args, **kwargs):
        raise AssertionError("a Dask cluster was started")

    monkeypatch.setattr(study_cluster, "study_client", no_cluster)
    here = f"{socket.gethostname()}:{os.getpid()}"
    rows = run_study(INCLINE, tmp_path / "one", workers=1, device="cpu", progress=False)
    assert [r["status"] for r in rows] == ["completed"] * 2 and {r["worker"] for r in rows} == {here}
    assert [r["id"] for r in jsonl_rows(tmp_path / "one")] == ["angle=20.0", "angle=30.0"]
    starts = Study("starts", "sand-blocks", grid={"--ensemble-seed": [1, 2]},
                   fixed={"--cell-size": 0.02, "--end-time": 0.004, "--frames": 1})
    batched = run_study(starts, tmp_path / "batched", device="cpu", progress=False, batch=2)
    assert [r["status"] for r in batched] == ["completed"] * 2 and {r["worker"] for r in batched} == {here}
    assert [r.get("batch_worlds") for r in batched] == [2, 2]


@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_finished_studys_cluster_closes_while_its_table_and_analysis_are_written(tmp_path):
    """The local cluster of a study whose runs all returned closes in a thread (its worker
    processes take their time to end) while the table and the analysis are written; run_study
    returns once it has closed. A study stopped early closes it before going on."""
    import threading

    closing_during_analysis = []

    def analyze(rows, out):
        closing_during_analysis.append(any(t.name == "mpmdem-cluster-close" for t in threading.enumerate()))

    study = Study("incline", INCLINE.case, INCLINE.grid, INCLINE.fixed, analyze=analyze)
    rows = run_study(study, tmp_path / "a", workers=2, device="cpu", progress=False)
    assert [r["status"] for r in rows] == ["completed"] * 2
    assert closing_during_analysis == [True]
    assert not any(t.name == "mpmdem-cluster-close" for t in threading.enumerate())
    runs = plan_runs(INCLINE, "cpu")
    stream = study_cluster.execute_runs(runs, INCLINE.case, tmp_path / "b", "cpu", workers=2)
    next(stream)
    stream.close()  # (the consumer stopped: the cluster is closed at once)
    assert not any(t.name == "mpmdem-cluster-close" for t in threading.enumerate())


def test_a_study_in_its_own_process_does_not_import_dask(tmp_path):
    """A study whose runs go in its own process (one worker) needs no Dask and imports none (its
    import is a quarter of a second): the rows name the process, not a Dask worker."""
    code = ("import sys\nfrom mpmdem.study.study import Study, run_study\n"
            "study = Study('one', 'study_raising_case', grid={'--end-time': [0.01]})\n"
            f"rows = run_study(study, {str(tmp_path)!r}, workers=1, device='cpu', progress=False)\n"
            "print(rows[0]['status'], 'distributed' in sys.modules)\n")
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # (the test case's folder)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.dirname(tests), tests])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert done.stdout.split() == ["completed", "False"], done.stderr[-2000:]
