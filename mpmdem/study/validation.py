"""Validation: every case's numbers against their analytic or published references, in one table.

A case declares ``VALIDATION = [Check(...), ...]``: a quantity of its summary.json, the reference
value and where it comes from (an equation, a table, a figure), and a tolerance with where *that*
comes from (the reference's own scatter, a convergence estimate or a stated physical argument,
never our previous result). ``run_validation`` runs each case once per distinct set of flags (at
its validation size, or at its quick size for ``--quick``), evaluates every check and writes
``validation.json`` and ``validation.md``.

Each row has a ``verdict``:

* ``match``: |deviation| ≤ tolerance;
* ``known-gap``: outside the tolerance, but inside the range of the gap the check documents
  (``gap_bounds``, with its cause ``known_gap`` and where the range was measured, ``gap_source``).
  A known gap is a bound, not an excuse: a miss beyond its range is a fail;
* ``fail``: anything else, or no value.

The row's explanation is written from the run (its value, deviation, the tolerance and the
documented range), never typed into the check. A check's ``kind`` says what a match means:
``reference`` (an analytic or published value) or ``self-consistency`` (the run against a quantity
it derives from its own set-up, e.g. an event position tuned in by bisection: agreement there is not
agreement with a paper).

A chaotic event (a block that tumbles) is compared as an ensemble: a check with ``starts`` runs the
case from that many perturbed starts and compares their median, the row keeping every start's value.

Where a check names coarser resolutions (``coarser``: the flags of each, coarsest first), the case
also runs at those, and the row shows the value and deviation at every resolution and whether the
deviation shrinks towards the validation resolution: a number is claimed only with its trend.
"""

from __future__ import annotations

import json
import math
import subprocess
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

from ..errors import InputError

__all__ = ["KINDS", "VERDICTS", "Check", "check_identity", "collect_checks", "evaluate", "head_commit",
           "row_identity", "run_validation", "table_differences", "write_table"]

#: what a check compares against
KINDS = ("reference", "self-consistency")
#: a row's verdicts
VERDICTS = ("match", "known-gap", "fail")


