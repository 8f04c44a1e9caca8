"""mpmdem validate: checks evaluated against a summary, the table, the quick table of every declared
check (run inside the suite), and the committed GPU table against the declared checks."""

import json
import re
from pathlib import Path

import pytest
from helpers import ROOT, quick_run

from mpmdem.cli import main
from mpmdem.errors import InputError
from mpmdem.study.validation import (
    Check,
    check_identity,
    collect_checks,
    counts,
    evaluate,
    run_validation,
    table_differences,
    write_table,
)

TABLE = ROOT / "bench" / "results" / "validation" / "h100.json"


def test_a_check_matches_is_a_known_gap_or_fails():
    ok = Check("a.b", 2.0, "eq. 1", 0.1, "the reference's scatter")
    assert evaluate(ok, {"status": "completed", "a": {"b": 2.1}})["verdict"] == "match"
    assert evaluate(ok, {"status": "completed", "a": {"b": 2.5}})["verdict"] == "fail"
    gap = Check("x", 1.0, "Fig. 2", 0.05, "stated", relative=False, known_gap="a known cause", gap_bounds=(0.1, 0.3),
                gap_source="runs A, B")
    row = evaluate(gap, {"status": "completed", "x": 1.2})
    assert row["verdict"] == "known-gap" and row["deviation"] == pytest.approx(0.2)
    assert row["gap_bounds"] == [0.1, 0.3] and row["gap_source"] == "runs A, B"
    # a miss beyond the documented range fails, on either side; a match is a match
    assert evaluate(gap, {"status": "completed", "x": 1.4})["verdict"] == "fail"
    assert evaluate(gap, {"status": "completed", "x": 0.9})["verdict"] == "fail"
    assert evaluate(gap, {"status": "completed", "x": 1.01})["verdict"] == "match"
    # an analytic reference the case computes from its inputs, and a run that did not finish
    assert evaluate(Check("a", "a_exact", "analytic", 0.01, "fit"), {"status": "completed", "a": 1.0,
                                                                     "a_exact": 1.005})["verdict"] == "match"
    assert evaluate(ok, {"status": "blown-up", "message": "NaN"})["verdict"] == "fail"


def test_the_explanation_is_written_from_the_run():
    """Two runs of one known-gap check: the numbers in the explanations are the runs' own."""
    gap = Check("x", 1.0, "Fig. 2", 0.05, "stated", relative=False, known_gap="a known cause", gap_bounds=(0.1, 0.3),
                gap_source="runs A, B")
    a = evaluate(gap, {"status": "completed", "x": 1.15})["explanation"]
    b = evaluate(gap, {"status": "completed", "x": 1.25})["explanation"]
    assert "1.15" in a and "+0.15" in a and "1.25" in b and "+0.25" in b
    assert a.startswith("a known cause") and "[+0.1, +0.3]" in a
    fail = evaluate(gap, {"status": "completed", "x": 1.5})["explanation"]
    assert "1.5" in fail and "beyond the documented gap" in fail


@pytest.mark.parametrize("kwargs, name", [
    (dict(known_gap="a cause"), "known_gap"),  # a gap without its range
    (dict(gap_bounds=(0.1, 0.2)), "gap_bounds"),  # a range without its cause and source
    (dict(known_gap="a cause", gap_bounds=(0.2, 0.1), gap_source="s"), "gap_bounds"),
    (dict(known_gap="a cause", gap_bounds=(0.1, float("nan")), gap_source="s"), "gap_bounds"),
    (dict(kind="agreement"), "kind"),
])
def test_a_check_declares_a_known_gap_with_its_range(kwargs, name):
    with pytest.raises(InputError, match=name):
        Check("x", 1.0, "ref", 0.1, "tol", **kwargs)
    with pytest.raises(InputError, match="tolerance"):
        Check("x", 1.0, "ref", 0.0, "tol")


def test_quick_size_flags_and_bounds():
    """The quick size appends --quick unless the check names its quick flags; a gap's range measured at
    the validation size does not carry over to a different quick run."""
    c = Check("x", 1.0, "r", 0.1, "t", flags=("--cells", "40"), known_gap="c", gap_bounds=(0.2, 0.4), gap_source="s")
    assert c.run_flags() == ("--cells", "40") and c.run_flags(True) == ("--cells", "40", "--quick")
    assert c.bounds() == (0.2, 0.4) and c.bounds(True) is None
    assert evaluate(c, {"status": "completed", "x": 1.3}, quick=True)["verdict"] == "fail"
    q = Check("x", 1.0, "r", 0.1, "t", flags=("--quick",), known_gap="c", gap_bounds=(0.2, 0.4), gap_source="s")
    assert q.run_flags(True) == ("--quick",) and q.bounds(True) == (0.2, 0.4)
    own = Check("x", 1.0, "r", 0.1, "t", quick_flags=(), known_gap="c", gap_bounds=(0.2, 0.4), gap_source="s",
                quick_gap_bounds=(-0.4, -0.2))
    assert own.run_flags(True) == () and own.bounds(True) == (-0.4, -0.2)


