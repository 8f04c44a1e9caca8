"""The host memory a new allocation can take [B], for the checks made before building large scenes."""

from __future__ import annotations

import os

__all__ = ["available_host_memory"]

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
