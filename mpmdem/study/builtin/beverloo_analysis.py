"""The Beverloo study's analysis: fits of the discharge rates of `silo-discharge` runs, and charts.

Every run folder holds the case's summary.json (W = ``rate`` [kg/(m s)], M(t), the orifice D0 and
the grid h). From the runs of the finest grid this fits

(a) the free power law W = A (D0 − D*)^β (a 2D silo: β = 3/2 by dimensional analysis, Mankoc et
    al. 2007), reporting β with its standard error;
(b) the paper's form W = C ρ sqrt(g) (D0 − k r_p)^(3/2) (MPM-SDEM Fig. 16) with C and k free, and C
    alone with the paper's k = 2.2, against the paper's C = 0.58, k = 2.2, r_p = 0.1 cm.

Standard errors come from the fit's covariance (the residual scatter), so with five orifices they
say how well the form holds, not the scatter of a laboratory silo.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..references.beverloo import BEVERLOO_C, BEVERLOO_K, ORIFICES_PAPER, beverloo
from ..references.table3 import DENSITY, GRAVITY, R_P_TABLE

PREFACTOR = DENSITY * math.sqrt(GRAVITY)  # ρ sqrt(g) [kg/(m³) m^0.5/s]


def fit_power_law(d0: np.ndarray, w: np.ndarray) -> dict:
    """W = A (D0 − D*)^β by least squares: A, D* [m], β and their standard errors."""
    from scipy.optimize import curve_fit

    def model(d, a, dstar, beta):
        return a * np.clip(d - dstar, 1e-9, None) ** beta

    p0 = (PREFACTOR * 0.6, 0.002, 1.5)
    lo, hi = [0.0, -0.05, 0.3], [np.inf, 0.99 * d0.min(), 4.0]
    p, cov = curve_fit(model, d0, w, p0=p0, bounds=(lo, hi), maxfev=20000)
    err = np.sqrt(np.diag(cov)) if np.all(np.isfinite(cov)) else np.full(3, np.nan)
    # a parameter pinned on a bound has no meaningful standard error (the fit wanted to go further)
    on_bound = bool(any(min(abs(v - a), abs(v - b)) <= 1e-6 * max(1e-3, abs(v))
                        for v, a, b in zip(p[1:], lo[1:], hi[1:], strict=True)))
    return {"A": p[0], "D_star_m": p[1], "beta": p[2], "A_err": err[0], "D_star_err_m": err[1], "beta_err": err[2],
            "rms_residual": float(np.sqrt(np.mean((model(d0, *p) - w) ** 2))), "on_bound": on_bound}


#: the orifices an exponent is read from are at least this many cells wide (narrower ones jam or
#: are set by the few cells across them: on the 5 mm grid D0 = 2 cm runs 0.3 kg/(m s))
MIN_ORIFICE_CELLS = 10


def exponent_test(d0: np.ndarray, w: np.ndarray, h: float, *, beta: float = 1.5, sigmas: float = 3.0,
                  min_cells: float = MIN_ORIFICE_CELLS) -> dict:
    """Does W(D0) tell the exponent β of W = A (D0 − D*)^β apart? The free power law is fitted on the
    orifices at least ``min_cells`` cells of ``h`` [m] wide. The test *decides* when the fit is off
    its bounds and ``sigmas`` standard errors are less than half the distance to the neighbouring
    half-integer exponents (3σ < 0.5: it could tell 3/2 from 1 or 2), and *holds* when it decides and
    |β_fit − β| ≤ ``sigmas`` σ."""
    d0, w = np.asarray(d0, dtype=float), np.asarray(w, dtype=float)
    wide = d0 / h >= min_cells - 1e-9
    out = {"orifices_m": d0[wide].tolist(), "min_cells": min_cells, "beta_expected": beta}
    if wide.sum() < 4:  # three parameters need a fourth point to have an error
        return {**out, "decides": False, "holds": False, "why": f"{int(wide.sum())} orifices ≥ {min_cells} cells"}
    fit = fit_power_law(d0[wide], w[wide])
    err = fit["beta_err"]
    decides = bool(not fit["on_bound"] and math.isfinite(err) and sigmas * err < 0.5)
    holds = bool(decides and abs(fit["beta"] - beta) <= sigmas * err)
    return {**out, "fit": fit, "decides": decides, "holds": holds}


def dead_zone(d0: np.ndarray, w: np.ndarray) -> float:
    """The intercept D* [m] of W^(2/3) against D0 (the 2D law's W^(2/3) ∝ D0 − D*, by least squares):
    the width of the orifice that does not discharge."""
    slope, intercept = np.polyfit(np.asarray(d0, dtype=float), np.asarray(w, dtype=float) ** (2.0 / 3.0), 1)
    return float(-intercept / slope)


def fit_beverloo(d0: np.ndarray, w: np.ndarray, r_p: float = R_P_TABLE) -> dict:
    """W = C ρ sqrt(g) (D0 − k r_p)^(3/2): (C, k) both free, and C with the paper's k."""
    from scipy.optimize import curve_fit

    def model(d, c, k):
        return c * PREFACTOR * np.clip(d - k * r_p, 1e-9, None) ** 1.5

    p, cov = curve_fit(model, d0, w, p0=(0.6, 2.0), bounds=([0.0, -20.0], [10.0, 0.99 * d0.min() / r_p]))
    err = np.sqrt(np.diag(cov))
    # C with k fixed: linear in C, so the least-squares C is closed-form
    basis = PREFACTOR * np.clip(d0 - BEVERLOO_K * r_p, 0.0, None) ** 1.5
    c_fixed = float(basis @ w / (basis @ basis))
    resid = w - c_fixed * basis
    c_fixed_err = float(np.sqrt(resid @ resid / max(len(w) - 1, 1) / (basis @ basis)))
    return {"C": p[0], "k": p[1], "C_err": err[0], "k_err": err[1], "C_k_paper": c_fixed, "C_k_paper_err": c_fixed_err,
            "r_p_m": r_p, "C_paper": BEVERLOO_C, "k_paper": BEVERLOO_K}


def analyze(runs: list[dict], out: Path) -> dict:
    """Fits, the resolution spread and the charts of a Beverloo study; writes OUT/beverloo_fit.json
    and OUT/beverloo_*.png and returns the fit."""
    out = Path(out)
    ok = [r for r in runs if r.get("status") == "completed" and r.get("rate") is not None
          and r.get("method", "granular") == "granular"]
    grids = sorted({r["cell_size"] for r in ok})
    report: dict = {"grids_m": grids, "runs": len(runs), "completed": len(ok),
                    "paper_rates": {f"{d:g}": beverloo(d) for d in ORIFICES_PAPER}}
    by_grid = {h: sorted((r["orifice_m"], r["rate"]) for r in ok if r["cell_size"] == h) for h in grids}
    fits = {}
    for h, pts in by_grid.items():
        if len(pts) >= 4:
            d0, w = (np.array(v, dtype=float) for v in zip(*pts, strict=True))
            rp = next(r["contact_radius"] for r in ok if r["cell_size"] == h)
            # the paper's form with its r_p = 0.1 cm, and with our contact radius h/√2 (the empty
            # annulus our contacts leave along the orifice's edges)
            fits[f"{h:g}"] = {"power_law": fit_power_law(d0, w), "beverloo": fit_beverloo(d0, w),
                              "beverloo_our_contact_radius": fit_beverloo(d0, w, r_p=rp),
                              "exponent_wide_orifices": exponent_test(d0, w, h), "dead_zone_m": dead_zone(d0, w)}
    report["fits"] = fits
    # spread of W over the grids, per orifice: (max − min) / mean
    spread = {}
    for d in sorted({r["orifice_m"] for r in ok}):
        ws = [r["rate"] for r in ok if r["orifice_m"] == d]
        if len(ws) >= 2:
            spread[f"{d:g}"] = {"rates": ws, "relative_spread": (max(ws) - min(ws)) / float(np.mean(ws))}
    report["resolution_spread"] = spread
    report["failed"] = [{"run": r.get("run"), "status": r.get("status"), "message": r.get("message", "")}
                        for r in runs if r.get("status") != "completed"]
    (out / "beverloo_fit.json").write_text(json.dumps(report, indent=2, default=float) + "\n")
    plot(runs, report, out)
    return report


def _save(fig, path: Path) -> Path:
    """Write a chart as a PNG and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot(runs: list[dict], report: dict, out: Path) -> list[Path]:
    """W against D0 (with the fits and the paper's curve), W^(2/3) against D0, M(t) of every run,
    and each run's wall time against its rate's deviation from the finest grid."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in runs if r.get("status") == "completed" and r.get("rate") is not None]
    grids = sorted({r["cell_size"] for r in ok if r.get("method", "granular") == "granular"})
    colours = dict(zip(grids, plt.cm.viridis(np.linspace(0.15, 0.85, max(len(grids), 1))), strict=False))
    markers = dict(zip(grids, "os^Dv", strict=False))
    dd = np.linspace(0.015, 0.065, 200)
    paper = np.array([beverloo(d) for d in dd])
    written = []

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for h in grids:
        pts = sorted((r["orifice_m"], r["rate"]) for r in ok
                     if r["cell_size"] == h and r.get("method", "granular") == "granular")
        if pts:
            d0, w = zip(*pts, strict=True)
            lab = f"h = {100 * h:.3g} cm"
            ax.plot(np.array(d0) * 100, w, markers[h], color=colours[h], label=lab)
            ax2.plot(np.array(d0) * 100, np.array(w) ** (2 / 3), markers[h], color=colours[h], label=lab)
    for ax_, y in ((ax, paper), (ax2, paper ** (2 / 3))):
        ax_.plot(dd * 100, y, "k--", label=f"paper: C = {BEVERLOO_C}, k = {BEVERLOO_K}, r_p = 0.1 cm")
    if grids and f"{grids[0]:g}" in report["fits"]:
        f = report["fits"][f"{grids[0]:g}"]
        pl, bv = f["power_law"], f["beverloo"]
        y = pl["A"] * np.clip(dd - pl["D_star_m"], 0, None) ** pl["beta"]
        ax.plot(dd * 100, y, "-", color=colours[grids[0]], lw=1,
                label=f"fit (finest): β = {pl['beta']:.2f} ± {pl['beta_err']:.2f}")
        y2 = bv["C"] * PREFACTOR * np.clip(dd - bv["k"] * bv["r_p_m"], 0, None) ** 1.5
        ax2.plot(dd * 100, y2 ** (2 / 3), "-", color=colours[grids[0]], lw=1,
                 label=f"fit (finest): C = {bv['C']:.2f}, k = {bv['k']:.1f}")
    ax.set(xlabel="orifice D0 [cm]", ylabel="discharge rate W [kg/(m s)]", title="silo discharge vs 2D Beverloo")
    ax2.set(xlabel="orifice D0 [cm]", ylabel="W^(2/3) [(kg/(m s))^(2/3)]", title="2D Beverloo: W^(2/3) linear in D0")
    for a in (ax, ax2):
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    written.append(_save(fig, out / "beverloo_rate.png"))

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for r in ok:
        if "times" not in r:
            continue
        h = r["cell_size"]
        ax.plot(r["times"], r["discharged_mass"], color=colours.get(h, "grey"), lw=1,
                ls="-" if r.get("method", "granular") == "granular" else ":")
    for h in grids:
        ax.plot([], [], color=colours[h], label=f"h = {100 * h:.3g} cm")
    ax.set(xlabel="t [s]", ylabel="discharged mass M [kg/m]", title="M(t) of every run (D0 = 2-6 cm bottom to top)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    written.append(_save(fig, out / "beverloo_mass.png"))

    # speed × accuracy: wall time against the deviation of W from the finest grid's at the same D0
    fig, ax = plt.subplots(figsize=(7, 4.5))
    finest = {r["orifice_m"]: r["rate"] for r in ok if grids and r["cell_size"] == grids[0]
              and r.get("method", "granular") == "granular"}
    for r in runs:
        d = r.get("orifice_m")
        ref = finest.get(d)
        t = r.get("wall_seconds")
        if t is None or ref is None:
            continue
        if r.get("status") == "completed" and r.get("rate") is not None:
            dev = abs(r["rate"] / ref - 1.0)
            h = r.get("cell_size")
            ax.plot(t, max(dev, 1e-3), markers.get(h, "o"), color=colours.get(h, "grey"))
        else:
            ax.plot(t, 1.0, "x", color="red")
    for h in grids:
        ax.plot([], [], markers[h], color=colours[h], label=f"h = {100 * h:.3g} cm")
    ax.plot([], [], "x", color="red", label="failed (detected)")
    ax.set(xscale="log", yscale="log", xlabel="wall time of the run [s]",
           ylabel="|W / W(finest grid) − 1| (floor 1e-3)", title="speed × accuracy of the silo runs")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    written.append(_save(fig, out / "beverloo_speed_accuracy.png"))
    return written


def methods_report(runs: list[dict], out: Path) -> dict:
    """The method comparison: W, wall time and status per (method, κ2); writes OUT/methods.json and
    OUT/beverloo_methods.png (W per method, failures marked, wall time beside each bar)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    rows = []
    for r in runs:
        flags = r.get("flags", {})
        kappa = float(flags["dem-kappa"]) if "dem-kappa" in flags else (r.get("config") or {}).get("dem_kappa")
        rows.append({"method": flags.get("method", r.get("method")), "dem_kappa": kappa, "status": r.get("status"),
                     "rate": r.get("rate"), "wall_seconds": r.get("wall_seconds"), "steps": r.get("steps"),
                     "message": r.get("message", "")})
    ref = next((x["rate"] for x in rows if x["method"] == "granular" and x["dem_kappa"] == 0.1
                and x["status"] == "completed"), None)
    for x in rows:
        x["rate_over_granular"] = x["rate"] / ref if ref and x["rate"] is not None else None
        x["beverloo_paper"] = beverloo(0.04)
    rows.sort(key=lambda x: (str(x["method"]), x["dem_kappa"] or 0.0))
    (out / "methods.json").write_text(json.dumps(rows, indent=2, default=float) + "\n")

    kappas = sorted({x["dem_kappa"] for x in rows if x["dem_kappa"] is not None})
    methods = list(dict.fromkeys(x["method"] for x in rows))
    fig, ax = plt.subplots(figsize=(9, 4.5))
    width = 0.8 / max(len(kappas), 1)
    for j, kappa in enumerate(kappas):
        for i, m in enumerate(methods):
            x = next((y for y in rows if y["method"] == m and y["dem_kappa"] == kappa), None)
            if x is None:
                continue
            pos = i + (j - 0.5 * (len(kappas) - 1)) * width
            if x["status"] == "completed" and x["rate"] is not None:
                ax.bar(pos, x["rate"], width, color=plt.cm.tab10(j), label=f"κ2 = {kappa:g}" if i == 0 else None)
                ax.text(pos, x["rate"], f"{x['wall_seconds']:.0f} s", ha="center", va="bottom", fontsize=7)
            else:
                seen = "failed (detected)" in ax.get_legend_handles_labels()[1]
                ax.plot(pos, 1.0, "x", color="red", ms=10, label=None if seen else "failed (detected)")
                ax.text(pos, 2.0, str(x["status"]), ha="center", va="bottom", fontsize=7, rotation=90, color="red")
    ax.axhline(beverloo(0.04), color="k", ls="--", lw=1, label="paper's Beverloo curve at 4 cm")
    ax.set_xticks(range(len(methods)), methods, rotation=20, fontsize=8)
    ax.set(ylabel="discharge rate W [kg/(m s)]", title="silo D0 = 4 cm, h = 3.5 mm: W and wall time per model")
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8)
    _save(fig, out / "beverloo_methods.png")
    return {"rows": rows}
