"""Shared fixtures: the Warp devices to test on (CPU always, CUDA when present)."""

import pytest
import warp as wp

import mpmdem  # noqa: F401  (sets Warp's log level)

wp.init()
DEVICES = ["cpu"] + (["cuda"] if wp.get_cuda_device_count() > 0 else [])


@pytest.fixture(params=DEVICES)
def device(request):
    """Every available Warp device."""
    return request.param
