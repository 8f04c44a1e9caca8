"""The three MPM variants "Granular MPM" §4 compares, run side by side on one scene.

"original": the plain algorithm, no critical density; "stress_free": stress-free below the
critical density (Dunatunga & Kamrin), no density control, one grid; "granular": Granular MPM
(density control of eq. 13-15 and a grid per component, §3). Each run is stepped frame by frame
on the device and summarised by the mean density of its points (the paper's Figs. 2 and 10)
and its final point cloud; a blow-up ends that variant's run and is reported, as in the paper
where some variants fail.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from mpmdem import BlowUpError, Scene, Simulation, SolverConfig

VARIANTS = {
    "original": {"critical": False, "config": {"granular": False, "density_control": "none"}},
    "stress_free": {"critical": True, "config": {"granular": False, "density_control": "none"}},
    "granular": {"critical": True, "config": {"granular": True, "density_control": "revert"}},
}


def run_variant(build: Callable[[bool], Scene], base: SolverConfig, name: str, end_time: float, frames: int,
                device: str, batch: int = 200) -> dict:
    """Run variant ``name`` of ``build(critical)`` to ``end_time`` [s]; per frame: t [s], mean density
    [kg/m³] of the points; at the end: x (N, 2) [m], speed (N,) [m/s], density (N,), status."""
    config = dataclasses.replace(base, **VARIANTS[name]["config"])
    sim = Simulation(build(VARIANTS[name]["critical"]), config, device=device)
    mpm = sim.mpm
    times, mean_rho = [], []
    status, reason = "completed", None

    def sample():
        f = mpm.fields()
        t = mpm.read_clock()[0]
        times.append(t)
        mean_rho.append(float(np.mean(f["mass"] / f["volume"])))
        return f

    f = sample()
    try:
        for k in range(1, frames + 1):
            target = end_time * k / frames
            mpm.set_stop_time(target)
            while True:
                for _ in range(batch):
                    mpm.step()
                t, dt, bound, _, flags = mpm.read_clock()
                mpm.check_status(t, dt, bound, flags)
                if dt == 0.0 or t >= target:
                    break
            f = sample()
    except BlowUpError as e:
        status, reason = "blown-up", str(e)
    return {
        "t": np.array(times), "mean_density": np.array(mean_rho), "x": f["x"],
        "speed": np.linalg.norm(f["v"], axis=1), "density": f["mass"] / f["volume"],
        "status": status, "reason": reason,
    }


def plot_variants(runs: dict, path, *, title: str, extra=None) -> None:
    """Final point clouds (coloured by speed) and the mean density history of every variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(runs) + 1, 1, figsize=(8, 2.2 * (len(runs) + 1)))
    for ax, (name, r) in zip(axes, runs.items(), strict=False):
        sc = ax.scatter(r["x"][:, 0], r["x"][:, 1], c=r["speed"], s=6, cmap="viridis")
        if extra is not None:
            extra(ax)
        ax.set_title(f"{name} ({r['status']}, t = {r['t'][-1]:.3g} s)", fontsize=8)
        ax.set_aspect("equal")
        fig.colorbar(sc, ax=ax, label="speed [m/s]")
    ax = axes[-1]
    for name, r in runs.items():
        ax.plot(r["t"], r["mean_density"], label=name)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("mean density [kg/m³]")
    ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
