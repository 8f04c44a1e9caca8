"""DEM sand that starts settled: grains poured behind a gate, then released (SI units).

The cases' ``--sand dem`` (``silo-discharge``, ``column-collapse``) start their grains from a
settled pack, as their continuum starts at rest. The pattern they share:

1. a scene whose gate (a fixed plate) closes the container holds grains placed on a loose lattice
   (``Scene.add_grains``);
2. ``settle_behind_gate`` pours them under gravity until at rest (``mpmdem.sim.packing.settle``) and
   times it;
3. the settled grains go into the same scene without the gate (``Scene.add_grain_set``) and flow
   from t = 0.

Also here: the grains of a set that fill a given area from the bottom up (``lowest_grains``: a
lattice taller than wanted, trimmed so that it settles to a wanted height), and what the cases
report of a settled pack (``settled_record``).

The grain material the cases share (so that one calibration, ``mpmdem study column-collapse-dem``
and ``bench/grain_calibration.py``, serves them all): μ = GRAIN_FRICTION between grains, a
restitution RESTITUTION, and a grain density chosen as the continuum's bulk density over
PACKING_FRACTION, the solid fraction of a settled pack of these ±15 % sphero-disks.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..errors import InputError
from ..model.config import SolverConfig
from ..model.grains import GrainSet
from ..model.scene import Scene
from .packing import Packing, settle

__all__ = ["GRAIN_FRICTION", "PACKING_FRACTION", "RESTITUTION", "grain_density", "lowest_grains",
           "settle_behind_gate", "settled_record"]

#: Coulomb μ between two grains (a sand's; a pair with a wall takes the smaller of the two values)
GRAIN_FRICTION = 0.5
#: restitution of a grain-grain impact (sets the normal dashpot, ``ContactLaw``)
RESTITUTION = 0.5
#: solid fraction of a settled pack of ±15 % sphero-disks (tests/model/test_grains.py measures 0.82-0.83;
#: Berryman 1983: 2D random close packing 0.82 ± 0.02)
PACKING_FRACTION = 0.82
#: the longest settling, in free falls through the height the grains start from
SETTLE_FALLS = 8.0


def grain_density(bulk_density: float) -> float:
    """ρ_s [kg/m³] of grains whose settled pack has the bulk density ``bulk_density`` [kg/m³]:
    ρ_b / PACKING_FRACTION."""
    return bulk_density / PACKING_FRACTION


def settle_behind_gate(closed: Scene, *, precision: str, device: str, height: float, gravity: float,
                       settle_max: float | None = None, flag: str = "--settle-max") -> tuple[Packing, float]:
    """Pour the grains of ``closed`` (the scene with its gate) until at rest: at least the free-fall
    time sqrt(2 H / g) through ``height`` H [m], at most ``settle_max`` [s] (default SETTLE_FALLS
    falls). Returns the ``Packing`` and the wall time it took [s]. InputError (naming ``flag``) for a
    settling time that is not a finite positive number."""
    fall = math.sqrt(2.0 * height / gravity)
    longest = SETTLE_FALLS * fall if settle_max is None else settle_max
    if not (math.isfinite(longest) and longest > 0.0):
        raise InputError(flag, settle_max, "a settling time > 0 [s]")
    t0 = time.perf_counter()
    packing = settle(closed, SolverConfig(precision=precision), device=device, min_time=min(fall, longest),
                     max_time=longest)
    return packing, time.perf_counter() - t0


def settled_record(packing: Packing, wall_seconds: float | None = None) -> dict:
    """What a case's summary reports of its settled pack: the settling time [s], RMS speed [m/s],
    packing fraction, bulk density [kg/m³], mean coordination number, grains in the measuring
    window, and the wall time of the settling [s] (part of the DEM cost; None when not timed)."""
    out = {"time": packing.time, "rms_speed": packing.rms_speed, "packing_fraction": packing.packing_fraction,
           "bulk_density": packing.bulk_density, "coordination": packing.coordination}
    out.update(window_grains=packing.grain_count, grains=sum(len(g) for g in packing.grains))
    if wall_seconds is not None:
        out["wall_seconds"] = wall_seconds
    return out


def lowest_grains(grains: GrainSet, area: float) -> GrainSet:
    """The grains of ``grains`` lowest in y whose areas add up to at most ``area`` [m²] (all of
    them when they hold less): a lattice placed taller than wanted, trimmed to the grains that
    settle to a wanted height (area = φ × the settled region's area)."""
    if not (math.isfinite(area) and area > 0.0):
        raise InputError("area", area, "an area > 0 [m^2]")
    order = np.argsort(grains.position[:, 1], kind="stable")
    n = int(np.searchsorted(np.cumsum(grains.area[order]), area, side="right"))
    keep = np.sort(order[:max(n, 1)])
    return dataclasses.replace(grains, position=grains.position[keep], angle=grains.angle[keep],
                               radius=grains.radius[keep], local=grains.local[keep], area=grains.area[keep],
                               second_moment=grains.second_moment[keep], core_radius=grains.core_radius[keep])
