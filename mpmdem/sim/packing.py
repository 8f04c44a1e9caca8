"""A settled grain packing: pour the scene's grains under gravity until at rest, then measure it (SI).

``settle`` runs the scene's DEM stage (``Simulation``) until the grains' RMS speed falls below a
small fraction of sqrt(g r) (r the mean grain radius), after at least the time of a free fall
through the domain, and returns a ``Packing``: the grain sets at their settled places, and

* packing fraction φ: the grains' own area inside a measuring window, over the window's area
  (the window: the region the grains were placed in, clipped to the pack below its free surface
  and kept ``margin`` grain diameters off its walls, top and bottom, where a wall orders the
  first layers);
* bulk density ρ_b = φ ρ_s [kg/m³] (grains of density ρ_s; per metre of thickness: the mass per
  unit thickness [kg/m] over the window's area [m²]);
* mean coordination number Z = 2 × contacts / grains, over the grains of the window, counting
  every pair of grains (and grain–wall pair) whose rounded outlines overlap (``overlaps``).

The contact law's dashpot (``ContactLaw.restitution``) is the damping that brings the pack to rest.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import shapely

from ..errors import InputError
from ..model.config import SolverConfig
from ..model.grains import GrainSet
from ..model.overlaps import overlap_pairs
from ..model.scene import Scene
from .simulation import Simulation
from .tuning import Tuning

__all__ = ["Packing", "measure_packing", "settle"]

#: The pack is at rest when its RMS speed is below this fraction of sqrt(g r).
REST_SPEED = 0.01
#: Window margin off the walls, the floor and the free surface, in mean grain diameters.
MARGIN = 3.0


@dataclass(frozen=True)
class Packing:
    """A settled (or measured) grain packing.

    Attributes:
        grains: the scene's grain sets at their settled places.
        time: simulated settling time [s] (0 for a packing measured as built).
        rms_speed: RMS grain speed at the end [m/s].
        packing_fraction: φ, grain area / window area.
        bulk_density: φ × grain density [kg/m³] (mass per unit thickness over area).
        coordination: mean contacts per grain of the window (walls included).
        window: (x0, y0, x1, y1) of the measuring window [m].
        grain_count: grains whose centre lies in the window.
    """

    grains: list[GrainSet]
    time: float
    rms_speed: float
    packing_fraction: float
    bulk_density: float
    coordination: float
    window: tuple[float, float, float, float]
    grain_count: int


def _grain_shapes(g: GrainSet) -> np.ndarray:
    """Shapely outlines (quad_segs 16) of the grains of ``g`` at their places [m]."""
    arrays = g.rigid_arrays()
    return shapely.buffer(arrays.cores, g.radius, quad_segs=16)


def measure_packing(scene: Scene, grains: list[GrainSet], *, margin: float = MARGIN,
                    window: tuple[float, float, float, float] | None = None) -> dict:
    """φ, ρ_b [kg/m³], Z and the window of ``grains`` (the scene's grain sets at some places) in
    ``scene`` (its rigid bodies as walls): see the module docstring. ``window`` (x0, y0, x1, y1) [m]
    overrides the automatic one."""
    if not grains:
        raise InputError("grains", grains, "a scene with grains (Scene.add_grains)")
    x = np.concatenate([g.position for g in grains])
    r_mean = float(np.mean(np.concatenate([np.sqrt(g.area / math.pi) for g in grains])))
    if window is None:
        reach = np.concatenate([g.bounding_radius for g in grains])
        d = 2.0 * r_mean * margin
        x0, y0 = (x - reach[:, None]).min(axis=0) + d
        x1 = float((x[:, 0] + reach).max()) - d
        # the free surface: the lowest of the column tops over strips 4 diameters wide
        strips = np.floor((x[:, 0] - x[:, 0].min()) / (8.0 * r_mean)).astype(int)
        tops = np.full(strips.max() + 1, -np.inf)
        np.maximum.at(tops, strips, x[:, 1] + reach)
        y1 = float(tops[np.isfinite(tops)].min()) - d
        window = (float(x0), float(y0), float(x1), float(y1))
    x0, y0, x1, y1 = window
    if not (x1 > x0 and y1 > y0):
        raise InputError("window", window, f"a pack deeper and wider than 2 x {margin} grain diameters (the margins)")
    box = shapely.box(x0, y0, x1, y1)
    area = mass = 0.0
    for g in grains:
        near = np.flatnonzero((g.position[:, 0] + g.bounding_radius > x0) & (g.position[:, 0] - g.bounding_radius < x1)
                              & (g.position[:, 1] + g.bounding_radius > y0)
                              & (g.position[:, 1] - g.bounding_radius < y1))
        cut = shapely.area(shapely.intersection(_grain_shapes(g)[near], box))
        # the polygonised outline misses a sliver of each arc: scale to the exact areas
        exact = g.area[near] / shapely.area(_grain_shapes(g)[near])
        area += float((cut * exact).sum())
        mass += float((cut * exact).sum()) * g.density
    phi = area / ((x1 - x0) * (y1 - y0))
    # contacts among every body (walls too), counted for the grains with their centre in the window
    cols = _placed(scene, grains)
    i, j, _ = overlap_pairs(cols)
    inside = ((cols.position[:, 0] >= x0) & (cols.position[:, 0] < x1) & (cols.position[:, 1] >= y0)
              & (cols.position[:, 1] < y1) & cols.grain)
    count = int(inside.sum())
    z = (np.count_nonzero(inside[i]) + np.count_nonzero(inside[j])) / max(count, 1)
    return {"packing_fraction": phi, "bulk_density": mass / ((x1 - x0) * (y1 - y0)), "coordination": float(z),
            "window": window, "grain_count": count}


def _placed(scene: Scene, grains: list[GrainSet]):
    """Body columns of the scene's rigid bodies with ``grains`` in place of its grain sets."""
    saved = scene.grains
    try:
        scene.grains = list(grains)
        return scene.body_arrays()
    finally:
        scene.grains = saved


def settle(scene: Scene, config: SolverConfig | None = None, *, device: str = "cpu", min_time: float | None = None,
           max_time: float | None = None, check_every: float | None = None, rest_speed: float = REST_SPEED,
           margin: float = MARGIN, tuning: Tuning | None = None) -> Packing:
    """Pour the scene's grains under its gravity until at rest and measure the packing.

    Runs ``Simulation(scene, config, device, tuning)`` in chunks of ``check_every`` [s] (default: a tenth
    of ``min_time``) from ``min_time`` [s] (default: the free-fall time sqrt(2 H / g) through the
    domain height H) until the grains' RMS speed is below ``rest_speed`` × sqrt(g r) or
    ``max_time`` [s] (default 20 × min_time) has passed. The scene is not changed. Returns the
    ``Packing`` (the settled grain sets, φ, ρ_b [kg/m³], Z)."""
    if not scene.grains:
        raise InputError("scene.grains", [], "a scene with grains (Scene.add_grains)")
    g = math.hypot(*scene.gravity)
    if g <= 0.0:
        raise InputError("scene.gravity", scene.gravity, "a gravity that pours the grains (|g| > 0)")
    (_, y0), (_, y1) = scene.domain
    fall = min_time or math.sqrt(2.0 * (y1 - y0) / g)
    chunk = check_every or 0.1 * fall
    end = max_time or 20.0 * fall
    r_mean = float(np.mean(np.concatenate([np.sqrt(gs.area / math.pi) for gs in scene.grains])))
    rest = rest_speed * math.sqrt(g * r_mean)
    sim = Simulation(scene, config or SolverConfig(), device=device, tuning=tuning)
    rigid = len(scene.rigid_bodies)
    t, speed = 0.0, math.inf
    while t < end:
        t, _ = sim.advance_to(min(t + chunk, end))
        v = sim.body_fields()["v"][rigid:]
        speed = float(np.sqrt(np.mean(np.sum(v * v, axis=1))))
        if t >= fall and speed < rest:
            break
    f = sim.body_fields()
    settled, k = [], rigid
    for gs in scene.grains:
        n = len(gs)
        settled.append(dataclasses.replace(gs, position=f["x"][k:k + n].astype(np.float64).copy(),
                                           angle=f["angle"][k:k + n].astype(np.float64).copy()))
        k += n
    m = measure_packing(scene, settled, margin=margin)
    return Packing(settled, float(t), speed, m["packing_fraction"], m["bulk_density"], m["coordination"], m["window"],
                   m["grain_count"])