@dataclass(frozen=True)
class Check:
    """One validated quantity of a case.

    Attributes:
        quantity: a key of the case's summary.json; "a.b" reads summary["a"]["b"].
        reference: the reference value, or the name of a summary key holding a value the case
            computes from its inputs alone (e.g. g (sin θ − μ cos θ)).
        source: where the reference comes from.
        tolerance: allowed |value − reference|, relative to |reference| if ``relative``.
        tolerance_source: where the tolerance comes from.
        relative: the deviation is (value − reference)/|reference| (else value − reference, in the
            quantity's units).
        flags: the case's flags for this check's run (its validation size when not the default).
        known_gap: the cause of a miss we understand, in words (the numbers come from the run).
        gap_bounds: (low, high), the range of the deviation (same units as the deviation) that the
            known gap documents; required with ``known_gap``.
        gap_source: where the range was measured (runs, studies, resolutions).
        quick_flags: the flags of the check's quick size (default: ``flags`` plus ``--quick``).
        quick_gap_bounds: the gap's range at the quick size, where the quick run differs from the
            validation run and misses (``known_gap`` names the cause there too).
        coarser: the flags of coarser resolutions than ``flags`` (coarsest first), run as well to show
            whether the deviation shrinks under refinement.
        kind: "reference" or "self-consistency" (see the module's docstring).
        starts: for a chaotic event, the number of perturbed starts at the validation size: the case
            runs with ``start_flag`` 1 … ``starts`` and the value is the median over the starts (the
            row keeps every start's value and their spread). The quick size runs one start, the
            case's own.
        start_flag: the case's flag that takes a start's seed.
    """

    quantity: str
    reference: float | str
    source: str
    tolerance: float
    tolerance_source: str
    relative: bool = True
    flags: tuple[str, ...] = ()
    known_gap: str = ""
    gap_bounds: tuple[float, float] | None = None
    gap_source: str = ""
    quick_flags: tuple[str, ...] | None = None
    quick_gap_bounds: tuple[float, float] | None = None
    coarser: tuple[tuple[str, ...], ...] = ()
    kind: str = "reference"
    starts: int = 1
    start_flag: str = "--ensemble-seed"

    def __post_init__(self):
        if not (isinstance(self.tolerance, int | float) and math.isfinite(self.tolerance) and self.tolerance > 0):
            raise InputError("tolerance", self.tolerance, "a finite tolerance > 0")
        if self.kind not in KINDS:
            raise InputError("kind", self.kind, f"one of {KINDS}")
        for name in ("gap_bounds", "quick_gap_bounds"):
            b = getattr(self, name)
            if b is None:
                continue
            if not (len(b) == 2 and all(isinstance(v, int | float) and math.isfinite(v) for v in b) and b[0] < b[1]):
                raise InputError(name, b, "(low, high) with low < high, finite")
            if not (self.known_gap and self.gap_source):
                raise InputError(name, b, "bounds of a known gap: known_gap (its cause) and gap_source as well")
        if not (isinstance(self.starts, int) and self.starts >= 1):
            raise InputError("starts", self.starts, "a whole number of starts ≥ 1")
        if self.starts > 1 and self.coarser:
            raise InputError("coarser", self.coarser, "no coarser ladder on a row of several starts (a median against "
                                                      "single runs): declare the trend on a single-run row")
        if self.known_gap and self.gap_bounds is None and self.quick_gap_bounds is None:
            raise InputError("known_gap", self.known_gap, "a known gap with its range (gap_bounds), not an excuse")

    def run_flags(self, quick: bool = False) -> tuple[str, ...]:
        """The case's flags for this check at its validation size, or at its quick size."""
        if not quick:
            return tuple(self.flags)
        if self.quick_flags is not None:
            return tuple(self.quick_flags)
        return tuple(self.flags) if "--quick" in self.flags else (*self.flags, "--quick")

    def bounds(self, quick: bool = False) -> tuple[float, float] | None:
        """The documented range of the gap at the validation size, or at the quick size: there
        ``quick_gap_bounds``, or ``gap_bounds`` where the quick run is the validation run (a range
        measured at one size says nothing about another)."""
        if quick and self.quick_gap_bounds is not None:
            return tuple(self.quick_gap_bounds)
        if quick and self.run_flags(True) != self.run_flags(False):
            return None
        return None if self.gap_bounds is None else tuple(self.gap_bounds)


def _lookup(summary: dict, key: str):
    value = summary
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    return value


def _fmt_deviation(deviation: float, relative: bool) -> str:
    return f"{100 * deviation:+.1f} %" if relative else f"{deviation:+.3g}"


def _fmt_band(lo: float, hi: float, relative: bool) -> str:
    return f"[{_fmt_deviation(lo, relative)}, {_fmt_deviation(hi, relative)}]"


