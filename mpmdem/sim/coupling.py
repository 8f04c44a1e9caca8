"""The coupled stage: material points and rigid spheropolygons in one explicit step (MPM-SDEM §4).

No physics here (that is ``mpmdem.kernels.coupling``): this module sizes the point–body lists and
bins, builds the friction table of (material, body) pairs, sets the coupled time step, and
launches one step in the order of MPM-SDEM §4.2:

1. DEM contacts: body–body forces (``DEMSolver.contact_stage``), then the identified material
   points: list check and (flagged) rebuild, IMP forces f_p on the points and their reactions on
   the bodies (eq. 44–46, 49–50);
2. MPM: P2G (the contact forces enter the nodal forces, eq. 47–48), grid update, G2P;
3. rigid-body update of the free and kinematic bodies (``DEMSolver.body_update``).

One dt for all stages (eq. 51): min(κ1 h / c_max, the DEM term, the contact term), where the
contact term is the DEM bound of a point of the smallest mass on one contact spring (see
``contact_time_step_bound``).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
import warp as wp

from ..checks import check_time_step, eq51_step
from ..errors import BlowUpError, InputError
from ..kernels import coupling as coupling_kernels
from ..model.config import SolverConfig
from ..model.finished import Model
from ..model.scene import Scene
from .dem import DEMSolver, spring_time_step_bound
from .diagnostics import coupled_likely_cause
from .host_copy import host_copy
from .launch_plan import IfAny, IfFlag, Launch, group_conditionals, run_plan, split_after_conditionals
from .mpm import AFTER_FORCE_UPDATE, MPMSolver
from .stage import ClockedStage
from .step_streams import StepStreams
from .tuning import Tuning
from .views import BodiesView

__all__ = ["CoupledStage", "bodies_view", "contact_time_step_bound"]


def contact_time_step_bound(scene: Scene | Model, point_mass: float) -> float:
    """Largest stable step [s] of a material point of mass ``point_mass`` [kg/m] on one contact
    spring of the coupling law, 2 sqrt(m_p / k) (sqrt(1 + ζ²) − ζ), k = max(k_n, k_t): the bound
    ``mpmdem.sim.dem.dem_time_step_bound`` gives a rigid body, with the point as the body.

    Eq. 51 counts the DEM bodies' mass only. A point's contact force is spread over nodes that
    carry more mass than the point, so this bound is on the safe side; bench/coupling_stability.py
    maps how far past it runs stay stable.
    """
    return spring_time_step_bound(scene.coupling_contact or scene.contact, point_mass)



def bodies_view(dem: DEMSolver) -> BodiesView:
    """What the coupled stage sees of ``dem``'s bodies (``mpmdem.sim.views``), built once."""
    return BodiesView(struct=dem.B, world=dem.world, count=dem.body_count, moving=dem.moving, free=dem.free,
                      order=dem.order, columns=dem.arrays)


class CoupledStatus(NamedTuple):
    """The status counters of a coupled step, per stage (each stage's own STATUS_* slots)."""

    mpm: np.ndarray
    dem: np.ndarray
    coupling: np.ndarray

