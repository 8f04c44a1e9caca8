"""What a run will cost before it starts: its output size, its frame interval against the step,
and its step count (``mpmdem run`` checks them once the scene is built, before the first step).

* The frame interval (end time / frames) may not be below the stable step: the clock lands on
  every frame time, so a shorter interval would force a shorter step (and a frame per step).
* The output (the run file, its XDMF sidecars and energy.csv) is estimated from the points,
  bodies, frames, fields and bytes per value; above a limit — ``--max-output``, else 20 % of the
  free space of the output folder's disk — the run is refused with the estimate.
* A run whose step count would take more than an hour even at the fastest step measured on its
  kind of device is announced in one line with the estimate (it still runs).
"""

from __future__ import annotations

import argparse
import math
import shutil
from pathlib import Path

from ..errors import InputError
from ..io.format import PRECISIONS, default_body_field_specs, default_field_specs

__all__ = ["DISK_FRACTION", "check_frame_interval", "check_output_size", "estimate_output_bytes",
           "long_run_warning", "parse_size"]

#: the share of the output disk's free space a run may fill without --max-output
DISK_FRACTION = 0.2
#: bytes per frame besides the fields (~100 float64 diagnostics in HDF5 and CSV, the per-frame
#: virtual views and XDMF entries of the sidecars), and once per file (HDF5 metadata, the first
#: chunks): measured on axial-bar --quick (64 points, 40 and 160 frames: 14.3 kB a frame, of which
#: the points' fields are 3.8 kB; 0.2 MB besides)
FRAME_OVERHEAD_BYTES = 10_500
FILE_OVERHEAD_BYTES = 200_000
#: the world outline of a body in the XDMF view of each frame: ~64 points × 3 float64
OUTLINE_BYTES_PER_BODY = 64 * 3 * 8
#: a lower bound for any scene's GPU step [s], under the fastest step measured (normal-force,
#: bench/results/small_scenes/h100.jsonl; docs/benchmarks.md)
GPU_STEP_FLOOR_S = 25e-6
#: the fastest CPU rate measured: 4.3e6 point-steps per second, plain MPM on a dense column of
#: 16,200 points (bench/results/granular_overhead/cpu.jsonl)
CPU_POINT_STEPS_PER_S = 4.3e6
#: a run is announced when even its fastest step takes longer than this in all [s]
LONG_RUN_S = 3600.0

_UNITS = {"": 1, "B": 1, "K": 1e3, "KB": 1e3, "M": 1e6, "MB": 1e6, "G": 1e9, "GB": 1e9, "T": 1e12, "TB": 1e12}


def _field_bytes(specs: dict, float_bytes: int) -> int:
    """Bytes of one item (point or body) under field specs name → (shape, dtype name)."""
    return sum(math.prod(shape) * (float_bytes if dtype == "float" else 4) for shape, dtype in specs.values())


def estimate_output_bytes(points: int, bodies: int, frames: int, precision: str = "f32",
                          coupled: bool = False, grains: int = 0) -> int:
    """Bytes a run writes: (frames + 1) × (points × bytes per point + bodies × bytes per body +
    a frame's overhead) + a file's overhead; the fields are those of ``mpmdem.io.format`` in the
    run's precision (plus the contact force of a coupled run). The HDF5 datasets are not compressed.
    ``grains`` of the ``bodies`` are grains (``Scene.add_grains``): their XDMF view is a point each,
    not an outline."""
    float_bytes = PRECISIONS[precision]().itemsize
    point_specs = default_field_specs()
    if coupled:
        point_specs["contact_force"] = ((2,), "float")
    per_frame = (points * _field_bytes(point_specs, float_bytes)
                 + bodies * _field_bytes(default_body_field_specs(), float_bytes)
                 + (bodies - grains) * OUTLINE_BYTES_PER_BODY
                 + FRAME_OVERHEAD_BYTES)
    return FILE_OVERHEAD_BYTES + (frames + 1) * per_frame


def human_bytes(n: float) -> str:
    """``n`` bytes in decimal units: "4.1 GB"."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def human_seconds(s: float) -> str:
    """A duration [s] in the largest unit that keeps it >= 1: "3.2 days"."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if s >= size:
            return f"{s / size:.3g} {unit}"
    return f"{s:.3g} s"


def parse_size(text: str) -> int:
    """argparse type of --max-output: bytes, or a number with k/M/G/T (decimal, B optional)."""
    t = text.strip().upper().replace(" ", "")
    unit = t.lstrip("0123456789.E+-")
    number = t[: len(t) - len(unit)] if unit else t
    try:
        v = float(number) * _UNITS[unit]
    except (ValueError, KeyError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text} is invalid: a size > 0 in bytes, or with k, M, G or T (500M, 2G)")
    return int(v)


def _free_bytes(folder: Path) -> int:
    """Free space [bytes] of the disk that holds ``folder`` (or its nearest existing parent)."""
    p = folder.resolve()
    while not p.exists() and p != p.parent:
        p = p.parent
    return shutil.disk_usage(p).free


def check_frame_interval(end_time: float, frames: int, dt: float) -> None:
    """InputError naming --frames when end_time / frames [s] is below the step dt [s] (one frame is
    always allowed: a run shorter than a step takes one short step)."""
    most = max(1, int(end_time / dt))
    if frames > most:
        raise InputError("--frames", frames, f"at most {most} for --end-time {end_time:g} s: a frame interval "
                         f"{end_time / frames:.3g} s below the stable step {dt:.3g} s would force that step down")


def check_output_size(estimate: int, out: Path, frames: int, limit: int | None = None) -> None:
    """InputError naming --frames when ``estimate`` [bytes] exceeds ``limit`` (--max-output), or,
    without a limit, DISK_FRACTION of the free space of the disk of ``out``."""
    if limit is None:
        limit = int(DISK_FRACTION * _free_bytes(out))
        what = f"{DISK_FRACTION:.0%} of the free disk; --max-output SIZE sets another"
    else:
        what = "--max-output"
    if estimate > limit:
        raise InputError("--frames", frames, f"fewer frames: the output would be about {human_bytes(estimate)}, "
                         f"above the limit {human_bytes(limit)} ({what})")


def long_run_warning(end_time: float, dt: float, points: int, device: str) -> str | None:
    """One line announcing a run of more than LONG_RUN_S even at the fastest step measured on its
    kind of device (GPU_STEP_FLOOR_S; CPU_POINT_STEPS_PER_S), with the steps and that time; None
    for a shorter run (or a CPU run without points, whose step has no measured bound here)."""
    steps = end_time / dt
    cuda = str(device).startswith("cuda")
    per_step = GPU_STEP_FLOOR_S if cuda else points / CPU_POINT_STEPS_PER_S
    least = steps * per_step
    if least <= LONG_RUN_S:
        return None
    return (f"mpmdem: warning: about {steps:.3g} steps of {dt:.3g} s to {end_time:g} s: at least "
            f"{human_seconds(least)} on {'a GPU' if cuda else 'a CPU'} (the fastest step measured there); "
            "Ctrl-C stops it and keeps the frames written")