def evaluate(check: Check, summary: dict, *, quick: bool = False) -> dict:
    """The table row of ``check`` against a run's summary: value, deviation, verdict, explanation."""
    ref = _lookup(summary, check.reference) if isinstance(check.reference, str) else check.reference
    value = _lookup(summary, check.quantity) if summary.get("status") == "completed" else None
    bounds = check.bounds(quick)
    row = {"quantity": check.quantity, "kind": check.kind, "reference": ref, "source": check.source,
           "value": value, "tolerance": check.tolerance, "relative": check.relative,
           "tolerance_source": check.tolerance_source, "flags": list(check.run_flags(quick)), "deviation": None,
           "gap_bounds": None if bounds is None else list(bounds), "gap_source": check.gap_source}
    if not isinstance(value, int | float) or not isinstance(ref, int | float) or not math.isfinite(value):
        row["verdict"] = "fail"
        row["explanation"] = f"no value (run {summary.get('status')}: {summary.get('message', '')})".strip()
        return row
    deviation = (value - ref) / abs(ref) if check.relative else value - ref
    row["deviation"] = deviation
    dev = _fmt_deviation(deviation, check.relative)
    tol = f"±{100 * check.tolerance:.3g} %" if check.relative else f"±{check.tolerance:.3g}"
    if abs(deviation) <= check.tolerance:
        row["verdict"] = "match"
        row["explanation"] = f"{value:.4g} is {dev} from {ref:.4g}, inside {tol}"
        if bounds is not None:
            row["explanation"] += f"; the documented gap {_fmt_band(*bounds, check.relative)} has closed"
    elif bounds is not None and bounds[0] <= deviation <= bounds[1]:
        row["verdict"] = "known-gap"
        row["explanation"] = (f"{check.known_gap}: {value:.4g} is {dev} from {ref:.4g}, outside {tol} but inside "
                              f"the documented gap {_fmt_band(*bounds, check.relative)} ({check.gap_source})")
    else:
        row["verdict"] = "fail"
        beyond = f" and beyond the documented gap {_fmt_band(*bounds, check.relative)}" if bounds else ""
        row["explanation"] = f"{value:.4g} is {dev} from {ref:.4g}: outside {tol}{beyond}"
    return row


def ensemble_summary(check: Check, summaries: list[dict]) -> dict:
    """One summary standing for several starts of a case: the median of ``check.quantity`` over the
    starts that completed with a value (None if fewer than half did), the reference from the first,
    and ``starts`` (the number of starts), ``start_values`` (each start's value, None where it gave
    none), ``start_spread`` ([min, max] of the values) and ``wall_seconds`` (the starts' wall times
    summed, a batch's once for all its starts)."""
    values = []
    for s in summaries:
        v = _lookup(s, check.quantity) if s.get("status") == "completed" else None
        values.append(float(v) if isinstance(v, int | float) and math.isfinite(v) else None)
    have = sorted(v for v in values if v is not None)
    median = None
    if 2 * len(have) > len(values):
        mid = len(have) // 2
        median = have[mid] if len(have) % 2 else 0.5 * (have[mid - 1] + have[mid])
    out: dict = {"status": "completed" if median is not None else "error",
                 "message": "" if median is not None else f"{len(values) - len(have)} of {len(values)} starts "
                                                            "gave no value"}
    if isinstance(check.reference, str):
        node, ref = out, _lookup(summaries[0], check.reference)
        *parents, leaf = check.reference.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = ref
    node = out
    *parents, leaf = check.quantity.split(".")
    for part in parents:
        node = node.setdefault(part, {})
    node[leaf] = median
    for key in ("device", "particles"):
        out[key] = summaries[0].get(key)
    # (the starts of one batch share its wall time: counted once per batch)
    walls = {(s["batch"], s.get("wall_seconds")) if s.get("batch") else (k, s.get("wall_seconds"))
             for k, s in enumerate(summaries)}
    out["wall_seconds"] = sum(w or 0.0 for _, w in walls)
    out["start_values"] = values
    out["start_spread"] = [have[0], have[-1]] if have else None
    return out


def convergence(ladder: list[dict], flags: list[list[str]]) -> dict:
    """The values and deviations of one check at resolutions coarsest → finest, and whether the
    deviation's size shrinks from the coarsest to the finest (None where a run gave no value)."""
    steps = [{"flags": f, "value": r["value"], "deviation": r["deviation"]} for r, f in zip(ladder, flags, strict=True)]
    ends = [steps[0]["deviation"], steps[-1]["deviation"]]
    shrinks = None if None in ends else abs(ends[1]) < abs(ends[0])
    return {"convergence": steps, "deviation_shrinks": shrinks}


