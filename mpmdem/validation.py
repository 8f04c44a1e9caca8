"""Validation: every case's numbers against their analytic or published references, in one table.

A case declares ``VALIDATION = [Check(...), ...]``: a quantity of its summary.json, the reference
value and where it comes from (an equation, a table, a figure), and a tolerance with where *that*
comes from (the reference's own scatter, a convergence estimate or a stated physical argument,
never our previous result). ``run_validation`` runs each case once per distinct set of flags (at
its validation size: the case's default, or ``--quick`` for a smoke table), evaluates every check
and writes ``validation.json`` and ``validation.md``. A check we miss for a reason we understand
carries that reason (``known_gap``): its status is "deviates" with the explanation, not a widened
band; a miss without one is "fails".

Where a check names coarser resolutions (``coarser``: the flags of each, coarsest first), the case
also runs at those, and the row shows the value and deviation at every resolution and whether the
deviation shrinks towards the validation resolution: a number is claimed only with its trend.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

__all__ = ["Check", "collect_checks", "evaluate", "run_validation", "write_table"]


@dataclass(frozen=True)
class Check:
    """One validated quantity of a case.

    Attributes:
        quantity: a key of the case's summary.json; "a.b" reads summary["a"]["b"].
        reference: the reference value, or the name of a summary key holding an analytic value the
            case computes from its inputs alone (e.g. g (sin θ − μ cos θ)).
        source: where the reference comes from.
        tolerance: allowed |value − reference|, relative to |reference| if ``relative``.
        tolerance_source: where the tolerance comes from.
        flags: the case's flags for this check's run (its validation size when not the default).
        known_gap: why we miss the reference, when we know; the check is then "deviates".
        coarser: the flags of coarser resolutions than ``flags`` (coarsest first), run as well to show
            whether the deviation shrinks under refinement.
    """

    quantity: str
    reference: float | str
    source: str
    tolerance: float
    tolerance_source: str
    relative: bool = True
    flags: tuple[str, ...] = ()
    known_gap: str = ""
    coarser: tuple[tuple[str, ...], ...] = ()


def _lookup(summary: dict, key: str):
    value = summary
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    return value


def evaluate(check: Check, summary: dict) -> dict:
    """The table row of ``check`` against a run's summary: value, deviation, status."""
    ref = _lookup(summary, check.reference) if isinstance(check.reference, str) else check.reference
    value = _lookup(summary, check.quantity) if summary.get("status") == "completed" else None
    row = {"quantity": check.quantity, "reference": ref, "source": check.source, "value": value,
           "tolerance": check.tolerance, "relative": check.relative, "tolerance_source": check.tolerance_source,
           "flags": list(check.flags), "deviation": None}
    if not isinstance(value, (int, float)) or not isinstance(ref, (int, float)) or not math.isfinite(value):
        row["status"] = "fails"
        row["explanation"] = f"no value (run {summary.get('status')}: {summary.get('message', '')})".strip()
        return row
    deviation = (value - ref) / abs(ref) if check.relative else value - ref
    row["deviation"] = deviation
    if abs(deviation) <= check.tolerance:
        row["status"], row["explanation"] = "matches", ""
    elif check.known_gap:
        row["status"], row["explanation"] = "deviates", check.known_gap
    else:
        row["status"], row["explanation"] = "fails", ""
    return row


def convergence(ladder: list[dict], flags: list[list[str]]) -> dict:
    """The values and deviations of one check at resolutions coarsest → finest, and whether the
    deviation's size shrinks from the coarsest to the finest (None where a run gave no value)."""
    steps = [{"flags": f, "value": r["value"], "deviation": r["deviation"]} for r, f in zip(ladder, flags, strict=True)]
    ends = [steps[0]["deviation"], steps[-1]["deviation"]]
    shrinks = None if None in ends else abs(ends[1]) < abs(ends[0])
    return {"convergence": steps, "deviation_shrinks": shrinks}


