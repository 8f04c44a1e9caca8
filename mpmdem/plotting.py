"""Quick-look PNGs of a run file: energy and momentum histories, particle snapshots.

Pure matplotlib (Agg backend), so it works on a headless machine and never touches Warp.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .io import RunFile

__all__ = ["SNAPSHOT_FIELDS", "plot_run"]


def _speed(rf: RunFile, k: int) -> np.ndarray:
    return np.linalg.norm(np.asarray(rf.field("v", k), dtype=np.float64), axis=1)


def _stress(i: int, j: int) -> Callable[[RunFile, int], np.ndarray]:
    def get(rf: RunFile, k: int) -> np.ndarray:
        return np.asarray(rf.field("stress", k)[:, i, j], dtype=np.float64)

    return get


def _pressure(rf: RunFile, k: int) -> np.ndarray:
    s = np.asarray(rf.field("stress", k), dtype=np.float64)
    return -0.5 * (s[:, 0, 0] + s[:, 1, 1])


def _plain(name: str) -> Callable[[RunFile, int], np.ndarray]:
    def get(rf: RunFile, k: int) -> np.ndarray:
        return np.asarray(rf.field(name, k), dtype=np.float64)

    return get


def _jacobian(rf: RunFile, k: int) -> np.ndarray:
    return np.linalg.det(np.asarray(rf.field("F", k), dtype=np.float64))


#: Colour fields of a snapshot: name → (extractor, colourbar label with units).
SNAPSHOT_FIELDS: dict[str, tuple[Callable[[RunFile, int], np.ndarray], str]] = {
    "speed": (_speed, "speed |v| [m/s]"),
    "stress_xx": (_stress(0, 0), "stress σxx [Pa]"),
    "stress_yy": (_stress(1, 1), "stress σyy [Pa]"),
    "stress_xy": (_stress(0, 1), "stress σxy [Pa]"),
    "pressure": (_pressure, "pressure −(σxx+σyy)/2 [Pa]"),
    "volume": (_plain("volume"), "volume per unit thickness [m²]"),
    "mass": (_plain("mass"), "mass per unit thickness [kg/m]"),
    "body": (_plain("body"), "body index [-]"),
    "J": (_jacobian, "J = det F [-]"),
}


def plot_run(
    path: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    field: str = "speed",
    frames: list[int] | None = None,
) -> list[Path]:
    """Write quick-look PNGs of a run file.

    Writes ``energy.png`` (every diagnostic named ``energy_*`` against time, J/m),
    ``momentum.png`` (every ``momentum_*`` diagnostic) and ``snapshot_<frame:04d>.png`` for each
    chosen frame: the particles at their positions, coloured by ``field``.

    Args:
        path: The HDF5 run file (also one left by a crashed run).
        out_dir: Folder for the PNGs (created if missing).
        field: Snapshot colour: one of ``SNAPSHOT_FIELDS`` (speed, stress_xx, stress_yy,
            stress_xy, pressure, volume, mass, body, J).
        frames: Frame indices to draw (negative counts from the end); None draws the first,
            middle and last frame.

    Returns:
        Paths of the PNGs written, energy and momentum first, then the snapshots.

    Raises:
        ValueError: unknown field, or a frame index out of range.
    """
    if field not in SNAPSHOT_FIELDS:
        raise ValueError(f"unknown field {field!r}; allowed: {', '.join(SNAPSHOT_FIELDS)}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    with RunFile(path) as rf:
        n_frames = rf.frame_count
        if frames is None:
            chosen = sorted({0, (n_frames - 1) // 2, n_frames - 1}) if n_frames else []
        else:
            chosen = []
            for k in frames:
                kk = int(k) + n_frames if int(k) < 0 else int(k)
                if not 0 <= kk < n_frames:
                    raise ValueError(f"frame {k} out of range for a run of {n_frames} frame(s)")
                if kk not in chosen:
                    chosen.append(kk)
        times = rf.times
        diags = rf.diagnostics

        for prefix, fname, ylabel in (
            ("energy_", "energy.png", "energy per unit thickness [J/m]"),
            ("momentum_", "momentum.png", "momentum per unit thickness [N·s/m]"),
        ):
            fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
            names = [k for k in diags if k.startswith(prefix)]
            for k in names:
                ax.plot(times, diags[k][: len(times)], label=k, marker="." if len(times) < 50 else None)
            if names:
                ax.legend(fontsize="small")
            else:
                ax.text(0.5, 0.5, f"no {prefix}* diagnostics", ha="center", va="center",
                        transform=ax.transAxes)
            ax.set_xlabel("time [s]")
            ax.set_ylabel(ylabel)
            ax.set_title(f"{prefix.rstrip('_')}: {Path(path).name}")
            ax.grid(True, alpha=0.3)
            p = out / fname
            fig.savefig(p, dpi=120)
            plt.close(fig)
            written.append(p)

        get, label = SNAPSHOT_FIELDS[field]
        for k in chosen:
            x = np.asarray(rf.field("x", k), dtype=np.float64)
            c = get(rf, k)
            try:
                vol = np.asarray(rf.field("volume", k), dtype=np.float64)
            except KeyError:
                vol = None
            png = out / f"snapshot_{k:04d}.png"
            written.append(_snapshot(plt, png, x, c, vol, label, field, k, float(times[k])))
    return written


def _snapshot(plt, path: Path, x: np.ndarray, c: np.ndarray, vol: np.ndarray | None,
              label: str, field: str, frame: int, t: float) -> Path:
    """Scatter particles at x coloured by c, marker size from the particle volume; save to path."""
    placed = np.isfinite(x).all(axis=1)  # a blown-up run may hold non-finite positions
    x, c = x[placed], c[placed]
    vol = vol[placed] if vol is not None else None
    n = len(x)
    aspect = 0.75
    if n:
        lo, hi = x.min(axis=0), x.max(axis=0)
        if vol is not None and np.all(np.isfinite(vol)) and np.any(vol > 0):
            d = np.sqrt(np.clip(vol, 0.0, None))  # side of the square each particle stands for [m]
        else:
            extent = float(np.prod(np.maximum(hi - lo, 1e-12)))
            d = np.full(n, np.sqrt(extent / n))
        pad = max(float(np.max(d)), 1e-9 * max(float(np.max(np.abs(x))), 1.0))
        aspect = float((hi[1] - lo[1] + 2 * pad) / (hi[0] - lo[0] + 2 * pad))
    # Fixed axes (no automatic layout) so the data → points scale used for the marker size is final;
    # the figure height follows the data's aspect ratio to limit empty margins.
    ax_w = 5.0
    ax_h = min(max(ax_w * aspect, 2.0), 8.0)
    fig_w, fig_h = 7.6, ax_h + 1.4
    fig = plt.figure(figsize=(fig_w, fig_h))
    ax = fig.add_axes((0.9 / fig_w, 0.7 / fig_h, ax_w / fig_w, ax_h / fig_h))
    if n:
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal", adjustable="box")
        ax.apply_aspect()
        p0, p1 = ax.transData.transform([(0.0, 0.0), (1.0, 0.0)])
        points_per_m = abs(p1[0] - p0[0]) * 72.0 / fig.dpi
        sizes = (d * points_per_m) ** 2
        finite = np.isfinite(c)
        kw = {}
        if field == "body":
            kw["cmap"] = "tab10"
            if finite.any():
                kw.update(vmin=float(np.nanmin(c)) - 0.5, vmax=float(np.nanmin(c)) + 9.5)
        else:
            kw["cmap"] = "viridis"
        sc = ax.scatter(x[finite, 0], x[finite, 1], c=c[finite], s=sizes[finite], marker="s",
                        linewidths=0, **kw)
        if (~finite).any():
            ax.scatter(x[~finite, 0], x[~finite, 1], s=sizes[~finite], marker="x", color="red",
                       linewidths=0.5, label="non-finite")
            ax.legend(loc="upper right", fontsize="small")
        pos = ax.get_position()
        cax = fig.add_axes((pos.x1 + 0.2 / fig_w, pos.y0, 0.2 / fig_w, pos.height))
        fig.colorbar(sc, cax=cax, label=label)
    else:
        ax.text(0.5, 0.5, "no particles with finite positions", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{field} at t = {t:.6g} s (frame {frame})")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