def collect_checks(cases: list[str] | None = None) -> dict[str, list[Check]]:
    """Case name → its checks, for every registered case that declares VALIDATION."""
    from .case import case_module, case_names

    out = {}
    for name in cases or list(case_names()):
        checks = getattr(case_module(name), "VALIDATION", None)
        if checks:
            out[name] = list(checks)
    return out


def check_identity(case: str, check: Check, *, quick: bool = False) -> dict:
    """What makes a row the row of this check: case, quantity, run flags, reference (a number, or the
    summary key of a computed one), sources, tolerance, kind and the documented gap's range."""
    return {"case": case, "quantity": check.quantity, "kind": check.kind, "flags": list(check.run_flags(quick)),
            "reference": check.reference if isinstance(check.reference, int | float) else None,
            "source": check.source, "tolerance": check.tolerance, "relative": check.relative,
            "tolerance_source": check.tolerance_source,
            "gap_bounds": None if check.bounds(quick) is None else list(check.bounds(quick)),
            "starts": 1 if quick else check.starts}


def row_identity(row: dict, computed_reference: bool = False) -> dict:
    """``check_identity`` read back from a table row (a computed reference reads as None)."""
    ident = {k: row.get(k) for k in ("case", "quantity", "kind", "flags", "reference", "source", "tolerance",
                                     "relative", "tolerance_source", "gap_bounds")}
    ident["starts"] = row.get("starts", 1)
    if computed_reference:
        ident["reference"] = None
    return ident


def table_differences(table: dict, checks: dict[str, list[Check]]) -> list[str]:
    """How a validation table (validation.json's content) differs from the declared checks: one line
    per missing, extra or changed row, in order; empty when its rows are exactly those checks."""
    quick = bool(table.get("quick"))
    want = [check_identity(case, c, quick=quick) for case, cs in checks.items() for c in cs]
    computed = [not isinstance(c.reference, int | float) for cs in checks.values() for c in cs]
    rows = table.get("rows", [])
    out = []
    if len(rows) != len(want):
        out.append(f"{len(rows)} rows in the table, {len(want)} declared checks")
    for k, (w, r) in enumerate(zip(want, rows, strict=False)):
        got = row_identity(r, computed[k])
        diff = {key: (got.get(key), w[key]) for key in w if got.get(key) != w[key]}
        if diff:
            out.append(f"row {k} ({w['case']} {w['quantity']}): " +
                       "; ".join(f"{key}: table {a!r}, declared {b!r}" for key, (a, b) in diff.items()))
    for key in ("commit", "device"):
        if not table.get(key):
            out.append(f"the table names no {key}")
    return out


def head_commit(repo: Path | None = None) -> str | None:
    """The environment's MPMDEM_COMMIT when set (a copy of the tree on another machine, whose .git,
    if any, may be stale); else the short hash of the checkout's HEAD (``repo``, else the checkout
    that holds this package, else the working directory's), with "+dirty" where tracked files differ
    from it; None outside a git checkout."""
    import os

    if os.environ.get("MPMDEM_COMMIT"):
        return os.environ["MPMDEM_COMMIT"]
    if repo is None:
        # a source checkout holds the package; an installed package does not, and then the checkout
        # it was installed from is the working directory (CI, the README's commands) or above it
        here = Path.cwd().resolve()
        candidates = [Path(__file__).resolve().parents[2], here, *here.parents]
        repo = next((c for c in candidates if (c / ".git").exists()), None)
        if repo is None:
            return None
    repo = Path(repo)
    if not (repo / ".git").exists():
        return None
    try:
        sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=repo, capture_output=True, text=True,
                             timeout=30, check=True).stdout.strip()
        dirty = subprocess.run(["git", "diff", "--quiet", "HEAD", "--"], cwd=repo, capture_output=True,
                               timeout=30).returncode != 0
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{sha}+dirty" if dirty else sha


def _on_gpu(device: str | None) -> bool:
    """Whether runs on ``device`` (None: the runs' default, a GPU where there is one) go to a GPU."""
    if device is not None:
        return str(device).startswith("cuda")
    import warp as wp

    return wp.get_cuda_device_count() > 0


