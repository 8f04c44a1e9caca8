"""Granular-matrix study (MPM-SDEM §7, Fig. 23): force–settlement and apparent modulus per fines content.

Runs cases/granular_matrix.py (through ``mpmdem.study.runner.run_case``, in this process) for every fines
content of the study (``--fines``, default 0, 0.1, 0.2, 0.3 of the void area) at the bar speed
``--bar-speed`` (default the case's 5 cm/s), and again at half that speed for the lowest and the
highest content (``--half-rate ends``; ``all`` or ``none``): the quasi-static check of the case's
header. The paper's finding to look for: more fines, a stiffer matrix (a larger modulus).

For each run it writes one JSON line to PREFIX.jsonl: the fines content (of the void area and of
the solid mass), the bar speed, points, pentagons, wall time, steps, the modulus [Pa] (least-squares
slope of σ = F / W against ε over the case's strain window after first contact), the force at the
end, the quasi-static figures (kinetic energy over the bar's work: at the end, its largest value in
the second half of the loading, and the mean kinetic energy after contact over the whole work) and
the curve (settlement [m], mean force [N/m], strain, stress [Pa]). A half-rate line also gets
``rate_curve_difference``: the RMS difference between its force–settlement curve and the
full-rate one (both interpolated on the settlements after both first contacts) over the RMS force
of the full-rate one, and ``rate_modulus_ratio`` (half-rate modulus / full-rate modulus).

PREFIX.png: left, force against settlement per fines content (half-rate runs dashed); right, the
modulus against the fines content (half-rate runs as open markers).

    python bench/granular_matrix.py --device cuda --out bench/results/granular_matrix/h200   # the study (H200)
    python bench/granular_matrix.py --quick --device cpu   # the quick size, about 15 s on 2 CPU cores

Each run's own files (HDF5, summary.json) go to results/<name>_runs/<label>/ (PREFIX_runs/<label>/
with --out). Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from mpmdem.cases import granular_matrix as case
from mpmdem.study.runner import run_case

ROOT = Path(__file__).resolve().parents[1]


def label(fines: float, speed: float) -> str:
    return f"fines{fines:g}_v{speed:g}"


def run_one(fines: float, speed: float, args, runs: Path) -> dict:
    """One run of the case; returns its summary.json (status "error" with the exit code if it failed)."""
    out = runs / label(fines, speed)
    argv = ["--fines", str(fines), "--bar-speed", str(speed), "--out", str(out), "--quiet"]
    if args.device:
        argv += ["--device", args.device]
    if args.quick:
        argv.append("--quick")
    argv += args.case_args
    t0 = time.perf_counter()
    code = run_case(case, argv, prog="bench/granular_matrix.py")
    path = out / "summary.json"
    summary = json.loads(path.read_text()) if path.exists() else {"status": "error"}
    summary["exit_code"] = code
    summary["bench_seconds"] = time.perf_counter() - t0
    return summary


def curve_difference(full: dict, half: dict) -> float | None:
    """RMS of (F_half − F_full) over the RMS of F_full on the settlements after both first contacts."""
    curves = []
    for s in (full, half):
        if s.get("contact_frame") is None:
            return None
        d = np.asarray(s["settlement_mid_m"], dtype=float)
        f = np.asarray(s["force_mean_n_per_m"], dtype=float)
        ok = np.isfinite(f) & (np.arange(len(f)) >= s["contact_frame"])
        curves.append((d[ok], f[ok]))
    lo = max(c[0][0] for c in curves)
    hi = min(c[0][-1] for c in curves)
    if not hi > lo:
        return None
    grid = np.linspace(lo, hi, 50)
    f_full, f_half = (np.interp(grid, d, f) for d, f in curves)
    rms = math.sqrt(float(np.mean(f_full**2)))
    return math.sqrt(float(np.mean((f_half - f_full) ** 2))) / rms if rms > 0 else None


KEYS = ("status", "exit_code", "device", "fines", "fines_void_fraction", "fines_mass_fraction", "bar_speed", "points",
        "pentagons", "cell_size", "steps", "wall_seconds", "bench_seconds", "modulus_pa", "modulus_strain_window",
        "contact_settlement_m", "sample_height_m", "force_final_n_per_m", "kinetic_over_work_final",
        "kinetic_over_work_max_late", "kinetic_mean_over_work", "deepest_overlap_final_m", "mass_max_relative_change",
        "settlement_mid_m", "force_mean_n_per_m", "strain", "stress_pa")


def line(summary: dict) -> dict:
    return {k: summary.get(k) for k in KEYS}


def chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    fines = sorted({r["fines"] for r in rows})
    colours = {f: plt.cm.viridis(i / max(1, len(fines) - 1)) for i, f in enumerate(fines)}
    fastest = max(r["bar_speed"] for r in rows)
    for r in rows:
        if r.get("settlement_mid_m") is None:
            continue
        d = 100.0 * np.asarray(r["settlement_mid_m"], dtype=float)
        f = 1e-3 * np.asarray(r["force_mean_n_per_m"], dtype=float)
        full = r["bar_speed"] == fastest
        ax.plot(d, f, "-" if full else "--", color=colours[r["fines"]],
                label=f"F = {r['fines']:g}" + ("" if full else f", v/2 = {100 * r['bar_speed']:g} cm/s"))
        if r.get("modulus_pa") is not None:
            bx.plot(r["fines"], 1e-3 * r["modulus_pa"], "o", color=colours[r["fines"]], mfc=None if full else "none",
                    ms=8)
    ax.set_xlabel("settlement of the bar [cm]")
    ax.set_ylabel("force on the bar [kN/m] (mean over a frame)")
    ax.set_title(f"force–settlement, bar at {100 * fastest:g} cm/s")
    ax.legend(fontsize=8)
    bx.set_xlabel("fines content F (fraction of the void area)")
    bx.set_ylabel("apparent modulus [kPa]")
    window = rows[0].get("modulus_strain_window") or case.MODULUS_STRAIN
    bx.set_title(f"σ–ε slope over ε = {100 * window[0]:g}–{100 * window[1]:g} % after contact")
    fig.suptitle("granular matrix, MPM-SDEM §7 (Fig. 23): open markers and dashes = half rate")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: the GPU if there is one)")
    p.add_argument("--quick", action="store_true", help="the case's --quick size (CI, a first look)")
    p.add_argument("--fines", default=",".join(map(str, case.FINES_STUDY)), help="comma-separated fines contents")
    p.add_argument("--bar-speed", type=float, default=case.BAR_SPEED, help="bar speed of the study [m/s]")
    p.add_argument("--half-rate", choices=("ends", "all", "none"), default="ends",
                   help="which contents run again at half the bar speed")
    p.add_argument("--out", default=None,
                   help="PREFIX of PREFIX.jsonl / PREFIX.png (default bench/results/granular_matrix/full, "
                        "quick with --quick)")
    p.add_argument("case_args", nargs="*", help="more flags for the case, after --")
    args = p.parse_args(argv)
    fines = [float(v) for v in args.fines.split(",") if v.strip()]
    name = "granular_matrix_quick" if args.quick else "granular_matrix"
    prefix = Path(args.out or ROOT / "bench" / "results" / "granular_matrix" / ("quick" if args.quick else "full"))
    prefix.parent.mkdir(parents=True, exist_ok=True)
    # the runs' own files (HDF5, summary.json, energy.csv): beside --out, else in the ignored results/
    runs = prefix.parent / f"{prefix.name}_runs" if args.out else ROOT / "results" / f"{name}_runs"
    half = {"ends": [min(fines), max(fines)], "all": fines, "none": []}[args.half_rate]
    jobs = [(f, args.bar_speed) for f in fines] + [(f, 0.5 * args.bar_speed) for f in dict.fromkeys(half)]
    rows, full = [], {}
    with open(prefix.with_suffix(".jsonl"), "w") as fh:
        for f, v in jobs:
            s = run_one(f, v, args, runs)
            if v == args.bar_speed:
                full[f] = s
            else:
                ref = full.get(f, {})
                s["rate_curve_difference"] = curve_difference(ref, s) if ref.get("status") == "completed" else None
                m0, m1 = ref.get("modulus_pa"), s.get("modulus_pa")
                s["rate_modulus_ratio"] = m1 / m0 if m0 and m1 else None
            row = line(s)
            for k in ("rate_curve_difference", "rate_modulus_ratio"):
                if k in s:
                    row[k] = s[k]
            rows.append(row)
            fh.write(json.dumps(row, default=float) + "\n")
            fh.flush()
            brief = {k: row[k] for k in ("fines", "bar_speed", "status", "points", "modulus_pa",
                                         "kinetic_mean_over_work", "wall_seconds")}
            brief.update({k: row[k] for k in ("rate_curve_difference", "rate_modulus_ratio") if k in row})
            print(json.dumps(brief, default=float), flush=True)
    chart(rows, prefix.with_suffix(".png"))
    print(f"wrote {prefix.with_suffix('.jsonl')} and {prefix.with_suffix('.png')}")
    return 0 if all(r["status"] == "completed" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
