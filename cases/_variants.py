"""The three MPM variants "Granular MPM" §4 compares, run side by side on one scene.

"original": the plain algorithm, no critical density; "stress_free": stress-free below the
critical density (Dunatunga & Kamrin), no density control, one grid; "granular": Granular MPM
(density control of eq. 13-15 and a grid per component, §3). A case declares them as its
``VARIANTS = GRANULAR_VARIANTS`` (``mpmdem.study.variants``): the runner runs each as a run of its
own (the one equal to the case's own run is that run), and the case's ``compare`` reads each run
file (``read_run``): the mean density of its points per frame (the paper's Figs. 2 and 10) and its final point cloud. A
blow-up ends that variant's run and is reported, as in the paper where some variants fail.
"""

from __future__ import annotations

import numpy as np

from mpmdem.io import RunFile
from mpmdem.study.variants import Variant

#: The three variants; ``critical_density``: whether the case's material has a critical density
#: (its ``build`` reads it with ``critical_density(args)``).
GRANULAR_VARIANTS = [
    Variant("original", config={"granular": False, "density_control": "none"}, args={"critical_density": False}),
    Variant("stress_free", config={"granular": False, "density_control": "none"}, args={"critical_density": True}),
    Variant("granular", config={"granular": True, "density_control": "revert"}, args={"critical_density": True}),
]


def critical_density(args) -> bool:
    """Whether the run's material has a critical density (True unless a variant says not)."""
    return getattr(args, "critical_density", True)


def read_run(path) -> dict:
    """One variant's run file: per frame t [s] and the mean density [kg/m³] of the points; at the
    last frame written: x (N, 2) [m], speed (N,) [m/s], density (N,); status (of the file)."""
    with RunFile(path) as rf:
        frames = range(rf.frame_count)
        mean_rho = [float(np.mean(rf.field("mass", k) / rf.field("volume", k))) for k in frames]
        x, v = rf.field("x", -1), rf.field("v", -1)
        density = rf.field("mass", -1) / rf.field("volume", -1)
        return {"t": rf.times, "mean_density": np.array(mean_rho), "x": x, "speed": np.linalg.norm(v, axis=1),
                "density": density, "status": rf.status, "reason": rf.attrs.get("status_message") or None}


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
