"""Draw the schematic figures of the Concepts pages (docs/figures/*.png) with matplotlib.

    python docs/figures/make_figures.py

Schematics only: no simulation runs. Each figure is a function below; the PNGs are committed.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyArrowPatch, Polygon  # noqa: E402

HERE = Path(__file__).resolve().parent
DPI = 90



def _save(fig, name: str) -> Path:
    """Write a figure into this folder and close it."""
    fig.tight_layout()
    out = HERE / name
    fig.savefig(out, dpi=DPI)
    plt.close(fig)
    return out

def _grid(ax, n: int = 5) -> None:
    for k in range(n + 1):
        ax.plot([0, n], [k, k], color="0.8", lw=0.8, zorder=0)
        ax.plot([k, k], [0, n], color="0.8", lw=0.8, zorder=0)
    ax.set_xlim(-0.3, n + 0.3)
    ax.set_ylim(-0.3, n + 0.3)
    ax.set_aspect("equal")
    ax.axis("off")


def mpm_step() -> Path:
    """P2G, grid update, G2P: points carry the state, the grid solves the momentum balance."""
    rng = np.random.default_rng(3)
    pts = np.array([[1.3, 1.4], [1.7, 1.3], [1.4, 1.8], [1.8, 1.75], [2.3, 1.35], [2.2, 1.8], [2.7, 1.6],
                    [1.35, 2.3], [1.8, 2.25], [2.3, 2.3], [2.7, 2.2]]) + rng.normal(0, 0.03, (11, 2))
    nodes = np.array([[i, j] for i in range(1, 4) for j in range(1, 4)], float)
    fig, axes = plt.subplots(1, 3, figsize=(10.5, 3.6))
    titles = ["1. P2G: points → nodes\n(mass, momentum, forces)", "2. grid update\n(v ← v + Δt f/m, walls)",
              "3. G2P: nodes → points\n(v, x, F, stress update)"]
    for ax, title in zip(axes, titles, strict=True):
        _grid(ax, 4)
        ax.set_title(title, fontsize=10)
        ax.scatter(nodes[:, 0], nodes[:, 1], s=40, color="tab:blue", marker="s", zorder=2)
        ax.scatter(pts[:, 0], pts[:, 1], s=30, color="tab:orange", zorder=3)
    p = pts[4]
    for n in ([2, 1], [3, 1], [2, 2], [3, 2]):
        axes[0].add_patch(FancyArrowPatch(p, n, arrowstyle="-|>", mutation_scale=10, color="0.3", lw=0.8))
    for n in nodes:
        axes[1].add_patch(FancyArrowPatch(n, n + [0.0, -0.45], arrowstyle="-|>", mutation_scale=10,
                                          color="tab:blue", lw=1.2))
    for n in ([2, 1], [3, 1], [2, 2], [3, 2]):
        axes[2].add_patch(FancyArrowPatch(n, p, arrowstyle="-|>", mutation_scale=10, color="0.3", lw=0.8))
    axes[2].add_patch(FancyArrowPatch(p, p + [0.0, -0.5], arrowstyle="-|>", mutation_scale=10,
                                      color="tab:orange", lw=1.5))
    return _save(fig, "mpm_step.png")


def shape_functions() -> Path:
    """1D shape functions of a node at 0 (cell size 1): tent, uGIMP, quadratic and cubic B-splines."""
    x = np.linspace(-2.2, 2.2, 881)
    a = np.abs(x)
    tent = np.clip(1 - a, 0, None)
    lp = 0.25  # half the particle domain at 2 points per cell
    ugimp = np.where(a < lp, 1 - (a**2 + lp**2) / (2 * lp),
                     np.where(a < 1 - lp, 1 - a, np.where(a < 1 + lp, (1 + lp - a) ** 2 / (4 * lp), 0.0)))
    b2 = np.where(a < 0.5, 0.75 - a**2, np.where(a < 1.5, 0.5 * (1.5 - a) ** 2, 0.0))
    b3 = np.where(a < 1, 0.5 * a**3 - a**2 + 2 / 3, np.where(a < 2, (2 - a) ** 3 / 6, 0.0))
    fig, ax = plt.subplots(figsize=(6.4, 3.4))
    for y, label in ((tent, "tent (linear)"), (ugimp, "uGIMP, l_p = h/4"), (b2, "quadratic B-spline"),
                     (b3, "cubic B-spline")):
        ax.plot(x, y, label=label)
    ax.set_xlabel("(x − x_node) / h")
    ax.set_ylabel("N")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, "shape_functions.png")


def grid_layers() -> Path:
    """Two components (connected groups of points) near one node: each gets its own copy of the node."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.9))
    left = np.array([[1.25, 1.25], [1.75, 1.25], [1.25, 1.75], [1.75, 1.75], [1.25, 2.25], [1.75, 2.25]])
    right = np.array([[2.35, 1.6], [2.8, 1.6], [2.35, 2.05], [2.8, 2.05]])
    for ax, title in zip(axes, ["original MPM: one grid, the groups stick", "Granular MPM: one grid copy "
                                                                            "(layer) per component"], strict=True):
        _grid(ax, 4)
        ax.set_title(title, fontsize=10)
        for c, pts in (("tab:orange", left), ("tab:green", right)):
            for p in pts:
                ax.add_patch(plt.Rectangle(p - 0.22, 0.44, 0.44, fc=c, alpha=0.25, ec=c))
            ax.scatter(pts[:, 0], pts[:, 1], color=c, s=25, zorder=3)
    axes[0].scatter([2], [2], s=120, marker="s", color="tab:blue", zorder=4)
    axes[0].annotate("shared node: one velocity", (2, 2), (2.2, 3.2), fontsize=9,
                     arrowprops={"arrowstyle": "->"})
    axes[1].scatter([1.93], [2], s=100, marker="s", color="tab:orange", zorder=4, ec="k")
    axes[1].scatter([2.07], [2], s=100, marker="s", color="tab:green", zorder=4, ec="k")
    axes[1].annotate("two copies of the node,\none per component", (2.0, 2.0), (2.2, 3.2), fontsize=9,
                     arrowprops={"arrowstyle": "->"})
    return _save(fig, "grid_layers.png")