class CoupledStage(ClockedStage):
    """One explicit step of a scene with material points and rigid bodies.

    Args:
        model: the finished scene (``Scene.finalize``) both stages were built from.
        config, device: as for ``Simulation``.
        mpm, dem: the two stages, built for this scene on one ``Clock`` (the coordinator's); the
            MPM stage's dt policy (``MPMSolver.start_clock``), capped here each step.
        tuning: the list build's tile, the sifted and the static point–body lists
            (``mpmdem.sim.tuning``; default: the MPM stage's).
    """

    def __init__(self, model: Model, config: SolverConfig, device: str, mpm: MPMSolver, dem: DEMSolver, *,
                 tuning: Tuning | None = None):
        # the point–body lists follow the points' memory order: no re-sort on a schedule, and the
        # automatic re-sorting of sort_interval None is off in coupled scenes (mpmdem.sim.auto_sort)
        if config.sort_interval:
            raise InputError("sort_interval", config.sort_interval,
                             "0 or None in a scene with rigid bodies and points (the point–body lists follow the "
                             "points' memory order; None re-sorts nothing here)")
        self.model, self.config, self.mpm, self.dem = model, config, mpm, dem
        #: what this stage reads and writes of the two stages' arrays (``mpmdem.sim.views``); the
        #: stages themselves only step, report and check
        self.points, self.grid, self.bodies = mpm.points_view, mpm.grid_view, bodies_view(dem)
        self.tuning = tuning or mpm.tuning
        self.device = wp.get_device(device)
        if mpm.sim_clock is not dem.sim_clock:
            raise ValueError("CoupledStage: build the MPM and DEM stages on one Clock (MPMSolver(..., clock=c), "
                             "DEMSolver(..., clock=c))")
        self.sim_clock = mpm.sim_clock
        self.clock, self.steps = mpm.clock, mpm.steps
        law = model.coupling_contact or model.contact
        self.law = law
        host_mass = host_copy(self.points.mass)
        self.contact_bound = contact_time_step_bound(model, float(host_mass.min()))
        self.dt_bound = min(self.contact_bound, dem.dt_bound)
        kappa = math.pi * config.dem_kappa
        self.dt_cap = kappa * self.dt_bound
        mpm.cap_time_step(self.dt_cap, self.dt_bound)  # (one launch with the CFL step's)
        check_time_step(config, self.dt_bound, f"{self.dt_bound:.6g} s of the contacts (a point of the smallest mass "
                        f"on k_n: {self.contact_bound:.6g} s; the rigid bodies: {dem.dt_bound:.6g} s); "
                        f"{eq51_step(config, self.dt_bound)}")
        self.k = coupling_kernels.make_coupling_kernels(config.precision, config.coupling, staged=self.points.staged,
                                           deterministic=config.deterministic)
        self._allocate()
        self.liu = None
        if config.coupling == "liu":
            self._allocate_liu()
            mpm.extend(AFTER_FORCE_UPDATE, self._liu_exchange)
        #: the side streams of the step: the DEM's contact forces and body update; the IMP forces beside
        #: the kernels of a relabel laid in line (``mpmdem.sim.step_streams``; not in deterministic mode,
        #: nor with Liu et al.'s exchange)
        self.streams = StepStreams(self.device, ("dem", "imp"), enabled=not config.deterministic and self.liu is None)

    # -- set-up -------------------------------------------------------------------------------
    def _allocate(self) -> None:
        k, pts, bodies, cfg, dev = self.k, self.points, self.bodies, self.config, self.device
        model = self.model
        n = pts.count
        S = cfg.imp_max_bodies
        T = np.float32 if cfg.precision == "f32" else np.float64
        t = pts.types
        h = model.cell_size
        veci = wp.types.vector(coupling_kernels.IMP_HISTORY, wp.int32)
        vech = wp.types.vector(coupling_kernels.IMP_HISTORY, t.scalar)

        nb = bodies.count
        device = "cuda" if dev.is_cuda else "cpu"
        tn = self.tuning
        #: every point lists every body, for the whole run (``tuning.static_imp_bodies``): no list check
        #: and no conditional rebuild in the step; the force kernel finds the bodies within reach by
        #: their bounding circle and box
        self.static_lists = (cfg.coupling != "liu" and nb <= tn.static_imp_bodies and n < tn.sifted_imp_points
                             and device in tn.static_imp_devices)
        if self.static_lists:
            S = nb
        L = k.Links()
        L.slots = S
        if self.static_lists:  # slot s of every point holds body s, sorted as finish_lists sorts
            L.body = wp.array(np.tile(np.arange(nb, dtype=np.int32), n), dtype=wp.int32, device=dev)
            L.count = wp.full(n, nb, dtype=wp.int32, device=dev)
        else:
            L.body = wp.full(n * S, -1, dtype=wp.int32, device=dev)
            L.count = wp.zeros(n, dtype=wp.int32, device=dev)
        L.key = wp.full(n * S, veci(-1, -1), dtype=veci, device=dev)
        L.slip = wp.zeros(n * S, dtype=vech, device=dev)
        L.old_body = wp.full(n * S, -1, dtype=wp.int32, device=dev)
        L.old_key = wp.full(n * S, veci(-1, -1), dtype=veci, device=dev)
        L.old_slip = wp.zeros(n * S, dtype=vech, device=dev)
        L.x_ref = wp.full(n, t.vec2(1.0e30, 1.0e30), dtype=t.vec2, device=dev)
        L.body_x_ref = wp.clone(bodies.struct.x)
        L.body_angle_ref = wp.clone(bodies.struct.angle)
        radius = pts.contact_radius.astype(T)
        L.radius = wp.array(radius, dtype=t.scalar, device=dev)
        L.energy = wp.zeros(n, dtype=t.scalar, device=dev)
        L.dissipated = wp.zeros(n, dtype=wp.vec2d, device=dev)
        L.contact_at = pts.contact_at
        L.active = wp.zeros(n, dtype=wp.int32, device=dev)
        if self.static_lists:  # every point, in order: the force kernel visits them all
            L.listed = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device=dev)
            L.listed_count = wp.full(1, n, dtype=wp.int32, device=dev)
        else:
            L.listed = wp.zeros(n, dtype=wp.int32, device=dev)
            L.listed_count = wp.zeros(1, dtype=wp.int32, device=dev)
        #: large scenes sift the listed points each step before the force search (``kernels.imp_sift``)
        self.sifted = not cfg.deterministic and n >= tn.sifted_imp_points
        L.near = wp.zeros(n if self.sifted else 1, dtype=wp.int32, device=dev)
        L.near_count = wp.zeros(1, dtype=wp.int32, device=dev)
        self.forces_kernel = k.make_forces(self.sifted, nb if self.static_lists else 0)
        self.L = L

        mats = model.materials
        rigid = len(model.rigid_bodies)
        names = [model.rigid_bodies[i].name if i < rigid else None for i in bodies.order.tolist()]
        own = bodies.columns.friction[bodies.order].tolist()  # (grains: their set's μ; no per-grain override)
        mu = np.array([[model.coupling_friction.get((m, name), f) for name, f in zip(names, own, strict=True)]
                       for m in mats], T)
        vols = host_copy(pts.vol)
        per_cell = h * h / float(vols.min())
        self.skin = float(cfg.imp_skin) if cfg.imp_skin is not None else 0.5 * h
        self.cell_cap = cfg.imp_cell_capacity or int(max(16, math.ceil(4.0 * per_cell)))
        rows, cols = self.grid.shape
        self.cells = (rows - 1, cols - 1)

        params = k.Params()
        params.law.kn = float(self.law.normal_stiffness)
        params.law.kt = self.law.kt
        params.law.zeta = self.law.damping_ratio
        params.skin = self.skin
        params.r_max = float(radius.max())
        params.cell_origin = self.grid.origin
        params.inv_cell = 1.0 / h
        params.cells_x, params.cells_y = self.cells
        params.cell_cap = self.cell_cap
        params.bodies = nb
        params.moving = bodies.moving
        params.tile = tn.imp_build_tile
        params.friction = wp.array(mu.ravel(), dtype=t.scalar, device=dev)
        self.params = params

        ncell = self.cells[0] * self.cells[1]
        self.cell_count = wp.zeros(ncell, dtype=wp.int32, device=dev)
        self.cell_items = wp.zeros(ncell * self.cell_cap, dtype=wp.int32, device=dev)
        self.flags = wp.full(1, 0 if self.static_lists else 1, dtype=wp.int32, device=dev)  # build in the first step
        self.rebuilds = wp.zeros(1, dtype=wp.int64, device=dev)
        #: whether a list rebuild runs in this step (``start_plan``)
        self.any_rebuild = wp.zeros(1, dtype=wp.int32, device=dev)
        #: whether a conditional block at the step's start runs (``launch_plan.group_conditionals``)
        self.any_start = wp.zeros(1, dtype=wp.int32, device=dev)
        self.status = wp.zeros(coupling_kernels.STATUS_SIZE, dtype=wp.int32, device=dev)
        self.diag = wp.zeros(len(coupling_kernels.IMP_DIAG_NAMES), dtype=wp.float64, device=dev)

    def _allocate_liu(self) -> None:
        """Carrier points of each body (its core's vertices and points along its edges at most half a
        cell apart, and the centroid; a disk: its centre and four points at half its radius) and the
        bodies' own grid. Edge carriers closer than a cell keep a long body (a floor slab) present at
        every node along it: carriers only at the vertices and edge midpoints of a 54 cm slab let
        sand fall through between them."""
        bodies, dev = self.bodies, self.device
        t = self.points.types
        h = self.model.cell_size
        local, owner, share = [], [], []

        def along(a, b):
            n = max(2, int(np.ceil(np.linalg.norm(b - a) / (0.5 * h))))
            return a + np.outer(np.arange(1, n) / n, b - a)  # interior points of edge a→b

        cols = bodies.columns
        for j, i in enumerate(bodies.order):
            v = cols.local[cols.starts[i]:cols.starts[i] + cols.counts[i]]
            if len(v) == 1:
                a = 0.5 * cols.radius[i]
                pts = np.vstack([v, v + [[a, 0.0], [0.0, a], [-a, 0.0], [0.0, -a]]])
            elif len(v) == 2:
                pts = np.vstack([v, along(v[0], v[1])])
            else:
                pts = np.vstack([v, *(along(v[k], v[(k + 1) % len(v)]) for k in range(len(v))), [[0.0, 0.0]]])
            local.append(pts)
            owner += [j] * len(pts)
            share += [1.0 / len(pts)] * len(pts)
        k = coupling_kernels.make_liu_kernels(self.config.precision)
        T = np.float32 if self.config.precision == "f32" else np.float64
        shape = self.grid.shape
        BG = k.BodyGrid()
        BG.mass = wp.zeros(shape, dtype=t.scalar, device=dev)
        BG.mom = wp.zeros(shape, dtype=t.vec2, device=dev)
        BG.grad = wp.zeros(shape, dtype=t.vec2, device=dev)
        BG.owner = wp.zeros(shape, dtype=wp.int32, device=dev)
        BG.local = wp.array(np.vstack(local).astype(T), dtype=t.vec2, device=dev)
        BG.body = wp.array(np.array(owner, np.int32), dtype=wp.int32, device=dev)
        BG.share = wp.array(np.array(share, T), dtype=t.scalar, device=dev)
        self.liu = (k, BG, len(owner))

    def _liu_carriers(self) -> None:
        k, BG, n = self.liu
        BG.mass.zero_()
        BG.mom.zero_()
        BG.grad.zero_()
        wp.launch(k.carriers_to_grid, n, inputs=[self.bodies.struct, BG, self.grid.domain, self.clock],
                  device=self.device)

    def _liu_exchange(self) -> None:
        k, BG, _ = self.liu
        grid = self.grid
        wp.launch(k.exchange, BG.mass.shape, inputs=[grid.struct, grid.domain, BG, self.bodies.struct, self.clock],
                  device=self.device)

    # -- stepping -------------------------------------------------------------------------------
    def step(self) -> None:
        """One coupled explicit step (MPM-SDEM §4.2). On CUDA, while the step is recorded as a graph
        and outside deterministic mode (``streams``), the body–body contact forces and then the body
        update run on a branch of their own beside the IMP forces and the MPM passes (the IMP forces
        read no body–body force, the MPM passes read no body), and the IMP forces on a second one
        beside the kernels of a relabel laid in line (they read no label), joined before P2G. Liu et
        al.'s exchange, which reads and loads the bodies from the grid, keeps the one-stream order."""
        mpm, dem, branches = self.mpm, self.dem, self.streams
        branches.begin()
        dem.contact_checks(clear_loads=not self.clears_loads)
        if self.listed:
            self.check_lists()
        # list rebuilds, relabel (when flagged): their conditional nodes are recorded only while no
        # branch is open (``mpmdem.sim.step_streams``); what follows the last of them (the kernels of a
        # relabel laid in line) runs beside the contact forces
        head, tail = split_after_conditionals(self.start_plan)
        run_plan(group_conditionals(head, self.any_start), self.device, mpm.extensions)
        with branches.branch("dem", work=bool(self.bodies.free)):
            dem.contact_forces()
        if self.liu is None:
            with branches.branch("imp", work=bool(tail)):  # (the IMP forces read no label)
                self.imp_forces()
            run_plan(tail, self.device, mpm.extensions)
            branches.join("imp")
            # (after the IMP forces: their reactions are in)
            with branches.branch("dem", work=bool(self.bodies.moving)):
                dem.body_update()
            mpm.run_sequence(start=False)
        else:  # (the exchange reads and loads the bodies: no branch is taken, ``streams``)
            run_plan(tail, self.device, mpm.extensions)
            self._liu_carriers()
            mpm.run_sequence(start=False)
            dem.body_update()
        branches.join()
        mpm.end_step()

    @functools.cached_property
    def rebuild_plan(self) -> list:
        """The point–body list rebuild as one conditional block: its kernels return at once unless
        flagged, so in a CUDA graph it is one conditional node (built once: its arrays live as long
        as the stage)."""
        k, L, params, flags, clock = self.k, self.L, self.params, self.flags, self.clock
        bodies = self.bodies
        points, B, n = self.points.struct, bodies.struct, self.points.count
        rebuild = [
            Launch(k.clear_cells, len(self.cell_count), [flags, self.cell_count]),
            Launch(k.bin_points, n, [points, L, params, clock, flags, self.cell_count, self.cell_items, self.status]),
            Launch(k.build_lists, bodies.count * self.tuning.imp_build_tile,
                   [points, B, L, params, bodies.world, flags, self.cell_count, self.cell_items, self.status]),
            Launch(k.finish_lists, n, [L, flags]),
            Launch(k.finish_rebuild, 1, [flags, self.rebuilds]),
        ]
        return [IfFlag(flags, rebuild)]

    def contact_forces(self) -> None:
        """Point–body lists (rebuilt when flagged) and the IMP forces of this step."""
        if self.listed:
            self.check_lists()
            run_plan(self.rebuild_plan, self.device)
        self.imp_forces()

    @property
    def listed(self) -> bool:
        """Whether the step keeps Verlet point–body lists (checked, and rebuilt when flagged): the
        IMP schemes, unless every point lists every body (``static_lists``)."""
        return self.liu is None and not self.static_lists

    @property
    def clears_loads(self) -> bool:
        """Whether ``check_lists`` clears the bodies' loads: with no free body the DEM stage has no
        contact launch of its own to do it (``DEMSolver.contact_checks``), and the IMP step has."""
        return self.listed and not self.bodies.free

    def check_lists(self) -> None:
        """Flag a rebuild of the point–body lists when a point or a moving body moved more than
        half the skin since the last build (with ``clears_loads``, the bodies' loads cleared in
        the same launch)."""
        n, bodies = self.points.count, self.bodies
        clear = bodies.count if self.clears_loads else 0
        wp.launch(self.k.check_lists, max(n, bodies.moving, clear),
                  inputs=[self.points.struct, bodies.struct, self.L, self.params, self.clock, self.flags,
                          bodies.moving, clear],
                  device=self.device)

    def imp_forces(self) -> None:
        """The IMP forces of this step on the points (and their reactions on the bodies); large
        scenes first sift the listed points, and search only those near a body (``sifted``)."""
        P, B, world, n = self.points.struct, self.bodies.struct, self.bodies.world, self.points.count
        if self.sifted:
            wp.launch(self.k.sift, n, inputs=[P, B, self.L, world, self.clock], device=self.device)
        wp.launch(self.forces_kernel, n, inputs=[P, B, self.L, self.params, world, self.clock, self.status],
                  device=self.device)

    @functools.cached_property
    def start_plan(self) -> list:
        """The conditional blocks of a step's start, decided before any force: the body–body list
        rebuild, the point–body list rebuild and (granular mode) the relabel of the points. The
        two list rebuilds are rare (a body or a point moved half a skin), so when both exist they
        sit under one conditional node (``IfAny``): a skipped conditional node costs ~4.8 µs on an
        H100, the kernel that ORs their flags ~1.2 µs (bench/launch_floor.py). The relabel keeps
        its own node: in a flowing granular scene it runs in nearly every step (98 % in sand-blocks
        and silo-discharge on an H100), and grouped with the lists it would make them pay the
        group's node as well (sand-blocks 159 → 168 µs a step with all three grouped). The blocks touch disjoint
        arrays, so their order among themselves and before the forces changes nothing."""
        lists = self.dem.contact_rebuild + (self.rebuild_plan if self.listed else [])
        if len(lists) == 2:
            lists = [IfAny([block.flag for block in lists], self.any_rebuild, lists)]
        return lists + self.mpm.start_plan

    def status_counts(self) -> CoupledStatus:
        """Status counts of both stages and of the coupling, by name."""
        return CoupledStatus(self.mpm.status_counts(), self.dem.status_counts(), host_copy(self.status))

    def likely_cause(self, dt: float, bound: float) -> str:
        """The rigid bodies' initial overlap, the points' causes, the contact stiffness."""
        return coupled_likely_cause(self.config, self.model, self.dem.overlap_cause(), dt, bound, self.contact_bound)

    def check_status(self, t: float, dt: float, bound: float, status: CoupledStatus) -> None:
        """The MPM and DEM checks, then overflowing point–body lists or bins."""
        self.mpm.check_status(t, dt, bound, status.mpm)
        self.dem.check_status(t, dt, bound, status.dem)
        own = status.coupling
        if own[coupling_kernels.STATUS_SLOT_OVERFLOW] > 0:
            raise BlowUpError("imp-overflow", f"at t = {t:.6g} s a material point was near more than "
                              f"{self.config.imp_max_bodies} rigid bodies: raise SolverConfig(imp_max_bodies=...) "
                              "or lower imp_skin.", t)
        if own[coupling_kernels.STATUS_CELL_OVERFLOW] > 0:
            raise BlowUpError("imp-cell-overflow", f"at t = {t:.6g} s more than {self.cell_cap} points sat in one "
                              "grid cell in the point–body search: raise SolverConfig(imp_cell_capacity=...), or "
                              f"the points collapsed ({self.mpm.likely_cause(dt, bound)}).", t)

    # -- output ---------------------------------------------------------------------------------
    #: Works done on the system (for the energy balance): the MPM stage's, the DEM stage's, and
    #: the damping and friction of the point–body contacts.
    WORK_TERMS = MPMSolver.WORK_TERMS + DEMSolver.WORK_TERMS + ("work_imp_damping", "work_imp_friction")

    _SUMMED = ("energy_kinetic", "energy_gravity", "momentum_x", "momentum_y", "momentum_angular", "mass")

    def diagnostics(self) -> dict[str, float]:
        """Energies [J/m], momenta and mass of points and bodies together, each stage's share
        (``points_*``, ``bodies_*``), contact energies and works, list rebuilds."""
        m = self.mpm.diagnostics()
        d = self.dem.diagnostics()
        self.diag.zero_()
        wp.launch(self.k.diagnostics, self.points.count, inputs=[self.L, self.diag], device=self.device)
        imp = dict(zip(coupling_kernels.IMP_DIAG_NAMES, (float(v) for v in host_copy(self.diag)), strict=True))
        out = dict(m)
        for name in self._SUMMED:
            out[f"points_{name}"] = m[name]
            out[f"bodies_{name}"] = d[name]
            out[name] = m[name] + d[name]
        out["energy_contact_bodies"] = d["energy_contact"]
        out["energy_contact_points"] = imp["energy_imp"]
        out["energy_contact"] = d["energy_contact"] + imp["energy_imp"]
        out["energy_total"] = out["energy_kinetic"] + out["energy_gravity"] + out["energy_strain"] + out[
            "energy_contact"]
        for name in DEMSolver.WORK_TERMS:
            out[name] = d[name]
        out["work_imp_damping"] = -imp["dissipated_imp_damping"]
        out["work_imp_friction"] = -imp["dissipated_imp_friction"]
        out["list_rebuilds"] = d["list_rebuilds"]
        out["imp_rebuilds"] = float(host_copy(self.rebuilds)[0])
        out["imp_pairs"] = imp["imp_pairs"]
        out["imp_contacts"] = imp["imp_contacts"]
        for name in d:  # mass probes: the points' mass and the free bodies' (grains included)
            if name.startswith("mass_"):
                out[name] = m[name] + d[name]
        return out

    def state_arrays(self) -> dict[str, wp.array]:
        """Every time-varying device array of both stages and the point–body lists."""
        arrays = {f"mpm.{k}": a for k, a in self.mpm.state_arrays().items()}
        arrays.update({f"dem.{k}": a for k, a in self.dem.state_arrays().items() if k not in ("clock", "steps")})
        L = self.L
        for name in ("body", "count", "key", "slip", "x_ref", "body_x_ref", "body_angle_ref", "energy",
                     "dissipated", "active", "listed", "listed_count"):
            arrays[f"imp.{name}"] = getattr(L, name)
        arrays.update({"imp.flags": self.flags, "imp.rebuilds": self.rebuilds, "imp.status": self.status,
                       "imp.fcont": self.points.fcont})
        return arrays
