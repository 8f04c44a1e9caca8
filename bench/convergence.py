"""Spatial convergence of the axial-bar case for every shape function.

Runs the axial bar (first-mode vibration against the analytic centre-of-mass velocity, one
period, f64, APIC, USL) at several resolutions for each shape in ``mpmdem.SHAPE_FUNCTIONS``.
The error is ``centre_velocity_error_max`` of ``cases/axial_bar.py``: the largest deviation of
the centre-of-mass velocity from the analytic one over 40 frames, relative to its amplitude.
``seconds`` is the wall time of ``Simulation.run``; the first run of each shape also pays for
Warp's kernel compilation (or its cache load).

Prints one JSON line per run, then a table of the observed order log2(e_h / e_{h/2}) per
refinement; writes the lines to bench/results/convergence/cpu.jsonl (whatever the device) and a log-log plot of error
against h (one line per shape, a slope-2 guide) to ``--png``.

    python bench/convergence.py                      # cpu, cells 8,16,32,64
    python bench/convergence.py --device cuda --cells 16,32,64,128
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import mpmdem.cases.axial_bar as ab
from mpmdem import SHAPE_FUNCTIONS, Simulation, SolverConfig

RESULTS = Path(__file__).resolve().parent / "results"
FRAMES = 40


def run_one(shape: str, cells: int, device: str) -> dict:
    """One axial-bar run; returns shape, cells, h [m], error, wall seconds and steps."""
    args = SimpleNamespace(quick=False, cells=cells, periods=None)
    setup = ab.build(args)
    sim = Simulation(setup.scene, SolverConfig(shape=shape, transfer="APIC", update="USL", precision="f64"),
                     device=device)
    start = time.perf_counter()
    result = sim.run(setup.end_time, frames=FRAMES)
    seconds = time.perf_counter() - start
    error = ab.summarize(sim, result, args)["centre_velocity_error_max"]
    return dict(shape=shape, cells=cells, h=setup.scene.cell_size, error=error, seconds=seconds,
                steps=result.steps)


def order_table(rows: list[dict], cells: list[int]) -> str:
    """Text table: per shape, the error at each resolution and log2(e_h / e_{h/2})."""
    errors = {(r["shape"], r["cells"]): r["error"] for r in rows}
    shapes = list(dict.fromkeys(r["shape"] for r in rows))
    head = ["shape"] + [f"e({c})" for c in cells] + [f"p({a}->{b})" for a, b in zip(cells, cells[1:], strict=False)]
    lines = ["  ".join(f"{h:>12}" for h in head)]
    for s in shapes:
        e = [errors[(s, c)] for c in cells]
        orders = [math.log2(a / b) if a > 0 and b > 0 else float("nan") for a, b in zip(e, e[1:], strict=False)]
        lines.append("  ".join([f"{s:>12}"] + [f"{v:12.3e}" for v in e] + [f"{p:12.2f}" for p in orders]))
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> None:
    """Log-log error vs h, one line per shape, with a slope-2 guide just below the finest errors."""
    fig, ax = plt.subplots(figsize=(6.4, 4.8), constrained_layout=True)
    shapes = list(dict.fromkeys(r["shape"] for r in rows))
    # distinct markers and dashes keep lines that coincide (uGIMP and cpGIMP often do) visible
    styles = [("o", "-"), ("s", "--"), ("^", ":"), ("D", "-"), ("v", "--")]
    for k, s in enumerate(shapes):
        pts = sorted((r["h"], r["error"]) for r in rows if r["shape"] == s)
        marker, dashes = styles[k % len(styles)]
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker=marker, linestyle=dashes,
                  markerfacecolor="none", label=s)
    hs = sorted({r["h"] for r in rows})
    e_anchor = 0.5 * min(r["error"] for r in rows if r["h"] == hs[0])
    ax.loglog(hs, [e_anchor * (h / hs[0]) ** 2 for h in hs], "k-", lw=0.8, alpha=0.6, label="slope 2")
    ax.set_xlabel("cell size h [m]")
    ax.set_ylabel("max centre-of-mass velocity error / amplitude")
    ax.set_title("Axial bar, one period (APIC, USL, f64)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> None:
    """Parse the flags; run every shape at every resolution; print the table; save lines and plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N (default cpu)")
    parser.add_argument("--cells", default="8,16,32,64", help="comma-separated cells along the bar")
    parser.add_argument("--png", type=Path, default=RESULTS / "convergence" / "cpu.png", help="plot file")
    args = parser.parse_args(argv)
    cells = sorted(int(c) for c in args.cells.split(","))

    RESULTS.mkdir(parents=True, exist_ok=True)
    rows = []
    with (RESULTS / "convergence" / "cpu.jsonl").open("w") as out:
        for shape in SHAPE_FUNCTIONS:
            for c in cells:
                row = run_one(shape, c, args.device)
                rows.append(row)
                line = json.dumps(row)
                print(line, flush=True)
                out.write(line + "\n")
    print()
    print(order_table(rows, cells))
    plot(rows, args.png)
    print(f"\nplot: {args.png}")


if __name__ == "__main__":
    main()