def _dilate(core: np.ndarray, r: float, n: int = 24) -> np.ndarray:
    """Outline of a convex polygon ⊕ disk of radius r (counter-clockwise core)."""
    out = []
    m = len(core)
    for i in range(m):
        prev, cur, nxt = core[i - 1], core[i], core[(i + 1) % m]
        e0, e1 = cur - prev, nxt - cur
        a0, a1 = np.arctan2(-e0[0], e0[1]), np.arctan2(-e1[0], e1[1])  # outward normals
        if a1 < a0:
            a1 += 2 * np.pi
        for t in np.linspace(a0, a1, n):
            out.append(cur + r * np.array([np.cos(t), np.sin(t)]))
    return np.array(out)


def spheropolygon() -> Path:
    """A spheropolygon (core polygon ⊕ disk) and a vertex–edge contact with its overlap."""
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    core_a = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.8], [0.0, 0.8]])
    r = 0.25
    ax.add_patch(Polygon(_dilate(core_a, r), fc="0.85", ec="0.3"))
    ax.add_patch(Polygon(core_a, fill=False, ec="k", ls="--"))
    ang = np.deg2rad(np.arange(5) * 72 + 90)
    core_b = np.c_[0.55 * np.cos(ang), 0.55 * np.sin(ang)] + [1.1, 1.95]
    core_b = (core_b - [1.1, 1.95]) @ np.array([[np.cos(0.6), np.sin(0.6)], [-np.sin(0.6), np.cos(0.6)]]) + [1.1, 1.95]
    shift = [0.0, -(core_b[:, 1].min() - (0.8 + 2 * r)) - 0.08]
    core_b = core_b + shift
    ax.add_patch(Polygon(_dilate(core_b, r), fc="tab:orange", alpha=0.5, ec="tab:orange"))
    ax.add_patch(Polygon(core_b, fill=False, ec="k", ls="--"))
    v = core_b[np.argmin(core_b[:, 1])]
    ax.add_patch(Circle(v, r, fill=False, ec="tab:red"))
    ax.plot([v[0], v[0]], [0.8, v[1]], color="tab:red", lw=1.5)
    ax.annotate("vertex of B's core within r_A + r_B of A's edge:\noverlap ξ = r_A + r_B − d, normal "
                "force k_n ξ + dashpot,\ntangential spring capped at μ F_n", (v[0], 0.95), (2.5, 1.6), fontsize=9,
                arrowprops={"arrowstyle": "->"})
    ax.annotate("core polygon (dashed) ⊕ disk of radius r", (1.8, 0.4), (2.5, 0.2), fontsize=9,
                arrowprops={"arrowstyle": "->"})
    ax.set_xlim(-0.5, 5.6)
    ax.set_ylim(-0.4, 3.0)
    ax.set_aspect("equal")
    ax.axis("off")
    return _save(fig, "spheropolygon.png")


def coupled_step() -> Path:
    """The order of one coupled step (MPM-SDEM §4.2)."""
    stages = ["body–body contacts\n(DEM forces)", "point–body contacts\n(identified material points)",
              "P2G\n(contact forces as nodal loads)", "grid update", "G2P", "rigid-body update\n(reactions, torques)"]
    fig, ax = plt.subplots(figsize=(10.5, 1.9))
    for i, s in enumerate(stages):
        x = i * 1.75
        ax.add_patch(plt.Rectangle((x, 0), 1.5, 1, fc="tab:orange" if i in (0, 5) else
                                   ("tab:purple" if i == 1 else "tab:blue"), alpha=0.3, ec="0.3"))
        ax.text(x + 0.75, 0.5, s, ha="center", va="center", fontsize=8)
        if i:
            ax.add_patch(FancyArrowPatch((x - 0.25, 0.5), (x, 0.5), arrowstyle="-|>", mutation_scale=10))
    ax.set_xlim(-0.1, len(stages) * 1.75)
    ax.set_ylim(-0.1, 1.1)
    ax.axis("off")
    return _save(fig, "coupled_step.png")


if __name__ == "__main__":
    for make in (mpm_step, shape_functions, grid_layers, spheropolygon, coupled_step):
        print(make())
