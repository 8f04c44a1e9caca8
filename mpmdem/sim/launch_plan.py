"""A step as data: the list of launches a stage lays out once and replays every step.

A plan is a list of items, run in order by ``run_plan``:

- ``Launch``: one ``wp.launch``;
- ``Zero``: clear an array;
- ``IfFlag``: a block that runs only when a device flag is non-zero (a conditional node inside a
  CUDA graph; elsewhere, or when laid ``inline``, the block's kernels are launched and each reads
  its flag and returns: cheaper than a conditional node taken in most steps, see
  ``mpmdem.sim.block_layout``);
- ``IfAny``: a block that runs when any of several flags is set, around blocks that are mostly
  skipped together (a step's list rebuilds and relabels): one conditional node where they would
  be several (a skipped conditional node costs ~4.8 µs on an H100, a one-thread kernel that ORs
  the flags ~1.2 µs: bench/launch_floor.py);
- ``ExtensionPoint``: a named place where another stage adds launches (``extensions[name]``, a
  list of callables), e.g. the coupling's exchange after the grid's force update.

Nothing in a plan syncs with the host, so a step built of plans records as one CUDA graph.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import warp as wp

__all__ = ["ExtensionPoint", "IfAny", "IfFlag", "Launch", "Zero", "group_conditionals", "plan_blocks", "plan_kernels",
           "run_plan", "split_after_conditionals"]


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
    """``body`` runs when ``flag[0]`` (an int32 device array) is non-zero. ``inline``: recorded
    without a conditional node, every kernel of ``body`` launched (each reads its flag and returns
    where the block would be skipped), as it always runs outside a CUDA graph."""

    flag: wp.array
    body: list
    inline: bool = False


@dataclass
class IfAny:
    """``body`` runs when any of ``flags`` (int32 device arrays, their element 0) is non-zero;
    ``any_flag`` (an int32[1] device array) holds their OR during the step. One to three flags."""

    flags: list
    any_flag: wp.array
    body: list

    def __post_init__(self):
        if not 1 <= len(self.flags) <= 3:
            raise ValueError(f"IfAny takes one to three flags, not {len(self.flags)}")


@wp.kernel
def _or_flags(out: wp.array(dtype=wp.int32), a: wp.array(dtype=wp.int32), b: wp.array(dtype=wp.int32),
              c: wp.array(dtype=wp.int32)):
    out[0] = wp.where(a[0] != 0 or b[0] != 0 or c[0] != 0, 1, 0)


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
            if dev.is_cuda and dev.is_capturing and wp.is_conditional_graph_supported() and not item.inline:
                wp.capture_if(item.flag, on_true=lambda body=item.body: run_plan(body, device, extensions))
            else:
                run_plan(item.body, device, extensions)
        elif isinstance(item, IfAny):
            dev = wp.get_device(device)
            if dev.is_cuda and dev.is_capturing and wp.is_conditional_graph_supported():
                a, b, c = (list(item.flags) * 3)[:3]  # (fewer than three: repeated)
                wp.launch(_or_flags, 1, inputs=[item.any_flag, a, b, c], device=device)
                wp.capture_if(item.any_flag, on_true=lambda body=item.body: run_plan(body, device, extensions))
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
        elif isinstance(item, (IfFlag, IfAny)):
            yield from plan_kernels(item.body)


def plan_blocks(plan: list) -> Iterator[IfFlag]:
    """Every ``IfFlag`` block of the plan, nested ones included, outer before inner."""
    for item in plan:
        if isinstance(item, IfFlag):
            yield item
            yield from plan_blocks(item.body)
        elif isinstance(item, IfAny):
            yield from plan_blocks(item.body)


def split_after_conditionals(plan: list) -> tuple[list, list]:
    """(head, tail): the plan with its in-line blocks opened (``IfFlag.inline``: their kernels,
    which read their flags, in order), cut after its last conditional node (an ``IfFlag`` not in
    line, an ``IfAny``). Run one after the other, they launch what ``plan`` launches, in its order;
    the tail holds no conditional node, so a CUDA graph can record it beside a parallel branch
    (``mpmdem.sim.step_streams``: a conditional node is recorded only while no branch is open)."""
    flat: list = []

    def open_inline(items):
        for item in items:
            if isinstance(item, IfFlag) and item.inline:
                open_inline(item.body)
            else:
                flat.append(item)

    open_inline(plan)
    last = max((k for k, item in enumerate(flat) if isinstance(item, (IfFlag, IfAny))), default=-1)
    return flat[:last + 1], flat[last + 1:]


def group_conditionals(plan: list, any_flag: wp.array) -> list:
    """The plan with its first run of two or three consecutive conditional blocks (``IfFlag`` not in
    line) under one ``IfAny`` of their flags (``any_flag``: its int32[1] device array): where each
    is mostly skipped, one skipped conditional node and the OR kernel cost less than a skipped node
    each (~4.8 µs against ~1.2 on an H100, bench/launch_floor.py). The same launches in the same
    order: in a CUDA graph the blocks become conditional nodes inside the group's."""
    out: list = []
    k = 0
    grouped = False
    while k < len(plan):
        run = 0
        while k + run < len(plan) and run < 3 and isinstance(plan[k + run], IfFlag) and not plan[k + run].inline:
            run += 1
        if run >= 2 and not grouped:
            blocks = plan[k:k + run]
            out.append(IfAny([block.flag for block in blocks], any_flag, blocks))
            grouped = True
            k += run
        else:
            out.append(plan[k])
            k += 1
    return out
