"""The sides of a scene's domain: the condition on each (fixed, slip, Coulomb friction, free or
periodic) and where a wall may lie."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from ..errors import InputError

__all__ = ["BOUNDARY_KINDS", "SIDES", "Boundary", "WallTiles", "as_boundary", "check_moving_walls",
           "check_periodic_sides", "check_sides", "check_walls_on_grid_lines"]

SIDES = ("left", "right", "bottom", "top")
BOUNDARY_KINDS = ("fixed", "slip", "friction", "free", "periodic")


@dataclass(frozen=True)
class Boundary:
    """Condition on one side of the domain, applied to the grid nodes on and beyond it.

    Attributes:
        kind: "fixed" (no-slip, v = 0), "slip" (roller: no normal motion), "friction" (a wall that
            points may leave, with Coulomb friction μ while pressed against it), "free" (none) or
            "periodic" (left and right together: material leaving one side enters by the other,
            ``kernels/periodic.py``).
        friction: Coulomb coefficient μ ≥ 0 of a "friction" wall.
        velocity: speed [m/s] at which a "fixed" wall moves along itself (along +x for bottom and
            top, +y for left and right): its nodes take that velocity, and the wall images reflect
            about it (``kernels/wall_images.py``). A rough wall driving a shear flow; 0: at rest.
    """

    kind: Literal["fixed", "slip", "friction", "free", "periodic"] = "slip"
    friction: float = 0.0
    velocity: float = 0.0

    def __post_init__(self):
        if self.kind not in BOUNDARY_KINDS:
            raise InputError("boundary kind", self.kind, f"one of {', '.join(BOUNDARY_KINDS)}")
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise InputError("friction", self.friction, "a coefficient of friction >= 0")
        if not math.isfinite(self.velocity) or (self.velocity != 0.0 and self.kind != "fixed"):
            raise InputError("velocity", self.velocity, "a finite wall speed [m/s], non-zero only on a fixed wall")

    @property
    def kind_id(self) -> int:
        """The side's kind as the kernels number it (``kernels/wall_kinds.py``). A periodic side is
        open to the grid update and the wall images (free); the periodic fold and copy
        (``kernels/periodic.py``) join it to the opposite side."""
        return BOUNDARY_KINDS.index("free" if self.kind == "periodic" else self.kind)


@dataclass(frozen=True)
class WallTiles:
    """The left and right walls repeated along x: the grid is ``count`` tiles of ``rows`` node rows,
    each with its walls ``cells`` cells apart where a lone domain of that width has them (a batch's
    worlds side by side, ``mpmdem.sim.batch_scene``; ``kernels/tiles.py``). The scene's domain runs
    from the first tile's left wall to the last tile's right wall."""

    count: int
    rows: int
    cells: int

    def __post_init__(self):
        if not (self.count >= 1 and self.cells >= 1 and self.rows > self.cells):
            raise InputError("wall_tiles", (self.count, self.rows, self.cells),
                             "count >= 1 tiles of rows > cells >= 1 node rows")


def as_boundary(side: str, b) -> Boundary:
    if isinstance(b, Boundary):
        return b
    if isinstance(b, str):
        return Boundary(b)
    raise InputError(f"boundaries[{side!r}]", b, "a Boundary or one of " + ", ".join(BOUNDARY_KINDS))


def check_sides(boundaries: dict) -> None:
    """The checks of the four sides together: periodic pairs, moving walls' corners."""
    check_periodic_sides(boundaries)
    check_moving_walls(boundaries)


def check_periodic_sides(boundaries: dict) -> None:
    """Periodic sides come as the pair left and right (periodic in x); y is not periodic."""
    left, right = (boundaries[s].kind == "periodic" for s in ("left", "right"))
    for side in ("bottom", "top"):
        if boundaries[side].kind == "periodic":
            raise InputError(f"boundaries[{side!r}]", "periodic", "fixed, slip, friction or free (only x is periodic: "
                             "left and right)")
    if left != right:
        side = "right" if left else "left"
        raise InputError(f"boundaries[{side!r}]", boundaries[side].kind,
                         "periodic, as the opposite side (periodic in x needs left and right both periodic)")


def check_moving_walls(boundaries: dict) -> None:
    """A moving wall's two neighbouring sides must be free or periodic: a corner image would
    reflect about two wall velocities at once (``kernels/wall_images.py``)."""
    for side, across in (("left", ("bottom", "top")), ("right", ("bottom", "top")), ("bottom", ("left", "right")),
                         ("top", ("left", "right"))):
        if boundaries[side].velocity == 0.0:
            continue
        for other in across:
            if boundaries[other].kind not in ("free", "periodic"):
                raise InputError(f"boundaries[{other!r}]", boundaries[other].kind,
                                 f"free or periodic beside the moving {side} wall (no corner of two walls)")


def check_walls_on_grid_lines(domain, cell_size: float, boundaries: dict) -> None:
    """A wall (fixed, slip or friction side) must lie on a grid line: the grid starts at the
    lower corner, so the right and top walls need a whole number of cells across. Rounding the
    grid up instead would put the wall up to a cell beyond the side the user gave. A periodic x
    needs it too: the period is a whole number of cells."""
    (x0, y0), (x1, y1) = domain
    h = cell_size
    for side, lo, hi, axis in (("right", x0, x1, "x"), ("top", y0, y1, "y")):
        if boundaries[side].kind == "free":
            continue
        cells = (hi - lo) / h
        if abs(cells - round(cells)) <= 1e-6 * max(1.0, cells):
            continue
        n_lo, n_hi = max(1, math.floor(cells)), math.ceil(cells)
        raise InputError(
            "domain", domain,
            f"a {side} wall on a grid line: {axis}1 - {axis}0 = {hi - lo:g} m is {cells:.4g} cells of "
            f"cell_size {h:g} m, so the wall would sit at {axis} = {lo + n_hi * h:.6g} m; use {axis}1 = "
            f"{lo + n_lo * h:.6g} or {lo + n_hi * h:.6g} m, cell_size {(hi - lo) / n_hi:.6g} or "
            f"{(hi - lo) / n_lo:.6g} m, or a free {side} side")
