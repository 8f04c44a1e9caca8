"""The column collapse's continuum runs measured against DEM grains of the same column (issue 43 §4).

The reference is the grain run of the same aspect ratio a: by default the rounded pentagons of
``column-collapse-dem-polygon`` (r = 1 mm), whose angle of repose (30.2 ± 2.1°, the heap study,
``bench/results/studies/grain-calibration``) is the continuum's friction angle φ = 30°: the one
grain set the Mohr–Coulomb runs are calibrated against. The sphero-disks (angle of repose 18°) are a
second reference, drawn but not the target.

For every continuum run (``column-collapse``: Mohr–Coulomb, 10-80 cells across the column;
``column-collapse-mu-i``: μ(I), 20-80 cells) the deviation of its runout (L_f − L0)/L0 and of its
final height H_f/L0 from the grains', against its work (points × steps) and its wall time; the
grains' own work and wall time beside them. Wall times are those of the committed studies, runs
sharing one GPU (4-8 at a time), so read them as upper bounds; the work is the fair axis.

    python -m mpmdem.study.builtin.collapse_against_grains [STUDIES_DIR]

writes STUDIES_DIR/column-collapse-dem/against_grains.json and .png.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .run_summaries import load_runs

#: continuum studies and their labels
CONTINUA = {"column-collapse": "Mohr-Coulomb (phi = 30 deg)", "column-collapse-mu-i": "mu(I) (d = 1 mm)"}
#: the grain references: study folder, the runs' grain shape and radius [m]
REFERENCES = {"pentagons": ("column-collapse-dem-polygon", "polygon", 0.001),
              "disks": ("column-collapse-dem", "disk", 0.001)}
#: the issue's criterion: within 10 % of the grains
WITHIN = 0.10


def grain_reference(root: Path, name: str = "pentagons") -> dict[float, dict]:
    """Per aspect ratio a: the grain run's runout, final height, work (grains × steps) and wall time."""
    study, shape, radius = REFERENCES[name]
    out = {}
    for r in load_runs(root / study):
        if r.get("status") != "completed" or r.get("grain_shape") != shape or r.get("grain_radius_m") != radius:
            continue
        out[float(r["aspect_ratio"])] = {"runout": r["normalized_runout"], "final_height": r["normalized_final_height"],
                                         "work": r["grains"] * r["steps"], "wall_seconds": r.get("wall_seconds")}
    return out


def continuum_rows(root: Path, reference: dict[float, dict]) -> list[dict]:
    """Every completed continuum run at an aspect ratio the reference has, with its deviations."""
    rows = []
    for study, label in CONTINUA.items():
        for r in load_runs(root / study):
            a = float(r.get("aspect_ratio", r.get("aspect-ratio", 0.0)))
            if r.get("status") != "completed" or a not in reference:
                continue
            ref = reference[a]
            rows.append({"law": label, "a": a, "cells": r["cells_per_width"], "work": r["particles"] * r["steps"],
                         "wall_seconds": r.get("wall_seconds"),
                         "runout": r["normalized_runout"], "final_height": r["normalized_final_height"],
                         "runout_deviation": r["normalized_runout"] / ref["runout"] - 1.0,
                         "height_deviation": r["normalized_final_height"] / ref["final_height"] - 1.0})
    return sorted(rows, key=lambda x: (x["law"], x["a"], x["cells"]))


def cheapest_within(rows: list[dict], key: str = "runout_deviation") -> dict:
    """Per law and a: the least work of a run within WITHIN of the grains (None where none is)."""
    out: dict = {}
    for r in rows:
        best = out.setdefault(r["law"], {}).setdefault(f"{r['a']:g}", None)
        if abs(r[key]) <= WITHIN and (best is None or r["work"] < best["work"]):
            out[r["law"]][f"{r['a']:g}"] = {"cells": r["cells"], "work": r["work"], "deviation": r[key]}
    return out


def against_grains(root: Path) -> dict:
    """The comparison as one dict (written to column-collapse-dem/against_grains.json)."""
    reference = grain_reference(root)
    rows = continuum_rows(root, reference)
    return {"reference": "pentagons, r = 1 mm (column-collapse-dem-polygon); angle of repose 30.2 +- 2.1 deg",
            "grains": {f"{a:g}": v for a, v in sorted(reference.items())},
            "disks": {f"{a:g}": v for a, v in sorted(grain_reference(root, "disks").items())},
            "continuum": rows, "within": WITHIN,
            "cheapest_within_runout": cheapest_within(rows),
            "cheapest_within_height": cheapest_within(rows, "height_deviation")}


def plot(result: dict, path: Path) -> None:
    """Work against |deviation| from the grains, runout and final height, one marker per law."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    markers = dict(zip(CONTINUA.values(), ("s", "D"), strict=True))
    colours = {0.5: "tab:blue", 1.0: "tab:orange", 2.0: "tab:green", 4.0: "tab:red", 8.0: "tab:purple"}
    for ax, key, title in ((axes[0], "runout_deviation", "runout (L_f - L0)/L0"),
                           (axes[1], "height_deviation", "final height H_f/L0")):
        for r in result["continuum"]:
            ax.loglog(r["work"], max(abs(r[key]), 1e-3), markers[r["law"]], color=colours.get(r["a"], "k"),
                      mfc="none" if "mu" in r["law"] else colours.get(r["a"], "k"), ms=6)
        for a, g in result["grains"].items():
            ax.axvline(g["work"], color=colours.get(float(a), "k"), ls=":", lw=1)
        ax.axhline(WITHIN, color="k", ls="--", lw=0.8)
        ax.set_xlabel("work [points x steps, or grains x steps for the dotted lines]")
        ax.set_ylabel("|deviation from the pentagon grains|")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    for law, m in markers.items():
        axes[0].plot([], [], m, color="k", mfc="none" if "mu" in law else "k", label=law)
    for a, c in colours.items():
        axes[0].plot([], [], "o", color=c, label=f"a = {a:g}")
    axes[0].plot([], [], "k:", label="the grains' own work")
    axes[0].plot([], [], "k--", label="10 %")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    root = Path((argv or sys.argv[1:] or ["bench/results/studies"])[0])
    result = against_grains(root)
    out = root / "column-collapse-dem"
    (out / "against_grains.json").write_text(json.dumps(result, indent=1) + "\n")
    plot(result, out / "against_grains.png")
    for law, per_a in result["cheapest_within_runout"].items():
        print(law, {a: (v["cells"] if v else None) for a, v in per_a.items()})
    return 0


if __name__ == "__main__":
    sys.exit(main())
