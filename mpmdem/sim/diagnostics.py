"""Diagnostics of a run: the per-frame sums of the MPM stage, the energy balance over a run, and
the blow-up checks with their messages (what most likely caused one).

The DEM and coupled stages sum their own diagnostics (``mpmdem.sim.dem``, ``mpmdem.sim.coupling``);
every stage names its likely causes through ``Stage.likely_cause``, built from the functions here.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
import warp as wp

from ..errors import BlowUpError
from ..kernels import grid as grid_kernels
from ..kernels import reductions as reduction_kernels
from ..model.config import SolverConfig
from ..model.finished import Model
from .granular_state import GranularPlan
from .host_copy import host_copy
from .stage import Clock

__all__ = ["EnergyBalance", "PointStage", "check_energy", "check_point_status", "coupled_likely_cause",
           "likely_cause", "point_diagnostics"]


def likely_cause(config, scene, dt: float, bound: float) -> str:
    """What most likely made the points of an MPM run blow up at step dt [s] and bound [s]."""
    causes = []
    if config.dt is not None:
        causes.append(f"the fixed dt = {config.dt:.3g} s against a current bound h/(c+|v|) = {bound:.3g} s "
                      "(leave dt unset or lower it)")
    else:
        causes.append(f"the time step (cfl = {config.cfl:g}, dt = {dt:.3g} s): lower --cfl")
    if config.scheme.flip_fraction > 0.0:
        causes.append(f"the transfer scheme {config.transfer} (FLIP noise): try APIC, or a FLIP fraction < 1")
    if config.shape == "linear":
        causes.append("cell-crossing of the linear shape function: try bspline2 or cpgimp")
    for b in scene.bodies:
        if b.material.poisson_ratio > 0.45:
            causes.append(f"the material of {b.name} (nu = {b.material.poisson_ratio} is nearly incompressible)")
    return "; ".join(causes)


def coupled_likely_cause(config, scene, overlap: str, dt: float, bound: float, contact_bound: float) -> str:
    """The likely causes of a coupled run: the rigid bodies' initial overlap (``overlap``, "" if
    none), the points' causes, then the contact stiffness against the point masses."""
    return ((f"{overlap}; else " if overlap else "") + likely_cause(config, scene, dt, bound)
            + f"; the contact stiffness against the point masses (dt = {dt:.3g} s, contact bound "
            f"{contact_bound:.3g} s): lower dem_kappa or dt")


class PointStage(Protocol):
    """What the checks and sums of the points read of the MPM stage (``MPMSolver``), none written."""

    model: Model
    config: SolverConfig
    device: object
    particle_count: int
    points: object  # the ``Particles`` struct
    D: object  # the ``Domain`` struct
    materials: wp.array
    sim_clock: Clock
    diag: wp.array  # float64[len(DIAG_NAMES)]
    work: wp.array  # float64: works and impulses per slot (``kernels.grid.WORK_SLOTS``)
    probe_boxes: wp.array
    probe_mass: wp.array
    diagnostics_kernel: wp.Kernel
    probe_mass_kernel: wp.Kernel
    granular_layers: int
    granular: GranularPlan | None

    def likely_cause(self, dt: float, bound: float) -> str: ...


def check_point_status(stage: PointStage, t: float, dt: float, bound: float, status: np.ndarray) -> None:
    """Raise BlowUpError for NaN/inf or escaped points, or a granular node out of grid layers
    (counted by the G2P and P2G kernels of the MPM ``stage``)."""
    if status[0] > 0 or not math.isfinite(t):
        raise BlowUpError(
            "non-finite",
            f"simulation blew up at t = {t:.6g} s: {int(status[0])} points have NaN/inf values. "
            f"Likely cause: {stage.likely_cause(dt, bound)}.", t)
    if len(status) > 2 and status[2] > 0:
        raise BlowUpError(
            "granular-layers",
            f"at t = {t:.6g} s more than {stage.granular_layers} components met at one grid node "
            f"({int(status[2])} point-node contributions had no grid layer left): raise "
            "SolverConfig.granular_layers (granular mode).", t)
    if status[1] > 0:
        raise BlowUpError(
            "left-domain",
            f"{int(status[1])} points left the domain at t = {t:.6g} s. Likely cause: a 'free' "
            f"boundary on that side, or an unstable step ({stage.likely_cause(dt, bound)}).", t)


