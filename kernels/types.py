"""Scalar, vector and matrix types for one precision, and the kernel decorator options."""


import functools
from typing import NamedTuple

import warp as wp

__all__ = ["KERNEL_OPTIONS", "ScalarTypes", "kernel", "scalar_types"]

#: No adjoints: the solver never differentiates, and skipping them halves compile time.
KERNEL_OPTIONS = {"enable_backward": False}


def kernel(fn):
    """``wp.kernel`` in its own module, without backward pass."""
    return wp.kernel(fn, module="unique", module_options=KERNEL_OPTIONS)


class ScalarTypes(NamedTuple):
    """The Warp types of one precision."""

    scalar: type
    vec2: type
    mat22: type
    vec4: type


@functools.cache
def scalar_types(precision: str) -> ScalarTypes:
    """Types for "f32" or "f64"."""
    t = wp.float32 if precision == "f32" else wp.float64
    return ScalarTypes(t, wp.types.vector(2, t), wp.types.matrix((2, 2), t), wp.types.vector(4, t))