def test_every_declared_check_names_its_sources():
    checks = collect_checks()
    assert {"sand-blocks", "silo-discharge", "column-collapse", "block-on-incline"} <= set(checks)
    for case in checks.values():
        for c in case:
            assert c.source and c.tolerance_source and c.tolerance > 0
            assert (c.gap_bounds is not None or c.quick_gap_bounds is not None) == bool(c.known_gap)
            assert not c.known_gap or c.gap_source


def test_a_known_gaps_cause_is_words_its_numbers_come_from_the_runs():
    """The cause of a known gap carries no measured numbers (they go stale): only section, table and
    equation numbers and names (v0, block 2); the range and where it was measured are separate."""
    for case, cs in collect_checks().items():
        for c in cs:
            words = re.sub(r"(§|Table |eq\. |Fig\. )\d+(\.\d+)*", "", c.known_gap)
            words = re.sub(r"\b[A-Za-z_]+\d\b|\bblock \d\b", "", words)  # v0; block 2 (a name)
            assert not re.search(r"\d", words), (case, c.quantity, c.known_gap)


def test_disconnection_rows_are_self_consistency():
    """Granular MPM §4.1's onsets are compared with the run's own geometric events, whose positions
    were tuned into the set-up by bisection: agreement with itself, not with the paper."""
    kinds = {c.kind for c in collect_checks(["disconnection-1d"])["disconnection-1d"]}
    assert kinds == {"self-consistency"}
    others = [c.kind for n, cs in collect_checks().items() if n != "disconnection-1d" for c in cs]
    assert set(others) == {"reference"}


def test_table_lists_every_row(tmp_path):
    rows = [{"case": "c", **evaluate(Check("x", 1.0, "ref", 0.1, "tol"), {"status": "completed", "x": 1.05})}]
    write_table(rows, tmp_path, commit="abc1234", device="cpu")
    md = (tmp_path / "validation.md").read_text()
    assert "| c | x | reference | 1 (ref) | 1.05 | +5.0 % | – | ±10 % (tol) | match |" in md
    assert "at commit abc1234 on cpu: 1 checks over 1 cases; 1 match, 0 known gaps, 0 fail" in md
    table = json.loads((tmp_path / "validation.json").read_text())
    assert table["commit"] == "abc1234" and table["counts"]["match"] == 1


def test_validate_runs_a_case_and_writes_the_table(tmp_path):
    """The block on the incline (quick, a second on a CPU) against a = g (sin θ − μ cos θ)."""
    assert main(["validate", "--cases", "block-on-incline", "--quick", "--device", "cpu", "--out", str(tmp_path)]) == 0
    table = json.loads((tmp_path / "validation.json").read_text())
    assert [r["verdict"] for r in table["rows"]] == ["match"]
    for key in ("reference", "source", "value", "tolerance", "tolerance_source", "verdict", "gap_bounds", "commit"):
        assert key in table["rows"][0]
    assert table["rows"][0]["commit"] and table["commit"] == table["rows"][0]["commit"]


def test_the_commit_outside_a_checkout_comes_from_the_environment(tmp_path, monkeypatch):
    from mpmdem.study.validation import head_commit

    monkeypatch.delenv("MPMDEM_COMMIT", raising=False)
    assert head_commit(tmp_path) is None
    if (ROOT / ".git").exists():
        assert head_commit(ROOT) is not None  # a checkout names its own HEAD
    monkeypatch.setenv("MPMDEM_COMMIT", "abc1234")
    assert head_commit(tmp_path) == "abc1234"
    # a copy on another machine may carry a stale .git: the environment names the tree that ran
    assert head_commit(ROOT) == "abc1234"


def test_resume_reads_a_completed_run_instead_of_running_it(tmp_path):
    """--resume: a completed summary.json already in OUT/runs is read (a made-up value shows it was not
    run again); without --resume the case runs."""
    folder = tmp_path / "runs" / "block-on-incline_quick"
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps({"status": "completed", "acceleration": 1.0,
                                                     "acceleration_expected": 2.0}))
    args = ["validate", "--cases", "block-on-incline", "--quick", "--device", "cpu", "--out", str(tmp_path)]
    assert main([*args, "--resume"]) == 1  # the made-up run fails its check: the command says so
    assert json.loads((tmp_path / "validation.json").read_text())["rows"][0]["value"] == 1.0
    assert main(args) == 0
    assert json.loads((tmp_path / "validation.json").read_text())["rows"][0]["verdict"] == "match"


