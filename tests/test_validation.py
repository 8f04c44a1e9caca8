"""mpmdem validate: checks evaluated against a summary, the table, and a real (quick) case run."""

import json

import pytest

from mpmdem.cli import main
from mpmdem.validation import Check, collect_checks, evaluate, write_table


def test_a_check_matches_deviates_or_fails():
    ok = Check("a.b", 2.0, "eq. 1", 0.1, "the reference's scatter")
    assert evaluate(ok, {"status": "completed", "a": {"b": 2.1}})["status"] == "matches"
    assert evaluate(ok, {"status": "completed", "a": {"b": 2.5}})["status"] == "fails"
    gap = Check("x", 1.0, "Fig. 2", 0.05, "stated", relative=False, known_gap="a known cause")
    row = evaluate(gap, {"status": "completed", "x": 1.2})
    assert row["status"] == "deviates" and row["explanation"] == "a known cause"
    assert row["deviation"] == pytest.approx(0.2)
    # an analytic reference the case computes from its inputs, and a run that did not finish
    assert evaluate(Check("a", "a_exact", "analytic", 0.01, "fit"), {"status": "completed", "a": 1.0,
                                                                     "a_exact": 1.005})["status"] == "matches"
    assert evaluate(ok, {"status": "blown-up", "message": "NaN"})["status"] == "fails"


def test_every_declared_check_names_its_sources():
    checks = collect_checks()
    assert {"sand-blocks", "silo-discharge", "column-collapse", "block-on-incline"} <= set(checks)
    for case in checks.values():
        for c in case:
            assert c.source and c.tolerance_source and c.tolerance > 0


def test_table_lists_every_row(tmp_path):
    rows = [{"case": "c", **evaluate(Check("x", 1.0, "ref", 0.1, "tol"), {"status": "completed", "x": 1.05})}]
    write_table(rows, tmp_path)
    assert "| c | x | 1 (ref) | 1.05 | +5.0 % | – | ±10 % (tol) | matches |" in (tmp_path / "validation.md").read_text()


def test_validate_runs_a_case_and_writes_the_table(tmp_path):
    """The block on the incline (quick, a second on a CPU) against a = g (sin θ − μ cos θ)."""
    assert main(["validate", "--cases", "block-on-incline", "--quick", "--device", "cpu", "--out", str(tmp_path)]) == 0
    rows = json.loads((tmp_path / "validation.json").read_text())["rows"]
    assert [r["status"] for r in rows] == ["matches"]


def test_unknown_or_undeclared_cases_are_one_line_errors(tmp_path, capsys):
    assert main(["validate", "--cases", "no-such-case", "--out", str(tmp_path)]) == 2
    assert main(["validate", "--cases", "sulsky-disks", "--out", str(tmp_path)]) == 2
    assert not (tmp_path / "validation.md").exists()


def test_a_check_with_coarser_runs_shows_whether_the_deviation_shrinks(tmp_path):
    """The table reports the value at each resolution and the trend of the deviation's size."""
    from mpmdem.validation import convergence

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