def point_diagnostics(stage: PointStage, mark: tuple[float, np.ndarray]) -> tuple[dict[str, float],
                                                                                 tuple[float, np.ndarray]]:
    """Energies [J/m], momenta [kg/s, kg m/s per m], mass [kg/m], works, forces on the obstacles
    [N/m] and granular counts of the MPM ``stage`` now, and the mark of the next call.

    ``mark``: (t [s], impulses on the obstacles [N s/m]) at the previous call (the forces are the
    impulse since then over the time since then); the new mark is returned, not stored."""
    stage.diag.zero_()
    t_now = stage.sim_clock.time
    wp.launch(stage.diagnostics_kernel, stage.particle_count,
              inputs=[stage.points, stage.D, stage.materials, stage.diag, t_now], device=stage.device)
    vals = host_copy(stage.diag)
    out = {name: float(v) for name, v in zip(reduction_kernels.DIAG_NAMES, vals, strict=True)}
    if stage.model.mass_probes:
        stage.probe_mass.zero_()
        wp.launch(stage.probe_mass_kernel, stage.particle_count,
                  inputs=[stage.points, stage.probe_boxes, stage.probe_mass, t_now], device=stage.device)
        for probe, m in zip(stage.model.mass_probes, host_copy(stage.probe_mass), strict=True):
            out[f"mass_{probe.name}"] = float(m)
    sums = host_copy(stage.work).reshape(-1, grid_kernels.WORK_SLOTS).sum(axis=1)
    works = sums[: len(grid_kernels.WORK_TERMS)]
    out.update({name: float(w) for name, w in zip(grid_kernels.WORK_TERMS, works, strict=True)})
    # force on the obstacles [N/m]: impulse since the previous call / time since then
    impulse = sums[grid_kernels.IMPULSE_BASE:]
    t_now = stage.sim_clock.time
    t_prev, i_prev = mark
    span = t_now - t_prev
    force = (impulse - i_prev) / span if span > 0.0 else np.zeros_like(impulse)
    for k, wall in enumerate(grid_kernels.WALLS if stage.model.obstacles else ()):
        out[f"force_{wall}_x"] = float(force[2 * k])
        out[f"force_{wall}_y"] = float(force[2 * k + 1])
    out["energy_total"] = out["energy_kinetic"] + out["energy_strain"] + out["energy_gravity"]
    if stage.granular is not None:
        out["components"], out["layers"] = (float(v) for v in stage.granular.statistics())
        out["granular_rebuilds"], out["granular_relabels"] = (float(v) for v in stage.granular.counts())
    return out, (t_now, impulse)


class EnergyBalance:
    """Energy balance of "Motion integration" eq. 67-68 over a run: the works of the walls, of
    Cundall damping, of plasticity and of contact damping and friction (W ≤ 0 when dissipating)
    explain part of ΔE_total; the residual W_num is what the discretisation itself gained or lost.

    Args:
        work_terms: the names of the diagnostics that are works (``Stage.WORK_TERMS``).
    """

    def __init__(self, work_terms: tuple[str, ...]):
        self.work_terms = work_terms
        #: the diagnostics of the first frame
        self.initial: dict[str, float] = {}

    def update(self, d: dict[str, float]) -> dict[str, float]:
        """Works since the first frame in ``d`` and ``work_numerical`` (the first call sets it)."""
        if not self.initial:
            self.initial.update(d)
        for name in self.work_terms:
            d[name] -= self.initial[name]
        d["work_numerical"] = (d["energy_total"] - self.initial["energy_total"]
                               - sum(d[name] for name in self.work_terms))
        return d


def check_energy(scene, config, t: float, d: dict, e0: dict, cause) -> None:
    """Energy growth past blowup_energy_factor × the scene's energy scale is a blow-up (``cause``:
    a callable giving the likely cause, only called for the message)."""
    if not all(math.isfinite(v) for v in d.values()):
        raise BlowUpError("non-finite", f"simulation blew up at t = {t:.6g} s: non-finite energy. "
                          f"Likely cause: {cause()}.", t)
    (x0, y0), (x1, y1) = scene.domain
    g = math.hypot(*scene.gravity)
    fall = g * math.hypot(x1 - x0, y1 - y0)  # [J/kg] the most a mass can fall in the domain
    stored = e0.get("energy_strain", 0.0) + e0.get("energy_contact", 0.0)
    # the energy in play: the initial kinetic and stored energy, the potential energy released
    # so far, and a floor of 5 % of a fall through the domain (a scene at rest starts with
    # none); the whole fall would hide a gain of many impact energies of a short drop
    released = max(e0["energy_gravity"] - d["energy_gravity"], 0.0)
    scale = e0["energy_kinetic"] + stored + released + 0.05 * e0["mass"] * fall
    # energy put in by driven (kinematic) bodies or moving walls, or brought by released points (or
    # across a periodic side) is not growth, and sets a scale of its own (the released mass falling
    # through the domain, at most)
    driven = d.get("work_driven", 0.0) + d.get("work_inflow", 0.0)
    if any(b.velocity != 0.0 for b in scene.boundaries.values()):
        driven += d.get("work_boundary", 0.0)  # (moving walls drive the material too)
    inflow = max(d.get("mass", 0.0) - e0.get("mass", 0.0), 0.0) * fall
    scale = max(scale + abs(driven) + inflow, 1e-30)
    growth = d["energy_total"] - e0["energy_total"] - driven
    if growth > config.blowup_energy_factor * scale:
        raise BlowUpError(
            "energy-growth",
            f"simulation blew up at t = {t:.6g} s: total energy grew by {growth:.3g} J/m, more than "
            f"{config.blowup_energy_factor:g} x its scale {scale:.3g} J/m. "
            f"Likely cause: {cause()}.", t)