def test_unknown_or_undeclared_cases_are_one_line_errors(tmp_path, capsys):
    assert main(["validate", "--cases", "no-such-case", "--out", str(tmp_path)]) == 2
    assert main(["validate", "--cases", "sulsky-disks", "--out", str(tmp_path)]) == 2
    assert not (tmp_path / "validation.md").exists()


def test_a_check_with_coarser_runs_shows_whether_the_deviation_shrinks(tmp_path):
    """The table reports the value at each resolution and the trend of the deviation's size."""
    from mpmdem.study.validation import convergence

    check = Check("x", 1.0, "ref", 0.05, "tol", flags=("--cells", "40"), coarser=(("--cells", "10"), ("--cells", "20")))
    ladder = [evaluate(check, {"status": "completed", "x": v}) for v in (1.4, 1.2, 1.1)]
    trend = convergence(ladder, [["--cells", "10"], ["--cells", "20"], ["--cells", "40"]])
    assert [s["value"] for s in trend["convergence"]] == [1.4, 1.2, 1.1]
    assert trend["deviation_shrinks"] is True
    growing = convergence(ladder[::-1], [["a"], ["b"], ["c"]])
    assert growing["deviation_shrinks"] is False
    missing = convergence([evaluate(check, {"status": "blown-up"}), ladder[-1]], [["a"], ["b"]])
    assert missing["deviation_shrinks"] is None
    write_table([{"case": "c", **ladder[-1], **trend}], tmp_path)
    assert "--cells 10: +40.0 % → --cells 20: +20.0 % → --cells 40: +10.0 % (shrinks)" in (
        tmp_path / "validation.md").read_text()


def test_table_differences_name_a_changed_a_missing_and_a_stale_row():
    """A test of the check below: the identity of the rows is compared field by field."""
    checks = {"c": [Check("x", 1.0, "ref", 0.1, "tol"), Check("y", 2.0, "ref", 0.1, "tol")]}
    rows = [{**check_identity("c", cs), "verdict": "match"} for cs in checks["c"]]
    table = {"quick": False, "commit": "abc", "device": "cpu", "rows": rows}
    assert table_differences(table, checks) == []
    changed = {**table, "rows": [rows[0], {**rows[1], "tolerance": 0.5}]}
    assert "tolerance: table 0.5, declared 0.1" in table_differences(changed, checks)[0]
    assert "1 rows in the table, 2 declared checks" in table_differences({**table, "rows": rows[:1]}, checks)
    assert "the table names no commit" in table_differences({**table, "commit": None}, checks)


#: the cases whose quick run their own test module makes through helpers.quick_run (the slow ones)
SHARED_QUICK_RUNS = {"sand-blocks": (), "silo-discharge": (), "silo-filling": (), "column-collapse": ()}


def test_an_ensemble_row_is_the_median_of_its_starts(tmp_path):
    """sand-blocks' block-1 row runs the case from 16 perturbed starts (--ensemble-seed 1-16) and
    compares their median with the paper, keeping every start's value; the single-run rows keep their
    coarser grid. Made-up summaries stand in for the runs."""
    asked = []

    def fake(case, flags):
        asked.append(flags)
        seed = int(flags[flags.index("--ensemble-seed") + 1]) if "--ensemble-seed" in flags else 0
        return {"status": "completed", "device": "cpu", "event_times_s": {
            "reach": 0.25, "block2_touch": 0.33, "block1_touch": 0.40 + 0.01 * (seed % 5)}}

    rows = run_validation(tmp_path, cases=["sand-blocks"], summary_source=fake)
    block1 = rows[2]
    assert block1["starts"] == 16 and len(block1["start_values"]) == 16
    seeds = sorted(int(f[f.index("--ensemble-seed") + 1]) for f in asked if "--ensemble-seed" in f)
    assert seeds == list(range(1, 17))
    assert block1["value"] == pytest.approx(0.42) and block1["start_spread"] == pytest.approx([0.40, 0.44])
    assert "convergence" not in block1 and "convergence" in rows[0]
    assert "median of 16 starts, 0.4-0.44" in (tmp_path / "validation.md").read_text()
    # the quick size runs one start, the case's own
    quick = run_validation(tmp_path / "q", quick=True, cases=["sand-blocks"], summary_source=fake)
    assert quick[2]["starts"] == 1 and quick[2]["value"] == pytest.approx(0.40)
    with pytest.raises(InputError, match="coarser"):
        Check("x", 1.0, "r", 0.1, "t", starts=4, coarser=(("--cells", "8"),))


