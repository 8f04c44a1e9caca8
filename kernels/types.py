"""Scalar, vector and matrix types for one precision, and the kernel decorator options."""


import functools
from typing import NamedTuple

import warp as wp

__all__ = ["KERNEL_OPTIONS", "MATERIAL_PARAMS", "Namespace", "ScalarTypes", "kernel", "scalar_types"]

#: Floats per material in the material table (layout in ``plasticity.py``).
MATERIAL_PARAMS = 10

#: No adjoints: the solver never differentiates, and skipping them halves compile time.
KERNEL_OPTIONS = {"enable_backward": False}


def kernel(fn=None, *, deterministic: bool = False, max_unroll: int | None = None,
           max_registers: int | None = None):
    """``wp.kernel`` in its own module, without backward pass.

    deterministic: order float atomics so that repeated runs on one GPU are bit-identical
    (Warp's ``DeterministicMode.RUN_TO_RUN``; CPU runs are always deterministic).
    max_unroll: unroll loops of a constant trip count up to this (Warp's default is 16).
    max_registers: registers per thread on CUDA (``__maxnreg__``; None: the compiler's choice).
    """
    options = dict(KERNEL_OPTIONS)
    if max_unroll is not None:
        options["max_unroll"] = max_unroll
    if deterministic and hasattr(wp, "DeterministicMode"):
        options["deterministic"] = wp.DeterministicMode.RUN_TO_RUN

    def wrap(f):
        if max_registers is not None:
            return wp.kernel(f, module="unique", module_options=options, cuda_max_registers=max_registers)
        return wp.kernel(f, module="unique", module_options=options)

    return wrap if fn is None else wrap(fn)


class Namespace:
    """What a kernel factory returns: its structs, functions and kernels as attributes."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


class ScalarTypes(NamedTuple):
    """The Warp types of one precision."""

    scalar: type
    vec2: type
    mat22: type
    vec4: type
    params: type  # one row of the material table (MATERIAL_PARAMS scalars)


@functools.cache
def scalar_types(precision: str) -> ScalarTypes:
    """Types for "f32" or "f64"."""
    t = wp.float32 if precision == "f32" else wp.float64
    return ScalarTypes(t, wp.types.vector(2, t), wp.types.matrix((2, 2), t), wp.types.vector(4, t),
                       wp.types.vector(MATERIAL_PARAMS, t))
