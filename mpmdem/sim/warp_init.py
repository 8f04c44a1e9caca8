"""Warp's start-up without its missing-driver warning: mpmdem says in its own words that it runs
on the CPU (``cpu_only``), once per run, instead of Warp's native line on every start."""

from __future__ import annotations

import os
import sys
import tempfile

import warp as wp

from ..errors import InputError

__all__ = ["check_device", "check_gpu_count", "cpu_only", "init_warp"]

#: Warp's native warning on a machine without an NVIDIA driver (printed by its C++ library).
DRIVER_WARNING = "Could not find or load the NVIDIA CUDA driver"

_state: dict[str, bool] = {}


def init_warp() -> None:
    """``wp.init()`` once, with Warp's missing-driver warning taken out of stderr.

    The warning is written by Warp's native library straight to file descriptor 2, so the
    descriptor is pointed at a temporary file during the call; every other line is passed on.
    """
    if _state.get("done"):
        return
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no usable descriptor 2: let Warp print as it likes
        wp.init()
        _state.update(done=True, missing=False)
        return
    with tempfile.TemporaryFile(mode="w+b") as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        captured.seek(0)
        lines = captured.read().decode(errors="replace").splitlines(keepends=True)
    kept = [ln for ln in lines if DRIVER_WARNING not in ln]
    if kept:
        sys.stderr.write("".join(kept))
        sys.stderr.flush()
    _state.update(done=True, missing=len(kept) < len(lines))


def cpu_only() -> bool:
    """Whether Warp found no NVIDIA CUDA driver (runs go to the CPU); initialises Warp."""
    init_warp()
    return _state["missing"] or wp.get_cuda_device_count() == 0


def check_device(device: str | None) -> None:
    """InputError for a CUDA device name on a machine without a CUDA device, before Warp is asked
    for it (Warp's native library would print its own error lines first); initialises Warp."""
    if device is not None and str(device).startswith("cuda"):
        init_warp()
        if wp.get_cuda_device_count() == 0:
            raise InputError("device", device, "cpu: this machine has no CUDA device"
                             + (" (no NVIDIA driver)" if _state["missing"] else ""))


def check_gpu_count(gpus: int) -> None:
    """InputError when a local cluster is asked for more GPUs than this machine has (``--gpus``),
    before any worker starts; initialises Warp."""
    init_warp()
    have = wp.get_cuda_device_count()
    if gpus > have:
        raise InputError("gpus", gpus, f"at most {have}: this machine has {have} CUDA device(s)"
                         + (" (no NVIDIA driver)" if _state["missing"] else "")
                         + "; --workers for CPU workers, or --scheduler for a cluster with GPUs")