def test_an_ensembles_starts_run_as_one_batched_call(tmp_path, monkeypatch):
    """With ``batch_starts`` (the default on a GPU) the 16 starts of block 1's row go to the study's
    batch executor in one call, in folders named as a lone start's, and the row reads their
    summaries (the executor is replaced here by one writing made-up summaries)."""
    from mpmdem.study import batch_worker

    calls = []

    def fake_batch(case, runs, out, device):
        calls.append((case, [r.argv for r in runs], device))
        for r in runs:
            seed = int(r.argv[r.argv.index("--ensemble-seed") + 1])
            folder = Path(out) / "runs" / r.id
            folder.mkdir(parents=True)
            times = {"block1_touch": 0.40 + 0.01 * (seed % 5)}
            (folder / "summary.json").write_text(json.dumps({"status": "completed", "device": "cuda:0",
                                                             "event_times_s": times, "batch": "b1",
                                                             "wall_seconds": 12.5}))
        return []

    def single_runs(case, flags):  # (the rows of one run each: made up; the starts: None, run here)
        if "--ensemble-seed" in flags:
            return None
        return {"status": "completed", "device": "cpu", "event_times_s": {"reach": 0.25, "block2_touch": 0.33}}

    monkeypatch.setattr(batch_worker, "execute_batch", fake_batch)
    rows = run_validation(tmp_path, cases=["sand-blocks"], summary_source=single_runs, batch_starts=True)
    assert len(calls) == 1 and calls[0][0] == "sand-blocks" and len(calls[0][1]) == 16
    assert sorted(int(a[a.index("--ensemble-seed") + 1]) for a in calls[0][1]) == list(range(1, 17))
    block1 = rows[2]
    assert block1["starts"] == 16 and block1["value"] == pytest.approx(0.42)
    counted = block1["wall_seconds"]  # (the made-up batch's 12.5 s, counted once, not 16 times)
    assert counted == 12.5
    folders = [p.name for p in (tmp_path / "runs").iterdir()]
    assert sorted(int(n.rsplit("_", 1)[1]) for n in folders if "ensemble-seed" in n) == list(range(1, 17))


def _shared_quick_summary(case: str, flags: tuple) -> dict | None:
    """The quick run a case's test module makes (helpers.quick_run), where the check's flags are that
    run's; None (run it here) for the others."""
    if case not in SHARED_QUICK_RUNS or flags != ("--quick", *SHARED_QUICK_RUNS[case]):
        return None
    return quick_run(case.replace("-", "_"), *SHARED_QUICK_RUNS[case])[0]


@pytest.mark.slow
def test_validate_quick_runs_every_declared_check_without_a_fail(tmp_path):
    """`mpmdem validate --quick` on the CPU: every declared check at its quick size, inside the suite.
    No row may fail (a miss beyond a known gap's documented range, or no value), and the table's rows
    are exactly the declared checks. The four slow quick runs (sand blocks, silo discharge and
    filling, column collapse) are shared with their own test modules (helpers.quick_run): in the
    whole suite this test adds about 70 s on 2 busy CPU cores, alone it takes about 4 minutes."""
    rows = run_validation(tmp_path, device="cpu", quick=True, summary_source=_shared_quick_summary)
    failed = [f"{r['case']} {r['quantity']}: {r['explanation']}" for r in rows if r["verdict"] == "fail"]
    assert not failed, failed
    table = json.loads((tmp_path / "validation.json").read_text())
    assert table_differences(table, collect_checks()) == []


def test_the_committed_table_is_the_declared_checks():
    """The committed GPU table holds exactly the checks declared at HEAD (same case, quantity, flags,
    reference, sources, tolerance, kind and gap range, in order), names its commit and device, and
    has no fail."""
    table = json.loads(TABLE.read_text())
    assert table_differences(table, collect_checks()) == []
    assert not table["quick"] and all(r["verdict"] != "fail" for r in table["rows"])


def test_the_readme_quotes_the_committed_tables_counts():
    """README's line on the table: its checks, cases and verdicts as the committed table counts them
    (a table from before issue 45 counts 'matches' as match and 'deviates' as a known gap)."""
    table = json.loads(TABLE.read_text())
    legacy = {"matches": "match", "deviates": "known-gap", "fails": "fail"}
    rows = [{**r, "verdict": r.get("verdict") or legacy[r["status"]]} for r in table["rows"]]
    c = counts(rows)
    text = " ".join((ROOT / "README.md").read_text().split())
    m = re.search(r"(\d+) checks over (\d+) cases: (\d+) match, (\d+) known gaps?, (\d+) fail", text)
    assert m, "README names the table's counts"
    assert tuple(map(int, m.groups())) == (c["checks"], c["cases"], c["match"], c["known-gap"], c["fail"])
