"""The block-impact studies' analysis: event times against MPM-SDEM §6, block 2's orientation
history, and each run's wall time against its largest event-time error."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..cases.sand_blocks import T_PAPER


def label(run: dict) -> str:
    """What distinguishes a run: grid, friction set, rounding, coupling and MPM variant."""
    gran = "granular" if run.get("granular") else "plain MPM"
    return (f"h {1000 * run['cell_size']:.3g} mm, μ {run['friction_set']}, r {1000 * run['sphero_radius']:.3g} mm, "
            f"{run['coupling']}, {gran}")


def analyze(runs: list[dict], out: Path, title: str) -> dict:
    """Writes OUT/block_impact.json (events per run) and OUT/block_impact_orientation.png,
    OUT/block_impact_speed_accuracy.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    table = []
    for r in runs:
        row = {"run": r.get("run"), "status": r.get("status"), "message": r.get("message", ""),
               "wall_seconds": r.get("wall_seconds"), "points": r.get("points"), "steps": r.get("steps")}
        if r.get("status") == "completed":
            row.update(label=label(r), events_s=r["event_times_s"], errors_s=r["event_errors_s"],
                       max_error_s=r["event_error_max_s"], deepest_penetration_m=r["deepest_penetration_m"],
                       block2_final_orientation_deg=r["block2_final_orientation_deg"])
        table.append(row)
    report = {"paper_s": T_PAPER, "runs": table}
    (out / "block_impact.json").write_text(json.dumps(report, indent=2, default=float) + "\n")

    done = [r for r in runs if r.get("status") == "completed"]
    fig, (a2, a1) = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    colours = plt.cm.tab10(np.linspace(0, 1, 10))
    for k, r in enumerate(done):
        for ax, n in ((a2, "block2"), (a1, "block1")):
            ax.plot(r["times"], r[f"{n}_orientation_deg"], color=colours[k % 10], lw=1.2, label=label(r))
    for ax, n in ((a2, "block2"), (a1, "block1")):
        ax.axvline(T_PAPER["reach"], color="k", ls=":", lw=1, label="paper: sand reaches the blocks")
        ax.axvline(T_PAPER[f"{n}_ground"], color="k", ls="--", lw=1, label=f"paper: {n} lands")
        ax.axhline(0.0, color="grey", lw=0.5)
        ax.set(xlabel="t [s]", title=f"{n} ({'middle' if n == 'block2' else 'top'}): orientation, 90° upright")
        ax.grid(alpha=0.3)
    a2.set_ylabel("orientation [deg]")
    a2.legend(fontsize=6, loc="lower left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out / "block_impact_orientation.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, r in enumerate(runs):
        t = r.get("wall_seconds")
        if t is None:
            continue
        err = r.get("event_error_max_s") if r.get("status") == "completed" else None
        if err is None:
            ax.plot(t, 0.3, "x", color="red", ms=9)
            ax.annotate(str(r.get("status")), (t, 0.3), fontsize=6, color="red")
        else:
            ax.plot(t, max(err, 1e-3), "o", color=colours[k % 10], label=label(r))
    ax.axhline(0.025, color="k", ls=":", lw=1, label="the paper's reading resolution (±0.025 s)")
    ax.set(xscale="log", yscale="log", xlabel="wall time of the run [s]",
           ylabel="largest |event time − paper| [s]", title=f"{title}: speed × accuracy")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "block_impact_speed_accuracy.png", dpi=120)
    plt.close(fig)
    return report
