"""Shared fixtures: the Warp devices to test on. CPU always; the CUDA copy of every device test is
collected everywhere and marked ``cuda``: without a GPU it shows as skipped with the reason, and
``pytest -m cuda`` on the GPU machine runs exactly those items (recorded in
bench/results/gpu_tests.txt)."""

import pytest
import warp as wp

import mpmdem  # noqa: F401  (sets Warp's log level)

wp.init()
HAS_CUDA = wp.get_cuda_device_count() > 0
DEVICES = [
    "cpu",
    pytest.param("cuda", marks=[pytest.mark.cuda, pytest.mark.skipif(
        not HAS_CUDA, reason="no CUDA device here: the CUDA items run on the GPU machine (pytest -m cuda)")]),
]


@pytest.fixture(params=DEVICES)
def device(request):
    """Every Warp device (the CUDA one skipped, with its reason, where there is none)."""
    return request.param
