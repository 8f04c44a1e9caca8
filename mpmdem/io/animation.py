"""Animations of a run file: the points coloured by a field, the bodies as their outlines, a time stamp.

Matplotlib's ``FuncAnimation`` (Agg backend) with its ffmpeg writer for MP4 or its Pillow writer
for GIF; the colour fields are those of ``mpmdem plot`` (``mpmdem.io.plotting``).
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from . import RunFile
from .plotting import (
    BODY_COLOR,
    BODY_SNAPSHOT_FIELDS,
    FIXED_BODY_COLOR,
    GRAIN_PIXELS,
    SNAPSHOT_FIELDS,
    _allowed_fields,
    _bodies_of_frame,
    _grains_of_frame,
    grain_image,
    split_grains,
)

__all__ = ["FORMATS", "animate_run", "parse_frames"]

#: Output formats by suffix: the matplotlib writer each needs.
FORMATS = {".mp4": "ffmpeg", ".gif": "pillow"}


def parse_frames(text: str | None, frame_count: int) -> list[int]:
    """The frame indices a ``--frames`` value selects.

    Args:
        text: None (every frame), a slice ``START:STOP[:STEP]`` (Python's rules, parts may be empty:
            ``::5`` every fifth frame) or comma-separated indices (negative count from the end).
        frame_count: Frames in the run.

    Raises:
        InputError: unparsable text, a zero step, an index out of range or an empty selection.
    """
    if text is None:
        chosen = list(range(frame_count))
    else:
        allowed = f"START:STOP[:STEP] or comma-separated frame numbers, within the run's {frame_count} frame(s)"
        try:
            if ":" in text:
                parts = [int(p) if p.strip() else None for p in text.split(":")]
                if len(parts) > 3 or parts[2:3] == [0]:
                    raise ValueError
                chosen = list(range(frame_count))[slice(*parts)]
            else:
                chosen = [int(p) for p in text.split(",")]
        except ValueError:
            raise InputError("frames", text, allowed) from None
        if any(not -frame_count <= k < frame_count for k in chosen):
            raise InputError("frames", text, allowed)
        chosen = [k % frame_count for k in chosen]
    if not chosen:
        raise InputError("frames", text, f"a selection of at least one frame (the run has {frame_count})")
    return chosen


def _output(path: Path, out: str | os.PathLike | None, field: str) -> tuple[Path, str]:
    """The file to write and its writer: ``out``'s suffix, else MP4 when ffmpeg is there and GIF otherwise."""
    from matplotlib import animation

    if out is None:
        suffix = ".mp4" if animation.writers.is_available("ffmpeg") else ".gif"
        return path.with_name(f"{path.stem}_{field}{suffix}"), FORMATS[suffix]
    target = Path(out)
    writer = FORMATS.get(target.suffix.lower())
    if writer is None:
        raise InputError("out", str(out), f"a file ending in {' or '.join(FORMATS)}")
    if not animation.writers.is_available(writer):
        raise InputError("out", str(out), f"a .gif: no {writer} writer here (install ffmpeg for MP4)")
    return target, writer


def _extent(rf: RunFile, frames: list[int], field: str, geometry: dict | None) -> tuple[np.ndarray, ...]:
    """Axis limits (lo, hi) [m] over the chosen frames, and the field's (min, max) there (NaN: none)."""
    geometry, rows, grain_radius = split_grains(geometry)
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    vmin, vmax = np.inf, -np.inf
    has_points = rf.particle_count > 0 and "x" in rf.fields
    for k in frames:
        values = []
        if has_points:
            x = np.asarray(rf.field("x", k), dtype=np.float64)
            x = x[np.isfinite(x).all(axis=1)]
            if len(x):
                lo, hi = np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0))
            if field in SNAPSHOT_FIELDS:
                values.append(SNAPSHOT_FIELDS[field][0](rf, k))
        bodies = _bodies_of_frame(rf, k, geometry, field, rows) if geometry is not None else None
        if bodies is not None and bodies.lo is not None:
            lo, hi = np.minimum(lo, bodies.lo), np.maximum(hi, bodies.hi)
            if bodies.values is not None:
                values.append(bodies.values[~bodies.fixed])
        if grain_radius is not None:
            x, v = _grains_of_frame(rf, k, rows, field)
            ok = np.isfinite(x).all(axis=1)
            if ok.any():
                lo = np.minimum(lo, (x[ok] - grain_radius[ok, None]).min(axis=0))
                hi = np.maximum(hi, (x[ok] + grain_radius[ok, None]).max(axis=0))
            if v is not None:
                values.append(v)
        finite = np.concatenate([np.ravel(v) for v in values] or [np.zeros(0)])
        finite = finite[np.isfinite(finite)]
        if finite.size:
            vmin, vmax = min(vmin, float(finite.min())), max(vmax, float(finite.max()))
    if not np.all(hi >= lo):
        lo, hi = np.zeros(2), np.ones(2)
    margin = 0.03 * max(float(np.max(hi - lo)), 1e-9)
    return lo - margin, hi + margin, np.array([vmin, vmax]) if vmax >= vmin else np.full(2, np.nan)


