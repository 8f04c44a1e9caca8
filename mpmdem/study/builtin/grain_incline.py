"""The μ(I) of the DEM grains from steady flows down a rough incline (issue 43 §2): ``grain-incline``
sweeps the slope of ``cases/grain_incline.py`` over six angles from the disks' angle of repose
(17.9 ± 0.6°, bench/results/studies/grain-calibration) to 30° (1.7 times it, toward the plateau μ2:
docs/studies/index.md, "μ(I) of the grains"), ``grain-incline-polygon`` the rounded pentagons over
26–33.5° about their angle of repose (30.2 ± 2.1°): their range of steady flow is narrow (the same
page), so the sweep is denser there instead of reaching 1.5 times the angle. The grains are those of the heap runs that
gave those angles: r = 1 mm (``--set grain-radius=0.0005,0.001`` adds the column's d = 1 mm grains:
I is dimensionless, so the two sizes should give one law up to the contacts' stiffness, k_n being
the same at both).

Each steady run is a point (I, μ = tan θ) of the friction law (the case's header); runs that stopped
(below the stopping angle of their depth) or accelerated (above the largest angle of steady flow)
bound it and are listed, not fitted. ``analyze`` fits Jop et al. 2006's μ(I) per grain shape to the
steady points (``mpmdem.study.mu_i_fit``: μs, μ2, I0 with 1-σ from the covariance; whether μ2 is
constrained), and writes OUT/mu_i_fit.json and OUT/mu_i.png (μ against I with the fit), with the
DEM's cost of each run (grains, steps, wall time, grain-steps per second).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from mpmdem.study.mu_i_fit import fit_jop, jop_mu
from mpmdem.study.study import Study

from .run_summaries import load_runs

#: the sweeps whose runs share the fit's file and chart when they lie side by side
SIBLINGS = ("grain-incline", "grain-incline-polygon")
#: the least σ_μ a point is given in the fit (the I scatter of a flat profile can be ~0)
MU_FLOOR = 0.002


def incline_points(runs: list[dict]) -> list[dict]:
    """The runs as rows: grain ("shape:radius"), angle, μ, state, core I ± σ, φ, flow height, DEM cost."""
    rows = []
    for r in runs:
        if r.get("status") != "completed":
            rows.append({"run": r["run"], "state": "failed", "status": r.get("status"), "message": r.get("message")})
            continue
        wall, steps, grains = r.get("wall_seconds"), r.get("steps"), r.get("grains", 0) + r.get("base_grains", 0)
        rate = grains * steps / wall if wall and steps else None
        rows.append({"run": r["run"], "shape": f"{r['grain_shape']}:{r['grain_radius_m']:g}",
                     "angle_deg": r["angle_deg"], "mu": r["mu"], "mu_balance": r.get("mu_balance"),
                     "state": r["state"], "I": r["I"], "I_std": r["I_std"], "phi": r["phi"], "phi_std": r["phi_std"],
                     "flow_height_in_d": r["flow_height_in_d"], "acceleration_over_drive": r["acceleration_over_drive"],
                     "grains": r.get("grains"), "steps": steps, "wall_seconds": wall, "device": r.get("device"),
                     "body_steps_per_second": rate})
    return sorted(rows, key=lambda x: (x.get("shape", ""), x.get("angle_deg", 0.0)))


def fit_shapes(rows: list[dict]) -> dict:
    """Per grain ("shape:radius", as bench/results/studies/grain-calibration keys them): the Jop fit to
    the steady points, the points, and the angles at which the layer stopped or accelerated."""
    out = {}
    for shape in sorted({r["shape"] for r in rows if "shape" in r}):
        mine = [r for r in rows if r.get("shape") == shape]
        steady = [r for r in mine if r["state"] == "steady" and r["I"] is not None and math.isfinite(r["I"])]
        fit = fit_jop([r["I"] for r in steady], [r["mu"] for r in steady], [r["I_std"] for r in steady],
                      mu_floor=MU_FLOOR)
        out[shape] = {"fit": fit, "steady_angles_deg": [r["angle_deg"] for r in steady],
                      "stopped_angles_deg": [r["angle_deg"] for r in mine if r["state"] == "stopped"],
                      "accelerating_angles_deg": [r["angle_deg"] for r in mine if r["state"] == "accelerating"],
                      "phi_range": [min((r["phi"] for r in steady), default=None),
                                    max((r["phi"] for r in steady), default=None)]}
    return out


def analyze(rows: list[dict], out: Path) -> dict:
    """Writes OUT/mu_i_fit.json and OUT/mu_i.png (module docstring) from this sweep's runs and its
    sibling's (disks and pentagons side by side)."""
    out = Path(out)
    runs = load_runs(out)
    for name in SIBLINGS:
        other = out.parent / name
        if other.resolve() != out.resolve() and (other / "runs").is_dir():
            runs += [r | {"run": f"{name}/{r['run']}"} for r in load_runs(other)]
    points = incline_points(runs)
    result = {"method": __doc__, "per_grain": fit_shapes(points), "runs": points}
    (out / "mu_i_fit.json").write_text(json.dumps(result, indent=2) + "\n")
    _chart(points, result["per_grain"], out / "mu_i.png")
    return result


