"""The MPM stage: device arrays of points and grid, and the kernel launches of one explicit step.

No physics is written here; it picks the kernel variants of ``mpmdem.kernels`` that the config
asks for and launches them in the order of the chosen stress update (USF, USL, MUSL).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
import warp as wp

from .checks import check_time_step
from .config import SolverConfig
from .errors import BlowUpError, InputError
from .kernels import granular as kgran
from .kernels import grid as kgrid
from .kernels import reductions as kred
from .kernels import scan as kscan
from .kernels import sorting as ksort
from .kernels import transfer as ktr
from .kernels.shape_functions import SUPPORT_NODES
from .kernels.state import make_state_structs
from .kernels.types import scalar_types
from .scene import Scene

__all__ = ["GHOST_NODES", "MPMSolver", "device_order", "initial_dt_bound"]

#: Point arrays that change during a run (what a checkpoint must hold).
_STATE_FIELDS = ("x", "v", "C", "F", "stress", "szz", "vol", "strain_energy", "mass", "vol0", "half0", "material",
                 "pid")

#: Granular mode: overlap tests closer than this many cells to flipping are listed and re-tested
#: at every step instead of setting the margin of the label reuse (below the 1.7e-3 cells by which
#: the paper's ρ_cr makes neighbouring domains of a dense packing overlap).
CRITICAL_BAND = 2.0**-11
#: The widest band of the pair lists [cells] (kernels/granular.py, WIDE_STEPS).
WIDE_BAND_CAP = 0.25
#: Whether the rebuild sits in a conditional graph node of its own inside the relabel's (else its
#: kernels are launched on every relabel and return at once when there is no rebuild).
NESTED_REBUILD = True

#: Ghost node layers around the domain, enough for the widest stencil (4 nodes) of a point that
#: sits on, or slightly beyond, the domain boundary.
GHOST_NODES = 3


def device_order(x: np.ndarray, origin, cell_size: float) -> np.ndarray:
    """Permutation that puts points (N, 2) [m] in the order they live in on the device.

    By cell column, then by height: consecutive threads touch nodes that are neighbours in memory
    (the grid is stored with j fastest), which keeps the P2G atomics coalesced (about 2x faster
    on an H100 than a row-by-row order). Outputs are returned in the scene's order (fields()).
    """
    return np.lexsort((x[:, 1], np.floor((x[:, 0] - origin[0]) / cell_size)))


def initial_dt_bound(scene: Scene, particles: dict | None = None) -> float:
    """Courant bound h / max_p(c_p + |v_p|) [s] of the initial state (κ = 1)."""
    particles = particles or scene.particles()
    speeds = []
    for k, b in enumerate(scene.bodies):
        sel = particles["body"] == k
        vmax = float(np.linalg.norm(particles["v"][sel], axis=1).max())
        speeds.append(b.material.wave_speed + vmax)
    return scene.cell_size / max(speeds)


@dataclass
class _Launch:
    kernel: object
    dim: object
    inputs: list
    block_dim: int | None = None  # tile kernels (dim then ends with it)


class MPMSolver:
    """Device state and step sequence of the MPM stage of one scene.

    Args:
        scene: the scene; its points are seeded and uploaded once.
        config: discretisation choices.
        device: Warp device ("cpu", "cuda", "cuda:0").
    """

    def __init__(self, scene: Scene, config: SolverConfig, device: str):
        self.scene = scene
        self.config = config
        self.device = wp.get_device(device)
        self.types = scalar_types(config.precision)
        host = scene.particles()
        self.particle_count = len(host["mass"])
        self.dt_bound0 = initial_dt_bound(scene, host)
        check_time_step(config, self.dt_bound0, f"h/max(c+|v|) = {self.dt_bound0:.6g} s of this scene "
                        f"(h = {scene.cell_size:g} m)", use="the CFL policy")
        if config.shape == "ugimp" and (host["half"] > 0.5 * scene.cell_size + 1e-12).any():
            raise InputError("shape", config.shape, "uGIMP needs points_per_cell >= 1 (half-lengths <= h/2)")
        self.body = host["body"]
        self.release_times = host["release"]  # [s], scene order
        ppc = max(b.points_per_cell for b in scene.bodies)
        reach = SUPPORT_NODES[config.shape] + (1 if config.shape == "cpdi1" else 0)
        # at most (cells reaching a node) × (points per cell) components can meet at one node
        self.granular_layers = (min(64, max(8, reach * reach * ppc * ppc)) if config.granular_layers is None
                                else config.granular_layers) if config.granular else 1
        self.staged = bool((host["release"] > 0.0).any())
        #: rigid bodies push on the points through contact forces (MPM-SDEM §4; mpmdem.coupling)
        self.coupled = scene.has_dem
        mats = scene.materials()
        self.critical = any(m.critical_density is not None for m in mats)
        self.order = device_order(host["x"], scene.domain[0], scene.cell_size)
        self._allocate({k: v[self.order] for k, v in host.items()})
        self._sort = None
        #: launches another stage puts into the step (name of the place → callables)
        self.hooks: dict[str, list] = {}
        self._build()

    # -- set-up -------------------------------------------------------------------------------
    def _allocate(self, host: dict) -> None:
        t = self.types
        T = np.float32 if self.config.precision == "f32" else np.float64
        dev = self.device
        scene = self.scene
        n = self.particle_count
        mats = scene.materials()
        mat_index = np.array([mats.index(b.material) for b in scene.bodies], np.int32)[host["body"]]
        host = {**host, "material_index": mat_index}
        self.point_contact_radius = host["contact_radius"]  # device order [m]
        self.material_kinds = tuple(sorted({m.kind_id for m in mats}))
        Particles, Grid, Domain = make_state_structs(self.config.precision)
        eye = np.tile(np.eye(2), (n, 1, 1))
        P = Particles()
        P.x = wp.array(host["x"].astype(T), dtype=t.vec2, device=dev)
        P.v = wp.array(host["v"].astype(T), dtype=t.vec2, device=dev)
        # APIC/TPIC start from the initial rigid rotation's velocity gradient (zero if none)
        C0 = np.zeros((n, 2, 2))
        for k, b in enumerate(scene.bodies):
            C0[host["body"] == k] = np.array([[0.0, -b.angular_velocity], [b.angular_velocity, 0.0]])
        P.C = wp.array(C0.astype(T), dtype=t.mat22, device=dev)
        P.F = wp.array(eye.astype(T), dtype=t.mat22, device=dev)
        P.stress = wp.zeros(n, dtype=t.mat22, device=dev)
        P.szz = wp.zeros(n, dtype=t.scalar, device=dev)
        P.comp = wp.zeros(n if self.config.granular else 1, dtype=wp.int32, device=dev)
        # the grid layer of each stencil node, kept by the step's claiming P2G (kernels/transfer.py)
        nodes = ktr.CORNERS.get(self.config.shape, 1) * SUPPORT_NODES[self.config.shape] ** 2
        P.slots = wp.zeros((n, kgran.slot_words(nodes)) if self.config.granular else (1, 1), dtype=wp.int32,
                           device=dev)
        P.release = wp.array(host["release"] if self.staged else np.zeros(1), dtype=wp.float64, device=dev)
        P.mass = wp.array(host["mass"].astype(T), dtype=t.scalar, device=dev)
        P.vol = wp.array(host["vol"].astype(T), dtype=t.scalar, device=dev)
        P.vol0 = wp.array(host["vol"].astype(T), dtype=t.scalar, device=dev)
        P.half0 = wp.array(host["half"].astype(T), dtype=t.vec2, device=dev)
        P.material = wp.array(mat_index, dtype=wp.int32, device=dev)
        P.strain_energy = wp.zeros(n, dtype=t.scalar, device=dev)
        xpic = self.config.scheme.xpic
        P.tmp = wp.zeros(n if xpic else 1, dtype=t.vec2, device=dev)
        P.pid = wp.array(self.order.astype(np.int32), dtype=wp.int32, device=dev)
        P.fcont = wp.zeros(n if self.coupled else 1, dtype=t.vec2, device=dev)
        # where each point's contact force acts (the "grid" coupling scheme spreads it from there)
        self.contact_at = wp.zeros(n if self.coupled else 1, dtype=t.vec2, device=dev)
        self.P = P

        nx, ny = scene.cell_counts
        g = GHOST_NODES
        rows = nx + 1 + 2 * g
        layers = self.granular_layers
        shape = (layers * rows, ny + 1 + 2 * g)
        self.grid_shape = shape
        G = Grid()
        G.owner = wp.full(shape if self.config.granular else (1, 1), -1, dtype=wp.int32, device=dev)
        runs = (rows, -(-shape[1] // kgran.COPY_RUN)) if self.config.granular else (1, 1)
        G.depth = wp.zeros(runs, dtype=wp.int32, device=dev)
        solid, normal = self._solid_nodes(rows, shape[1])
        G.solid = wp.array(solid, dtype=wp.int32, device=dev)
        G.solid_normal = wp.array(normal.astype(T), dtype=t.vec2, device=dev)
        G.mass = wp.zeros(shape, dtype=t.scalar, device=dev)
        G.mom = wp.zeros(shape, dtype=t.vec2, device=dev)
        G.force = wp.zeros(shape, dtype=t.vec2, device=dev)
        G.v = wp.zeros(shape, dtype=t.vec2, device=dev)
        G.vt = wp.zeros(shape, dtype=t.vec2, device=dev)
        G.vm = wp.zeros(shape if self.config.update in ("MUSL", "USAVG") else (1, 1), dtype=t.vec2, device=dev)
        for name in ("vs", "vk", "pk"):
            setattr(G, name, wp.zeros(shape if xpic else (1, 1), dtype=t.vec2, device=dev))
        self.G = G

        h = scene.cell_size
        (x0, y0), _ = scene.domain
        D = Domain()
        D.origin = t.vec2(x0 - g * h, y0 - g * h)
        D.h = t.scalar(h)
        D.inv_h = t.scalar(1.0 / h)
        D.lo = t.vec2(x0, y0)
        D.hi = t.vec2(x0 + nx * h, y0 + ny * h)
        D.node_lo = wp.vec2i(g, g)
        D.node_hi = wp.vec2i(g + nx, g + ny)
        bcs = [scene.boundaries[s] for s in ("left", "right", "bottom", "top")]
        D.bc_kind = wp.vec4i(*[b.kind_id for b in bcs])
        D.bc_mu = t.vec4(*[b.friction for b in bcs])
        D.gravity = t.vec2(*scene.gravity)
        D.gravity_ramp = float(scene.gravity_ramp)
        D.mass_eps = t.scalar(1.0e-12 * float(host["mass"].min()))
        D.damping = t.scalar(self.config.damping)
        D.layer_rows = rows
        D.layers = layers
        self.D = D
        if self.config.granular:
            # interaction graph of Granular MPM (kernels/granular.py); cells = nodes of one layer
            cells = rows * shape[1]
            S = kgran.make_interaction_struct(self.config.precision)()
            # points by cell (CSR): counts, their prefix sums in three levels (kernels/scan.py), ranks, order
            n1, n2 = kscan.scan_lengths(cells + 1)
            S.count = wp.zeros(n1, dtype=wp.int32, device=dev)
            S.prefix1 = wp.zeros(n1, dtype=wp.int32, device=dev)
            S.prefix2 = wp.zeros(n2, dtype=wp.int32, device=dev)
            S.prefix3 = wp.zeros(kscan.SCAN_TILE, dtype=wp.int32, device=dev)
            # the tile totals of levels 1 and 2, and a sink for level 3's
            self._scan_totals = (wp.zeros(n2, dtype=wp.int32, device=dev),
                                 wp.zeros(kscan.SCAN_TILE, dtype=wp.int32, device=dev),
                                 wp.zeros(1, dtype=wp.int32, device=dev))
            S.rank = wp.zeros(n, dtype=wp.int32, device=dev)
            S.cell0 = wp.zeros(1 if self.config.shape in kgran.DEFORMING_DOMAINS else n, dtype=wp.int32, device=dev)
            S.order = wp.zeros(n, dtype=wp.int32, device=dev)
            tent = self.config.shape == "linear" and not self.staged  # (its node range follows from its cell)
            S.labels = wp.zeros(n if tent else 1, dtype=wp.int32, device=dev)  # (for its node threads)
            # the bytes of P.slots, which the tent's node threads store one by one (a view: P.slots
            # is allocated once and never replaced)
            words = self.P.slots.shape[1]
            S.slot_bytes = (wp.array(ptr=self.P.slots.ptr, dtype=wp.uint8, shape=(n, 4 * words), device=dev)
                            if tent else wp.zeros((1, 4), dtype=wp.uint8, device=dev))
            S.parent = wp.zeros(n, dtype=wp.int32, device=dev)
            deforming = self.config.shape in kgran.DEFORMING_DOMAINS
            S.dom_a = wp.zeros(n if deforming else 1, dtype=t.vec2, device=dev)
            S.dom_b = wp.zeros(n if deforming else 1, dtype=t.vec2, device=dev)
            # reuse of the labels between rebuilds (kernels/granular.py): a rebuild on the first step
            S.ext = wp.zeros(1 if deforming else n, dtype=t.vec2, device=dev)
            S.anchor = wp.zeros(1 if deforming else n, dtype=t.vec2, device=dev)
            S.records = wp.zeros(1 if deforming else n, dtype=t.vec4, device=dev)
            S.reach = wp.zeros(1 if tent else n, dtype=wp.vec4i, device=dev)
            S.ext_max = wp.array(self._static_extent(host, mats), dtype=wp.float32, device=dev)
            S.slack = wp.full(kgran.EXT_SLOTS, kgran.NO_MARGIN, dtype=wp.int32, device=dev)
            S.motion = wp.zeros(3 * kgran.EXT_SLOTS, dtype=wp.int32, device=dev)
            S.cell_ref = wp.full(cells, -1, dtype=wp.int32, device=dev)
            S.ref = wp.zeros(1 if deforming else n, dtype=wp.int32, device=dev)
            # pairs within a band of flipping are listed per point and re-tested every step rather
            # than let them set the margin of all; a flip relabels over the lists, on top of the
            # forest of the other pairs (kernels/granular.py)
            listed = 1 if deforming else n
            S.pairs = wp.zeros((kgran.PAIR_SLOTS, listed), dtype=wp.int32, device=dev)
            S.npairs = wp.zeros(listed, dtype=wp.int32, device=dev)
            # (at most one entry per point: ``check`` and ``relink`` test entry p in thread p)
            S.spill = wp.zeros(1 if deforming else min(n, max(1024, n // 4)), dtype=wp.vec2i, device=dev)
            S.base = wp.zeros(listed, dtype=wp.int32, device=dev)
            S.home = wp.zeros(n if tent else 1, dtype=wp.int32, device=dev)
            # the tent's relabels give out anew only the copies of nodes whose points changed labels:
            # the cells where one did, marked with the labelling's stamp (FLAG_STAMP)
            S.dirty = wp.full(cells if tent else 1, -1, dtype=wp.int32, device=dev)
            S.quantum = t.scalar(self.scene.cell_size * 2.0**-20)
            S.band_min = int(CRITICAL_BAND * 2.0**20)  # (in quanta of h 2^-20)
            S.band_cap = int(WIDE_BAND_CAP * 2.0**20)
            # a point may change cells without a rebuild when every point is granular and every
            # domain of interaction under half a cell (the tent outside staged scenes): then the
            # pairs the search did not visit need (1 − 2 largest half-extent) h to meet
            ext = float(self._static_extent(host, mats)[:2].max())
            rho_cr = np.array([m.critical_density or 0.0 for m in mats])[host["material_index"]]
            granular_only = bool((rho_cr > 0.0).all())
            S.moves = int(tent and granular_only and ext < 0.5)
            S.moves_margin = (int(math.floor((1.0 - 2.0 * ext * (1.0 + 1.0e-6)) * 2.0**20)) if S.moves
                              else kgran.NO_MARGIN)
            flags = np.zeros(kgran.FLAG_SLOTS, np.int32)
            flags[kgran.FLAG_REBUILD] = 1  # the first step builds the graph
            flags[kgran.FLAG_RELABEL] = 1
            flags[kgran.FLAG_BAND] = S.band_min
            flags[kgran.FLAG_MEASURED] = 1  # (a narrow rebuild that keeps margins: it counts for the next band)
            S.flags = wp.array(flags, dtype=wp.int32, device=dev)
            # round-off of one displacement, offset or margin: every one is a difference of two
            # nearby coordinates (exact when they are within a factor 2 of each other, Sterbenz;
            # else rounded to half an ulp of the small result) followed by a few operations on
            # lengths of a few cells, so each carries a few ulps of ~4h whatever the coordinates:
            # 32 eps h leaves room
            eps = float(np.finfo(T).eps)
            S.roundoff = t.scalar(32.0 * eps * self.scene.cell_size)
            self.interaction = S
            self.granular_stats = wp.zeros(2, dtype=wp.int32, device=dev)

        self.materials = wp.array(np.array([m.packed() for m in mats], T), dtype=t.params, device=dev)
        self.clock = wp.zeros(kred.CLOCK_SIZE, dtype=wp.float64, device=dev)
        clock = np.zeros(kred.CLOCK_SIZE)
        clock[4] = self.config.dt or 0.0
        clock[5] = self.config.cfl
        self.clock.assign(clock)
        self.steps = wp.zeros(1, dtype=wp.int64, device=dev)
        self.max_speed = wp.zeros(kred.SPEED_SLOTS, dtype=wp.float32, device=dev)
        self.status = wp.zeros(3, dtype=wp.int32, device=dev)
        self.diag = wp.zeros(len(kred.DIAG_NAMES), dtype=wp.float64, device=dev)
        probes = scene.mass_probes
        self.probe_boxes = wp.array(np.array([[*p.lo, *p.hi] for p in probes], dtype=np.float64).reshape(-1, 4),
                                    dtype=wp.vec4d, device=dev)
        self.probe_mass = wp.zeros(max(1, len(probes)), dtype=wp.float64, device=dev)
        self.work = wp.zeros((len(kgrid.WORK_TERMS) + 2 * len(kgrid.WALLS)) * kgrid.WORK_SLOTS, dtype=wp.float64,
                             device=dev)
        self._impulse_mark = (0.0, np.zeros(2 * len(kgrid.WALLS)))

    def _build(self) -> None:
        """Pick the kernel variants of this config and lay out the launches of one step."""
        c = self.config
        s = c.scheme
        prec = c.precision
        n = self.particle_count
        # grid kernels run over the nodes of one layer (in granular mode they loop over the copies)
        grid_dim = (self.D.layer_rows, self.grid_shape[1])
        P, G, D, clock, mats, work = self.P, self.G, self.D, self.clock, self.materials, self.work
        # image points at walls (kernels/grid.py: fold_ghosts, mirror_ghosts)
        mirror_walls = any(b.kind != "free" for b in self.scene.boundaries.values())
        layered = c.granular
        self._grid_kernels = {}
        mirror = kgrid.make_mirror_ghosts(prec, layered=layered)

        def fold(**flags):
            if not mirror_walls:
                return []
            return [_Launch(kgrid.make_fold_ghosts(prec, layered=layered, **flags), grid_dim, [G, D, clock])]

        def mirrored(*fields):
            return [_Launch(mirror, grid_dim, [f, D, clock, G.owner]) for f in fields] if mirror_walls else []

        def p2g(**flags):
            kernel = ktr.make_p2g(c.shape, s.affine, prec, deterministic=c.deterministic, layered=layered,
                                  staged=self.staged, contact=self.coupled and c.coupling == "imp", **flags)
            fused = flags.get("fused_impulse", False)
            extra = []
            if self.coupled and c.coupling == "grid" and (flags["force"] or fused):
                scatter = ktr.make_contact_scatter(prec, fused_impulse=fused, deterministic=c.deterministic)
                extra = [_Launch(scatter, n, [P, G, D, clock, self.contact_at])]
            return [_Launch(kernel, n, [P, G, D, clock, self.status])] + extra + fold(
                mass=flags["mass"], momentum=flags["momentum"] or fused, force=flags["force"] and not fused,
                remap=flags.get("remap", False))

        def grid(**flags):
            def make(clear=False):
                return kgrid.make_grid_update(prec, damping=c.damping > 0.0, layered=layered,
                                              obstacles=bool(self.scene.obstacles), clear=clear, **flags)

            kernel = make()
            self._grid_kernels[id(kernel)] = make
            if flags.get("remap"):
                fields = [G.vm]
            elif flags.get("fused_impulse"):
                fields = [G.vt]
            else:
                fields = ([G.v] if flags.get("velocity") else []) + ([G.vt] if flags.get("force") else [])
            return [_Launch(kernel, grid_dim, [G, D, clock, work])] + mirrored(*fields)

        def g2p(**flags):
            k = ktr.make_g2p(c.shape, s.affine, s.flip_fraction, s.position, prec, self.material_kinds,
                             density_control=c.density_control, critical=self.critical, layered=layered,
                             staged=self.staged, **flags)
            return [_Launch(k, n, [P, G, D, clock, mats, self.max_speed, self.status, work])]

        def xpic_smoothing():
            """Σ_k (−1)^{k+1} C(m,k) v*_k into Grid.vs ("Motion integration" eq. 39-40)."""
            if not s.xpic:
                return []
            m = c.xpic_order
            init, update = kgrid.make_xpic_grid(prec)
            gather = ktr.make_xpic_gather(c.shape, prec)
            scatter = ktr.make_xpic_scatter(c.shape, prec, deterministic=c.deterministic)
            out = [_Launch(init, grid_dim, [G, D, clock, float(m)])]
            for k in range(2, m + 1):
                coef = float((-1) ** (k + 1) * math.comb(m, k))
                out += [_Launch(gather, n, [P, G, D, clock]), ("zero", G.pk), _Launch(scatter, n, [P, G, D, clock])]
                out += fold(mass=False, momentum=False, force=False, xpic=True)
                out += [_Launch(update, grid_dim, [G, D, clock, coef])] + mirrored(G.vk)
            return out + mirrored(G.vs)

        self.fused = c.update == "USL" and s.flip_fraction == 0.0 and not s.xpic and c.damping == 0.0
        seq: list = []
        self._judge = None  # granular mode, non-deforming domains: the rebuild decision (end_step)
        if c.granular:
            # Granular MPM tasks 1-2: interaction graph and components; the copies of each node
            # are claimed in the P2G below (kernels/granular.py)
            deforming = c.shape in kgran.DEFORMING_DOMAINS
            S = self.interaction
            gin = [P, G, D, mats, S, self.status, clock]
            check, prepare, place, link, settle, relink, label, assign = kgran.make_granular_kernels(
                c.shape, prec, staged=self.staged)
            incremental = c.shape == "linear" and not self.staged  # (the tent's ``assign``)
            reset = _Launch(kgran.make_reset_copies(prec, deforming, incremental), grid_dim,
                            [G, D, S.ext_max, S.slack, S.cell_ref, S.flags, S.motion])
            rebuild = [_Launch(prepare, n, gin)]
            # the start of each cell's run in the cell-sorted list: prefix sums of the counts (gated
            # by the rebuild flag: outside a CUDA graph the kernels of a skipped rebuild are launched
            # and return; deforming domains rebuild every step: an open gate)
            gate = S.flags[kgran.FLAG_REBUILD:] if check is not None else wp.ones(1, dtype=wp.int32, device=self.device)
            if wp.get_device(self.device).is_cuda:
                scan, threads = kscan.make_tile_scan(), kscan.SCAN_THREADS
                totals = self._scan_totals
                levels = [(S.count, S.prefix1, totals[0]), (totals[0], S.prefix2, totals[1]),
                          (totals[1], S.prefix3, totals[2])]
                # (a level whose input is one tile adds nothing: its prefix stays zero)
                rebuild += [_Launch(scan, (values.shape[0] // kscan.SCAN_TILE, threads),
                                    [values, prefix, totals, gate], threads)
                            for k, (values, prefix, totals) in enumerate(levels)
                            if k == 0 or levels[k - 1][0].shape[0] > kscan.SCAN_TILE]
            else:
                rebuild += [_Launch(kscan.make_serial_scan(), 1, [S.count, S.prefix1, gate])]
            rebuild += [_Launch(k, n, gin) for k in (place, link)]
            relabel = [_Launch(relink, n, gin), _Launch(label, n, gin)]
            if assign is not None:
                # the tent: each node gives out its copies (instead of the claims in P2G)
                relabel += [_Launch(assign, grid_dim, gin)]
            if check is not None:
                # the rebuild runs only when the previous step's judge (end_step) asked for it, the
                # relabel when it asked for either: inside a CUDA graph conditional nodes skip their
                # launches; elsewhere each kernel reads its flag and returns at once. ``check`` goes
                # after the step's last G2P (below).
                rebuild += [_Launch(settle, n, gin)]
                if NESTED_REBUILD and incremental:
                    # (the tent's relabels without a rebuild free no copies: ``reset_copies`` only
                    # runs with the rebuild, not as an empty launch over the grid at every relabel)
                    inner = [("if", S.flags[kgran.FLAG_REBUILD:], [reset] + rebuild)]
                    seq += [("if", S.flags[kgran.FLAG_RELABEL:], inner + relabel)]
                else:
                    inner = [("if", S.flags[kgran.FLAG_REBUILD:], rebuild)] if NESTED_REBUILD else rebuild
                    seq += [("if", S.flags[kgran.FLAG_RELABEL:], [reset] + inner + relabel)]
                self._judge = kgran.make_rebuild_decision(prec)
            else:
                seq += [reset] + rebuild + relabel
        if c.update == "USL":
            if self.fused:
                seq += p2g(mass=True, momentum=True, force=True, fused_impulse=True)
                seq += grid(velocity=False, force=False, fused_impulse=True)
            else:
                seq += p2g(mass=True, momentum=True, force=True) + grid(velocity=True, force=True)
            if self.coupled and c.coupling == "liu":
                seq += [("hook", "after_force_update")]  # mpmdem.coupling: Liu et al.'s exchange
            seq += xpic_smoothing() + g2p(velocity=True, position=True, stress="vt")
        elif c.update == "USF":
            seq += p2g(mass=True, momentum=True, force=False) + grid(velocity=True, force=False)
            seq += g2p(velocity=False, position=False, stress="v")
            seq += p2g(mass=False, momentum=False, force=True) + grid(velocity=False, force=True)
            seq += xpic_smoothing() + g2p(velocity=True, position=True, stress="none")
        else:
            # MUSL; USAVG ("Motion integration" §3.4) adds a first half stress update from V
            # before the forces and makes the MUSL update the second half.
            half = 0.5 if c.update == "USAVG" else 1.0
            if c.update == "USAVG":
                seq += p2g(mass=True, momentum=True, force=False) + grid(velocity=True, force=False)
                seq += g2p(velocity=False, position=False, stress="v", stress_fraction=half)
                seq += p2g(mass=False, momentum=False, force=True) + grid(velocity=False, force=True)
            else:
                seq += p2g(mass=True, momentum=True, force=True) + grid(velocity=True, force=True)
            seq += xpic_smoothing() + g2p(velocity=True, position=False, stress="none")
            seq += [("zero", G.vm)] + p2g(mass=False, momentum=True, force=False, remap=True)
            seq += grid(velocity=False, force=False, remap=True)
            seq += g2p(velocity=False, position=True, stress="vm", stress_fraction=half)
        if layered:
            # the step's last grid update clears the copies it used (kernels/grid.py)
            last = max(k for k, item in enumerate(seq)
                       if isinstance(item, _Launch) and id(item.kernel) in self._grid_kernels)
            item = seq[last]
            seq[last] = _Launch(self._grid_kernels[id(item.kernel)](clear=True), item.dim, item.inputs)
            if self._judge is not None:
                # the positions the next step starts from are final: whether it may keep the labels
                seq += [_Launch(check, n, gin)]
        self._sequence = seq
        self._diagnostics = kred.make_diagnostics(prec, self.material_kinds, staged=self.staged)
        self._probe_mass = kred.make_probe_mass(prec, staged=self.staged)
        # speeds of the initial state, for the first step's dt (later steps: inside G2P)
        wp.launch(kred.make_wave_speed(prec), n, inputs=[P, D, mats, self.max_speed, self.status], device=self.device)

    def _static_extent(self, host: dict, mats: list) -> np.ndarray:
        """Slots of the largest half-extent of a domain of interaction [cells] (kernels/granular.py):
        for shapes whose domains do not follow F it is fixed, so it is computed here once."""
        out = np.zeros(2 * kgran.EXT_SLOTS, np.float32)
        if self.config.shape in kgran.DEFORMING_DOMAINS:
            return out
        h = self.scene.cell_size
        rho_cr = np.array([m.critical_density or 0.0 for m in mats])[host["material_index"]]
        half = host["half"]
        granular = rho_cr > 0.0
        scale = np.ones(len(half))
        scale[granular] = np.sqrt(host["mass"][granular] / (rho_cr[granular] * 4.0 * half[granular].prod(axis=1)))
        ext = half * scale[:, None] / h
        if (~granular).any():  # a continuum reaches its whole stencil
            ext[~granular] = SUPPORT_NODES[self.config.shape] + 1
        out[:2] = ext.max(axis=0)
        return out

    def _solid_nodes(self, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray]:
        """Obstacle nodes of one layer: kind (0 none, 1 fixed, 2 slip) and, for slip nodes, the
        outward normal of the nearest edge of the obstacle (rows, cols, 2). (1, 1) arrays if none."""
        if not self.scene.obstacles:
            return np.zeros((1, 1), np.int32), np.zeros((1, 1, 2))
        h = self.scene.cell_size
        (x0, y0), _ = self.scene.domain
        g = GHOST_NODES
        ii, jj = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
        xy = np.column_stack([(x0 + (ii - g) * h).ravel(), (y0 + (jj - g) * h).ravel()])
        kind = np.zeros(rows * cols, np.int32)
        normal = np.zeros((rows * cols, 2))
        for obstacle in self.scene.obstacles:
            shape = obstacle.shape
            if shape.kind == "disk":
                (cx, cy), r = shape._circle()
                d = xy - np.array([cx, cy])
                inside = (d ** 2).sum(axis=1) <= r * r * (1.0 + 1e-12)
                n = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
            else:
                # nodes inside or on the outline; normal of the nearest edge of the (CCW) outline
                inside = shapely.intersects_xy(shape.polygon, xy[:, 0], xy[:, 1])
                ring = np.asarray(shapely.geometry.polygon.orient(shape.polygon, 1.0).exterior.coords)
                a, b = ring[:-1], ring[1:]
                e = b - a
                length = np.linalg.norm(e, axis=1)
                tpar = np.clip(((xy[:, None, :] - a[None]) * e[None]).sum(-1) / (length ** 2)[None], 0.0, 1.0)
                dist = np.linalg.norm(xy[:, None, :] - (a[None] + tpar[..., None] * e[None]), axis=-1)
                nearest = np.argmin(dist, axis=1)
                n = np.column_stack([e[nearest, 1], -e[nearest, 0]]) / length[nearest][:, None]
            kind[inside] = 1 if obstacle.kind == "fixed" else 2
            normal[inside] = n[inside]
        return kind.reshape(rows, cols), normal.reshape(rows, cols, 2)

    # -- stepping -------------------------------------------------------------------------------
    def step(self) -> None:
        """Launch one explicit step (dt from the device clock; a no-op once t reaches t_stop)."""
        self.begin_step()
        self.run_sequence()
        self.end_step()

    def begin_step(self) -> None:
        """dt of this step from the CFL speeds (or the fixed dt) onto the device clock."""
        wp.launch(kred.compute_dt, 1, inputs=[self.clock, self.max_speed, float(self.scene.cell_size)],
                  device=self.device)

    def run_sequence(self) -> None:
        """P2G, grid update and G2P of the chosen stress-update order (the MPM stage of a step)."""
        G = self.G
        if not self.config.granular:  # granular mode: the grid update clears the copies it used
            G.mass.zero_()
            G.mom.zero_()
            if not self.fused:
                G.force.zero_()
        self._run(self._sequence)

    def step_kernels(self) -> list:
        """Every kernel the MPM stage of a step may launch (those of conditional parts included)."""
        def walk(sequence):
            for item in sequence:
                if isinstance(item, _Launch):
                    yield item.kernel
                elif item[0] == "if":
                    yield from walk(item[2])

        return list(walk(self._sequence)) + ([self._judge] if self._judge is not None else [])

    def _run(self, sequence: list) -> None:
        dev = self.device
        for item in sequence:
            if isinstance(item, tuple):
                if item[0] == "if":
                    device = wp.get_device(dev)
                    if device.is_cuda and device.is_capturing and wp.is_conditional_graph_supported():
                        wp.capture_if(item[1], on_true=lambda body=item[2]: self._run(body))
                    else:
                        self._run(item[2])
                elif item[0] == "hook":
                    for fn in self.hooks.get(item[1], ()):
                        fn()
                elif item[0] == "fill":
                    item[1].fill_(-1)
                else:
                    item[1].zero_()
            else:
                extra = {"block_dim": item.block_dim} if item.block_dim else {}
                wp.launch(item.kernel, item.dim, inputs=item.inputs, device=dev, **extra)

    def end_step(self) -> None:
        """t += dt on the device clock (in granular mode with it, whether the next step rebuilds the
        interaction graph: one launch)."""
        if self._judge is not None:
            wp.launch(self._judge, 1, inputs=[self.interaction, self.clock, self.steps], device=self.device)
        else:
            wp.launch(kred.advance_time, 1, inputs=[self.clock, self.steps], device=self.device)

    _POINT_FIELDS = ("x", "v", "C", "F", "stress", "szz", "mass", "vol", "vol0", "half0", "material", "strain_energy",
                     "pid")

    def _reorder(self, order: wp.array | None = None) -> None:
        """Permute every per-point array by ``order`` (new[p] = old[order[p]]); None: by grid cell."""
        dev = self.device
        n = self.particle_count
        if self._sort is None:
            Particles = make_state_structs(self.config.precision)[0]
            scratch = Particles()
            for name in self._POINT_FIELDS:
                setattr(scratch, name, wp.empty_like(getattr(self.P, name)))
            scratch.tmp = self.P.tmp
            scratch.comp = self.P.comp
            scratch.slots = self.P.slots
            scratch.fcont = self.P.fcont
            scratch.release = wp.empty_like(self.P.release) if self.staged else self.P.release
            keys = wp.empty(2 * n, dtype=wp.int32, device=dev)
            values = wp.empty(2 * n, dtype=wp.int32, device=dev)
            self._sort = (scratch, keys, values)
        scratch, keys, values = self._sort
        if order is None:
            rows, cols = self.grid_shape[1], self.grid_shape[0]
            wp.launch(ksort.make_cell_keys(self.config.precision), n,
                      inputs=[self.P, self.D, rows, cols, keys, values], device=dev)
            wp.utils.radix_sort_pairs(keys, values, n)
            order = values
        wp.launch(ksort.make_gather_points(self.config.precision, self.staged), n, inputs=[self.P, scratch, order],
                  device=dev)
        for name in self._POINT_FIELDS + (("release",) if self.staged else ()):
            wp.copy(getattr(self.P, name), getattr(scratch, name))
        self.invalidate_interactions()

    def invalidate_interactions(self) -> None:
        """Granular mode: the next step rebuilds the interaction graph (after the points were
        reordered or overwritten from the host, e.g. a checkpoint); a no-op otherwise."""
        if self.config.granular:
            flag = wp.array([1], dtype=wp.int32, device="cpu")
            for slot in (kgran.FLAG_REBUILD, kgran.FLAG_RELABEL):  # (a rebuild labels too)
                wp.copy(self.interaction.flags, flag, dest_offset=slot, count=1)

    def sort_points(self) -> None:
        """Reorder the points by grid cell (radix sort on the device); outputs keep the scene's order."""
        self._reorder()

    def shuffle_points(self, seed: int = 0) -> None:
        """Put the points in a random memory order (benchmarks of sorting; results are unchanged)."""
        perm = np.random.default_rng(seed).permutation(self.particle_count).astype(np.int32)
        self._reorder(wp.array(perm, dtype=wp.int32, device=self.device))

    def set_stop_time(self, t_stop: float) -> None:
        """Steps run until the clock reaches t_stop [s]; later steps do nothing."""
        wp.copy(self.clock, wp.array([t_stop], dtype=wp.float64, device="cpu"), dest_offset=2, count=1)

    def read_clock(self) -> tuple[float, float, float, int, np.ndarray]:
        """(t, dt, dt_bound, steps, status counts) — one host sync."""
        c = self.clock.numpy()
        return float(c[0]), float(c[1]), float(c[3]), int(self.steps.numpy()[0]), self.status.numpy()

    #: Diagnostics that are works done on the points (for the energy balance).
    WORK_TERMS = kgrid.WORK_TERMS

    def state_arrays(self) -> dict[str, wp.array]:
        """Every time-varying device array (what a checkpoint holds), by a stable name."""
        arrays = {f"P.{name}": getattr(self.P, name) for name in _STATE_FIELDS + (("release",) if self.staged else ())}
        arrays.update(clock=self.clock, steps=self.steps, max_speed=self.max_speed, status=self.status,
                      work=self.work)
        return arrays

    def _likely_cause(self, dt: float, bound: float) -> str:
        c = self.config
        causes = []
        if c.dt is not None:
            causes.append(f"the fixed dt = {c.dt:.3g} s against a current bound h/(c+|v|) = {bound:.3g} s "
                          "(leave dt unset or lower it)")
        else:
            causes.append(f"the time step (cfl = {c.cfl:g}, dt = {dt:.3g} s): lower --cfl")
        if c.scheme.flip_fraction > 0.0:
            causes.append(f"the transfer scheme {c.transfer} (FLIP noise): try APIC, or a FLIP fraction < 1")
        if c.shape == "linear":
            causes.append("cell-crossing of the linear shape function: try bspline2 or cpgimp")
        for b in self.scene.bodies:
            if b.material.poisson_ratio > 0.45:
                causes.append(f"the material of {b.name} (nu = {b.material.poisson_ratio} is nearly incompressible)")
        return "; ".join(causes)

    def check_status(self, t: float, dt: float, bound: float, status: np.ndarray) -> None:
        """Raise BlowUpError for NaN/inf or escaped points (counted by the G2P kernel)."""
        if status[0] > 0 or not math.isfinite(t):
            raise BlowUpError(
                "non-finite",
                f"simulation blew up at t = {t:.6g} s: {int(status[0])} points have NaN/inf values. "
                f"Likely cause: {self._likely_cause(dt, bound)}.", t)
        if len(status) > 2 and status[2] > 0:
            raise BlowUpError(
                "granular-layers",
                f"at t = {t:.6g} s more than {self.granular_layers} components met at one grid node "
                f"({int(status[2])} point-node contributions had no grid layer left): raise "
                "SolverConfig.granular_layers (granular mode).", t)
        if status[1] > 0:
            raise BlowUpError(
                "left-domain",
                f"{int(status[1])} points left the domain at t = {t:.6g} s. Likely cause: a 'free' "
                f"boundary on that side, or an unstable step ({self._likely_cause(dt, bound)}).", t)

    def diagnostics(self) -> dict[str, float]:
        """Energies [J/m], momenta [kg/s, kg m/s per m] and mass [kg/m] of the points."""
        self.diag.zero_()
        t_now = float(self.clock.numpy()[0])
        wp.launch(self._diagnostics, self.particle_count, inputs=[self.P, self.D, self.materials, self.diag, t_now],
                  device=self.device)
        vals = self.diag.numpy()
        out = {name: float(v) for name, v in zip(kred.DIAG_NAMES, vals, strict=True)}
        if self.scene.mass_probes:
            self.probe_mass.zero_()
            wp.launch(self._probe_mass, self.particle_count, inputs=[self.P, self.probe_boxes, self.probe_mass, t_now],
                      device=self.device)
            for probe, m in zip(self.scene.mass_probes, self.probe_mass.numpy(), strict=True):
                out[f"mass_{probe.name}"] = float(m)
        sums = self.work.numpy().reshape(-1, kgrid.WORK_SLOTS).sum(axis=1)
        works = sums[: len(kgrid.WORK_TERMS)]
        out.update({name: float(w) for name, w in zip(kgrid.WORK_TERMS, works, strict=True)})
        # force on the obstacles [N/m]: impulse since the previous call / time since then
        impulse = sums[kgrid.IMPULSE_BASE:]
        t_now = float(self.clock.numpy()[0])
        t_prev, i_prev = self._impulse_mark
        span = t_now - t_prev
        force = (impulse - i_prev) / span if span > 0.0 else np.zeros_like(impulse)
        self._impulse_mark = (t_now, impulse)
        for k, wall in enumerate(kgrid.WALLS if self.scene.obstacles else ()):
            out[f"force_{wall}_x"] = float(force[2 * k])
            out[f"force_{wall}_y"] = float(force[2 * k + 1])
        out["energy_total"] = out["energy_kinetic"] + out["energy_strain"] + out["energy_gravity"]
        if self.config.granular:
            out["components"], out["layers"] = (float(v) for v in self.granular_statistics())
            flags = self.interaction.flags.numpy()
            out["granular_rebuilds"] = float(flags[kgran.FLAG_COUNT])
            out["granular_relabels"] = float(flags[kgran.FLAG_RELABELS])
        return out

    def granular_statistics(self) -> tuple[int, int]:
        """(components, grid layers in use at the busiest node) of the last step (granular mode)."""
        if not self.config.granular:
            raise InputError("granular", False, "granular mode (SolverConfig(granular=True))")
        self.granular_stats.zero_()
        dim = max(self.particle_count, self.D.layer_rows * self.grid_shape[1])
        wp.launch(kgran.make_granular_statistics(self.config.precision, self.staged), dim,
                  inputs=[self.P, self.G, self.D, self.clock, self.granular_stats], device=self.device)
        c, layers = self.granular_stats.numpy()
        return int(c), int(layers)

    def components(self) -> np.ndarray:
        """Component label of every point in the scene's order: the smallest scene index among the
        points of its component (granular mode; −1 otherwise)."""
        if not self.config.granular:
            return np.full(self.particle_count, -1, np.int64)
        comp = self.P.comp.numpy()
        pid = self.P.pid.numpy()
        # labels are device indices of the root points (kernels/granular.py ``priority``): in the
        # scene's order, each component named by its smallest member
        root = np.empty(self.particle_count, np.int64)
        root[pid] = comp  # the root (a device index) of each point, in the scene's order
        smallest = np.full(self.particle_count, self.particle_count, np.int64)
        np.minimum.at(smallest, root, np.arange(self.particle_count))
        return smallest[root]

    def node_ranges(self) -> np.ndarray:
        """(N, 4) int32 range (x0, x1, y0, y1) of grid nodes that each point's stencil reaches now,
        in device order (indices of one grid layer): what the interaction graph's pre-task compares."""
        out = wp.empty(self.particle_count, dtype=wp.vec4i, device=self.device)
        wp.launch(kgran.make_node_ranges(self.config.shape, self.config.precision), self.particle_count,
                  inputs=[self.P, self.D, out], device=self.device)
        return out.numpy()

    def interaction_domains(self) -> tuple[np.ndarray, np.ndarray]:
        """Half-vectors a, b [m] of each point's domain of interaction at the last rebuild of the
        interaction graph, in device order (granular mode): the parallelogram x ± a ± b. A continuum
        point of a non-deforming shape (no critical density) gets zeros: it interacts through its nodes."""
        if not self.config.granular:
            raise InputError("granular", False, "granular mode (SolverConfig(granular=True))")
        S = self.interaction
        if self.config.shape in kgran.DEFORMING_DOMAINS:
            return S.dom_a.numpy().copy(), S.dom_b.numpy().copy()
        ext = np.maximum(S.ext.numpy(), 0.0)  # the half-extents of the search's axis-aligned records
        zero = np.zeros(len(ext))
        return np.column_stack([ext[:, 0], zero]), np.column_stack([zero, ext[:, 1]])

    def fields(self) -> dict[str, np.ndarray]:
        """Host copies of the per-point output fields (copies: on the CPU ``numpy()`` is a view)."""
        P = self.P
        fields = {"x": P.x, "v": P.v, "stress": P.stress, "volume": P.vol, "mass": P.mass, "F": P.F}
        pid = P.pid.numpy()
        out = {}
        for k, a in fields.items():
            out[k] = np.empty_like(a.numpy())
            out[k][pid] = a.numpy()  # back to the scene's order
        out["body"] = self.body.copy()
        if self.coupled:
            out["contact_force"] = np.empty_like(P.fcont.numpy())
            out["contact_force"][pid] = P.fcont.numpy()
        if self.staged:
            waiting = self.release_times > float(self.clock.numpy()[0])
            out["x"][waiting] = np.nan  # not in the scene yet
            out["v"][waiting] = np.nan
        return out