def animate_run(
    path: str | os.PathLike,
    out: str | os.PathLike | None = None,
    *,
    field: str = "speed",
    fps: float = 10.0,
    frames: str | None = None,
    dpi: int = 100,
) -> Path:
    """Write an animation of a run: one picture per chosen frame.

    The points are drawn as squares of their own size, coloured by ``field``; the bodies as filled
    outlines (fixed ones grey, the others coloured by ``field`` when it is a body quantity), grains
    as disks of their radius (one ``EllipseCollection``: a million grains are one artist); one
    colour scale over the whole animation; the simulated time in the title.

    Args:
        path: The HDF5 run file (also one left by a crashed run).
        out: The file to write, ``.mp4`` (needs ffmpeg) or ``.gif``; None gives
            ``<run>_<field>.mp4`` beside the run when ffmpeg is available, else ``.gif``.
        field: A colour field of ``mpmdem plot``: speed, stress_xx, stress_yy, stress_xy, pressure,
            volume, mass, body, J, or a body one (omega, angle, force, torque).
        fps: Frames per second of the animation (> 0).
        frames: Which frames, as ``parse_frames`` reads them (None: every frame).
        dpi: Resolution of the 6.4 x 4.8 inch pictures.

    Returns:
        The path written.

    Raises:
        InputError: missing or unreadable file, unknown field, bad fps, frames or output suffix.
    """
    path = Path(path)
    if field not in SNAPSHOT_FIELDS and field not in BODY_SNAPSHOT_FIELDS:
        raise InputError("field", field, f"one of {', '.join(_allowed_fields())}")
    if not (isinstance(fps, (int, float)) and np.isfinite(fps) and fps > 0):
        raise InputError("fps", fps, "a positive number of frames per second")
    if not path.is_file():
        raise InputError("FILE", str(path), "an existing mpmdem HDF5 run file")
    if not h5py.is_hdf5(path):
        raise InputError("FILE", str(path), "an mpmdem HDF5 run file (this one is not HDF5)")
    import matplotlib

    matplotlib.use("Agg")
    target, writer_name = _output(path, out, field)
    with RunFile(path) as rf:
        if rf.frame_count == 0:
            raise InputError("FILE", str(path), "a run file with at least one frame")
        chosen = parse_frames(frames, rf.frame_count)
        target.parent.mkdir(parents=True, exist_ok=True)
        _render(rf, chosen, field, fps, dpi, target, writer_name)
    return target