def run_validation(out: Path, *, device: str | None = None, quick: bool = False, cases: list[str] | None = None,
                   summary_source: Callable[[str, tuple[str, ...]], dict | None] | None = None,
                   resume: bool = False, batch_starts: bool | None = None) -> list[dict]:
    """Run every declared case (once per distinct flags) and evaluate its checks; writes
    OUT/validation.json and OUT/validation.md and returns the rows.

    ``summary_source(case, flags)``, where given, may hand back the summary of a run with exactly
    those flags made elsewhere (the test suite shares its quick runs this way); None runs the case.
    ``resume``: a run whose completed summary.json is already in OUT/runs (a call cut short by a time
    limit) is read, not run again; only for the same code, so it is off unless asked for.
    ``batch_starts``: run the starts of an ensemble check as batched simulations, as a study does
    (``batch_worker.execute_batch``: one batch per batch key, each world written as its lone run);
    None: on a GPU.
    """
    from .runner import case_module, run_case

    out = Path(out)
    rows = []
    runs: dict[tuple, dict] = {}
    commit = head_commit()
    if batch_starts is None:
        batch_starts = _on_gpu(device)

    def folder_of(name: str, flags: tuple[str, ...]) -> Path:
        return out / "runs" / "_".join([name, *(f.strip("-") for f in flags)]).replace("/", "-")

    def run_starts(name: str, flag_sets: list[tuple[str, ...]]) -> None:
        """Run, as batches, the starts among ``flag_sets`` not run (or given, or resumed) yet."""
        todo = [f for f in flag_sets if (name, f) not in runs
                and (summary_source is None or summary_source(name, f) is None)
                and not (resume and _completed(folder_of(name, f)))]
        if len(todo) < 2:
            return
        from .batch_worker import execute_batch
        from .study import Run

        extra = ("--device", device) if device else ()
        execute_batch(name, [Run(folder_of(name, f).name, {}, (*f, *extra)) for f in todo], str(out), device)
        for f in todo:
            path = folder_of(name, f) / "summary.json"
            runs[name, f] = json.loads(path.read_text()) if path.is_file() else {"status": "error"}

    def summary_of(name: str, flags: tuple[str, ...]) -> dict:
        """The summary of case ``name`` run with ``flags`` (run once per distinct flags)."""
        if (name, flags) not in runs:
            given = summary_source(name, flags) if summary_source else None
            if given is not None:
                runs[name, flags] = given
                return given
            folder = folder_of(name, flags)
            done = folder / "summary.json"
            if resume and done.is_file() and json.loads(done.read_text()).get("status") == "completed":
                runs[name, flags] = json.loads(done.read_text())
                return runs[name, flags]
            argv = [*flags, "--out", str(folder), "--quiet"] + (["--device", device] if device else [])
            run_case(case_module(name), argv)
            path = folder / "summary.json"
            runs[name, flags] = json.loads(path.read_text()) if path.is_file() else {"status": "error"}
        return runs[name, flags]

    for name, checks in collect_checks(cases).items():
        for check in checks:
            flags = check.run_flags(quick)
            if check.starts > 1 and not quick:
                starts = [(*flags, check.start_flag, str(k)) for k in range(1, check.starts + 1)]
                if batch_starts:
                    run_starts(name, starts)
                summary = ensemble_summary(check, [summary_of(name, f) for f in starts])
            else:
                summary = summary_of(name, flags)
            row = {"case": name, **evaluate(check, summary, quick=quick), "commit": commit,
                   "device": summary.get("device"), "points": summary.get("particles"),
                   "wall_seconds": summary.get("wall_seconds"), "starts": 1 if quick else check.starts}
            if "start_values" in summary:
                row.update(start_values=summary["start_values"], start_spread=summary["start_spread"])
            if check.coarser and not quick:  # a quick table is a smoke run: no resolution trend
                ladder = [evaluate(check, summary_of(name, tuple(f))) for f in check.coarser] + [row]
                row.update(convergence(ladder, [list(f) for f in check.coarser] + [list(check.flags)]))
            rows.append(row)
    devices = sorted({str(r["device"]) for r in rows if r.get("device")})
    write_table(rows, out, quick=quick, commit=commit, device=", ".join(map(_device_name, devices)) or None)
    return rows


