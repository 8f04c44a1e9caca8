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

__all__ = ["host_copy"]

_buffers: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def host_copy(array: wp.array, fresh: bool = True) -> np.ndarray:
    """The values of ``array`` on the host, once the work issued on the current stream has run (a
    view of the array itself for a CPU array, as ``numpy()`` gives). ``fresh`` False: on CUDA, the
    pinned buffer itself, valid until the next ``host_copy`` of the array (for a caller that copies
    out what it keeps)."""
    if not array.device.is_cuda or not array.is_contiguous or array.size == 0:
        return array.numpy()
    buf = _buffers.get(array)
    if buf is None or buf.shape != array.shape or buf.dtype != array.dtype:
        buf = wp.empty(array.shape, dtype=array.dtype, device="cpu", pinned=True)
        _buffers[array] = buf
    wp.copy(buf, array)
    wp.synchronize_stream(wp.get_stream(array.device))
    return np.array(buf.numpy(), copy=True) if fresh else buf.numpy()