def _render(rf: RunFile, chosen: list[int], field: str, fps: float, dpi: int, target: Path, writer_name: str) -> None:
    """Draw the chosen frames of rf into target with matplotlib's writer ``writer_name``."""
    import matplotlib
    import matplotlib.pyplot as plt
    from matplotlib import animation
    from matplotlib.collections import EllipseCollection, PatchCollection
    from matplotlib.colors import ListedColormap, Normalize
    from matplotlib.patches import PathPatch

    geometry = rf.body_geometry() if rf.body_count else None
    lo, hi, (vmin, vmax) = _extent(rf, chosen, field, geometry)
    outlined, rows, grain_radius = split_grains(geometry)
    norm = Normalize(vmin, vmax) if np.isfinite(vmin) else None
    # Fixed bodies and non-finite values take the colour of fixed bodies.
    cmap = matplotlib.colormaps["tab10" if field == "body" else "viridis"].with_extremes(bad=FIXED_BODY_COLOR)
    times = rf.times
    has_points = rf.particle_count > 0 and "x" in rf.fields

    fig, ax = plt.subplots(figsize=(6.4, 4.8), layout="constrained")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    points = ax.scatter([], [], c=[], s=[], marker="s", linewidths=0, cmap=cmap, norm=norm, zorder=2)
    if norm is not None:
        label = (SNAPSHOT_FIELDS if field in SNAPSHOT_FIELDS and has_points else BODY_SNAPSHOT_FIELDS)[field][1]
        fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=label)
    fig.canvas.draw()  # fixes the layout, so the data → points scale below is final
    p0, p1 = ax.transData.transform([(0.0, 0.0), (1.0, 0.0)])
    points_per_m = abs(p1[0] - p0[0]) * 72.0 / fig.dpi
    drawn: list = []
    grains = pixels = None
    if grain_radius is not None:
        box = ax.get_window_extent()
        shape = (max(1, round(box.width)), max(1, round(box.height)))  # the axes in pixels
        if 2.0 * float(np.mean(grain_radius)) * points_per_m * fig.dpi / 72.0 >= GRAIN_PIXELS:
            d = 2.0 * grain_radius  # disks in data units: they scale with the axes
            grains = EllipseCollection(d, d, np.zeros(len(d)), units="xy", offsets=np.zeros((len(d), 2)),
                                       offset_transform=ax.transData, cmap=cmap, norm=norm, linewidths=0,
                                       zorder=1.5)
            ax.add_collection(grains)
        else:  # grains below a pixel or two (10⁶ of them): an image of the pixels' mean value
            pixels = ax.imshow(np.ma.masked_all(shape[::-1]), origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]),
                               cmap=cmap if norm is not None else ListedColormap([BODY_COLOR]),
                               norm=norm if norm is not None else Normalize(0.0, 1.0), interpolation="nearest",
                               aspect="auto", zorder=1.5)

    def draw(k: int) -> list:
        for artist in drawn:
            artist.remove()
        drawn.clear()
        if has_points:
            x = np.asarray(rf.field("x", k), dtype=np.float64)
            side = np.sqrt(np.clip(np.asarray(rf.field("volume", k), dtype=np.float64), 0.0, None)) \
                if "volume" in rf.fields else np.full(len(x), 0.01 * float(np.max(hi - lo)))
            ok = np.isfinite(x).all(axis=1) & np.isfinite(side)
            points.set_offsets(x[ok])
            points.set_sizes((side[ok] * points_per_m) ** 2)
            if field in SNAPSHOT_FIELDS:
                c = SNAPSHOT_FIELDS[field][0](rf, k)[ok]
                points.set_array(np.ma.masked_invalid(c))
            else:
                points.set_array(None)
                points.set_facecolor("tab:blue")
        if grains is not None:
            x, v = _grains_of_frame(rf, k, rows, field)
            grains.set_offsets(np.where(np.isfinite(x), x, np.nan))
            if v is not None and norm is not None:
                grains.set_array(np.ma.masked_invalid(v))
            else:
                grains.set_array(None)
                grains.set_facecolor(BODY_COLOR)
        if pixels is not None:
            x, v = _grains_of_frame(rf, k, rows, field)
            pixels.set_data(grain_image(x, v if norm is not None else None, lo, hi, shape))
        bodies = _bodies_of_frame(rf, k, outlined, field, rows) if outlined is not None else None
        if bodies is not None and bodies.paths:
            patches = PatchCollection([PathPatch(p) for p in bodies.paths], edgecolor="k", linewidths=0.5,
                                      zorder=1, cmap=cmap, norm=norm)
            if bodies.values is not None and norm is not None:
                patches.set_array(np.ma.masked_invalid(np.where(bodies.fixed, np.nan, bodies.values)))
            else:
                patches.set_facecolor([FIXED_BODY_COLOR if f else BODY_COLOR for f in bodies.fixed])
            ax.add_collection(patches)
            drawn.append(patches)
        ax.set_title(f"{rf.path.name}: {field}, t = {times[k]:.4g} s (frame {k})")
        return [points, *drawn, *(a for a in (grains, pixels) if a is not None)]

    anim = animation.FuncAnimation(fig, draw, frames=chosen, blit=False, repeat=False)
    writer = animation.writers[writer_name](fps=fps)
    try:
        anim.save(target, writer=writer, dpi=dpi)
    finally:
        plt.close(fig)