def _chart(points: list[dict], shapes: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for (shape, per), colour in zip(shapes.items(), ("C0", "C3", "C2"), strict=False):
        steady = [r for r in points if r.get("shape") == shape and r["state"] == "steady"]
        ax.errorbar([r["I"] for r in steady], [r["mu"] for r in steady], xerr=[r["I_std"] for r in steady], fmt="o",
                    color=colour, capsize=3, label=f"{shape}: steady flows (tan θ, core I ± σ)")
        for angle in per["stopped_angles_deg"]:
            ax.axhline(math.tan(math.radians(angle)), color=colour, ls=":", lw=0.8)
        for angle in per["accelerating_angles_deg"]:
            ax.axhline(math.tan(math.radians(angle)), color=colour, ls="--", lw=0.8)
        f = per["fit"]
        if f["mu_s"] is not None:
            top = max([r["I"] for r in steady] + [1e-3])
            ii = np.linspace(1e-4, 1.5 * top, 200)
            ax.plot(ii, jop_mu(ii, f["mu_s"], f["mu_2"], f["i0"]), color=colour,
                    label=f"fit: μs {f['mu_s']:.3f}±{f['mu_s_std']:.3f}, μ2 {f['mu_2']:.3f}±{f['mu_2_std']:.2g}, "
                          f"I0 {f['i0']:.3g}±{f['i0_std']:.2g}")
    ax.plot([], [], "k:", lw=0.8, label="tan θ of runs that stopped")
    ax.plot([], [], "k--", lw=0.8, label="tan θ of runs that accelerated")
    ax.set(xlabel="inertial number I", ylabel="μ = tan θ", xlim=(0.0, None),
           title="μ(I) of the DEM grains, steady flows on a rough incline")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


STUDY = Study(
    name="grain-incline",
    case="grain-incline",
    description="mu(I) of the DEM disks (r = 1 mm) from steady flows down a rough incline, periodic along it: six "
                "angles from the angle of repose (17.9 deg) to 1.7 times it; Jop's mu_s, mu_2, I0 fitted",
    grid={"--angle": [18.0, 20.0, 22.5, 25.0, 27.5, 30.0]},
    fixed={"--grain-shape": "disk", "--grain-radius": 0.001},
    analyze=analyze,
)

POLYGON = Study(
    name="grain-incline-polygon",
    case="grain-incline",
    description="mu(I) of the DEM rounded pentagons (r = 1 mm) from steady incline flows, 26-33.5 deg about their "
                "angle of repose (30.2 deg); Jop's mu_s, mu_2, I0 fitted",
    grid={"--angle": [26.0, 27.5, 29.0, 30.5, 32.0, 33.5]},
    fixed={"--grain-shape": "polygon", "--grain-radius": 0.001},
    analyze=analyze,
)
