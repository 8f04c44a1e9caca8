"""Memory budgets checked before large scenes are built: the host memory a new allocation can take,
and whether a DEM stage of N bodies fits its device."""

from __future__ import annotations

import os

from ..errors import InputError

__all__ = ["available_host_memory", "check_device_memory", "device_bytes_per_body"]

#: Assumed when the system tells nothing (no /proc/meminfo, no sysconf): 16 GiB.
FALLBACK = 16 * 2**30


def available_host_memory() -> float:
    """Bytes of host memory available to a new allocation: Linux's MemAvailable (free memory plus
    the page cache it can drop), else the free physical pages (sysconf), else FALLBACK."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return float(FALLBACK)


def device_bytes_per_body(slots: int, vertices_per_body: float, precision: str) -> float:
    """Device memory one DEM body takes [B]: its ~24 per-body scalars and vectors, its core
    vertices (body frame and world, owner), its ``slots`` Verlet slots (neighbour, history keys and
    slips, energy, dissipated work, old partner: ~44 B + 5 scalars each), its broad-phase cell share
    and the split search's records (16 candidates, 4 pairs of 8 hits: bounded by 2 kB)."""
    s = 4 if precision == "f32" else 8
    per_body = 24 * s + 64
    per_vertex = 4 * s + 4
    per_slot = 44 + 5 * s
    return per_body + vertices_per_body * per_vertex + slots * per_slot + 2048


def check_device_memory(device, bodies: int, vertices: int, slots: int, precision: str) -> None:
    """InputError before any allocation when ``bodies`` DEM bodies (``vertices`` core vertices in
    all, ``slots`` list slots each) would not fit the device: 80 % of the free memory of a CUDA
    device, or half of the free host memory for the CPU."""
    per = device_bytes_per_body(slots, vertices / max(bodies, 1), precision)
    need = per * bodies
    if device.is_cuda:
        free = float(device.free_memory)
        limit, where = 0.8 * free, f"80 % of the {free / 2**30:.3g} GiB free on {device.alias}"
    else:
        free = available_host_memory()
        limit, where = 0.5 * free, f"half of the {free / 2**30:.3g} GiB of host memory available ({device.alias})"
    if need > limit:
        raise InputError("DEM bodies", bodies, f"at most {int(limit // per)} bodies (grains included) on this device: "
                         f"about {per:.0f} B each ({slots} list slots), {need / 2**30:.3g} GiB against {where}; "
                         "take fewer or larger grains, or a larger device")
