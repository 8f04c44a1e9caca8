"""A step as data: the list of launches a stage lays out once and replays every step.

A plan is a list of items, run in order by ``run_plan``:

- ``Launch``: one ``wp.launch``;
- ``Zero``: clear an array;
- ``IfFlag``: a block that runs only when a device flag is non-zero (a conditional node inside a
  CUDA graph; elsewhere the block's kernels are launched and each reads its flag and returns);
- ``ExtensionPoint``: a named place where another stage adds launches (``extensions[name]``, a
  list of callables), e.g. the coupling's exchange after the grid's force update.

Nothing in a plan syncs with the host, so a step built of plans records as one CUDA graph.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import warp as wp

__all__ = ["ExtensionPoint", "IfFlag", "Launch", "Zero", "plan_kernels", "run_plan"]


@dataclass
class Launch:
    """``wp.launch(kernel, dim, inputs=inputs)``."""

    kernel: object
    dim: object
    inputs: list
    block_dim: int | None = None  # tile kernels (dim then ends with it)


@dataclass
class Zero:
    """``array.zero_()``."""

    array: wp.array


@dataclass
class IfFlag:
    """``body`` runs when ``flag[0]`` (an int32 device array) is non-zero."""

    flag: wp.array
    body: list


@dataclass
class ExtensionPoint:
    """Where the callables another stage registered under ``name`` run."""

    name: str


def run_plan(plan: list, device, extensions: dict[str, list[Callable[[], None]]] | None = None) -> None:
    """Launch every item of ``plan`` in order on ``device``."""
    for item in plan:
        if isinstance(item, Launch):
            extra = {"block_dim": item.block_dim} if item.block_dim else {}
            wp.launch(item.kernel, item.dim, inputs=item.inputs, device=device, **extra)
        elif isinstance(item, IfFlag):
            dev = wp.get_device(device)
            if dev.is_cuda and dev.is_capturing and wp.is_conditional_graph_supported():
                wp.capture_if(item.flag, on_true=lambda body=item.body: run_plan(body, device, extensions))
            else:
                run_plan(item.body, device, extensions)
        elif isinstance(item, ExtensionPoint):
            for fn in (extensions or {}).get(item.name, ()):
                fn()
        elif isinstance(item, Zero):
            item.array.zero_()
        else:
            raise TypeError(f"not a plan item: {item!r}")


def plan_kernels(plan: list) -> Iterator:
    """Every kernel the plan may launch (those of conditional blocks included)."""
    for item in plan:
        if isinstance(item, Launch):
            yield item.kernel
        elif isinstance(item, IfFlag):
            yield from plan_kernels(item.body)
