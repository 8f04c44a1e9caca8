"""Column-collapse runout under refinement ("Motion integration" §5, `column-collapse`): aspect ratios
a = 0.5, 1, 2, 4, 8 at 10, 20, 40 and 80 cells across the column, against Lube et al. (2005).

The runout is the deposit's front (the edge of the continuous deposit, as the experiments read it),
the farthest point is kept beside it; the chart shows the finest grid with a resolution error bar
(its change from the next coarser grid) against the two coefficient sets quoted for Lube et al. and the
band between them (not their scatter: the papers were not read here), the coarser grids faint.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpmdem.study.study import Study

from ..references.lube2005 import lube_height, lube_runout, runout_band
from .run_summaries import load_runs


def analyze(rows: list[dict], out: Path) -> dict:
    """Writes OUT/column_collapse_runout.json and .png: per a and grid, the runout (front and
    farthest point) and the final height, normalised by L0, with Lube's fits."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    runs = [r for r in load_runs(out) if r.get("status") == "completed"]
    failed = [{"run": r["run"], "status": r.get("status"), "message": r.get("message", "")}
              for r in load_runs(out) if r.get("status") != "completed"]
    table = sorted(({"a": r["aspect_ratio"], "cells": r["cells_per_width"], "runout": r["normalized_runout"],
                     "runout_farthest_point": r["normalized_runout_farthest_point"],
                     "final_height": r["normalized_final_height"], "lube_runout": r["predicted_normalized_runout"],
                     "lube_height": r["predicted_normalized_final_height"], "wall_seconds": r.get("wall_seconds"),
                     "points": r.get("particles")} for r in runs), key=lambda x: (x["a"], x["cells"]))
    (out / "column_collapse_runout.json").write_text(json.dumps({"runs": table, "failed": failed}, indent=2) + "\n")

    cells = sorted({x["cells"] for x in table})
    ratios = sorted({x["a"] for x in table})
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    aa = np.geomspace(0.4, 10, 200)
    band = np.array([runout_band(v) for v in aa])
    ax.plot(aa, [lube_runout(v, "A") for v in aa], "k--", lw=1, label="Lube et al. 2005, set A (1.2 a, 1.9 a^2/3)")
    ax.plot(aa, [lube_runout(v, "B") for v in aa], "k:", lw=1, label="set B (1.6 a, 2.2 a^2/3)")
    ax.fill_between(aa, band[:, 0], band[:, 1], color="0.85", zorder=0,
                    label="between the sets (the papers not read: not their scatter)")
    ax2.plot(aa, [lube_height(v) for v in aa], "k--", lw=1, label="Lube et al. 2005")
    for j, c in enumerate(cells[:-1]):  # the coarser grids, faint
        sel = [x for x in table if x["cells"] == c]
        shift = 1.0 + 0.03 * (j - 0.5 * (len(cells) - 1))
        col = plt.cm.viridis(0.15 + 0.7 * j / max(len(cells) - 1, 1))
        ax.plot([x["a"] * shift for x in sel], [x["runout"] for x in sel], "os^D"[j % 4], color=col, alpha=0.45,
                ms=4, label=f"front, {c} cells across")
        ax2.plot([x["a"] * shift for x in sel], [x["final_height"] for x in sel], "os^D"[j % 4], color=col,
                 alpha=0.45, ms=4, label=f"{c} cells across")
    # the finest grid with a resolution error bar: its change from the next coarser grid (the
    # front converges, so that change bounds the finest grid's own error)
    if len(cells) >= 2:
        fine, prev = cells[-1], cells[-2]
        for key, axis in (("runout", ax), ("final_height", ax2)):
            pts = []
            for a in ratios:
                f = [x[key] for x in table if x["a"] == a and x["cells"] == fine]
                p = [x[key] for x in table if x["a"] == a and x["cells"] == prev]
                if f and p:
                    pts.append((a, f[0], abs(f[0] - p[0])))
            if pts:
                axis.errorbar([q[0] for q in pts], [q[1] for q in pts], yerr=[q[2] for q in pts], fmt="D",
                              color="crimson", ms=6, capsize=4, lw=1.5, zorder=5,
                              label=f"{fine} cells; bar: change from {prev}")
        far = [x for x in table if x["cells"] == fine]
        ax.plot([x["a"] for x in far], [x["runout_farthest_point"] for x in far], "D", color="crimson", mfc="none",
                alpha=0.5, label=f"farthest point, {fine} cells")
    for a_, lab in ((ax, "(L_f − L0) / L0"), (ax2, "H_f / L0")):
        a_.set(xscale="log", yscale="log", xlabel="aspect ratio a", ylabel=lab)
        a_.grid(alpha=0.3, which="both")
        a_.legend(fontsize=7)
    ax.set_title("runout: deposit front, finest grid with resolution error bars", fontsize=10)
    ax2.set_title("final height at the wall", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "column_collapse_runout.png", dpi=120)
    plt.close(fig)
    return {"runs": table}


