"""Quick-look PNGs of a run file: energy and momentum histories, particle and body snapshots.

Pure matplotlib (Agg backend) and shapely, so it works on a headless machine and never touches Warp.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..model.outlines import body_outlines
from . import RunFile

__all__ = ["BODY_SNAPSHOT_FIELDS", "SNAPSHOT_FIELDS", "body_outlines", "plot_run"]


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


#: Colour fields of the particles in a snapshot: name → (extractor, colourbar label with units).
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


def _body_norm(name: str) -> Callable[[RunFile, int], np.ndarray]:
    def get(rf: RunFile, k: int) -> np.ndarray:
        return np.linalg.norm(np.asarray(rf.body_field(name, k), dtype=np.float64).reshape(rf.body_count, -1), axis=1)

    return get


def _body_plain(name: str) -> Callable[[RunFile, int], np.ndarray]:
    def get(rf: RunFile, k: int) -> np.ndarray:
        return np.asarray(rf.body_field(name, k), dtype=np.float64).reshape(rf.body_count)

    return get


#: Colour fields of the rigid bodies in a snapshot: name → (extractor, colourbar label with units).
#: A snapshot field that is not listed here draws the (non-fixed) bodies in a single colour.
BODY_SNAPSHOT_FIELDS: dict[str, tuple[Callable[[RunFile, int], np.ndarray], str]] = {
    "speed": (_body_norm("v"), "speed |v| [m/s]"),
    "omega": (_body_plain("omega"), "angular velocity ω [rad/s]"),
    "angle": (_body_plain("angle"), "rotation angle [rad]"),
    "force": (_body_norm("force"), "contact force |F| [N/m]"),
    "torque": (_body_plain("torque"), "contact torque [N·m/m]"),
}

#: Face colours of bodies: fixed ones, and moving ones when the field is not a body quantity.
FIXED_BODY_COLOR = "0.65"
BODY_COLOR = "#d9a05b"
PARTICLE_COLOR = "tab:blue"


def _allowed_fields() -> list[str]:
    return [*SNAPSHOT_FIELDS, *(k for k in BODY_SNAPSHOT_FIELDS if k not in SNAPSHOT_FIELDS)]


def _geometry_path(geom) -> object | None:
    """A matplotlib Path (holes included) of a shapely (Multi)Polygon; None when empty."""
    from matplotlib.path import Path as MplPath
    from shapely.geometry.polygon import orient

    if geom is None or geom.is_empty:
        return None
    polys = getattr(geom, "geoms", [geom])
    rings = []
    for p in polys:
        if p.geom_type != "Polygon" or p.is_empty:
            continue
        p = orient(p, 1.0)
        rings.append(MplPath(np.asarray(p.exterior.coords)[:, :2], closed=True))
        rings += [MplPath(np.asarray(r.coords)[:, :2], closed=True) for r in p.interiors]
    return MplPath.make_compound_path(*rings) if rings else None


@dataclass
class _BodyDraw:
    """The bodies of one snapshot: outline paths, colour values (None: single colour), fixed flags."""

    paths: list
    values: np.ndarray | None
    fixed: np.ndarray
    lo: np.ndarray | None
    hi: np.ndarray | None


def _bodies_of_frame(rf: RunFile, k: int, geometry: dict, field: str, rows: int | None = None) -> _BodyDraw | None:
    """Outlines and colours of the bodies at frame k (the first ``rows`` of them: the others are
    grains, drawn as disks; None: all); None when the file has no drawable bodies."""
    m = rf.body_count if rows is None else rows
    if m == 0 or "x" not in rf.body_fields or len(geometry["vertex_count"]) != m:
        return None
    x = np.asarray(rf.body_field("x", k), dtype=np.float64)[:m]
    angle = rf.body_field("angle", k)[:m] if "angle" in rf.body_fields else None
    geoms = body_outlines(geometry, x, angle)
    values = None
    if field in BODY_SNAPSHOT_FIELDS:
        try:
            values = BODY_SNAPSHOT_FIELDS[field][0](rf, k)[:m]
        except KeyError:  # this file has no such body field
            values = None
    motion = np.asarray(geometry["motion"])
    keep, paths = [], []
    for i, g in enumerate(geoms):
        p = _geometry_path(g)
        if p is not None:
            keep.append(i)
            paths.append(p)
    keep = np.asarray(keep, dtype=np.int64)
    if paths:
        allv = np.concatenate([p.vertices for p in paths])
        lo, hi = allv.min(axis=0), allv.max(axis=0)
    else:
        lo = hi = None
    return _BodyDraw(
        paths=paths,
        values=values[keep] if values is not None else None,
        fixed=(motion[keep] == 1) if len(motion) == m else np.zeros(len(keep), bool),
        lo=lo,
        hi=hi,
    )


#: Grains whose mean diameter is below this many pixels are drawn as an image (``grain_image``):
#: disks under a pixel each cost as much to draw and show nothing more (10⁶ disks: 4.3 s a frame).
GRAIN_PIXELS = 1.5

def split_grains(geometry: dict | None) -> tuple[dict | None, int, np.ndarray | None]:
    """(the geometry of the bodies drawn as outlines, how many they are, the grains' radii [m] or
    None): grains (``grain`` 1 in the geometry, the last bodies) are drawn as disks."""
    if geometry is None:
        return None, 0, None
    m = len(geometry["vertex_count"])
    grain = np.asarray(geometry.get("grain", np.zeros(m)), dtype=bool)
    rows = m - int(np.count_nonzero(grain))
    if rows == m:
        return geometry, m, None
    outlined = {k: (v if k == "vertices" else v[:rows]) for k, v in geometry.items()} if rows else None
    # a disk's radius; a polygon grain's sphero radius + the mean distance of its core vertices
    start = np.asarray(geometry["vertex_start"])[rows:]
    count = np.asarray(geometry["vertex_count"])[rows:]
    norms = np.hypot(*np.asarray(geometry["vertices"], dtype=np.float64)[start[0]:].T)
    core = np.add.reduceat(norms, start - start[0]) / count
    return outlined, rows, np.asarray(geometry["radius"], dtype=np.float64)[rows:] + core


def _grains_of_frame(rf: RunFile, k: int, rows: int, field: str) -> tuple[np.ndarray, np.ndarray | None]:
    """(centroids [m] of the grains at frame k, their values of ``field`` or None)."""
    x = np.asarray(rf.body_field("x", k), dtype=np.float64)[rows:]
    values = None
    if field in BODY_SNAPSHOT_FIELDS:
        try:
            values = np.asarray(BODY_SNAPSHOT_FIELDS[field][0](rf, k), dtype=np.float64)[rows:]
        except KeyError:
            values = None
    return x, values


def grain_image(x: np.ndarray, values: np.ndarray | None, lo, hi, shape: tuple[int, int]) -> np.ma.MaskedArray:
    """(ny, nx) image of grains at x (n, 2) [m] over the box lo–hi [m], ``shape`` (nx, ny) pixels:
    each pixel holding grain centres shows their mean value (1 when ``values`` is None), the
    others masked. O(n): how ``animate`` and ``plot`` draw grains smaller than GRAIN_PIXELS pixels."""
    ok = np.isfinite(x).all(axis=1)
    v = np.ones(int(ok.sum())) if values is None else np.asarray(values, dtype=np.float64)[ok]
    keep = np.isfinite(v)
    x, v = x[ok][keep], v[keep]
    nx, ny = shape
    i = np.floor((x[:, 0] - lo[0]) / (hi[0] - lo[0]) * nx).astype(np.int64)
    j = np.floor((x[:, 1] - lo[1]) / (hi[1] - lo[1]) * ny).astype(np.int64)
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    cell = j[inside] * nx + i[inside]
    count = np.bincount(cell, minlength=nx * ny).reshape(ny, nx)
    total = np.bincount(cell, weights=v[inside], minlength=nx * ny).reshape(ny, nx)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.ma.masked_where(count == 0, total / count)


def plot_run(
    path: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    field: str = "speed",
    frames: list[int] | None = None,
) -> list[Path]:
    """Write quick-look PNGs of a run file.

    Writes ``energy.png`` (two panels against time, J/m: every diagnostic named ``energy_*``, the
    total in black; every ``work_*``, grouped by what does the work, ``ENERGY_GROUPS``, the balance's
    residual ``work_numerical`` in black; the legends outside), ``momentum.png`` (every
    ``momentum_*`` diagnostic; angular ones on a second axis when linear ones exist too) and
    ``snapshot_<frame:04d>.png`` for each chosen frame: the particles at their positions coloured
    by ``field``, and the rigid bodies (if any) as filled rounded polygons: fixed ones grey, the
    others coloured by ``field`` when it is a body quantity (``BODY_SNAPSHOT_FIELDS``) and in a
    single colour otherwise.

    Args:
        path: The HDF5 run file (also one left by a crashed run).
        out_dir: Folder for the PNGs (created if missing).
        field: Snapshot colour: one of ``SNAPSHOT_FIELDS`` (speed, stress_xx, stress_yy,
            stress_xy, pressure, volume, mass, body, J) or of ``BODY_SNAPSHOT_FIELDS`` (speed,
            omega, angle, force, torque). A field of one kind only leaves the other kind in a
            single colour.
        frames: Frame indices to draw (negative counts from the end); None draws the first,
            middle and last frame.

    Returns:
        Paths of the PNGs written, energy and momentum first, then the snapshots.

    Raises:
        ValueError: unknown field, or a frame index out of range.
    """
    if field not in SNAPSHOT_FIELDS and field not in BODY_SNAPSHOT_FIELDS:
        raise ValueError(f"unknown field {field!r}; allowed: {', '.join(_allowed_fields())}")
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

        written.append(_energy_history(plt, out / "energy.png", times, diags, Path(path).name))
        written.append(_history(plt, out / "momentum.png", times, diags, ("momentum_",), ("angular",),
                                "momentum per unit thickness [N·s/m]", "momentum", Path(path).name,
                                twin_label="angular momentum per unit thickness [N·m·s/m]"))

        has_particles = rf.particle_count > 0 and "x" in rf.fields
        outlined, rows, grain_radius = split_grains(rf.body_geometry() if rf.body_count else None)
        for k in chosen:
            if has_particles:
                x = np.asarray(rf.field("x", k), dtype=np.float64)
                c = SNAPSHOT_FIELDS[field][0](rf, k) if field in SNAPSHOT_FIELDS else None
                try:
                    vol = np.asarray(rf.field("volume", k), dtype=np.float64)
                except KeyError:
                    vol = None
            else:
                x, c, vol = np.zeros((0, 2)), None, None
            bodies = _bodies_of_frame(rf, k, outlined, field, rows) if outlined is not None else None
            grains = (*_grains_of_frame(rf, k, rows, field), grain_radius) if grain_radius is not None else None
            png = out / f"snapshot_{k:04d}.png"
            written.append(_snapshot(plt, png, x, c, vol, field, k, float(times[k]), bodies, grains))
    return written


#: The groups of energy.png: (prefix of the diagnostic names, panel 0 energies / 1 works, the
#: group's name in the legend, its line style), the first matching prefix wins. In a panel every
#: curve has a colour of its own; the line style tells its group.
ENERGY_GROUPS = (
    ("energy_total", 0, "total", "-"),
    ("energy_contact", 0, "contact", "-."),
    ("energy_imp", 0, "contact", "-."),
    ("energy_", 0, "", "--"),
    ("work_numerical", 1, "balance residual", ":"),
    ("work_imp_", 1, "points on bodies", "-."),
    ("work_contact_", 1, "DEM bodies", "--"),
    ("work_driven", 1, "DEM bodies", "--"),
    ("work_", 1, "MPM points", "-"),
)
#: the curves drawn in black (and thicker): what the others add up to
ENERGY_BLACK = ("energy_total", "work_numerical")


def _energy_group(name: str) -> tuple[int, int, str, str]:
    """(rank in ENERGY_GROUPS, panel, group, line style) of an ``energy_*`` or ``work_*`` diagnostic."""
    for rank, (prefix, panel, group, style) in enumerate(ENERGY_GROUPS):
        if name.startswith(prefix):
            return rank, panel, group, style
    raise KeyError(name)


def _legend_outside(ax, handles, *, below: bool = False) -> None:
    """The legend right of the axes (``below``: under the figure, for axes with a right y axis),
    where it covers no curve."""
    if below:
        ax.figure.legend(handles=handles, fontsize="small", loc="outside lower center", ncols=min(len(handles), 3))
    else:
        ax.legend(handles=handles, fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


def _energy_history(plt, path: Path, times: np.ndarray, diags: dict[str, np.ndarray], run_name: str) -> Path:
    """energy.png: the energies [J/m] (top) and the works since the start [J/m] (bottom) against
    time [s], grouped by ``ENERGY_GROUPS``, each legend right of its panel."""
    names = [k for k in diags if k.startswith(("energy_", "work_"))]
    panels = [[k for k in names if _energy_group(k)[1] == p] for p in (0, 1)]
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True, layout="constrained")
    marker = "." if len(times) < 50 else None
    for ax, panel, ylabel in zip(axes, panels, ("energy [J/m]", "work since the start [J/m]"), strict=True):
        handles = []
        # (in the order of ENERGY_GROUPS, so that a legend lists a group's curves together)
        order = sorted(panel, key=lambda k: _energy_group(k)[0])
        colours = iter(f"C{i % 10}" for i in range(len(order)))
        for k in order:
            _, _, group, style = _energy_group(k)
            black = k in ENERGY_BLACK
            short = k.split("_", 1)[1].replace("_", " ")
            label = group if black else (f"{group}: {short}" if group and not short.startswith(group) else short)
            (h,) = ax.plot(times, diags[k][: len(times)], style, color="black" if black else next(colours),
                           lw=2.0 if black else 1.4, label=label, marker=marker)
            handles.append(h)
        if handles:
            _legend_outside(ax, handles)
        else:
            ax.text(0.5, 0.5, "none in this run", ha="center", va="center", transform=ax.transAxes)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(f"energy per unit thickness: {run_name}")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _history(plt, path: Path, times: np.ndarray, diags: dict[str, np.ndarray], prefixes: tuple[str, ...],
             twin_keys: tuple[str, ...], ylabel: str, title: str, run_name: str,
             twin_label: str = "") -> Path:
    """Plot the diagnostics whose names start with one of prefixes against time; save to path.

    Names after the first prefix are dashed; names containing one of twin_keys go on a second
    y axis (labelled twin_label) when other names exist too.
    """
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    names = [k for k in diags if k.startswith(prefixes)]
    twin_names = [k for k in names if any(t in k for t in twin_keys)]
    if len(twin_names) == len(names):
        twin_names = []
    marker = "." if len(times) < 50 else None
    handles = []
    ax2 = ax.twinx() if twin_names else None
    for i, k in enumerate(names):
        target = ax2 if k in twin_names else ax
        style = "-" if k.startswith(prefixes[0]) else "--"
        color = f"C{i % 10}"
        label = f"{k} (right axis)" if target is ax2 else k
        (h,) = target.plot(times, diags[k][: len(times)], style, color=color, label=label, marker=marker)
        handles.append(h)
    if names:
        _legend_outside(ax, handles, below=ax2 is not None)
    else:
        ax.text(0.5, 0.5, f"no {'/'.join(p + '*' for p in prefixes)} diagnostics", ha="center", va="center",
                transform=ax.transAxes)
    if ax2 is not None:
        ax2.set_ylabel(twin_label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(f"{title}: {run_name}")
    ax.grid(True, alpha=0.3)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _snapshot(plt, path: Path, x: np.ndarray, c: np.ndarray | None, vol: np.ndarray | None, field: str,
              frame: int, t: float, bodies: _BodyDraw | None = None, grains: tuple | None = None) -> Path:
    """Draw the particles at x (coloured by c, or one colour when c is None; marker size from the
    particle volume), the bodies (filled outlines) and the grains ((centroids [m], values or None,
    radii [m]): disks, or an image of pixel means below GRAIN_PIXELS pixels); save to path."""
    from matplotlib.collections import EllipseCollection, PatchCollection
    from matplotlib.colors import ListedColormap, Normalize
    from matplotlib.patches import PathPatch

    placed = np.isfinite(x).all(axis=1)  # a blown-up run may hold non-finite positions
    x = x[placed]
    c = c[placed] if c is not None else None
    vol = vol[placed] if vol is not None else None
    n = len(x)
    nb = len(bodies.paths) if bodies is not None else 0
    body_values = bodies.values if bodies is not None else None
    lo = hi = None
    d = np.zeros(0)
    pad = 0.0
    if n:
        lo, hi = x.min(axis=0), x.max(axis=0)
        if vol is not None and np.all(np.isfinite(vol)) and np.any(vol > 0):
            d = np.sqrt(np.clip(vol, 0.0, None))  # side of the square each particle stands for [m]
        else:
            extent = float(np.prod(np.maximum(hi - lo, 1e-12)))
            d = np.full(n, np.sqrt(extent / n))
        pad = float(np.max(d))
        lo, hi = lo - pad, hi + pad
    if nb and bodies.lo is not None:
        lo = bodies.lo if lo is None else np.minimum(lo, bodies.lo)
        hi = bodies.hi if hi is None else np.maximum(hi, bodies.hi)
    grain_values = None
    if grains is not None:
        gx, grain_values, gr = grains
        ok = np.isfinite(gx).all(axis=1)
        if ok.any():
            glo, ghi = (gx[ok] - gr[ok, None]).min(axis=0), (gx[ok] + gr[ok, None]).max(axis=0)
            lo = glo if lo is None else np.minimum(lo, glo)
            hi = ghi if hi is None else np.maximum(hi, ghi)
    aspect = 0.75
    if lo is not None:
        span = float(np.max(hi - lo))
        margin = max(0.02 * span, 1e-9 * max(float(np.max(np.abs(np.concatenate([lo, hi])))), 1.0))
        lo, hi = lo - margin, hi + margin
        aspect = float((hi[1] - lo[1]) / (hi[0] - lo[0]))
    # Fixed axes (no automatic layout) so the data → points scale used for the marker size is final;
    # the figure height follows the data's aspect ratio to limit empty margins.
    ax_w = 5.0
    ax_h = min(max(ax_w * aspect, 2.0), 8.0)
    fig_w, fig_h = 7.6, ax_h + 1.4
    fig = plt.figure(figsize=(fig_w, fig_h))
    ax = fig.add_axes((0.9 / fig_w, 0.7 / fig_h, ax_w / fig_w, ax_h / fig_h))
    if lo is not None:
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.apply_aspect()
        # One colour scale for everything coloured by the field (particles and bodies share "speed").
        kw: dict = {}
        finite_vals = [v[np.isfinite(v)] for v in (c, body_values, grain_values) if v is not None]
        finite_vals = np.concatenate(finite_vals) if finite_vals else np.zeros(0)
        if field == "body" and c is not None:
            kw["cmap"] = "tab10"
            if finite_vals.size:
                kw["norm"] = Normalize(float(finite_vals.min()) - 0.5, float(finite_vals.min()) + 9.5)
        else:
            kw["cmap"] = "viridis"
            if finite_vals.size:
                kw["norm"] = Normalize(float(finite_vals.min()), float(finite_vals.max()))
        mappable = None
        label = ""
        if nb:
            fixed = bodies.fixed
            patches = [PathPatch(p) for p in bodies.paths]
            fixed_patches = [p for p, f in zip(patches, fixed, strict=True) if f]
            if fixed_patches:
                ax.add_collection(PatchCollection(fixed_patches, facecolor=FIXED_BODY_COLOR, edgecolor="0.3",
                                                  linewidths=0.5, zorder=1))
            free = np.flatnonzero(~fixed)
            if free.size:
                free_patches = [patches[i] for i in free]
                if body_values is not None:
                    v = body_values[free]
                    ok = np.isfinite(v)
                    coll = PatchCollection([free_patches[i] for i in np.flatnonzero(ok)], edgecolor="k",
                                           linewidths=0.4, zorder=1, **kw)
                    coll.set_array(v[ok])
                    ax.add_collection(coll)
                    if ok.any():
                        mappable, label = coll, BODY_SNAPSHOT_FIELDS[field][1]
                    if (~ok).any():
                        ax.add_collection(PatchCollection([free_patches[i] for i in np.flatnonzero(~ok)],
                                                          facecolor="white", edgecolor="red", linewidths=0.8,
                                                          zorder=1))
                else:
                    ax.add_collection(PatchCollection(free_patches, facecolor=BODY_COLOR, edgecolor="k",
                                                      linewidths=0.4, zorder=1))
        if grains is not None:
            p0, p1 = ax.transData.transform([(0.0, 0.0), (1.0, 0.0)])
            pixels_per_m = abs(p1[0] - p0[0])
            colours = kw if grain_values is not None and "norm" in kw else {}
            if 2.0 * float(np.mean(gr)) * pixels_per_m >= GRAIN_PIXELS:
                d = 2.0 * gr
                coll = EllipseCollection(d, d, np.zeros(len(d)), units="xy",
                                         offsets=np.where(np.isfinite(gx), gx, np.nan), offset_transform=ax.transData,
                                         linewidths=0, zorder=1.5, **colours)
                if colours:
                    coll.set_array(np.ma.masked_invalid(grain_values))
                else:
                    coll.set_facecolor(BODY_COLOR)
                ax.add_collection(coll)
            else:
                box = ax.get_window_extent()
                shape = (max(1, round(box.width)), max(1, round(box.height)))
                image = grain_image(gx, grain_values if colours else None, lo, hi, shape)
                coll = ax.imshow(image, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), interpolation="nearest",
                                 aspect="auto", zorder=1.5, **(colours or {"cmap": ListedColormap([BODY_COLOR]),
                                                                         "norm": Normalize(0.0, 1.0)}))
            if colours and mappable is None:
                mappable, label = coll, BODY_SNAPSHOT_FIELDS[field][1]
        if n:
            p0, p1 = ax.transData.transform([(0.0, 0.0), (1.0, 0.0)])
            points_per_m = abs(p1[0] - p0[0]) * 72.0 / fig.dpi
            sizes = (d * points_per_m) ** 2
            if c is not None:
                finite = np.isfinite(c)
                sc = ax.scatter(x[finite, 0], x[finite, 1], c=c[finite], s=sizes[finite], marker="s",
                                linewidths=0, zorder=2, **kw)
                mappable, label = sc, SNAPSHOT_FIELDS[field][1]
                if (~finite).any():
                    ax.scatter(x[~finite, 0], x[~finite, 1], s=sizes[~finite], marker="x", color="red",
                               linewidths=0.5, label="non-finite", zorder=3)
                    ax.legend(loc="upper right", fontsize="small")
            else:
                ax.scatter(x[:, 0], x[:, 1], color=PARTICLE_COLOR, s=sizes, marker="s", linewidths=0, zorder=2)
        if mappable is not None:
            pos = ax.get_position()
            cax = fig.add_axes((pos.x1 + 0.2 / fig_w, pos.y0, 0.2 / fig_w, pos.height))
            fig.colorbar(mappable, cax=cax, label=label)
    else:
        ax.text(0.5, 0.5, "no particles or bodies with finite positions", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{field} at t = {t:.6g} s (frame {frame})")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
