"""Host copies of device arrays through page-locked buffers.

``wp.array.numpy()`` of a CUDA array copies into fresh pageable host memory. Such a copy does not
only wait for the array's own stream: it held back the work of the process's other streams too
(bench/side_by_side.py), so runs side by side on one GPU (``mpmdem.sim.device_turns``) would run
one after another at each read of a clock or a frame. A copy into page-locked (pinned) memory
waits for the calling stream alone. ``host_copy`` keeps one pinned buffer per array and returns
a fresh copy of it, as ``numpy()`` returns fresh memory; on the CPU it is ``numpy()`` itself.
"""

from __future__ import annotations

import weakref

import numpy as np
import warp as wp

__all__ = ["host_copies", "host_copy"]

_buffers: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _pinned(array: wp.array) -> wp.array:
    """The page-locked host buffer kept for ``array`` (made, or made anew, to its shape and dtype)."""
    buf = _buffers.get(array)
    if buf is None or buf.shape != array.shape or buf.dtype != array.dtype:
        buf = wp.empty(array.shape, dtype=array.dtype, device="cpu", pinned=True)
        _buffers[array] = buf
    return buf


def _through_pinned(array: wp.array) -> bool:
    return array.device.is_cuda and array.is_contiguous and array.size > 0


def host_copy(array: wp.array, fresh: bool = True) -> np.ndarray:
    """The values of ``array`` on the host, once the work issued on the current stream has run (a
    view of the array itself for a CPU array, as ``numpy()`` gives). ``fresh`` False: on CUDA, the
    pinned buffer itself, valid until the next ``host_copy`` of the array (for a caller that copies
    out what it keeps)."""
    if not _through_pinned(array):
        return array.numpy()
    buf = _pinned(array)
    wp.copy(buf, array)
    wp.synchronize_stream(wp.get_stream(array.device))
    return np.array(buf.numpy(), copy=True) if fresh else buf.numpy()


def host_copies(arrays: list[wp.array]) -> list[np.ndarray]:
    """Fresh host copies of ``arrays``, as ``host_copy`` gives each, after one wait: every copy is
    issued on its device's current stream first, then each such stream is synchronised once (a
    frame of a batch reads some thirty small arrays; one wait each gave the writer thread Python's
    lock back thirty times)."""
    waits = {}
    for a in arrays:
        if _through_pinned(a):
            wp.copy(_pinned(a), a)
            waits[a.device.alias] = a.device
    for device in waits.values():
        wp.synchronize_stream(wp.get_stream(device))
    return [np.array(_buffers[a].numpy(), copy=True) if _through_pinned(a) else a.numpy() for a in arrays]