STUDY = Study(
    name="column-collapse",
    case="column-collapse",
    description="column-collapse runout and final height at a = 0.5-8 and four grids vs Lube et al. (2005)",
    grid={"--aspect-ratio": [0.5, 1.0, 2.0, 4.0, 8.0], "--cells-per-width": [10, 20, 40, 80]},
    analyze=analyze,
)


#: the same sweep with μ(I) (glass-bead friction law, d = 1 mm) on the three finer grids
MU_I = Study(
    name="column-collapse-mu-i",
    case="column-collapse",
    description="column collapse with mu(I): runout and final height vs a at 20, 40 and 80 cells across",
    grid={"--aspect-ratio": [0.5, 1.0, 2.0, 4.0, 8.0], "--cells-per-width": [20, 40, 80]},
    fixed={"--material": "mu-i"},
    analyze=analyze,
)


def analyze_disks(rows: list[dict], out: Path) -> dict:
    """The μ(I) columns with our disks' incline-fitted law against the DEM disk columns (r_p = 1 mm,
    ``column-collapse-dem`` beside OUT): per run the runout and final height and their deviation from
    the grains' at the same a; OUT/column_mu_i_disks.json and a chart of both against a."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .collapse_against_grains import grain_reference

    out = Path(out)
    dem_dir = out.parent / "column-collapse-dem"
    ref = grain_reference(out.parent, "disks") if (dem_dir / "runs").is_dir() else {}
    result = {"reference": "column-collapse-dem, sphero-disks r_p = 1 mm (rough floor of glued grains)",
              "grains": {f"{a:g}": r for a, r in sorted(ref.items())}, "runs": []}
    for r in load_runs(out):
        if r.get("status") != "completed":
            continue
        a = float(r["aspect_ratio"])
        row = {"a": a, "cells": r["cells_per_width"], "runout": r["normalized_runout"],
               "final_height": r["normalized_final_height"], "work": r["particles"] * r["steps"],
               "wall_seconds": r.get("wall_seconds")}
        if a in ref:
            row["runout_deviation"] = row["runout"] / ref[a]["runout"] - 1.0
            row["final_height_deviation"] = row["final_height"] / ref[a]["final_height"] - 1.0
        result["runs"].append(row)
    result["runs"].sort(key=lambda x: (x["cells"], x["a"]))
    (out / "column_mu_i_disks.json").write_text(json.dumps(result, indent=1))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, label in ((axes[0], "runout", "(L_f - L0) / L0"), (axes[1], "final_height", "H_f / L0")):
        if ref:
            xs = sorted(ref)
            ax.plot(xs, [ref[a][key] for a in xs], "ks-", label="DEM disks, r_p = 1 mm")
        for i, cells in enumerate(sorted({x["cells"] for x in result["runs"]})):
            sel = [x for x in result["runs"] if x["cells"] == cells]
            ax.plot([x["a"] for x in sel], [x[key] for x in sel], "o--", color=f"C{i}",
                    label=f"mu(I) of the disks, {cells} cells")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks([0.5, 1.0, 2.0, 4.0, 8.0], ["0.5", "1", "2", "4", "8"])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("aspect ratio a")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=8)
    fig.suptitle("column collapse: mu(I) fitted on the disks' incline flows against the disks themselves", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "column_mu_i_disks.png", dpi=120)
    plt.close(fig)
    return result


MU_I_DISKS = Study(
    name="column-collapse-mu-i-disks",
    case="column-collapse",
    description="column collapse with mu(I) fitted on our DEM disks' incline flows (grain-incline), against the DEM "
                "disk columns (column-collapse-dem, r_p = 1 mm)",
    grid={"--aspect-ratio": [0.5, 1.0, 2.0, 4.0, 8.0], "--cells-per-width": [20, 40]},
    # the disks' own μs, μ2, I0, d and ρs; a no-slip floor for the glued grains of the DEM's rough floor; the
    # DEM columns' box (3 × Lube's runout)
    fixed={"--material": "mu-i", "--mu-i-set": "dem-disks", "--floor": "fixed", "--box-runout": 3.0},
    analyze=analyze_disks,
)
