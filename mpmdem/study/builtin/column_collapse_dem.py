"""Column collapse with DEM grains (`column-collapse --sand dem`): the grains' runout and final height against
a = 0.5-8 at two grain sizes, on one chart with the continuum's (the committed `column-collapse` and
`column-collapse-mu-i` studies, their finest grid) and the experiments' formulas.

What was read of the experiments (the search corpora, November 2026): neither Lube et al. 2005 (PRE 72,
041301) nor Lajeunesse et al. 2005 (Phys. Fluids 17, 103302) is held in them, nor Staron & Hinch 2005
(JFM 545) beyond its abstract. Besides sets A and B of cases/column_collapse.py (its header), one
secondary source was read: K. Kumar's PhD thesis (Cambridge 2015, github.com/kks32/phd-thesis, LaTeX
source). What it states, none of it checked against the primary papers:

* Chapter2/chapter2.tex, §"Axisymmetric versus two-dimensional collapse": in a rectangular channel
  (the quasi-2D collapse, in the context of Lajeunesse et al. 2005) (L_f − L0)/L0 ≈ 1.2 a for a ≲ 2.3
  and 1.9 a^(2/3) for a ≳ 2.3: set A's prefactors with one split at 2.3 instead of 1.8 and 2.8. This
  is set C on the chart.
* the same chapter, earlier, beside a figure of plane-strain and axisymmetric data: 1.24 a (a ≲ 1.7),
  1.6 a^1.2 above, for Lube et al. 2005, and 1.35 a (a ≲ 0.74), 2.0 a^1.2 above, for Lajeunesse et al.
  2005. An exponent above 1 matches no quasi-2D description read here (2/3 above; 0.65-0.9 in
  Balmforth & Kerswell 2005's abstract), so these are not drawn.
* the final height in 2D: a for a ≲ 0.7, then a^(1/3) (chapter 2) or a^(2/3) (chapter 4): the two
  chapters disagree, so neither is drawn; Lube's a^(2/5) of the case is.
* Chapter4/chapter4.tex: its own 2D DEM runs (disks, randomly packed) give 1.67 a for a ≲ 2.7 and
  2.7 a^(2/3) above: a grain-scale simulation, not an experiment, drawn as such.

``STUDY``: a = 0.5, 1, 2, 4, 8 × r = 0.5 mm (d = 1 mm, the case's default and its μ(I) grain) and 1 mm
(the seed's r_p), L0 = 0.2 m (L0/d = 200 and 100). ``SEEDS``: a = 0.5 and 1 at r = 1 mm, five seeds of
the grains' sizes and places: the scatter of the deposit's flank angle and of the settled pack, for the
calibration (bench/grain_calibration.py). ``HEAP``: the angle of repose by the discharge method
(--floor ledge: the column's floor ends at the gate over a pit; the heap left on the ledge), a = 0.3,
five seeds at each grain size and shape (disks, rounded random pentagons). ``POLYGON``: the sweep of
``STUDY`` with pentagons at r = 1 mm.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpmdem.study.study import Study

from ..references.lube2005 import lube_height, lube_runout, runout_band
from .grain_calibration import analyze_heap
from .run_summaries import load_runs

#: the committed continuum studies the chart reads (repository-relative)
CONTINUUM = {"Mohr-Coulomb (phi = 30 deg)": "bench/results/studies/column-collapse/column_collapse_runout.json",
             "mu(I) (d = 1 mm)": "bench/results/studies/column-collapse-mu-i/column_collapse_runout.json"}
#: sweeps whose runs share a chart when they lie side by side (each study's own folder name)
SIBLINGS = ("column-collapse-dem", "column-collapse-dem-polygon")
#: drawn besides sets A and B (module docstring): (linear prefactor, upper a of the linear regime, power
#: prefactor, exponent), as the secondary source states them
RESTATED = {"set C: quasi-2D channel, Kumar 2015's restatement (1.2 a, 1.9 a^2/3, split 2.3)":
            (1.2, 2.3, 1.9, 2.0 / 3.0),
            "2D DEM disks of Kumar 2015, ch. 4 (1.67 a, 2.7 a^2/3)": (1.67, 2.7, 2.7, 2.0 / 3.0)}


def restated_runout(a: float, name: str) -> float:
    """(L_f − L0)/L0 of one of the ``RESTATED`` formulas at aspect ratio a."""
    k1, split, k2, n = RESTATED[name]
    return k1 * a if a <= split else k2 * a**n


def continuum_finest(path: Path) -> list[dict]:
    """Per aspect ratio, the finest grid's runout and final height of a committed continuum study
    (``column_collapse_runout.json``), with the change from the next coarser grid as its error."""
    runs = json.loads(Path(path).read_text())["runs"]
    out = []
    for a in sorted({r["a"] for r in runs}):
        at = sorted((r for r in runs if r["a"] == a), key=lambda r: r["cells"])
        fine = at[-1]
        prev = at[-2] if len(at) > 1 else None
        out.append({"a": a, "cells": fine["cells"], "runout": fine["runout"], "final_height": fine["final_height"],
                    "runout_error": abs(fine["runout"] - prev["runout"]) if prev else None,
                    "height_error": abs(fine["final_height"] - prev["final_height"]) if prev else None,
                    "wall_seconds": fine.get("wall_seconds")})
    return out


def grain_table(runs: list[dict]) -> list[dict]:
    """The completed grain runs as rows (a, grain radius, runouts, final height, flank angle, settled
    pack, cost)."""
    rows = []
    for r in runs:
        if r.get("status") != "completed":
            continue
        s = r.get("settled", {})
        rows.append({"run": r["run"], "a": r["aspect_ratio"], "settled_a": r.get("settled_aspect_ratio"),
                     "grain_radius_m": r["grain_radius_m"], "shape": r.get("grain_shape", "disk"),
                     "seed": r.get("seed"), "grains": r["grains"],
                     "width_in_diameters": r["width_in_diameters"], "runout": r["normalized_runout"],
                     "runout_connected": r["normalized_runout_connected"],
                     "runout_farthest_grain": r["normalized_runout_farthest_point"],
                     "final_height": r["normalized_final_height"], "flank_angle_deg": r["flank_angle_deg"],
                     "flank_angle_stderr_deg": r["flank_angle_stderr_deg"], "stop_time_normalized":
                     r["stop_time_normalized"], "reached_far_wall": r.get("reached_far_wall"),
                     "packing_fraction": s.get("packing_fraction"), "bulk_density": s.get("bulk_density"),
                     "coordination": s.get("coordination"), "settle_wall_seconds": s.get("wall_seconds"),
                     "wall_seconds": r.get("wall_seconds"), "steps": r.get("steps"), "device": r.get("device"),
                     "lube_band": r["reference_runout_band"]})
    return sorted(rows, key=lambda x: (x["shape"], x["grain_radius_m"], x["a"], x["seed"] or 0))


def analyze(rows: list[dict], out: Path, root: Path | None = None) -> dict:
    """Writes OUT/column_collapse_dem.json and .png: the grains' runout and final height against a per
    grain size, the continuum's finest grids (``CONTINUUM`` under ``root``, the repository by
    default) and the experiments' formulas (sets A, B and C: the module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    root = Path(root) if root is not None else Path(__file__).resolve().parents[3]
    runs = load_runs(out)
    # the sibling sweeps beside this one (disks and pentagons) go on the same chart
    for name in SIBLINGS:
        other = out.parent / name
        if other.resolve() != out.resolve() and (other / "runs").is_dir():
            runs += [r | {"run": f"{name}/{r['run']}"} for r in load_runs(other)]
    table = grain_table(runs)
    failed = [{"run": r["run"], "status": r.get("status"), "message": r.get("message", "")}
              for r in runs if r.get("status") != "completed"]
    continuum = {name: continuum_finest(root / p) for name, p in CONTINUUM.items() if (root / p).is_file()}
    result = {"grains": table, "failed": failed, "continuum": continuum,
              "experiments": {"sets A and B": "cases/column_collapse.py header (not read from the papers)",
                              "restated": {k: dict(zip(("linear", "linear_upper_a", "power", "exponent"), v,
                                                       strict=True)) for k, v in RESTATED.items()}}}
    (out / "column_collapse_dem.json").write_text(json.dumps(result, indent=2) + "\n")

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.8))
    aa = np.geomspace(0.4, 10, 200)
    band = np.array([runout_band(v) for v in aa])
    ax.fill_between(aa, band[:, 0], band[:, 1], color="0.85", zorder=0, label="Lube 2005, between sets A and B")
    ax.plot(aa, [lube_runout(v, "A") for v in aa], "k--", lw=1, label="set A (1.2 a, 1.9 a^2/3)")
    ax.plot(aa, [lube_runout(v, "B") for v in aa], "k:", lw=1, label="set B (1.6 a, 2.2 a^2/3)")
    for (name, style) in zip(RESTATED, ("-.", (0, (5, 1, 1, 1, 1, 1))), strict=True):
        ax.plot(aa, [restated_runout(v, name) for v in aa], color="0.4", ls=style, lw=1, label=name)
    ax2.plot(aa, [lube_height(v) for v in aa], "k--", lw=1, label="Lube 2005 as the case quotes it (a, a^2/5)")
    for (name, rows_c), colour in zip(continuum.items(), ("C2", "C4"), strict=False):
        for key, axis, err in (("runout", ax, "runout_error"), ("final_height", ax2, "height_error")):
            axis.errorbar([r["a"] for r in rows_c], [r[key] for r in rows_c], yerr=[r[err] or 0.0 for r in rows_c],
                          fmt="s", color=colour, mfc="none", capsize=3, label=f"MPM {name}, {rows_c[-1]['cells']} "
                          "cells (bar: change from the next grid)")
    kinds = sorted({(r["shape"], r["grain_radius_m"]) for r in table})
    for (shape, radius), colour in zip(kinds, ("C3", "C0", "C1", "C5", "C6", "C7"), strict=False):
        sel = [r for r in table if r["grain_radius_m"] == radius and r["shape"] == shape]
        d = 2e3 * radius
        for key, axis in (("runout", ax), ("final_height", ax2)):
            axis.plot([r["a"] for r in sel], [r[key] for r in sel], "o", color=colour,
                      mfc="none" if shape == "polygon" else None,
                      label=f"DEM {shape}s, d = {d:g} mm (L0/d = {sel[0]['width_in_diameters']:.0f})")
    for axis, label in ((ax, "(L_f − L0) / L0"), (ax2, "H_f / L0")):
        axis.set(xscale="log", yscale="log", xlabel="aspect ratio a", ylabel=label)
        axis.grid(alpha=0.3, which="both")
        axis.legend(fontsize=6)
    ax.set_title("runout: grains, continuum, experiments' formulas", fontsize=10)
    ax2.set_title("final height at the wall", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "column_collapse_dem.png", dpi=120)
    plt.close(fig)
    return result


