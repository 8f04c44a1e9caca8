"""Typed roles of the MPM step's launches while ``MPMSolver._build`` lays the step out.

The step's first plan is rewritten in three places: MUSL's last grid update before the re-mapping
zeroes the re-mapped momentum (``mpm_orders.plan_musl``), the step's last grid update clears the
nodes it used and a fold of the wall images right before a grid update moves into that update
(``MPMSolver._build``). Each rewrite needs to know which
launch is which: a ``GridUpdate`` keeps the maker of its kernel's variants and whether it re-maps
or clears, a ``WallFold`` the fields it folds. ``launches`` then keeps only the launches.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from .launch_plan import Launch

__all__ = ["GridUpdate", "WallFold", "launches", "last_grid_update"]


@dataclass(frozen=True)
class GridUpdate:
    """A grid update of the step (``kernels.grid.make_grid_update``).

    Attributes:
        launch: Its launch.
        make: Its kernel with further options: ``make(clear=, zero_remap=, fold=, images=)``.
        remap: Whether it is MUSL's re-mapping update.
        clears: Whether it is the step's last update, which clears the nodes (copies) it used.
    """

    launch: Launch
    make: Callable[..., object]
    remap: bool = False
    clears: bool = False

    def remade(self, **options) -> GridUpdate:
        """This update with its kernel made again with ``options`` kept from now on (zero_remap)."""
        make = functools.partial(self.make, **options)
        return replace(self, launch=Launch(make(), self.launch.dim, self.launch.inputs), make=make)

    def clearing(self) -> GridUpdate:
        """This update as the step's last one: it clears the nodes it used."""
        return replace(self, launch=Launch(self.make(clear=True), self.launch.dim, self.launch.inputs), clears=True)


@dataclass(frozen=True)
class WallFold:
    """A fold of the wall images into the nodes (``kernels.wall_images.make_fold_ghosts``) and its
    flags (mass, momentum, force, remap, xpic)."""

    launch: Launch
    flags: dict = field(default_factory=dict)


def last_grid_update(seq: list) -> int:
    """The index of the last ``GridUpdate`` of ``seq``."""
    return max(k for k, item in enumerate(seq) if isinstance(item, GridUpdate))


def launches(seq: list) -> list:
    """``seq`` with each role replaced by its launch."""
    return [item.launch if isinstance(item, GridUpdate | WallFold) else item for item in seq]
