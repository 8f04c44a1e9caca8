"""The MPM stage: the kernel launches of one explicit step of the material points.

No physics is written here; it picks the kernel variants of ``mpmdem.kernels`` that the config
asks for and lays out their launches (``mpmdem.sim.launch_plan``) in the order of the chosen stress
update (USF, USL, MUSL, USAVG). The arrays are built by ``mpmdem.sim.mpm_state`` (points, grid) and
``mpmdem.sim.granular_state`` (interaction graph); the blow-up checks and the per-frame sums are in
``mpmdem.sim.diagnostics``.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..checks import check_time_step
from ..errors import InputError
from ..kernels import clock as clock_kernels
from ..kernels import constitutive as constitutive_kernels
from ..kernels import contact_scatter as contact_scatter_kernels
from ..kernels import granular as granular_kernels
from ..kernels import grid as grid_kernels
from ..kernels import output_fields as output_kernels
from ..kernels import reductions as reduction_kernels
from ..kernels import transfer as transfer_kernels
from ..kernels import xpic as xpic_kernels
from ..kernels.shape_functions import SUPPORT_NODES
from ..kernels.types import scalar_types
from ..model.config import SolverConfig
from ..model.finished import Model
from . import diagnostics as diagnostics_
from . import granular_state
from .block_layout import BlockLayout
from .cell_sort import PointSorter, device_order
from .grid_edges import GridEdges
from .host_copy import host_copy
from .launch_plan import Launch, Zero, plan_blocks, plan_kernels, run_plan
from .mpm_orders import AFTER_FORCE_UPDATE, ORDER_PLANS, StepPieces
from .mpm_roles import GridUpdate, WallFold, last_grid_update, launches
from .mpm_state import GHOST_NODES, STATE_FIELDS, initial_dt_bound, make_domain, make_grid, make_points
from .stage import Clock, ClockedStage
from .tuning import Tuning
from .views import GridView, PointsView

__all__ = ["AFTER_FORCE_UPDATE", "GHOST_NODES", "MPMSolver", "device_order", "initial_dt_bound"]

class MPMSolver(ClockedStage):
    """Device state and step sequence of the MPM stage of one scene.

    Args:
        model: the finished scene (``Scene.finalize``); its seeded points are uploaded once.
        config: discretisation choices.
        device: Warp device ("cpu", "cuda", "cuda:0").
        clock: the run's clock (``Simulation`` passes its own); None makes one with this stage's
            dt policy (the CFL bound or the fixed dt).
        tuning: which kernel variants and fused launches to use (``mpmdem.sim.tuning``; default
            ``Tuning()``).

    Attributes:
        points: the ``Particles`` struct (device order; ``points.pid`` maps to the scene's).
        G, D: the ``Grid`` and ``Domain`` structs.
        clock, steps: the device arrays of ``sim_clock`` that the kernels take.
    """

    def __init__(self, model: Model, config: SolverConfig, device: str, *, clock: Clock | None = None,
                 tuning: Tuning | None = None):
        self.model = model
        self.config = config
        self.tuning = tuning or Tuning()
        self.device = wp.get_device(device)
        self.types = scalar_types(config.precision)
        host = model.particles
        self.particle_count = len(host["mass"])
        self.dt_bound0 = initial_dt_bound(model, host)
        check_time_step(config, self.dt_bound0, f"h/max(c+|v|) = {self.dt_bound0:.6g} s of this scene "
                        f"(h = {model.cell_size:g} m)", use="the CFL policy")
        if config.shape == "ugimp" and (host["half"] > 0.5 * model.cell_size + 1e-12).any():
            raise InputError("shape", config.shape, "uGIMP needs points_per_cell >= 1 (half-lengths <= h/2)")
        self.body = host["body"]
        self.release_times = host["release"]  # [s], scene order
        ppc = max(b.points_per_cell for b in model.bodies)
        reach = SUPPORT_NODES[config.shape] + (1 if config.shape == "cpdi1" else 0)
        # at most (cells reaching a node) × (points per cell) components can meet at one node
        self.granular_layers = (min(64, max(8, reach * reach * ppc * ppc)) if config.granular_layers is None
                                else config.granular_layers) if config.granular else 1
        self.staged = bool((host["release"] > 0.0).any())
        #: rigid bodies push on the points through contact forces (MPM-SDEM §4; mpmdem.sim.coupling)
        self.coupled = model.has_dem
        self._packed_output: wp.array | None = None  # (``fields``: the frame's points, packed in scene order)
        mats = model.materials
        self.critical = any(m.critical_density is not None for m in mats)
        self.order = device_order(host["x"], model.domain[0], model.cell_size)
        own_clock = clock is None
        if own_clock:
            clock = Clock(self.device)
        self.sim_clock = clock
        self.clock, self.steps = clock.values, clock.steps
        self._allocate({k: v[self.order] for k, v in host.items()})
        #: what the coupled stage sees of the points and the grid (``mpmdem.sim.views``)
        self.points_view = PointsView(
            struct=self.points, count=self.particle_count, mass=self.points.mass, vol=self.points.vol,
            fcont=self.points.fcont, contact_radius=self.point_contact_radius, contact_at=self.contact_at,
            staged=self.staged, types=self.types)
        self.grid_view = GridView(struct=self.G, domain=self.D, shape=(self.D.layer_rows, self.grid_shape[1]),
                                  origin=self.D.origin, cell_size=float(model.cell_size))
        self._sorter = PointSorter(self.points, self.D, self.grid_shape, config.precision, self.staged, self.device)
        #: (cap, bound) [s] of every step's dt (``cap_time_step``); cap 0: none
        self.dt_cap = (0.0, 0.0)
        #: callables another stage runs at a named place of the step (``extend``)
        self.extensions: dict[str, list] = {}
        self._build()
        if own_clock:
            self.start_clock(clock)

    def start_clock(self, clock: Clock) -> None:
        """Set this stage's dt policy on ``clock`` (once, before the first step): the fixed dt, else
        κ h / max(c + |v|), the speeds measured by the initial pass of ``_build``."""
        clock.set_policy(dt_fixed=self.config.dt, factor=self.config.cfl, land=self.land_step)
        wp.launch(reduction_kernels.prime_step, 1, inputs=[clock.values, self.max_speed, float(self.model.cell_size)],
                  device=self.device)

    def extend(self, place: str, launch) -> None:
        """Run ``launch()`` (host code that only launches kernels) at ``place`` of every step.

        The places: AFTER_FORCE_UPDATE (USL steps of coupled scenes). Call before the first step:
        a CUDA graph records what is registered then.
        """
        if place != AFTER_FORCE_UPDATE:
            raise InputError("place", place, f"one of {AFTER_FORCE_UPDATE}")
        self.extensions.setdefault(place, []).append(launch)

    @property
    def P(self):
        """The ``Particles`` struct (``points``), under the name the kernels give it."""
        return self.points

    # -- set-up -------------------------------------------------------------------------------
    def _allocate(self, host: dict) -> None:
        t = self.types
        T = np.float32 if self.config.precision == "f32" else np.float64
        dev = self.device
        model = self.model
        mats = list(model.materials)
        mat_index = np.array([mats.index(b.material) for b in model.bodies], np.int32)[host["body"]]
        host = {**host, "material_index": mat_index}
        n = self.particle_count
        self.point_contact_radius = host["contact_radius"]  # device order [m]
        self.material_kinds = tuple(sorted({m.kind_id for m in mats}))
        #: hyperelastic scenes store F alone: σ and V are recomputed from it where needed
        #: (``kernels.constitutive.stress_from_deformation``; ``refresh_derived`` for the host)
        self.derived_stress = constitutive_kernels.stress_from_deformation(self.material_kinds, self.critical)
        self.points = make_points(model, self.config, host, self.order, mat_index, staged=self.staged,
                                  coupled=self.coupled, device=dev)
        # where each point's contact force acts (the "grid" coupling scheme spreads it from there)
        self.contact_at = wp.zeros(n if self.coupled else 1, dtype=t.vec2, device=dev)
        self.G, self.grid_shape = make_grid(model, self.config, self.granular_layers, device=dev)
        self.D = make_domain(model, self.config, self.granular_layers, float(host["mass"].min()))
        self.materials = wp.array(np.array([m.packed() for m in mats], T), dtype=t.params, device=dev)
        self.max_speed = wp.zeros(reduction_kernels.SPEED_SLOTS, dtype=wp.float32, device=dev)
        self.status = wp.zeros(granular_kernels.STATUS_SLOTS, dtype=wp.int32, device=dev)
        self.diag = wp.zeros(len(reduction_kernels.DIAG_NAMES), dtype=wp.float64, device=dev)
        probes = model.mass_probes
        self.probe_boxes = wp.array(np.array([[*p.lo, *p.hi] for p in probes], dtype=np.float64).reshape(-1, 4),
                                    dtype=wp.vec4d, device=dev)
        self.probe_mass = wp.zeros(max(1, len(probes)), dtype=wp.float64, device=dev)
        walls = grid_kernels.WALLS
        self.work = wp.zeros((len(grid_kernels.WORK_TERMS) + 2 * len(walls)) * grid_kernels.WORK_SLOTS,
                             dtype=wp.float64, device=dev)
        #: (t [s], impulses on the obstacles) at the last diagnostics, for their mean forces
        self.impulse_mark = (0.0, np.zeros(2 * len(walls)))
        #: granular mode: the interaction graph, its kernels and launches (``granular_state.GranularPlan``)
        self.granular: granular_state.GranularPlan | None = None
        if self.config.granular:
            self.granular = granular_state.make_granular_plan(
                model, self.config, host, mats, points=self.points, G=self.G, D=self.D, grid_shape=self.grid_shape,
                materials=self.materials, status=self.status, clock=self.clock, types=t, staged=self.staged,
                device=dev, tuning=self.tuning)

    def _build(self) -> None:
        """Pick the kernel variants of this config and lay out the launches of one step."""
        c = self.config
        s = c.scheme
        prec = c.precision
        n = self.particle_count
        # grid kernels run over the nodes of one layer (in granular mode they loop over the copies)
        grid_dim = (self.D.layer_rows, self.grid_shape[1])
        points, G, D, clock, mats, work = self.points, self.G, self.D, self.clock, self.materials, self.work
        # the wall images and the periodic images at the grid's edges (mpmdem/sim/grid_edges.py)
        #: G2P reads the wall images itself (``transfer.make_g2p``'s ``mirror``): USL and MUSL,
        #: where only G2P reads the mirrored velocities, not XPIC's passes or Liu's exchange
        tn = self.tuning
        edges = GridEdges(self.model, c, grid_dim, G=G, D=D, clock=clock, device=self.device, mirror_in_g2p=(
            tn.mirror_in_g2p and c.update in ("USL", "MUSL") and not s.xpic
            and not (self.coupled and c.coupling == "liu") and n < tn.images_in_kernels_points))
        self.wall_band, self.mirror_in_g2p = edges.wall_band, edges.mirror_in_g2p
        #: G2P's register cap on CUDA (``Tuning.g2p_registers`` from ``Tuning.g2p_registers_points`` points on;
        #: None: the compiler's choice)
        self.g2p_registers = tn.g2p_registers if n >= tn.g2p_registers_points else None
        fold, mirrored, moving = edges.fold, edges.mirrored, edges.moving
        layered = c.granular

        tile = self.p2g_tile()
        rows = self.p2g_rows(tile)

        def p2g(**flags):
            kernel = transfer_kernels.make_p2g(c.shape, s.affine, prec, deterministic=c.deterministic,
                                               layered=layered, staged=self.staged,
                                               contact=self.coupled and c.coupling == "imp",
                                               derived=self.material_kinds if self.derived_stress else (),
                                               tile=tile, rows=rows,
                                               tile_layers=self.tuning.tiled_p2g_layers if tile and layered else 1,
                                               **flags)
            fused = flags.get("fused_impulse", False)
            extra = []
            if self.coupled and c.coupling == "grid" and (flags["force"] or fused):
                scatter = contact_scatter_kernels.make_contact_scatter(prec, fused_impulse=fused,
                                                                       deterministic=c.deterministic)
                extra = [Launch(scatter, n, [points, G, D, clock, self.contact_at])]
            launch = Launch(kernel, n * SUPPORT_NODES[c.shape] if rows else n, [points, G, D, clock, self.status, mats])
            if tile:  # whole blocks: every thread of a block reaches the shared-tile calls
                launch = Launch(kernel, -(-n // tile[0]) * tile[0], launch.inputs, block_dim=tile[0])
            return [launch] + extra + fold(
                mass=flags["mass"], momentum=flags["momentum"] or fused, force=flags["force"] and not fused,
                remap=flags.get("remap", False))

        # the granular update's batch of copies and register cap (other updates ignore them: left at
        # their defaults there, so that they share one kernel whatever the tuning)
        copies = ({"copies": self.tuning.grid_update_copies, "max_registers": self.tuning.grid_update_registers}
                  if layered else {})

        def grid(**flags):
            def make(clear=False, zero_remap=False, fold=(), images=False):
                return grid_kernels.make_grid_update(prec, damping=c.damping > 0.0, layered=layered,
                                                     obstacles=bool(self.model.obstacles), clear=clear,
                                                     zero_remap=zero_remap, fold=fold, images=images, **flags,
                                                     **moving, **copies)

            if flags.get("remap"):
                fields = [G.vm]
            elif flags.get("fused_impulse"):
                fields = [G.vt]
            else:
                fields = ([G.v] if flags.get("velocity") else []) + ([G.vt] if flags.get("force") else [])
            update = GridUpdate(Launch(make(), grid_dim, [G, D, clock, work]), make, remap=bool(flags.get("remap")))
            return [update] + mirrored(*fields)

        def g2p(**flags):
            k = transfer_kernels.make_g2p(c.shape, s.affine, s.flip_fraction, s.position, prec, self.material_kinds,
                                          density_control=c.density_control, critical=self.critical,
                                          layered=layered, staged=self.staged, derived=self.derived_stress,
                                          mirror=self.mirror_in_g2p, max_registers=self.g2p_registers,
                                          **flags,
                                          **({"periodic_x": True} if edges.periodic and flags["position"] else {}))
            return [Launch(k, n, [points, G, D, clock, mats, self.max_speed, self.status, work])]

        def xpic_smoothing():
            """Σ_k (−1)^{k+1} C(m,k) v*_k into Grid.vs ("Motion integration" eq. 39-40)."""
            if not s.xpic:
                return []
            m = c.xpic_order
            init, update = grid_kernels.make_xpic_grid(prec, **moving)
            gather = xpic_kernels.make_xpic_gather(c.shape, prec)
            scatter = xpic_kernels.make_xpic_scatter(c.shape, prec, deterministic=c.deterministic)
            out = [Launch(init, grid_dim, [G, D, clock, float(m)])]
            for k in range(2, m + 1):
                coef = float((-1) ** (k + 1) * math.comb(m, k))
                out += [Launch(gather, n, [points, G, D, clock]), Zero(G.pk), Launch(scatter, n, [points, G, D, clock])]
                out += fold(mass=False, momentum=False, force=False, xpic=True)
                out += [Launch(update, grid_dim, [G, D, clock, coef])] + mirrored(G.vk)
            return out + mirrored(G.vs)

        self.fused = c.update == "USL" and s.flip_fraction == 0.0 and not s.xpic and c.damping == 0.0
        #: granular mode: the relabel at the start of a step (as a block)
        self.start_plan: list = self.granular.start if self.granular is not None else []
        # the first plan of the step in the order of its stress update (mpmdem/sim/mpm_orders.py)
        pieces = StepPieces(
            p2g=p2g, grid=grid, g2p=g2p, xpic=xpic_smoothing, fold=fold, fused=self.fused,
            liu=self.coupled and c.coupling == "liu",
            # MUSL's re-mapping P2G in the velocity G2P (tuning.remap_in_g2p), where P2G runs a thread a point
            remap_in_g2p=tn.remap_in_g2p and not tile and not rows and not c.deterministic)
        seq = ORDER_PLANS[c.update](pieces)
        # the step's last grid update clears the nodes (copies) it used (kernels/grid.py), so no
        # memset of the grid starts the next step; not where something after it reads the nodal
        # mass (XPIC's updates, Liu et al.'s exchange): there the grid is cleared at the start
        self.clears_grid = layered or not (s.xpic or (self.coupled and c.coupling == "liu"))
        if self.clears_grid:
            last = last_grid_update(seq)
            seq[last] = seq[last].clearing()
        # the ghosts beyond the walls need no update where G2P reads the wall images and nothing
        # there does work (fixed and slip walls, no damping, no obstacle node among them): then the
        # clearing update folds too, each node clearing the ghost copies it read
        # (``kernels.grid.make_grid_update``'s images)
        kinds = {b.kind for b in self.model.boundaries.values()}
        images = (self.mirror_in_g2p and kinds <= {"fixed", "slip", "free"} and c.damping == 0.0
                  and not self._obstacle_ghosts())
        if tn.fold_in_grid_update and n < tn.images_in_kernels_points and not edges.unfused:
            # a fold launch right before a grid update that clears and re-maps nothing (or, with
            # images, the clearing one): the update folds its own node first
            for k in range(len(seq) - 1):
                a, b = seq[k], seq[k + 1]
                if not isinstance(a, WallFold) or a.flags.get("xpic") or not isinstance(b, GridUpdate):
                    continue
                flags = a.flags
                fold = (flags["mass"], flags["momentum"], flags["force"], flags.get("remap", False))
                if not b.clears and not fold[3] and not b.remap:
                    fused = b.make(fold=fold)
                elif images and b.clears:
                    fused = b.make(clear=True, fold=fold, images=True)
                else:
                    continue
                seq[k] = None
                seq[k + 1] = Launch(fused, b.launch.dim, b.launch.inputs)
            seq = [item for item in seq if item is not None]
        seq = launches(seq)
        if self.granular is not None and self.granular.check is not None:
            # the positions the next step starts from are final: whether it may keep the labels
            seq += [self.granular.check]
        self._sequence = seq
        self.diagnostics_kernel = reduction_kernels.make_diagnostics(prec, self.material_kinds, staged=self.staged)
        self.probe_mass_kernel = reduction_kernels.make_probe_mass(prec, staged=self.staged)
        # speeds of the initial state, for the first step's dt (later steps: inside G2P)
        wp.launch(reduction_kernels.make_wave_speed(prec), n, inputs=[points, D, mats, self.max_speed, self.status],
                  device=self.device)

    def _obstacle_ghosts(self) -> bool:
        """Whether an obstacle marks a ghost node (beyond the domain's edge): there a grid update
        reads the obstacle's load, so the ghosts must be updated."""
        if not self.model.obstacles:
            return False
        solid = host_copy(self.G.solid)
        lo, hi = self.D.node_lo, self.D.node_hi
        inner = np.zeros(solid.shape, bool)
        for first in range(0, solid.shape[0], self.D.tile_rows):  # (every tile's: kernels/tiles.py)
            inner[first + lo[0]:first + hi[0] + 1, lo[1]:hi[1] + 1] = True
        return bool(np.any(solid[~inner] != 0))

    def p2g_tile(self) -> tuple:
        """(B, TX, TY) of the shared-memory P2G (``kernels.p2g.make_p2g``'s ``tile``), or ()
        for one global atomic per point and node: tiles pay on CUDA from ``tuning.tiled_p2g_points``
        points on, for single-stencil shapes, outside deterministic mode, in granular mode with
        ``tuning.tiled_p2g_granular``. A block of B
        cell-sorted points spans about B / ppc cells of one cell column, so the tile is K + 1
        nodes wide and B / ppc + K + 3 high (K the stencil's nodes per axis)."""
        c = self.config
        K = SUPPORT_NODES[c.shape]
        if (not self.device.is_cuda or self.particle_count < self.tuning.tiled_p2g_points
                or (c.granular and not self.tuning.tiled_p2g_granular)
                or c.deterministic or transfer_kernels.CORNERS.get(c.shape, 1) != 1):
            return ()
        ppc = min(b.points_per_cell for b in self.model.bodies) ** 2
        B = self.tuning.tiled_p2g_block
        TX, TY = K + 1, B // ppc + K + 3
        if TX > self.grid_shape[0] or TY > self.grid_shape[1]:
            return ()
        return (B, TX, TY)

    def p2g_rows(self, tile: tuple) -> bool:
        """Whether P2G runs a stencil row a thread (``kernels.p2g.make_p2g``'s ``rows``): in
        scenes of fewer than ``tuning.row_p2g_points`` points on ``tuning.row_p2g_devices``, for
        single-stencil shapes, untiled, outside granular mode (its first P2G claims the point's
        node copies all at once)."""
        c = self.config
        device = "cuda" if self.device.is_cuda else "cpu"
        tn = self.tuning
        return (device in tn.row_p2g_devices and self.particle_count < tn.row_p2g_points and not tile
                and not c.granular and transfer_kernels.CORNERS.get(c.shape, 1) == 1)

    # -- stepping -------------------------------------------------------------------------------
    def step(self) -> None:
        """Launch one explicit step (dt from the device clock, set by the step before or by
        ``set_stop_time``; a no-op once t reaches t_stop)."""
        self.run_sequence()
        self.end_step()

    def cap_time_step(self, cap: float, bound: float) -> None:
        """Coupled scenes: every step's dt is at most ``cap`` [s] (unless fixed by the user) and the
        reported bound at most ``bound`` [s] (MPM-SDEM eq. 51's contact and DEM terms). Call before
        the first step (a CUDA graph records the launch)."""
        self.dt_cap = (float(cap), float(bound))

    def land_step(self) -> None:
        """The next step's dt onto the device clock after the host moved t_stop (the policy's
        ``land``, ``Clock.set_policy``): from the bound the last step measured, capped in coupled
        scenes, landed on t_stop (``kernels.clock.land_step``)."""
        cap, bound = self.dt_cap
        wp.launch(clock_kernels.land_step, 1, inputs=[self.clock, cap, bound], device=self.device)

    def run_sequence(self, start: bool = True) -> None:
        """P2G, grid update and G2P of the chosen stress-update order (the MPM stage of a step),
        after ``start_plan`` (granular mode: the relabel) unless ``start`` is False (a coupled
        step runs it with its list rebuilds)."""
        G = self.G
        if not self.clears_grid:  # (else the last grid update of the step before cleared the nodes it used)
            G.mass.zero_()
            G.mom.zero_()
            if not self.fused:
                G.force.zero_()
        if start:
            run_plan(self.start_plan, self.device, self.extensions)
        run_plan(self._sequence, self.device, self.extensions)

    def block_layouts(self) -> list[BlockLayout]:
        """Granular mode with a rebuild decision: the layouts of the relabel block (run by the
        rebuilds and the relabels without one) and of the rebuild block nested in it, each in its
        conditional node or in line by how often it runs (``mpmdem.sim.block_layout``); else none."""
        blocks = list(plan_blocks(self.start_plan))
        if not blocks or self._judge() is None:
            return []
        flags = self.granular.interaction.flags
        rebuilds, relabels = granular_kernels.FLAG_COUNT, granular_kernels.FLAG_RELABELS
        layouts = [BlockLayout(blocks[0], flags, (rebuilds, relabels), self.tuning)]
        layouts += [BlockLayout(block, flags, (rebuilds,), self.tuning) for block in blocks[1:]]
        return layouts

    def _judge(self):
        """Granular mode, domains that do not deform: the kernel of the end of a step that decides
        whether the next one rebuilds the interaction graph (``GranularPlan.judge``); else None."""
        return self.granular.judge if self.granular is not None else None

    def step_kernels(self) -> list:
        """Every kernel the MPM stage of a step may launch (those of conditional parts included)."""
        return (list(plan_kernels(self.start_plan + self._sequence))
                + ([self._judge()] if self._judge() is not None else []))

    def end_step(self) -> None:
        """t += dt on the device clock and the next step's dt from the CFL speeds this step's G2P
        measured, capped in coupled scenes (``kernels.reductions.finish_step``); in granular mode
        with them, whether the next step rebuilds the interaction graph: one launch."""
        cap, bound = self.dt_cap
        clock = [self.clock, self.steps, self.max_speed, float(self.model.cell_size), cap, bound]
        judge = self._judge()
        if judge is not None:
            wp.launch(judge, 1, inputs=[self.granular.interaction, *clock], device=self.device)
        else:
            wp.launch(reduction_kernels.end_step, 1, inputs=clock, device=self.device)

    def invalidate_interactions(self) -> None:
        """Granular mode: the next step rebuilds the interaction graph (after the points were
        reordered or overwritten from the host, e.g. a checkpoint); a no-op otherwise."""
        if self.granular is not None:
            self.granular.invalidate()

    def sort_points(self) -> None:
        """Reorder the points by grid cell (radix sort on the device); outputs keep the scene's order."""
        self._sorter.reorder()
        self.invalidate_interactions()

    def order_drift(self) -> float:
        """How far the points' memory order has drifted from cell order: the fraction [-] of
        consecutive pairs whose cells are not neighbours (``PointSorter.drift``; one host sync)."""
        return self._sorter.drift()

    def shuffle_points(self, seed: int = 0) -> None:
        """Put the points in a random memory order (benchmarks of sorting; results are unchanged)."""
        perm = np.random.default_rng(seed).permutation(self.particle_count).astype(np.int32)
        self._sorter.reorder(wp.array(perm, dtype=wp.int32, device=self.device))
        self.invalidate_interactions()

    # -- status and output ------------------------------------------------------------------------
    #: Diagnostics that are works done on the points (for the energy balance).
    WORK_TERMS = grid_kernels.WORK_TERMS

    def status_counts(self) -> np.ndarray:
        """Non-finite points, points outside, point-node contributions with no grid layer left."""
        return host_copy(self.status)

    def refresh_derived(self) -> None:
        """Hyperelastic scenes (``derived_stress``): write every point's volume and stress from its F
        into ``points.vol`` and ``points.stress``, which the step itself does not store; a no-op
        otherwise. Anything that reads those arrays on the host calls this first."""
        if self.derived_stress:
            refresh = constitutive_kernels.make_derived_state(self.material_kinds, self.config.precision).refresh
            wp.launch(refresh, self.particle_count, inputs=[self.points, self.materials], device=self.device)

    def state_arrays(self) -> dict[str, wp.array]:
        """Every time-varying device array (what a checkpoint holds), by a stable name (volume and
        stress refreshed first: ``refresh_derived``)."""
        self.refresh_derived()
        arrays = {f"P.{name}": getattr(self.points, name)
                  for name in STATE_FIELDS + (("release",) if self.staged else ())}
        arrays.update(clock=self.clock, steps=self.steps, max_speed=self.max_speed, status=self.status,
                      work=self.work)
        return arrays

    def likely_cause(self, dt: float, bound: float) -> str:
        """What most likely made the points blow up at step dt [s] and bound [s]."""
        return diagnostics_.likely_cause(self.config, self.model, dt, bound)

    def check_status(self, t: float, dt: float, bound: float, status: np.ndarray) -> None:
        """Raise BlowUpError for NaN/inf or escaped points (counted by the G2P kernel)."""
        diagnostics_.check_point_status(self, t, dt, bound, status)

    def diagnostics(self) -> dict[str, float]:
        """Energies [J/m], momenta [kg/s, kg m/s per m] and mass [kg/m] of the points."""
        out, self.impulse_mark = diagnostics_.point_diagnostics(self, self.impulse_mark)
        return out

    @property
    def interaction(self):
        """Granular mode: the interaction graph's ``Interaction`` struct (``granular.interaction``)."""
        return self._granular_plan().interaction

    def _granular_plan(self) -> granular_state.GranularPlan:
        """The ``GranularPlan``; an InputError outside granular mode."""
        if self.granular is None:
            raise InputError("granular", False, "granular mode (SolverConfig(granular=True))")
        return self.granular

    def granular_statistics(self) -> tuple[int, int]:
        """(components, grid layers in use at the busiest node) of the last step (granular mode; the
        copies a relabel kept for a component that has left a node count until the next rebuild)."""
        return self._granular_plan().statistics()

    def components(self) -> np.ndarray:
        """Component label of every point in the scene's order (``GranularPlan.components``; −1
        outside granular mode)."""
        if self.granular is None:
            return np.full(self.particle_count, -1, np.int64)
        return self.granular.components()

    def node_ranges(self) -> np.ndarray:
        """Grid nodes each point's stencil reaches now (``granular_state.node_ranges``)."""
        return granular_state.node_ranges(self.points, self.D, self.config.shape, self.config.precision,
                                          self.device)

    def interaction_domains(self) -> tuple[np.ndarray, np.ndarray]:
        """Domains of interaction at the last rebuild (granular mode; ``GranularPlan.interaction_domains``)."""
        return self._granular_plan().interaction_domains()

    def fields(self) -> dict[str, np.ndarray]:
        """Host copies of the per-point output fields, in the scene's order: packed on the device
        (``kernels.output_fields``) and read back in one copy."""
        self.refresh_derived()
        n = self.particle_count
        width = output_kernels.output_width(self.coupled)
        if self._packed_output is None:
            self._packed_output = wp.empty((n, width), dtype=scalar_types(self.config.precision).scalar,
                                           device=self.device)
        wp.launch(output_kernels.make_pack_output(self.config.precision, self.coupled), n,
                  inputs=[self.points, self._packed_output], device=self.device)
        packed = host_copy(self._packed_output, fresh=False)  # (every field is copied out below)
        out = {}
        for name, (first, shape) in output_kernels.OUTPUT_COLUMNS.items():
            if name == "contact_force":
                out["body"] = self.body.copy()
                if not self.coupled:
                    continue
            size = int(np.prod(shape, dtype=int))
            # (a fresh contiguous array: on the CPU ``numpy()`` is a view of the reused device buffer)
            out[name] = np.ascontiguousarray(packed[:, first:first + size].reshape(n, *shape))
        if self.staged:
            waiting = self.release_times > self.sim_clock.time
            out["x"][waiting] = np.nan  # not in the scene yet
            out["v"][waiting] = np.nan
        return out
