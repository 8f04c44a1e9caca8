"""Host copies through pinned buffers (``mpmdem.sim.host_copy``): ``host_copies`` reads several device
arrays after one wait and must give what ``numpy()`` gives for each, as fresh memory."""

import numpy as np
import warp as wp

from mpmdem.sim.host_copy import host_copies, host_copy


def _arrays(device):
    rng = np.random.default_rng(7)
    a = wp.array(rng.standard_normal(1000), dtype=wp.float64, device=device)
    b = wp.array(rng.standard_normal((50, 3)).astype(np.float32), dtype=wp.float32, device=device)
    v = wp.array(rng.standard_normal((40, 2)).astype(np.float32), dtype=wp.vec2, device=device)
    empty = wp.zeros(0, dtype=wp.int32, device=device)
    strided = wp.array(rng.standard_normal((20, 6)), dtype=wp.float64, device=device)[:, 1:3]
    return [a, b, v, empty, strided]


def test_host_copies_give_what_numpy_gives(device):
    """Verify every array (1-D, 2-D, vectors, empty, a non-contiguous view) comes back equal to its
    ``numpy()``, with its shape and dtype, and equal to ``host_copy`` of it."""
    arrays = _arrays(device)
    got = host_copies(arrays)
    assert len(got) == len(arrays)
    for a, g in zip(arrays, got, strict=True):
        want = a.numpy()
        assert g.shape == want.shape and g.dtype == want.dtype
        np.testing.assert_array_equal(g, want)
        np.testing.assert_array_equal(host_copy(a), want)


def test_host_copies_are_fresh_after_the_kernels_before_them(device):
    """Verify a copy reads the values written by work issued before it (no stale pinned buffer) and
    is not changed by a later write to the array (on CUDA it is not the reused pinned buffer)."""
    a = wp.zeros(256, dtype=wp.float32, device=device)
    first = host_copies([a])[0]
    a.fill_(3.0)
    second, again = host_copies([a, a])
    a.fill_(5.0)
    host_copies([a])
    if wp.get_device(device).is_cuda:
        np.testing.assert_array_equal(first, 0.0)
        np.testing.assert_array_equal(second, 3.0)
        np.testing.assert_array_equal(again, 3.0)
    else:  # (a CPU array's copy is a view of it, as ``numpy()`` is)
        np.testing.assert_array_equal(second, 5.0)
