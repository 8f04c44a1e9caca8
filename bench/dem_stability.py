"""DEM stability map: how far past MPM-SDEM eq. 51's time step the explicit DEM stays stable.

For three scenes (a disk dropped on a floor: one translational contact; a tilted rounded square
dropped on a floor: corner impacts that turn the body; a small pile of random pentagons: many
contacts per body) × restitution e × r = dt / dt_default, with dt_default = 2π·0.1·sqrt(m*/k_n)
(sqrt(1+ζ²) − ζ) the default step (eq. 51 with the rotational effective mass m* and the
explicit-dashpot factor, see mpmdem.sim.dem.dem_time_step_bound), each run is classified:

- ``blown-up``: the solver stopped it (BlowUpError: NaN/inf, a body left the box, energy growth);
- ``energy-gain``: it finished but the total energy ended above its initial value by more than
  2 %, or the energy balance residual W_num (energy not explained by the works of contact
  damping and friction; O((ω dt)²) when stable) rose above 10 % of the initial energy;
- ``stable`` otherwise.

``r_paper`` is the same dt over eq. 51 taken literally (with the smallest body mass m_min).
Writes JSON lines to --out and a map PNG to --png. CPU, f64; about a minute on 2 cores.

    python bench/dem_stability.py --out bench/results/dem_stability/cpu.jsonl --png bench/results/dem_stability/cpu.png
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from mpmdem import BlowUpError, ContactLaw, Scene, Simulation, SolverConfig, rounded_rectangle, sphero_disk
from mpmdem.sim.dem import dem_time_step_bound

RATIOS = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0)
RESTITUTIONS = (1.0, 0.5, 0.1)
SCENES = ("disk-drop", "square-drop", "pentagon-pile")
GAIN = 0.02  # final energy above the initial one
RESIDUAL = 0.10  # largest energy-balance residual, of the initial energy


def build(scene_name: str, e: float) -> tuple[Scene, float]:
    """(scene, end time [s])."""
    law = ContactLaw(1.0e6, restitution=e)
    if scene_name == "pentagon-pile":
        from mpmdem.cases import pentagon_pile

        args = argparse.Namespace(quick=True, bodies=30, columns=6, seed=2)
        setup = pentagon_pile.build(args)
        scene = setup.scene
        scene.contact = law
        return scene, 0.6
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), gravity=(0.0, -9.81), contact=law)
    scene.add_walls(("left", "right", "bottom"), friction=0.5)
    if scene_name == "disk-drop":
        scene.add_rigid_body(sphero_disk(0.05), density=2500.0, position=(0.5, 0.15), friction=0.5)
    else:
        scene.add_rigid_body(rounded_rectangle(0.1, 0.1, radius=0.005), density=2500.0, position=(0.5, 0.2),
                             angle=0.3, angular_velocity=2.0, friction=0.5)
    return scene, 0.6


def run_one(scene_name: str, e: float, ratio: float) -> dict:
    scene, end = build(scene_name, e)
    masses = [b.mass for b in scene.rigid_bodies if b.motion == "free"]
    dt51_paper = 2.0 * math.pi * 0.1 * math.sqrt(min(masses) / scene.contact.normal_stiffness)
    dt_bound = dem_time_step_bound(scene)
    kappa = 0.1 * ratio
    config = SolverConfig(precision="f64", dem_kappa=kappa, allow_unstable=True, blowup_energy_factor=1.0)
    row = {"scene": scene_name, "restitution": e, "ratio": ratio, "dt": math.pi * kappa * dt_bound,
           "r_paper": math.pi * kappa * dt_bound / dt51_paper, "dt_over_bound": math.pi * kappa}
    t0 = time.perf_counter()
    try:
        sim = Simulation(scene, config, device="cpu")
        result = sim.run(end, frames=30)
        d = result.diagnostics
        e0 = float(d["energy_total"][0])
        residual = float(np.max(d["work_numerical"])) / e0
        final = float(d["energy_total"][-1] / e0)
        bad = residual > RESIDUAL or final > 1.0 + GAIN
        row.update(status="energy-gain" if bad else "stable", max_numerical_work=residual, energy_final=final)
    except BlowUpError as err:
        row.update(status="blown-up", reason=err.reason, time=err.time)
    row["seconds"] = time.perf_counter() - t0
    return row


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {"stable": "#2a9d4b", "energy-gain": "#f0a500", "blown-up": "#c0392b"}
    fig, axes = plt.subplots(1, len(SCENES), figsize=(4.2 * len(SCENES), 3.4), sharey=True)
    for ax, name in zip(axes, SCENES, strict=True):
        for r in rows:
            if r["scene"] != name:
                continue
            ax.scatter(r["ratio"], r["restitution"], s=160, marker="s", color=colours[r["status"]])
        ax.axvline(1.0, color="k", lw=0.8, ls="--")
        ax.axvline(1.0 / (math.pi * 0.1), color="k", lw=0.8, ls=":")
        ax.set_title(name)
        ax.set_xlabel("dt / default dt")
        ax.set_xscale("log")
        ax.set_xticks(RATIOS)
        ax.set_xticklabels([f"{r:g}" for r in RATIOS])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[0].set_ylabel("restitution e")
    handles = [plt.Line2D([], [], marker="s", ls="", color=c, label=k) for k, c in colours.items()]
    handles += [plt.Line2D([], [], color="k", ls="--", label="default dt"),
                plt.Line2D([], [], color="k", ls=":", label="user-dt bound")]
    fig.legend(handles=handles, loc="lower center", ncol=5, frameon=False)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=None)
    p.add_argument("--png", default=None)
    p.add_argument("--replot", default=None, help="plot an existing JSON-lines file")
    args = p.parse_args(argv)
    if args.replot:
        rows = [json.loads(line) for line in Path(args.replot).read_text().splitlines() if line.strip()]
    else:
        rows = []
        for name in SCENES:
            for e in RESTITUTIONS:
                for ratio in RATIOS:
                    row = run_one(name, e, ratio)
                    rows.append(row)
                    print(json.dumps(row), flush=True)
        if args.out:
            Path(args.out).write_text("".join(json.dumps(r) + "\n" for r in rows))
    if args.png:
        plot(rows, Path(args.png))
    for name in SCENES:
        for e in RESTITUTIONS:
            ok = [r["ratio"] for r in rows if r["scene"] == name and r["restitution"] == e and r["status"] == "stable"]
            bad = [r["ratio"] for r in rows if r["scene"] == name and r["restitution"] == e and r["status"] != "stable"]
            print(f"{name:14s} e={e:.1f}: stable up to r = {max(ok) if ok else None}, first failure at r = "
                  f"{min(bad) if bad else None}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
