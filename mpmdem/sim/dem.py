"""The DEM stage: device arrays of the rigid spheropolygon bodies and the launches of one step.

No physics here (that is ``mpmdem.kernels.dem``): this module lays the bodies out on the device
(free and kinematic bodies first, fixed last, each group in cell order), sizes the broad-phase
cells and the Verlet lists, and launches the kernels of a step:

world vertices → displacement check → (list rebuild, only when flagged on the device) →
(scenes with disk grains: the disk–disk pass, ``kernels.dem_disks``) → contact forces (one
kernel; in large GPU scenes three, the search split over candidate vertices:
``kernels.dem_split``) → rigid-body update → clock.

The rebuild kernels run every step but return at once unless the device flag is set, so the
step never waits on the host and can be recorded as one CUDA graph.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import warp as wp

from ..checks import check_time_step, eq51_step
from ..errors import BlowUpError, InputError
from ..kernels import clock as clock_kernels
from ..kernels import dem as dem_kernels
from ..kernels import dem_disks, dem_lists, dem_split
from ..kernels import reductions as reduction_kernels
from ..kernels.scan import pack_launch
from ..model.bodies import ContactLaw
from ..model.config import SolverConfig
from ..model.finished import Model
from ..model.memory import check_device_memory
from ..model.rigid_arrays import RigidArrays
from ..model.scene import Scene
from .dem_period import periodic_cells
from .host_copy import host_copy
from .launch_plan import IfFlag, Launch, run_plan
from .stage import Clock, ClockedStage
from .tuning import Tuning

__all__ = ["DEMSolver", "dem_time_step_bound", "spring_time_step_bound"]

_MOTION_IDS = {"free": dem_kernels.FREE, "fixed": dem_kernels.FIXED, "kinematic": dem_kernels.KINEMATIC}

#: Body arrays that change during a run (what a checkpoint must hold), and the contact arrays.
_BODY_STATE = ("x", "angle", "v", "omega", "force", "torque", "x_ref", "angle_ref", "work")
_CONTACT_STATE = ("nbr", "count", "key", "slip", "energy", "dissipated", "body_dissipated", "pairs", "total")


def effective_mass(mass, inertia, core_radius):
    """Smallest mass [kg/m] a contact on a body of mass m [kg/m], moment of inertia I [kg m²/m] and
    core radius R [m] can feel (floats or arrays): a force at its farthest vertex, normal to the
    lever arm, sees 1 / (1/m + R²/I) (m for a disk, m/4 for any rectangle)."""
    return 1.0 / (1.0 / mass + core_radius * core_radius / inertia)


def dem_time_step_bound(scene: Scene | Model, arrays: RigidArrays | None = None) -> float:
    """Largest stable explicit step [s] of one free body on one damped contact spring,
    2 sqrt(m* / k) (sqrt(1 + ζ²) − ζ), with k the larger of k_n and k_t, m* the smallest
    effective mass of the free bodies and ζ the damping ratio of the contact law.

    MPM-SDEM eq. 51 takes 2π κ2 sqrt(m_min / k_n), κ2 = 0.1 by default (π κ2 ≈ 0.31 of this
    bound without damping). It counts the mass and the spring only. Two things it misses made
    runs fail at its step (bench/dem_stability.py): a polygon pressed at a corner also turns,
    which makes the contact stiffer than m suggests (a block rocking on two corners blew up), so
    the rotational effective mass m* (``effective_mass``) stands in for m_min (for disks m* = m);
    and the explicit dashpot, acting on the lagged velocity, is stable only for
    ω dt < 2 (sqrt(1 + ζ²) − ζ) (a damped pentagon pile gained energy at eq. 51's step).
    ``arrays``: ``scene.body_arrays()`` when the caller has them.
    """
    b = scene.body_arrays() if arrays is None else arrays
    masses = effective_mass(b.mass, b.inertia, b.core_radius)[b.free]
    if not len(masses):
        if scene.has_mpm:  # fixed or driven bodies under material points: no DEM bound
            return math.inf
        raise InputError("rigid_bodies", [b.name for b in scene.rigid_bodies], "at least one free rigid body or grain")
    return spring_time_step_bound(scene.contact, float(masses.min()))


def motion_ids(arrays: RigidArrays) -> np.ndarray:
    """(n,) int32 motion codes of the bodies (kernels.dem FREE, FIXED, KINEMATIC)."""
    return np.where(arrays.free, dem_kernels.FREE,
                    np.where(arrays.fixed, dem_kernels.FIXED, dem_kernels.KINEMATIC)).astype(np.int32)


def spring_time_step_bound(law: ContactLaw, mass: float) -> float:
    """Largest stable explicit step [s] of a mass [kg/m] on one spring–dashpot contact of ``law``,
    2 sqrt(m / k) (sqrt(1 + ζ²) − ζ) with k = max(k_n, k_t) and ζ the law's damping ratio: the
    bound of the DEM bodies (``dem_time_step_bound``) and of the coupling's points
    (``mpmdem.sim.coupling.contact_time_step_bound``)."""
    k = max(float(law.normal_stiffness), law.kt)
    zeta = law.damping_ratio
    return 2.0 * math.sqrt(mass / k) * (math.sqrt(1.0 + zeta * zeta) - zeta)


class DEMSolver(ClockedStage):
    """Device state and step sequence of the DEM stage of one scene.

    Args:
        model: the finished scene (``Scene.finalize``): its DEM bodies' columns are uploaded once.
        config: solver choices (precision, dt, dem_kappa, dem_skin, dem_max_neighbors...).
        device: Warp device.
        clock: the run's clock (``Simulation`` passes its own); None makes one with this stage's
            dt policy (MPM-SDEM eq. 51's DEM term, or the fixed dt).
        tuning: the broad phase's large bodies, the disk–disk pass and the split search
            (``mpmdem.sim.tuning``; default ``Tuning()``).
    """

    def __init__(self, model: Model, config: SolverConfig, device: str, *, clock: Clock | None = None,
                 tuning: Tuning | None = None):
        if model.contact is None:
            raise InputError("contact", None, "a ContactLaw(normal_stiffness=...) in the Scene for rigid bodies")
        self.model = model
        self.config = config
        self.tuning = tuning or Tuning()
        self.device = wp.get_device(device)
        #: x periodic (``kernels.dem_period``): kernels built with the minimum image, cells tiling the period
        self.periodic = model.periodic_x
        self.k = dem_kernels.make_dem_kernels(config.precision, config.deterministic, self.periodic)
        #: the body–body contact kernel of the one-kernel search, built uncapped: a cap of 96
        #: registers made large scenes slower with real steps (bench/README.md, "The one-kernel
        #: search uncapped")
        self.contact_kernel = self.k.contact_forces
        #: the disk–disk pass (``kernels.dem_disks``): scenes with disk grains (``_disk_flags``)
        self.disk_pairs = self.tuning.disk_pairs and any(g.shape == "disk" for g in model.grains)
        #: columns of the scene's rigid bodies (scene order), then its grains
        self.arrays = model.arrays
        self.dt_bound = dem_time_step_bound(model, self.arrays)
        check_time_step(config, self.dt_bound, f"2 sqrt(m*/k_n) (sqrt(1+ζ²)−ζ) = {self.dt_bound:.6g} s of these "
                        f"bodies ({eq51_step(config, self.dt_bound)})")
        self.body_count = len(self.arrays)
        #: (body, body, depth [m]) of the pairs let start overlapping (Scene(allow_initial_overlap=True))
        self.initial_overlaps = list(model.initial_overlaps)
        self._layout()
        check_device_memory(self.device, self.body_count, self.vertex_total, self.slots, config.precision)
        if clock is None:
            clock = Clock(self.device)
            self.start_clock(clock)
        self.sim_clock = clock
        self.clock, self.steps = clock.values, clock.steps
        self._allocate()

    def start_clock(self, clock: Clock) -> None:
        """Set this stage's dt policy on ``clock``: the fixed dt, else π κ2 × the DEM bound
        (dt = 2π κ2 sqrt(m/k), eq. 51; the bound depends on masses and k_n only)."""
        clock.set_policy(dt_fixed=self.config.dt, factor=math.pi * self.config.dem_kappa, bound=self.dt_bound,
                         land=lambda: wp.launch(clock_kernels.land_step, 1, inputs=[clock.values, 0.0, 0.0],
                                                device=self.device))

    # -- set-up -------------------------------------------------------------------------------
    def _layout(self) -> None:
        """Device order of the bodies, the large/small split, cell size, list sizes."""
        motion = motion_ids(self.arrays)
        pos = self.arrays.position
        bound = self.arrays.bounding_radius
        ref = bound[motion == dem_kernels.FREE]
        if not len(ref):  # only fixed or driven bodies (under material points)
            ref = bound
        median = float(np.median(ref))
        # bodies larger than tuning.large_factor × the median (walls, gates) are not binned in
        # cells: every small body tests them directly
        big = np.flatnonzero(bound > self.tuning.large_factor * median)
        big = big[np.argsort(-bound[big])][:self.tuning.max_large]
        is_large = np.zeros(len(motion), bool)
        is_large[big] = True
        small_bound = bound[~is_large]
        r_cut = float(small_bound.max()) if len(small_bound) else median
        cfg = self.config
        self.skin = float(cfg.dem_skin) if cfg.dem_skin is not None else 0.25 * median
        self.cell = 2.0 * r_cut + self.skin
        # moving bodies first, then fixed; each group by cell column, then height (locality)
        cx = np.floor(pos[:, 0] / self.cell)
        order = np.lexsort((pos[:, 1], cx, motion == dem_kernels.FIXED))
        self.order = order
        self.moving = int(np.count_nonzero(motion != dem_kernels.FIXED))
        #: free bodies: a body–body contact needs one (build_lists pairs no two fixed or kinematic bodies)
        self.free = int(np.count_nonzero(motion == dem_kernels.FREE))
        self.motion = motion[order]
        self.is_large = is_large[order]
        # cells over the domain and every small body (a fixed peg may sit outside the domain)
        (x0, y0), (x1, y1) = self.model.domain
        sp = pos[~is_large]
        lo = np.minimum([x0, y0], sp.min(axis=0) if len(sp) else [x0, y0]) - self.cell
        hi = np.maximum([x1, y1], sp.max(axis=0) if len(sp) else [x1, y1]) + self.cell
        self.cell_origin = lo
        self.cells = tuple(int(v) for v in np.maximum(np.ceil((hi - lo) / self.cell), 1))
        if self.periodic:
            self.cell, self.cell_origin, self.cells = periodic_cells(self.model.domain, self.cell, lo, hi)
        # capacity of a cell: bodies whose centroids fit in it without overlapping much
        areas = self.arrays.area[~is_large]
        a_min = float(areas.min()) if len(areas) else 1.0
        self.cell_cap = int(min(128, math.ceil(1.5 * (self.cell + r_cut) ** 2 / a_min) + 4))
        if cfg.dem_max_neighbors is not None:
            self.slots = cfg.dem_max_neighbors
        else:
            ratio = float(small_bound.max() / small_bound.min()) if len(small_bound) else 1.0
            self.slots = 12 if ratio <= 1.5 else 24 if ratio <= 3.0 else 48
            self.slots += min(len(big), 4)
        self.large = np.flatnonzero(self.is_large).astype(np.int32)
        self.vertex_total = int(self.arrays.counts.sum())

    def _allocate(self) -> None:
        k = self.k
        dev = self.device
        T = np.float32 if self.config.precision == "f32" else np.float64
        n = self.body_count

        def arr(values, dtype, shape=None):
            a = np.asarray(values, dtype=T if dtype is None else dtype)
            return wp.array(a if shape is None else a.reshape(shape), dtype=self._wp(dtype, a), device=dev)

        cols = self.arrays.take(self.order)
        mass, inertia = cols.mass, cols.inertia
        free = self.motion == dem_kernels.FREE
        kinematic = self.motion == dem_kernels.KINEMATIC
        counts = cols.counts.astype(np.int32)
        starts = cols.starts.astype(np.int32)
        local = cols.local.astype(T)
        owner = np.repeat(np.arange(n, dtype=np.int32), counts)
        world = cols.world.astype(T)
        self.vertex_count = int(counts.sum())
        self.moving_vertices = int(counts[: self.moving].sum())

        B = k.Bodies()
        B.x = arr(cols.position, None, (n, 2))
        B.angle = arr(cols.angle, None)
        B.v = arr(np.where(free[:, None], cols.velocity, 0.0), None, (n, 2))
        B.omega = arr(np.where(free, cols.angular_velocity, 0.0), None)
        B.force = arr(np.zeros((n, 2)), None)
        B.torque = arr(np.zeros(n), None)
        B.mass = arr(mass, None)
        B.inertia = arr(inertia, None)
        B.inv_mass = arr(np.where(free, 1.0 / mass, 0.0), None)
        B.inv_inertia = arr(np.where(free, 1.0 / inertia, 0.0), None)
        B.radius = arr(cols.radius, None)
        B.core_radius = arr(cols.core_radius, None)
        B.friction = arr(cols.friction, None)
        B.motion = arr(self.motion, np.int32)
        B.vstart = arr(starts, np.int32)
        B.vcount = arr(counts, np.int32)
        B.x_ref = arr(cols.position, None, (n, 2))
        B.angle_ref = arr(cols.angle, None)
        B.kin_v = arr(np.where(kinematic[:, None], cols.velocity, 0.0), None, (n, 2))
        B.kin_omega = arr(np.where(kinematic, cols.angular_velocity, 0.0), None)
        window = np.array(cols.active, np.float64).reshape(n, 2)
        window[:, 1] = np.minimum(window[:, 1], 1e300)
        B.kin_window = wp.array(window, dtype=wp.vec2d, device=dev)
        B.work = wp.zeros(n, dtype=wp.float64, device=dev)
        disk = self._disk_flags(cols, local)
        B.disk = arr(disk, np.int32)
        self.B = B
        self.local = wp.array(local, dtype=self._vec2, device=dev)
        self.owner = wp.array(owner, dtype=wp.int32, device=dev)
        self.world = wp.array(world, dtype=self._vec2, device=dev)

        K = self.slots
        C = k.Contacts()
        C.slots = K
        C.nbr = wp.full(n * K, -1, dtype=wp.int32, device=dev)
        C.count = wp.zeros(n, dtype=wp.int32, device=dev)
        C.key = wp.full(n * K, wp.vec4i(-1, -1, -1, -1), dtype=wp.vec4i, device=dev)
        C.slip = wp.zeros(n * K, dtype=self._vec4, device=dev)
        C.energy = wp.zeros(n * K, dtype=self._scalar, device=dev)
        C.dissipated = wp.zeros(n * K, dtype=wp.vec2d, device=dev)
        C.body_dissipated = wp.zeros(n, dtype=wp.vec2d, device=dev)
        C.old_nbr = wp.full(n * K, -1, dtype=wp.int32, device=dev)
        C.pairs = wp.zeros(n * K, dtype=wp.int32, device=dev)
        C.total = wp.zeros(1, dtype=wp.int32, device=dev)
        self.C = C
        self.D = None
        if self.disk_pairs:
            self.contact_kernel = self.k.make_contact_forces(None, True)
            self.disks = dem_disks.make_disk_pairs(self.config.precision, self.config.deterministic, self.periodic,
                                                   self.tuning.disk_force_registers)
            self.D = self.disks.DiskPairs()
            self.D.incoming = wp.zeros(n * K, dtype=wp.int32, device=dev)
            self.D.fill = wp.zeros(n, dtype=wp.int32, device=dev)
            self.D.count = wp.zeros(n, dtype=wp.int32, device=dev)
            self.D.slip = wp.zeros(n * K, dtype=self._scalar, device=dev)
        self.split = self._split_search(n, int(np.max(counts)) if n else 0)

        law = self.model.contact
        (x0, y0), (x1, y1) = self.model.domain
        params = k.Params()
        params.law.kn = float(law.normal_stiffness)
        params.law.kt = law.kt
        params.law.zeta = law.damping_ratio
        params.skin = self.skin
        params.gravity = self._vec2(*self.model.gravity)
        params.gravity_ramp = float(self.model.gravity_ramp)
        params.lo = self._vec2(x0, y0)
        params.hi = self._vec2(x1, y1)
        params.cell_origin = self._vec2(*self.cell_origin)
        params.inv_cell = 1.0 / self.cell
        params.cells_x, params.cells_y = self.cells
        params.cell_cap = self.cell_cap
        params.moving = self.moving
        self.params = params

        self.small = wp.array(np.flatnonzero(~self.is_large).astype(np.int32), dtype=wp.int32, device=dev)
        self.large_ids = wp.array(self.large if len(self.large) else np.zeros(1, np.int32), dtype=wp.int32,
                                  device=dev)
        self.is_large_arr = wp.array(self.is_large.astype(np.int32), dtype=wp.int32, device=dev)
        ncell = self.cells[0] * self.cells[1]
        self.cell_count = wp.zeros(ncell, dtype=wp.int32, device=dev)
        self.cell_items = wp.zeros(ncell * self.cell_cap, dtype=wp.int32, device=dev)
        self.flags = wp.ones(1, dtype=wp.int32, device=dev)  # build the lists in the first step
        self.rebuilds = wp.zeros(1, dtype=wp.int64, device=dev)
        self.status = wp.zeros(dem_kernels.STATUS_SIZE, dtype=wp.int32, device=dev)
        self.diag = wp.zeros(len(dem_kernels.DIAG_NAMES), dtype=wp.float64, device=dev)

    def _disk_flags(self, cols: RigidArrays, local: np.ndarray) -> np.ndarray:
        """(n,) 1 for the bodies (device order) whose pairs with each other take the disk–disk pass:
        small (not "large") sphero-disks, a core of one vertex at the centroid; all 0 unless
        ``disk_pairs``."""
        one = (cols.counts == 1) & ~self.is_large & (cols.core_radius == 0.0)
        one[one] = np.all(local[cols.starts[one]] == 0.0, axis=1)
        self.disk_pairs = bool(self.disk_pairs and self.free and one.any())
        return (one & self.disk_pairs).astype(np.int32)

    @property
    def _scalar(self):
        return wp.float32 if self.config.precision == "f32" else wp.float64

    @property
    def _vec2(self):
        return wp.types.vector(2, self._scalar)

    @property
    def _vec4(self):
        return wp.types.vector(4, self._scalar)

    def _wp(self, dtype, a):
        if dtype is not None:
            return wp.int32
        return self._vec2 if a.ndim == 2 else self._scalar

    @property
    def dt_default(self) -> float:
        """The time step of this scene [s]: the fixed dt, or MPM-SDEM eq. 51's DEM term."""
        return self.config.dt or math.pi * self.config.dem_kappa * self.dt_bound

    # -- stepping -------------------------------------------------------------------------------
    def step(self, own_clock: bool = True) -> None:
        """Launch one DEM step (contacts, then the rigid-body update) on the device clock; with
        ``own_clock`` it ends the step on the clock (t += dt, the next step's dt: one launch)."""
        self.contact_stage()
        self.body_update()
        if own_clock:
            wp.launch(self.k.end_step, 1, inputs=[self.clock, self.steps], device=self.device)

    @functools.cached_property
    def rebuild_plan(self) -> list:
        """The Verlet-list rebuild as one conditional block: every kernel of it returns at once
        unless the rebuild flag is set, so in a CUDA graph it is one conditional node instead of
        five launches (built once: the arrays it names live as long as the stage)."""
        k, B, C, params = self.k, self.B, self.C, self.params
        lists = dem_lists.make_dem_lists(self.config.precision, self.config.deterministic, self.disk_pairs,
                                         self.periodic, self.tuning.list_build_registers)
        rebuild = [Launch(k.clear_cells, len(self.cell_count), [self.flags, self.cell_count])]
        if len(self.small):
            rebuild.append(Launch(lists.bin_bodies, len(self.small),
                                  [B, params, self.small, self.flags, self.cell_count, self.cell_items, self.status]))
        dim, block = pack_launch(self.body_count, self.device)  # (build_lists packs the pairs a block at a time)
        rebuild += [
            Launch(k.reset_total, 1, [self.flags, C]),
            Launch(lists.build_lists, dim,
                   [B, C, params, self.world, self.is_large_arr, self.large_ids, len(self.large), self.flags,
                    self.cell_count, self.cell_items, self.status, C.total, self.body_count], block_dim=block),
        ]
        if self.disk_pairs:  # each disk's pairs owned by lower disks (kernels.dem_disks)
            rebuild += [Launch(self.disks.list_incoming, self.body_count, [B, C, self.D, self.flags, self.status]),
                        Launch(self.disks.sort_incoming, self.body_count, [C, self.D, self.flags])]
        rebuild.append(Launch(k.finish_rebuild, 1, [self.flags, self.rebuilds]))
        return [IfFlag(self.flags, rebuild)]

    def contact_stage(self) -> None:
        """World vertices, Verlet lists (rebuilt only when flagged on the device) and the
        body–body contact forces of this step into ``B.force``, ``B.torque``."""
        self.contact_checks()
        run_plan(self.contact_rebuild, self.device)
        self.contact_forces()

    def contact_checks(self, clear_loads: bool = True) -> None:
        """The start of the contact stage, one launch (``kernels.dem_contacts.start_contacts``): world vertices
        of the moving bodies, this step's loads cleared and, with free bodies, whether the lists
        must be rebuilt (a device flag). Without free bodies (a silo's walls, a fixed floor under
        points: no body–body contact, the lists would stay empty), ``clear_loads`` False leaves the
        clearing to the caller's launch (the coupling's ``check_lists``)."""
        clear = self.body_count if self.free or clear_loads else 0
        moving = self.moving if self.free else 0
        threads = max(self.moving_vertices, clear)
        if clear and not self.moving_vertices:  # nothing moves: the loads only
            wp.launch(self.k.clear_loads, clear, inputs=[self.B], device=self.device)
        elif threads:
            wp.launch(self.k.start_contacts, threads,
                      inputs=[self.B, self.local, self.owner, self.world, self.params, self.flags, self.moving_vertices,
                              clear, moving], device=self.device)

    @property
    def contact_rebuild(self) -> list:
        """The plan of the list rebuild (``rebuild_plan``; nothing without a free body)."""
        return self.rebuild_plan if self.free else []

    def _split_search(self, n: int, max_vertices: int):
        """The kernels and records of the split pair search (``kernels.dem_split``) where this scene
        takes it (``tuning.split_search_bodies`` and ``split_search_devices``, not deterministic, every
        core of at most ``dem_split.MAX_VERTICES`` vertices), else None: the one-kernel search. The
        same bits as the one-kernel search, whatever the split's ``tuning``."""
        dev = self.device
        tn = self.tuning
        if (n < tn.split_search_bodies or ("cuda" if dev.is_cuda else "cpu") not in tn.split_search_devices
                or self.config.deterministic or not self.free or max_vertices > dem_split.MAX_VERTICES
                or self.periodic):
            return None
        kernels = dem_split.make_split_search(self.config.precision, tn.split_hits_per_pair,
                                              tn.split_assemble_registers)
        S = kernels.Split()
        S.pairs = min(n * tn.split_pairs_per_body, n * self.slots, 1 << 25)  # (a candidate's code holds q < 2^25)
        cap = n * tn.split_candidates_per_body
        S.candidate = wp.zeros(cap, dtype=wp.int32, device=dev)
        S.candidate_count = wp.zeros(1, dtype=wp.int32, device=dev)
        S.whole = wp.zeros(S.pairs, dtype=wp.int32, device=dev)
        S.touches = wp.zeros(S.pairs, dtype=wp.int32, device=dev)
        hits = S.pairs * tn.split_hits_per_pair
        S.code = wp.zeros(hits, dtype=wp.int32, device=dev)
        S.normal = wp.zeros(hits, dtype=self._vec2, device=dev)
        S.distance = wp.zeros(hits, dtype=self._scalar, device=dev)
        per_body = 0 if self.disk_pairs else tn.split_threads_per_body  # (with disks: the few general pairs)
        threads = (min(cap, max(tn.split_threads_per_sm * dev.sm_count, per_body * n)) if dev.is_cuda
                   else min(cap, tn.split_cpu_threads))
        return kernels, S, threads

    def contact_forces(self) -> None:
        """The body–body contact forces of this step (lists up to date), with free bodies."""
        if not self.free:
            return
        B, C, world, dev = self.B, self.C, self.world, self.device
        pairs = self.body_count * self.slots
        if self.disk_pairs:  # (before the general search: a disk's sum starts with its disk partners)
            wp.launch(self.disks.disk_forces, self.body_count, inputs=[B, C, self.D, self.params, self.clock],
                      device=dev)
        if self.split is None:
            wp.launch(self.contact_kernel, pairs, inputs=[B, C, self.params, world, self.clock, self.status],
                      device=dev)
            return
        k, S, threads = self.split
        dim, block = pack_launch(threads, dev)
        wp.launch(k.candidates, dim, inputs=[B, C, world, S, S.candidate_count, dim], device=dev,
                  **({"block_dim": block} if block else {}))
        wp.launch(k.search, threads, inputs=[B, C, world, S, threads], device=dev)
        # (on the CPU a thread a pair, in order: the bodies' forces summed as ``contact_forces`` sums them)
        assemblers = threads if dev.is_cuda else pairs
        wp.launch(k.assemble, assemblers, inputs=[B, C, self.params, world, S, self.clock, self.status, assemblers],
                  device=dev)

    def body_update(self) -> None:
        """Rigid-body update of the free and kinematic bodies (fixed bodies are not integrated)."""
        if self.moving:
            wp.launch(self.k.integrate, self.moving, inputs=[self.B, self.params, self.clock, self.status],
                      device=self.device)

    def status_counts(self) -> np.ndarray:
        """The DEM status counters (``kernels/dem.py`` STATUS_*)."""
        return host_copy(self.status)

    def check_status(self, t: float, dt: float, bound: float, status: np.ndarray) -> None:
        """Raise BlowUpError for non-finite or escaped bodies and overflowing lists."""
        cfg = self.config
        cause = self.likely_cause(dt)
        if status[dem_kernels.STATUS_NONFINITE] > 0 or not math.isfinite(t):
            raise BlowUpError("non-finite", f"the DEM blew up at t = {t:.6g} s: "
                              f"{int(status[dem_kernels.STATUS_NONFINITE])} bodies have NaN/inf values. "
                              f"Likely cause: {cause}.", t)
        if status[dem_kernels.STATUS_OUTSIDE] > 0:
            # the flag counts body-steps outside over the steps since the last check, not bodies
            outside = int(status[dem_kernels.STATUS_OUTSIDE])
            raise BlowUpError("left-domain", f"rigid bodies left the domain by t = {t:.6g} s (outside the domain "
                              f"{outside} times, counted per body and step since the last "
                              f"check). Likely cause: an open side (close it with Scene.add_walls) or {cause}.", t)
        if status[dem_kernels.STATUS_NEIGHBOR_OVERFLOW] > 0:
            raise BlowUpError("list-overflow", f"a DEM Verlet list overflowed at t = {t:.6g} s (more than "
                              f"{self.slots} neighbours of one body): raise SolverConfig(dem_max_neighbors=...) "
                              f"(now {cfg.dem_max_neighbors}) or lower dem_skin.", t)
        if status[dem_kernels.STATUS_CELL_OVERFLOW] > 0:
            raise BlowUpError("cell-overflow", f"a DEM broad-phase cell held more than {self.cell_cap} bodies at "
                              f"t = {t:.6g} s: bodies are piled into each other. Likely cause: {cause}.", t)

    def overlap_cause(self) -> str:
        """The initial overlaps as a cause of a blow-up ("" when the bodies started apart)."""
        if not self.initial_overlaps:
            return ""
        a, b, depth = self.initial_overlaps[0]
        n = len(self.initial_overlaps)
        return (f"the initial overlap of rigid bodies {a!r} and {b!r} ({depth:.3g} m deep"
                f"{f'; {n} pairs start overlapping' if n > 1 else ''}, let through by "
                "Scene(allow_initial_overlap=True)): the first steps turn it into speed; move the bodies apart")

    def likely_cause(self, dt: float, bound: float | None = None) -> str:
        """What most likely made the DEM blow up: initial overlaps, the step, or soft contacts (the
        bound is this stage's own, ``dt_bound``)."""
        step = (f"the time step (dt = {dt:.3g} s against the bound 2 sqrt(m*/k_n) (sqrt(1+ζ²)−ζ) = "
                f"{self.dt_bound:.3g} s; lower dem_kappa or dt) or a contact stiffness too low for the "
                "loads (bodies pass through each other)")
        overlap = self.overlap_cause()
        return f"{overlap}; else {step}" if overlap else step

    def diagnostics(self) -> dict[str, float]:
        """Energies [J/m], momenta and mass of the free bodies; contact energy and dissipation."""
        self.diag.zero_()
        wp.launch(self.k.diagnostics, self.body_count, inputs=[self.B, self.C, self.params, self.diag],
                  device=self.device)
        vals = dict(zip(dem_kernels.DIAG_NAMES, (float(v) for v in host_copy(self.diag)), strict=True))
        out = {name: vals[name] for name in ("energy_kinetic", "energy_gravity", "energy_contact")}
        out["energy_total"] = out["energy_kinetic"] + out["energy_gravity"] + out["energy_contact"]
        out.update({name: vals[name] for name in ("momentum_x", "momentum_y", "momentum_angular", "mass")})
        # works done on the bodies (<= 0: dissipated), as the MPM stage's work terms
        out["work_contact_damping"] = -vals["dissipated_damping"]
        out["work_contact_friction"] = -vals["dissipated_friction"]
        out["work_driven"] = vals["work_driven"]  # by kinematic bodies (and, periodic x, across the seam)
        out["list_rebuilds"] = float(host_copy(self.rebuilds)[0])
        out["listed_pairs"] = float(host_copy(self.C.count).sum())
        out["history_overflows"] = float(host_copy(self.status)[dem_kernels.STATUS_HISTORY_OVERFLOW])
        out.update(self.probe_masses())
        return out

    def probe_masses(self) -> dict[str, float]:
        """``mass_<probe>`` [kg/m]: the mass of the free bodies and grains whose centroid lies in
        each of the scene's mass probes, summed on the device (``kernels.reductions``)."""
        probes = self.model.mass_probes
        if not probes:
            return {}
        if not hasattr(self, "_probe_boxes"):
            self._probe_boxes = wp.array(np.array([[*p.lo, *p.hi] for p in probes], np.float64).reshape(-1, 4),
                                         dtype=wp.vec4d, device=self.device)
            self._probe_mass = wp.zeros(len(probes), dtype=wp.float64, device=self.device)
            self._probe_kernel = reduction_kernels.make_body_probe_mass(self.config.precision)
        self._probe_mass.zero_()
        wp.launch(self._probe_kernel, self.body_count,
                  inputs=[self.B.x, self.B.mass, self.B.motion, self._probe_boxes, self._probe_mass],
                  device=self.device)
        return {f"mass_{p.name}": float(m) for p, m in zip(probes, host_copy(self._probe_mass), strict=True)}

    #: Diagnostics that are works done on the system (for the energy balance).
    WORK_TERMS = ("work_contact_damping", "work_contact_friction", "work_driven")

    def fields(self) -> dict[str, np.ndarray]:
        """Host copies of the per-body output fields, in the scene's order."""
        B = self.B
        out = {}
        for name, a in (("x", B.x), ("angle", B.angle), ("v", B.v), ("omega", B.omega), ("force", B.force),
                        ("torque", B.torque)):
            values = host_copy(a)
            out[name] = np.empty_like(values)
            out[name][self.order] = values
        return out

    def scene_geometry(self) -> dict:
        """Static per-body data (vertices, radius, motion, mass, name) in the scene's order."""
        inv = np.empty_like(self.order)
        inv[self.order] = np.arange(len(self.order))
        bodies = self.model.rigid_bodies
        grains = self.model.grains
        counts = np.array([len(b.shape.vertices) for b in bodies], np.int32)
        vertices = [b.shape.vertices for b in bodies] or [np.zeros((0, 2))]
        radius = [np.array([b.shape.radius for b in bodies])]
        motion = [np.array([_MOTION_IDS[b.motion] for b in bodies], np.int32)]
        mass = [np.array([b.mass for b in bodies])]
        for g in grains:  # grains last, as arrays (``grain`` marks them for the writers and plots)
            counts = np.concatenate([counts, np.full(len(g), g.local.shape[1], np.int32)])
            vertices.append(g.local.reshape(-1, 2))
            radius.append(g.radius)
            motion.append(np.full(len(g), dem_kernels.FREE, np.int32))
            mass.append(g.mass)
        out = {
            "vertex_start": np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int32),
            "vertex_count": counts,
            "vertices": np.concatenate(vertices).astype(float),
            "radius": np.concatenate(radius),
            "motion": np.concatenate(motion).astype(np.int32),
            "mass": np.concatenate(mass),
            "name": list(self.model.body_names),
        }
        if grains:
            out["grain"] = np.repeat([0, 1], [len(bodies), self.body_count - len(bodies)]).astype(np.int32)
        return out

    # -- checkpoints ----------------------------------------------------------------------------
    def state_arrays(self) -> dict[str, wp.array]:
        """Every time-varying device array, by a stable name."""
        arrays = {f"B.{name}": getattr(self.B, name) for name in _BODY_STATE}
        arrays.update({f"C.{name}": getattr(self.C, name) for name in _CONTACT_STATE})
        if self.D is not None:
            arrays.update({f"D.{name}": getattr(self.D, name) for name in ("incoming", "count", "slip")})
        arrays.update(world=self.world, flags=self.flags, rebuilds=self.rebuilds, status=self.status,
                      clock=self.clock, steps=self.steps)
        return arrays
