"""Does the silo's discharge rate converge with the grid, and what sets its length? (issue: μ(I))

Runs: `silo-discharge` at D0 = 2 ... 6 cm on six grids (5 mm down to 1 mm), once with Table 3's
Drucker–Prager (``beverloo-refined``) and once with μ(I) (``beverloo-mu-i``), and the μ(I) silo at
one grid with four grain diameters (``beverloo-mu-i-grain``). Each run's summary.json gives
W [kg/(m s)]. This module computes, per material:

* per D0, W against h, and a Richardson extrapolation W∞: W(h) = W∞ + A h^p fitted on the four
  finest grids (p free in [0.25, 4]); its uncertainty is the larger of the fit's standard error and
  the distance from W∞ to the finest-grid W (the extrapolation is no better than the last step it
  extrapolates). The change over the last halving (2 mm → 1 mm) is the convergence figure.
* per grid (or per d), the 2D Beverloo form W^(2/3) = (C ρ sqrt(g))^(2/3) (D0 − D*): the
  intercept D* [m] and C from a straight line through W^(2/3), on the orifices at least ten cells
  wide (narrower ones are resolved by fewer than ten cells and carry the grid's own length).
  D* against h (a grid length) and against d (a grain length) is the question.

Charts: W(h) per D0 for both laws, and D* against h and against d.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .run_summaries import load_runs

#: the Beverloo line is fitted on orifices at least this many cells wide
MIN_CELLS_ACROSS = 10
#: the Richardson fit uses this many finest grids
RICHARDSON_GRIDS = 4
#: the continuum studies charted against the DEM silo: (law, study); a study not run is left out
LAWS_AGAINST_GRAINS = (("Drucker-Prager", "beverloo-refined"), ("mu(I)", "beverloo-mu-i"),
                       ("Drucker-Prager, phi of the grains", "beverloo-calibrated"),
                       ("mu(I) of the grains", "beverloo-mu-i-disks"))


def _rates(runs: list[dict], key: str) -> dict[tuple[float, float], float]:
    """{(D0, key value): W} over the completed runs with a rate."""
    out = {}
    for r in runs:
        if r.get("status") == "completed" and r.get("rate") is not None:
            out[(round(float(r["orifice_m"]), 6), round(float(r[key]), 7))] = float(r["rate"])
    return out


def richardson(h: np.ndarray, w: np.ndarray) -> dict:
    """W∞, the order p and their uncertainty from W(h) = W∞ + A h^p on the finest grids (see above)."""
    from scipy.optimize import curve_fit

    order = np.argsort(h)[:RICHARDSON_GRIDS]
    hh, ww = h[order], w[order]
    out = {"w_finest": float(ww[0]), "h_finest_m": float(hh[0])}
    if len(hh) < 3:
        return {**out, "w_inf": None, "w_inf_err": None, "order": None}
    scale = float(hh.max())
    try:
        p, cov = curve_fit(lambda x, a, b, q: a + b * (x / scale) ** q, hh, ww, p0=(ww[0], ww[-1] - ww[0], 1.0),
                           bounds=([-np.inf, -np.inf, 0.25], [np.inf, np.inf, 4.0]), maxfev=20000)
        err = float(np.sqrt(cov[0, 0])) if np.isfinite(cov[0, 0]) else math.inf
    except (RuntimeError, ValueError):
        return {**out, "w_inf": None, "w_inf_err": None, "order": None}
    return {**out, "w_inf": float(p[0]), "order": float(p[2]),
            "w_inf_err": max(err, abs(float(p[0]) - float(ww[0])))}


def beverloo_line(d0: np.ndarray, w: np.ndarray, density: float, gravity: float) -> dict:
    """Straight line through W^(2/3) against D0: the intercept D* [m] and C of W = C ρ sqrt(g) (D0 − D*)^(3/2),
    with their standard errors (from the line's residual scatter)."""
    y = w ** (2.0 / 3.0)
    if len(d0) < 3:
        return {"D_star_m": None, "C": None, "n": len(d0)}
    a = np.vstack([d0, np.ones_like(d0)]).T
    coef, res, *_ = np.linalg.lstsq(a, y, rcond=None)
    slope, icpt = coef
    dof = max(len(d0) - 2, 1)
    s2 = float(np.sum((a @ coef - y) ** 2)) / dof
    cov = s2 * np.linalg.inv(a.T @ a)
    d_star = -icpt / slope
    # error propagation of D* = −b/s
    g = np.array([icpt / slope**2, -1.0 / slope])
    d_star_err = float(np.sqrt(g @ cov @ g))
    c = slope**1.5 / (density * math.sqrt(gravity))
    c_err = 1.5 * slope**0.5 * math.sqrt(cov[0, 0]) / (density * math.sqrt(gravity))
    return {"D_star_m": float(d_star), "D_star_err_m": d_star_err, "C": float(c), "C_err": float(c_err),
            "n": len(d0), "orifices_m": [float(v) for v in d0]}


def analyze_refinement(runs: list[dict], density: float, gravity: float) -> dict:
    """Per D0 the Richardson W∞ and the last-halving change; per grid the Beverloo line."""
    rates = _rates(runs, "cell_size")
    orifices = sorted({d for d, _ in rates})
    grids = sorted({h for _, h in rates})
    per_orifice = {}
    for d in orifices:
        hs = np.array([h for h in grids if (d, h) in rates])
        ws = np.array([rates[(d, h)] for h in hs])
        entry = {"h_m": hs.tolist(), "rate": ws.tolist(), **richardson(hs, ws)}
        fine = [h for h in hs if any(abs(2.0 * h - g) < 1e-9 for g in hs)]
        if fine:
            h1 = min(fine)
            w1, w2 = rates[(d, h1)], rates[(d, round(2.0 * h1, 7))]
            entry["last_halving"] = {"h_m": [2.0 * h1, h1], "relative_change": (w1 - w2) / w1}
        per_orifice[f"{d:g}"] = entry
    per_grid = {}
    for h in grids:
        ds = np.array([d for d in orifices if (d, h) in rates and d >= MIN_CELLS_ACROSS * h - 1e-12])
        ws = np.array([rates[(d, h)] for d in ds])
        per_grid[f"{h:g}"] = beverloo_line(ds, ws, density, gravity) if len(ds) else {"n": 0}
    return {"per_orifice": per_orifice, "per_grid": per_grid, "min_cells_across": MIN_CELLS_ACROSS}


def analyze_grain(runs: list[dict], density: float, gravity: float) -> dict:
    """Per grain diameter d (one grid), the Beverloo line: does D* follow d?"""
    rates = _rates(runs, "grain_diameter_m")
    per_d = {}
    for dg in sorted({g for _, g in rates}):
        h = {float(r["cell_size"]) for r in runs if r.get("grain_diameter_m") is not None}
        hmin = min(h) if h else 0.0
        ds = np.array(sorted(d for d, g in rates if g == dg and d >= MIN_CELLS_ACROSS * hmin - 1e-12))
        ws = np.array([rates[(d, dg)] for d in ds])
        line = beverloo_line(ds, ws, density, gravity)
        if line.get("D_star_m") is not None:
            line["k_over_radius"] = line["D_star_m"] / (0.5 * dg)
        per_d[f"{dg:g}"] = {**line, "rate": dict(zip([f"{d:g}" for d in ds], ws.tolist(), strict=True))}
    ks = [(float(k), v["D_star_m"]) for k, v in per_d.items() if v.get("D_star_m") is not None]
    slope = None
    if len(ks) >= 2:
        x, y = np.array(ks).T
        slope = float(np.polyfit(x, y, 1)[0])  # dD*/dd: 0 if d sets no length, ~k/2 if it sets it
    return {"per_grain_diameter": per_d, "d_star_slope_per_d": slope}


def analyze_dem(runs: list[dict], density: float, gravity: float) -> dict:
    """Per grain radius r_p (the DEM silos, ``--sand dem``), the Beverloo line on every orifice: C and
    D*, and k = D*/r_p to set beside the seed's k = 2.2."""
    per_r = {}
    for r_p in sorted({float(r["flags"]["grain-radius"]) for r in runs if "grain-radius" in r.get("flags", {})}):
        done = sorted((float(r["orifice_m"]), float(r["rate"])) for r in runs
                      if r.get("status") == "completed" and r.get("rate") is not None
                      and float(r["flags"].get("grain-radius", "nan")) == r_p)
        if not done:
            continue
        d0, w = (np.array(v) for v in zip(*done, strict=True))
        line = beverloo_line(d0, w, density, gravity)
        if line.get("D_star_m") is not None:
            line["k_over_radius"] = line["D_star_m"] / r_p
        per_r[f"{r_p:g}"] = {**line, "rate": dict(zip([f"{d:g}" for d in d0], w.tolist(), strict=True))}
    return {"per_grain_radius": per_r}


def write(result: dict, out: Path, name: str) -> None:
    (Path(out) / f"{name}.json").write_text(json.dumps(result, indent=1))


def chart_rates(results: dict[str, dict], path: Path, grains: dict | None = None) -> None:
    """W against h per D0, one panel per law (``results``: law name → ``analyze_refinement``); the
    DEM silos' W (``analyze_dem``) as horizontal lines, dashed for r_p = 1 mm, dotted for 0.5 mm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(5.5 * len(results), 4.2), squeeze=False, sharey=True)
    for ax, (law, res) in zip(axes[0], results.items(), strict=True):
        for i, (d, e) in enumerate(res["per_orifice"].items()):
            ax.plot(np.array(e["h_m"]) * 1e3, e["rate"], "o-", color=f"C{i}", label=f"D0 = {float(d) * 100:g} cm")
            if e.get("w_inf") is not None:
                ax.errorbar([0.0], [e["w_inf"]], yerr=[e["w_inf_err"]], fmt="s", color=f"C{i}", capsize=3)
            for style, r_p in (("--", "0.001"), (":", "0.0005")):
                w = ((grains or {}).get("per_grain_radius", {}).get(r_p, {}).get("rate", {})).get(d)
                if w is not None:
                    ax.axhline(w, color=f"C{i}", ls=style, lw=0.8)
        ax.set_xlabel("cell size h [mm]")
        ax.set_title(law)
        ax.set_xlim(left=-0.3)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("discharge rate W [kg/(m s)]")
    axes[0][-1].legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    fig.suptitle("squares at h = 0: Richardson W∞;\nhorizontal lines: DEM grains, r_p = 1 mm (dashed) and "
                 "0.5 mm (dotted)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def chart_intercepts(results: dict[str, dict], grain: dict | None, path: Path) -> None:
    """D* of the Beverloo line against h per law, and against d for μ(I) (if run)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2 if grain else 1, figsize=(11 if grain else 5.5, 4.2), squeeze=False)
    ax = axes[0][0]
    for i, (law, res) in enumerate(results.items()):
        pts = [(float(h), v["D_star_m"], v["D_star_err_m"]) for h, v in res["per_grid"].items()
               if v.get("D_star_m") is not None]
        if pts:
            h, ds, err = np.array(pts).T
            ax.errorbar(h * 1e3, ds * 1e3, yerr=err * 1e3, fmt="o-", color=f"C{i}", capsize=3, label=law)
    ax.set_xlabel("cell size h [mm]")
    ax.set_ylabel("Beverloo intercept D* [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if grain:
        ax = axes[0][1]
        pts = [(float(d), v["D_star_m"], v["D_star_err_m"]) for d, v in grain["per_grain_diameter"].items()
               if v.get("D_star_m") is not None]
        if pts:
            d, ds, err = np.array(pts).T
            ax.errorbar(d * 1e3, ds * 1e3, yerr=err * 1e3, fmt="o-", color="C1", capsize=3, label="μ(I), one grid")
        ax.set_xlabel("grain diameter d [mm]")
        ax.set_ylabel("Beverloo intercept D* [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def chart_work_accuracy(studies: Path, path: Path) -> dict:
    """Every continuum run's work (points × steps) against its deviation from the r_p = 1 mm DEM silo
    at the same D0, with the DEM runs' work (grains × steps): what the continuum saves, and at what
    accuracy. Work, not wall time: the runs shared a GPU twelve at a time, so their wall times are not
    their own. Returns the plotted rows."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dem = {round(float(r["orifice_m"]), 6): r for r in load_runs(studies / "beverloo-dem")
           if r.get("rate") is not None and r["flags"].get("grain-radius") == "0.001"}
    rows = []
    for law, name in LAWS_AGAINST_GRAINS:
        if not (studies / name).is_dir():
            continue
        for r in load_runs(studies / name):
            if r.get("rate") is None:  # (a run that failed has no rate, nor its geometry)
                continue
            ref = dem.get(round(float(r["orifice_m"]), 6))
            if ref is None:
                continue
            rows.append({"law": law, "orifice_m": r["orifice_m"], "cell_size": r["cell_size"],
                         "work": r["particles"] * r["steps"], "deviation": r["rate"] / ref["rate"] - 1.0})
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for i, (law, _) in enumerate(LAWS_AGAINST_GRAINS):
        sel = [x for x in rows if x["law"] == law]
        ax.scatter([x["work"] for x in sel], [100 * abs(x["deviation"]) for x in sel], color=f"C{i}", s=18,
                   label=f"{law} (5 orifices x grids)")
    work_dem = [r["grains"] * r["steps"] for r in dem.values()]
    for k, w in enumerate(work_dem):
        ax.axvline(w, color="k", ls=":", lw=0.8, label="DEM grains, r_p = 1 mm (the reference)" if k == 0 else None)
    ax.axhline(10.0, color="0.5", ls="--", lw=0.8, label="10 %")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("work of the run: points (or grains) x steps")
    ax.set_ylabel("|W / W_DEM - 1| [%]")
    ax.set_title("silo discharge: the continuum against the grains (H100 runs)", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return {"rows": rows, "dem_work": work_dem}


def against_grains(result: dict, grains: dict, radius: str = "0.001") -> dict:
    """Per D0, the continuum's finest-grid W and its W∞ relative to the DEM silo's W at grain radius
    ``radius`` (``grains``: ``analyze_dem``): {D0: {"dem", "finest", "w_inf"}}, deviations as W / W_DEM − 1."""
    dem = grains.get("per_grain_radius", {}).get(radius, {}).get("rate", {})
    rows = {}
    for d, e in result["per_orifice"].items():
        ref = dem.get(d)
        if ref is None:
            continue
        rows[d] = {"dem": ref, "finest": e["rate"][int(np.argmin(e["h_m"]))] / ref - 1.0,
                   "w_inf": None if e.get("w_inf") is None else e["w_inf"] / ref - 1.0}
    return rows


def analyze_study(out: Path, name: str, density: float, gravity: float) -> dict:
    """The ``analyze`` of the refinement studies: fits into OUT/<name>.json and a W(h) chart, with the DEM
    silo (a ``beverloo-dem`` study beside OUT, if there is one) drawn and compared per D0."""
    result = analyze_refinement(load_runs(out), density, gravity)
    dem_study = Path(out).parent / "beverloo-dem"
    grains = analyze_dem(load_runs(dem_study), density, gravity) if (dem_study / "runs").is_dir() else None
    if grains:
        result["against_grains_r1mm"] = against_grains(result, grains)
    write(result, out, name)
    chart_rates({name: result}, Path(out) / f"{name}_rate_vs_h.png", grains)
    chart_intercepts({name: result}, None, Path(out) / f"{name}_intercept.png")
    return result


def compare(studies: Path, out: Path) -> dict:
    """The committed refinement studies side by side (``studies``: bench/results/studies): W(h) of
    Drucker–Prager and μ(I), D* against h and d, with the DEM silos beside them; writes
    ``refinement_summary.json`` and the two charts into ``out``."""
    from ..references.table3 import DENSITY, GRAVITY

    studies, out = Path(studies), Path(out)
    laws = {"Drucker-Prager (Table 3)": "beverloo-refined", "mu(I), d = 2 mm": "beverloo-mu-i",
            "Drucker-Prager, phi of the grains": "beverloo-calibrated", "mu(I) of the grains": "beverloo-mu-i-disks"}
    results = {law: analyze_refinement(load_runs(studies / name), DENSITY, GRAVITY) for law, name in laws.items()
               if (studies / name).is_dir()}
    grain = analyze_grain(load_runs(studies / "beverloo-mu-i-grain"), DENSITY, GRAVITY)
    dem = {}
    for path in sorted((studies / "beverloo-dem").glob("silo_dem_*.json")):
        s = json.loads(path.read_text())
        dem[path.stem] = {k: s.get(k) for k in ("grains", "orifice_m", "width_m", "fill_height_m", "rate", "steps",
                                                   "wall_seconds", "dt", "device", "rate_over_paper", "end_time")}
    grains = analyze_dem(load_runs(studies / "beverloo-dem"), DENSITY, GRAVITY)
    out.mkdir(parents=True, exist_ok=True)
    chart_rates(results, out / "refinement_rate_vs_h.png", grains)
    chart_intercepts(results, grain, out / "refinement_intercept.png")
    work = chart_work_accuracy(studies, out / "refinement_work_vs_grains.png")
    summary = {"laws": results, "grain_diameter": grain, "dem": dem, "dem_study": grains, "work_accuracy": work}
    (out / "refinement_summary.json").write_text(json.dumps(summary, indent=1))
    return summary


if __name__ == "__main__":
    import sys

    compare(Path(sys.argv[1]), Path(sys.argv[2]))