STUDY = Study(
    name="column-collapse-dem",
    case="column-collapse",
    description="column collapse with DEM grains (sphero-disks, r = 0.5 and 1 mm) at a = 0.5-8: runout and final "
                "height against the continuum and the experiments",
    grid={"--aspect-ratio": [0.5, 1.0, 2.0, 4.0, 8.0], "--grain-radius": [0.0005, 0.001]},
    fixed={"--sand": "dem"},
    analyze=analyze,
)

HEAP = Study(
    name="column-collapse-dem-heap",
    case="column-collapse",
    description="the angle of repose of the DEM grains (disks and pentagons, r = 0.5 and 1 mm), five seeds each: a "
                "column with a = 0.3 behind a gate over a ledge; the heap left on the ledge (grain calibration)",
    grid={"--grain-shape": ["disk", "polygon"], "--grain-radius": [0.0005, 0.001], "--seed": [1, 2, 3, 4, 5]},
    fixed={"--sand": "dem", "--floor": "ledge", "--aspect-ratio": 0.3},
    analyze=analyze_heap,
)

POLYGON = Study(
    name="column-collapse-dem-polygon",
    case="column-collapse",
    description="column collapse with rounded random pentagons (r = 1 mm) at a = 0.5-8: runout and final height "
                "against the disks, the continuum and the experiments",
    grid={"--aspect-ratio": [0.5, 1.0, 2.0, 4.0, 8.0]},
    fixed={"--sand": "dem", "--grain-radius": 0.001, "--grain-shape": "polygon"},
    analyze=analyze,
)

SEEDS = Study(
    name="column-collapse-dem-seeds",
    case="column-collapse",
    description="column collapse with DEM grains (r = 1 mm) at a = 0.5 and 1, five seeds: the scatter of the "
                "deposit's flank angle and of the settled pack (grain calibration)",
    grid={"--aspect-ratio": [0.5, 1.0], "--seed": [1, 2, 3, 4, 5]},
    fixed={"--sand": "dem", "--grain-radius": 0.001},
    analyze=analyze,
)