def collect_checks(cases: list[str] | None = None) -> dict[str, list[Check]]:
    """Case name → its checks, for every registered case that declares VALIDATION."""
    from .cases import CASES
    from .runner import case_module

    out = {}
    for name in cases or list(CASES):
        checks = getattr(case_module(name), "VALIDATION", None)
        if checks:
            out[name] = list(checks)
    return out


def run_validation(out: Path, *, device: str | None = None, quick: bool = False,
                   cases: list[str] | None = None) -> list[dict]:
    """Run every declared case (once per distinct flags) and evaluate its checks; writes
    OUT/validation.json and OUT/validation.md and returns the rows."""
    from .runner import case_module, run_case

    out = Path(out)
    rows = []
    runs: dict[tuple, dict] = {}

    def summary_of(name: str, flags: tuple[str, ...]) -> dict:
        """The summary of case ``name`` run with ``flags`` (run once per distinct flags)."""
        if (name, flags) not in runs:
            folder = out / "runs" / "_".join([name, *(f.strip("-") for f in flags)]).replace("/", "-")
            argv = [*flags, "--out", str(folder), "--quiet"] + (["--device", device] if device else [])
            run_case(case_module(name), argv)
            path = folder / "summary.json"
            runs[name, flags] = json.loads(path.read_text()) if path.is_file() else {"status": "error"}
        return runs[name, flags]

    for name, checks in collect_checks(cases).items():
        for check in checks:
            quick_flag = ("--quick",) if quick else ()
            summary = summary_of(name, tuple(check.flags) + quick_flag)
            row = {"case": name, **evaluate(check, summary), "device": summary.get("device"),
                   "points": summary.get("particles"), "wall_seconds": summary.get("wall_seconds")}
            if check.coarser and not quick:  # a quick table is a smoke run: no resolution trend
                ladder = [evaluate(check, summary_of(name, tuple(f))) for f in check.coarser] + [row]
                row.update(convergence(ladder, [list(f) for f in check.coarser] + [list(check.flags)]))
            rows.append(row)
    write_table(rows, out, quick=quick)
    return rows


def write_table(rows: list[dict], out: Path, *, quick: bool = False) -> None:
    """validation.json (every field) and validation.md (one line per check)."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "validation.json").write_text(json.dumps({"quick": quick, "rows": rows}, indent=2, default=float) + "\n")

    def num(v):
        return "–" if v is None else f"{v:.4g}"

    def deviation(r):
        if r["deviation"] is None:
            return "–"
        return f"{100 * r['deviation']:+.1f} %" if r["relative"] else f"{r['deviation']:+.3g}"

    def trend(r):
        if not r.get("convergence"):
            return "–"
        word = {True: "shrinks", False: "does not shrink", None: "–"}[r["deviation_shrinks"]]
        steps = " → ".join(f"{' '.join(s['flags']) or 'default'}: {deviation({**r, **s})}" for s in r["convergence"])
        return f"{steps} ({word})"

    lines = ["| case | quantity | reference (source) | ours | deviation | under refinement | tolerance (source) | "
             "status |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        dev = deviation(r)
        tol = f"±{100 * r['tolerance']:.3g} %" if r["relative"] else f"±{r['tolerance']:.3g}"
        status = r["status"] + (f": {r['explanation']}" if r["explanation"] else "")
        flags = f" ({' '.join(r['flags'])})" if r["flags"] else ""
        lines.append(f"| {r['case']}{flags} | {r['quantity']} | {num(r['reference'])} ({r['source']}) | "
                     f"{num(r['value'])} | {dev} | {trend(r)} | {tol} ({r['tolerance_source']}) | {status} |")
    head = "Validation table" + (" (quick sizes: a smoke run, not the validation resolution)" if quick else "")
    (out / "validation.md").write_text(f"# {head}\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps([asdict(c) for cs in collect_checks().values() for c in cs], indent=1))