def _completed(folder: Path) -> bool:
    """Whether ``folder`` holds the summary.json of a completed run."""
    done = folder / "summary.json"
    return done.is_file() and json.loads(done.read_text()).get("status") == "completed"


def _device_name(device: str) -> str:
    """A Warp device with the card's name where Warp knows it ("cuda:0 (NVIDIA H100 80GB HBM3)")."""
    try:
        import warp as wp

        name = wp.get_device(device).name
    except Exception:  # noqa: BLE001 - a name is a nicety; the device string is the record
        return device
    return f"{device} ({name})" if name and name.lower() != device.lower() else device


def counts(rows: list[dict]) -> dict:
    """Checks, distinct cases and rows per verdict of a table's rows."""
    out = {"checks": len(rows), "cases": len({r["case"] for r in rows})}
    out.update({v: sum(r.get("verdict") == v for r in rows) for v in VERDICTS})
    return out


def write_table(rows: list[dict], out: Path, *, quick: bool = False, commit: str | None = None,
                device: str | None = None) -> None:
    """validation.json (every field) and validation.md (one line per check)."""
    out.mkdir(parents=True, exist_ok=True)
    table = {"quick": quick, "commit": commit, "device": device, "counts": counts(rows), "rows": rows}
    (out / "validation.json").write_text(json.dumps(table, indent=2, default=float) + "\n")

    def num(v):
        return "–" if v is None else f"{v:.4g}"

    def deviation(r):
        return "–" if r["deviation"] is None else _fmt_deviation(r["deviation"], r["relative"])

    def trend(r):
        if not r.get("convergence"):
            return "–"
        word = {True: "shrinks", False: "does not shrink", None: "–"}[r["deviation_shrinks"]]
        steps = " → ".join(f"{' '.join(s['flags']) or 'default'}: {deviation({**r, **s})}" for s in r["convergence"])
        return f"{steps} ({word})"

    lines = ["| case | quantity | kind | reference (source) | ours | deviation | under refinement | "
             "tolerance (source) | verdict |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        tol = f"±{100 * r['tolerance']:.3g} %" if r["relative"] else f"±{r['tolerance']:.3g}"
        verdict = r["verdict"] + (f": {r['explanation']}" if r["verdict"] != "match" else "")
        flags = f" ({' '.join(r['flags'])})" if r["flags"] else ""
        if r.get("starts", 1) > 1:
            spread = r.get("start_spread")
            flags += f" [median of {r['starts']} starts" + (f", {spread[0]:.4g}-{spread[1]:.4g}]" if spread else "]")
        lines.append(f"| {r['case']}{flags} | {r['quantity']} | {r['kind']} | {num(r['reference'])} ({r['source']}) | "
                     f"{num(r['value'])} | {deviation(r)} | {trend(r)} | {tol} ({r['tolerance_source']}) | {verdict} |")
    c = counts(rows)
    head = "Validation table" + (" (quick sizes: a smoke run, not the validation resolution)" if quick else "")
    meta = (f"`mpmdem validate{' --quick' if quick else ''}` at commit {commit or 'unknown'} on {device or 'unknown'}: "
            f"{c['checks']} checks over {c['cases']} cases; {c['match']} match, {c['known-gap']} known gaps, "
            f"{c['fail']} fail.")
    (out / "validation.md").write_text(f"# {head}\n\n{meta}\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps([asdict(c) for cs in collect_checks().values() for c in cs], indent=1))
