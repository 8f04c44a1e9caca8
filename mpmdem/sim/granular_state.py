"""Granular MPM on the MPM stage ("Granular MPM" §3.3–3.4): the arrays of the interaction graph
(``make_interaction``) and the ``GranularPlan`` the stage owns: the kernels of its variant, the
launches that build the graph and label its components at the start of a step, and host-side
inspection (components, layers in use, domains of interaction).

The kernels are in ``kernels/granular.py``; this module sizes their arrays and orders them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..errors import InputError
from ..kernels import granular as granular_kernels
from ..kernels import scan as scan_kernels
from ..kernels.shape_functions import SUPPORT_NODES
from .host_copy import host_copy
from .launch_plan import IfFlag, Launch
from .tuning import Tuning

__all__ = ["GranularPlan", "make_granular_plan", "make_interaction", "node_ranges", "static_extent"]


def static_extent(scene, config, host: dict, mats: list) -> np.ndarray:
    """Slots of the largest half-extent of a domain of interaction [cells] (kernels/granular.py):
    for shapes whose domains do not follow F it is fixed, so it is computed here once."""
    out = np.zeros(2 * granular_kernels.EXT_SLOTS, np.float32)
    if config.shape in granular_kernels.DEFORMING_DOMAINS:
        return out
    h = scene.cell_size
    rho_cr = np.array([m.critical_density or 0.0 for m in mats])[host["material_index"]]
    half = host["half"]
    granular = rho_cr > 0.0
    scale = np.ones(len(half))
    scale[granular] = np.sqrt(host["mass"][granular] / (rho_cr[granular] * 4.0 * half[granular].prod(axis=1)))
    ext = half * scale[:, None] / h
    if (~granular).any():  # a continuum reaches its whole stencil
        ext[~granular] = SUPPORT_NODES[config.shape] + 1
    out[:2] = ext.max(axis=0)
    return out


def make_interaction(scene, config, host: dict, mats: list, points, grid_shape, layer_rows: int, types, *,
                     staged: bool, device, tuning: Tuning):
    """The interaction-graph struct of ``kernels/granular.py`` and the scan's tile totals (the bands
    of the pair lists and the node-range moves from ``tuning``)."""
    if scene.periodic_x:
        raise InputError("granular", True, "False with periodic x boundaries (the domains of interaction and the "
                         "component grids know no periodic image yet)")
    T = np.float32 if config.precision == "f32" else np.float64
    t = types
    n = len(host["mass"])
    dev = device
    # interaction graph of Granular MPM (kernels/granular.py); cells = nodes of one layer
    cells = layer_rows * grid_shape[1]
    S = granular_kernels.make_interaction_struct(config.precision)()
    # points by cell (CSR): counts, their prefix sums in three levels (kernels/scan.py), ranks, order
    n1, n2 = scan_kernels.scan_lengths(cells + 1)
    S.count = wp.zeros(n1, dtype=wp.int32, device=dev)
    S.prefix1 = wp.zeros(n1, dtype=wp.int32, device=dev)
    S.prefix2 = wp.zeros(n2, dtype=wp.int32, device=dev)
    S.prefix3 = wp.zeros(scan_kernels.SCAN_TILE, dtype=wp.int32, device=dev)
    # the tile totals of levels 1 and 2, and a sink for level 3's
    scan_totals = (wp.zeros(n2, dtype=wp.int32, device=dev),
                   wp.zeros(scan_kernels.SCAN_TILE, dtype=wp.int32, device=dev),
                   wp.zeros(1, dtype=wp.int32, device=dev))
    S.rank = wp.zeros(n, dtype=wp.int32, device=dev)
    S.cell0 = wp.zeros(1 if config.shape in granular_kernels.DEFORMING_DOMAINS else n, dtype=wp.int32, device=dev)
    S.order = wp.zeros(n, dtype=wp.int32, device=dev)
    tent = config.shape == "linear" and not staged  # (its node range follows from its cell)
    S.labels = wp.zeros(n if tent else 1, dtype=wp.int32, device=dev)  # (for its node threads)
    # the bytes of points.slots, which the tent's node threads store one by one (a view:
    # points.slots is allocated once and never replaced)
    words = points.slots.shape[1]
    S.slot_bytes = (wp.array(ptr=points.slots.ptr, dtype=wp.uint8, shape=(n, 4 * words), device=dev)
                    if tent else wp.zeros((1, 4), dtype=wp.uint8, device=dev))
    S.parent = wp.zeros(n, dtype=wp.int32, device=dev)
    deforming = config.shape in granular_kernels.DEFORMING_DOMAINS
    S.dom_a = wp.zeros(n if deforming else 1, dtype=t.vec2, device=dev)
    S.dom_b = wp.zeros(n if deforming else 1, dtype=t.vec2, device=dev)
    # reuse of the labels between rebuilds (kernels/granular.py): a rebuild on the first step
    S.ext = wp.zeros(1 if deforming else n, dtype=t.vec2, device=dev)
    S.anchor = wp.zeros(1 if deforming else n, dtype=t.vec2, device=dev)
    S.records = wp.zeros(1 if deforming else n, dtype=t.vec4, device=dev)
    S.reach = wp.zeros(1 if tent else n, dtype=wp.vec4i, device=dev)
    extent = static_extent(scene, config, host, mats)
    S.ext_max = wp.array(extent, dtype=wp.float32, device=dev)
    S.slack = wp.full(granular_kernels.EXT_SLOTS, granular_kernels.NO_MARGIN, dtype=wp.int32, device=dev)
    S.motion = wp.zeros(3 * granular_kernels.EXT_SLOTS, dtype=wp.int32, device=dev)
    S.cell_ref = wp.full(cells, -1, dtype=wp.int32, device=dev)
    S.ref = wp.zeros(1 if deforming else n, dtype=wp.int32, device=dev)
    # pairs within a band of flipping are listed per point and re-tested every step rather
    # than let them set the margin of all; a flip relabels over the lists, on top of the
    # forest of the other pairs (kernels/granular.py)
    listed = 1 if deforming else n
    S.pairs = wp.zeros((granular_kernels.PAIR_SLOTS, listed), dtype=wp.int32, device=dev)
    S.npairs = wp.zeros(listed, dtype=wp.int32, device=dev)
    # (at most one entry per point: ``check`` and ``relink`` test entry p in thread p)
    S.spill = wp.zeros(1 if deforming else min(n, max(1024, n // 4)), dtype=wp.vec2i, device=dev)
    S.base = wp.zeros(listed, dtype=wp.int32, device=dev)
    S.home = wp.zeros(n if tent else 1, dtype=wp.int32, device=dev)
    # the tent's relabels give out anew only the copies of nodes whose points changed labels:
    # the cells where one did, marked with the labelling's stamp (FLAG_STAMP)
    S.dirty = wp.full(cells if tent else 1, -1, dtype=wp.int32, device=dev)
    S.quantum = t.scalar(scene.cell_size * 2.0**-20)
    S.band_min = int(tuning.critical_band * 2.0**20)  # (in quanta of h 2^-20)
    S.band_cap = int(tuning.wide_band_cap * 2.0**20)
    # a point may change cells and node ranges without a rebuild when every point is granular
    # and every domain of interaction under half a cell (domains that do not deform, outside
    # staged scenes): two overlapping domains are then less than a cell apart on each axis, and
    # any stencil of such points shares a node, so the pre-task holds for every pair that passes
    # task 1 whatever the ranges. The search then visits one cell around each point (its domain
    # and the largest reach less than a cell), and so does ``check``'s window of references: the
    # pairs farther apart need (1 − 2 largest half-extent) h to meet, which the absolute moves bound
    ext = float(extent[:2].max())
    rho_cr = np.array([m.critical_density or 0.0 for m in mats])[host["material_index"]]
    granular_only = bool((rho_cr > 0.0).all())
    S.moves = int(not deforming and not staged and granular_only and ext < 0.5 and (tent or tuning.node_range_moves))
    S.moves_margin = (int(math.floor((1.0 - 2.0 * ext * (1.0 + 1.0e-6)) * 2.0**20)) if S.moves
                      else granular_kernels.NO_MARGIN)
    flags = np.zeros(granular_kernels.FLAG_SLOTS, np.int32)
    flags[granular_kernels.FLAG_REBUILD] = 1  # the first step builds the graph
    flags[granular_kernels.FLAG_RELABEL] = 1
    flags[granular_kernels.FLAG_BAND] = S.band_min
    flags[granular_kernels.FLAG_MEASURED] = 1  # (a narrow rebuild that keeps margins: it counts for the next band)
    S.flags = wp.array(flags, dtype=wp.int32, device=dev)
    # round-off of one displacement, offset or margin: every one is a difference of two
    # nearby coordinates (exact when they are within a factor 2 of each other, Sterbenz;
    # else rounded to half an ulp of the small result) followed by a few operations on
    # lengths of a few cells, so each carries a few ulps of ~4h whatever the coordinates:
    # 32 eps h leaves room
    eps = float(np.finfo(T).eps)
    S.roundoff = t.scalar(32.0 * eps * scene.cell_size)
    return S, scan_totals


@dataclass(frozen=True)
class GranularPlan:
    """Granular MPM on one MPM stage, built once (``make_granular_plan``) and owned by it
    (``MPMSolver.granular``): the interaction graph, the kernels of its variant by name, the launches
    of a step's start and end, and the host-side inspection.

    Attributes:
        interaction: the ``Interaction`` struct (``kernels/granular.py``; its ``flags`` say what the
            next step rebuilds or relabels).
        scan_totals: the tile totals of the cell counts' prefix sums (``kernels/scan.py``).
        stats: int32[2]: components and layers in use (``statistics``).
        kernels: the interaction graph's kernels of this variant (``GranularKernels``).
        start: the plan of a step's start: tasks 1-2, the graph (when flagged) and the components
            (the copies of each node are claimed in the P2G that follows, kernels/granular.py).
        judge: the kernel that decides at the end of a step whether the next one rebuilds (None:
            domains that deform rebuild every step).
        check: the launch that goes after the step's last G2P (None with no judge).
        points, G, D, clock: the MPM stage's structs and clock the kernels take.
        shape, precision, staged: the variant (``SolverConfig.shape``, ``precision``; points
            released later).
        layer_nodes: nodes of one grid layer (rows × columns).
        device: the Warp device.
    """

    interaction: object
    scan_totals: tuple
    stats: wp.array
    kernels: granular_kernels.GranularKernels
    start: list
    judge: object | None
    check: Launch | None
    points: object
    G: object
    D: object
    clock: wp.array
    shape: str
    precision: str
    staged: bool
    layer_nodes: int
    device: object

    @property
    def particle_count(self) -> int:
        """Number of material points."""
        return len(self.points.x)

    @property
    def deforming(self) -> bool:
        """Whether the domains of interaction follow F (``DEFORMING_DOMAINS``): a rebuild every step."""
        return self.shape in granular_kernels.DEFORMING_DOMAINS

    def counts(self) -> tuple[int, int]:
        """(rebuilds, relabels) of the interaction graph since the start (one host sync)."""
        flags = host_copy(self.interaction.flags)
        return int(flags[granular_kernels.FLAG_COUNT]), int(flags[granular_kernels.FLAG_RELABELS])

    def invalidate(self) -> None:
        """The next step rebuilds the graph (after the points were reordered or overwritten from the
        host, e.g. a checkpoint)."""
        flag = wp.array([1], dtype=wp.int32, device="cpu")
        for slot in (granular_kernels.FLAG_REBUILD, granular_kernels.FLAG_RELABEL):  # (a rebuild labels too)
            wp.copy(self.interaction.flags, flag, dest_offset=slot, count=1)

    def statistics(self) -> tuple[int, int]:
        """(components, grid layers in use at the busiest node) of the last step (the copies a
        relabel kept for a component that has left a node count until the next rebuild)."""
        self.stats.zero_()
        dim = max(self.particle_count, self.layer_nodes)
        wp.launch(granular_kernels.make_granular_statistics(self.precision, self.staged), dim,
                  inputs=[self.points, self.G, self.D, self.clock, self.stats], device=self.device)
        c, layers = host_copy(self.stats)
        return int(c), int(layers)

    def components(self) -> np.ndarray:
        """Component label of every point in the scene's order: the smallest scene index among the
        points of its component."""
        n = self.particle_count
        comp = host_copy(self.points.comp)
        pid = host_copy(self.points.pid)
        # labels are device indices of the root points (kernels/granular.py ``priority``): in the
        # scene's order, each component named by its smallest member
        root = np.empty(n, np.int64)
        root[pid] = comp  # the root (a device index) of each point, in the scene's order
        smallest = np.full(n, n, np.int64)
        np.minimum.at(smallest, root, np.arange(n))
        return smallest[root]

    def interaction_domains(self) -> tuple[np.ndarray, np.ndarray]:
        """Half-vectors a, b [m] of each point's domain of interaction at the last rebuild of the
        interaction graph, in device order: the parallelogram x ± a ± b. A continuum point of a
        non-deforming shape (no critical density) gets zeros: it interacts through its nodes."""
        S = self.interaction
        if self.deforming:
            return host_copy(S.dom_a).copy(), host_copy(S.dom_b).copy()
        ext = np.maximum(host_copy(S.ext), 0.0)  # the half-extents of the search's axis-aligned records
        zero = np.zeros(len(ext))
        return np.column_stack([ext[:, 0], zero]), np.column_stack([zero, ext[:, 1]])


def make_granular_plan(scene, config, host: dict, mats: list, *, points, G, D, grid_shape, materials: wp.array,
                       status: wp.array, clock: wp.array, types, staged: bool, device,
                       tuning: Tuning) -> GranularPlan:
    """The ``GranularPlan`` of an MPM stage: the interaction graph's arrays (``make_interaction``:
    ``host`` the points' columns in device order, ``mats`` the scene's materials) and Granular MPM
    tasks 1-2 at the start of a step over them and the stage's structs (``points``, ``G``, ``D``,
    ``materials``, ``status``, ``clock``); the lanes and the nesting of the rebuild from ``tuning``."""
    grid_dim = (D.layer_rows, grid_shape[1])  # the nodes of one layer
    interaction, scan_totals = make_interaction(scene, config, host, mats, points, grid_shape, D.layer_rows, types,
                                                staged=staged, device=device, tuning=tuning)
    stats = wp.zeros(2, dtype=wp.int32, device=device)
    c = config
    n = len(points.x)
    prec = c.precision
    deforming = c.shape in granular_kernels.DEFORMING_DOMAINS
    S = interaction
    gin = [points, G, D, materials, S, status, clock]
    dev = wp.get_device(device)
    kind = "cuda" if dev.is_cuda else "cpu"
    tn = tuning
    small = kind in tn.link_lanes_devices and n < tn.link_lanes_points
    lanes = tn.link_lanes if small else 1
    relink_lanes = tn.relink_lanes if small and not deforming else 1
    kernels = granular_kernels.make_granular_kernels(
        c.shape, prec, staged=staged, link_lanes=lanes, relink_lanes=relink_lanes,
        check_capped=n >= tn.link_lanes_points, moves=bool(S.moves))
    reset = Launch(granular_kernels.make_reset_search(prec, deforming), grid_dim,
                   [G, D, S.ext_max, S.slack, S.cell_ref, S.flags, S.motion])
    rebuild = [reset, Launch(kernels.prepare, n, gin)]
    # the start of each cell's run in the cell-sorted list: prefix sums of the counts (gated
    # by the rebuild flag: outside a CUDA graph the kernels of a skipped rebuild are launched
    # and return; deforming domains rebuild every step: an open gate)
    gate = (S.flags[granular_kernels.FLAG_REBUILD:] if kernels.check is not None
            else wp.ones(1, dtype=wp.int32, device=device))
    if dev.is_cuda:
        scan, threads = scan_kernels.make_tile_scan(), scan_kernels.SCAN_THREADS
        totals = scan_totals
        levels = [(S.count, S.prefix1, totals[0]), (totals[0], S.prefix2, totals[1]),
                  (totals[1], S.prefix3, totals[2])]
        # (a level whose input is one tile adds nothing: its prefix stays zero)
        rebuild += [Launch(scan, (values.shape[0] // scan_kernels.SCAN_TILE, threads),
                           [values, prefix, totals, gate], threads)
                    for k, (values, prefix, totals) in enumerate(levels)
                    if k == 0 or levels[k - 1][0].shape[0] > scan_kernels.SCAN_TILE]
    else:
        rebuild += [Launch(scan_kernels.make_serial_scan(), 1, [S.count, S.prefix1, gate])]
    rebuild += [Launch(kernels.place, n, gin), Launch(kernels.link, n * lanes, gin)]
    relabel = [Launch(kernels.relink, n * relink_lanes, gin), Launch(kernels.label, n, gin)]
    if kernels.assign is not None:
        # the tent: each node gives out its copies (instead of the claims in P2G)
        relabel += [Launch(kernels.assign, grid_dim, gin)]
    common = dict(interaction=S, scan_totals=scan_totals, stats=stats, kernels=kernels, points=points, G=G, D=D,
                  clock=clock, shape=c.shape, precision=prec, staged=staged, layer_nodes=grid_dim[0] * grid_dim[1],
                  device=device)
    if kernels.check is None:
        return GranularPlan(start=rebuild + relabel, judge=None, check=None, **common)
    # the rebuild runs only when the previous step's judge (end_step) asked for it, the
    # relabel when it asked for either: inside a CUDA graph conditional nodes skip their
    # launches; elsewhere each kernel reads its flag and returns at once. ``check`` goes
    # after the step's last G2P.
    rebuild += [Launch(kernels.settle, n, gin)]
    rebuild_flag = S.flags[granular_kernels.FLAG_REBUILD:]
    relabel_flag = S.flags[granular_kernels.FLAG_RELABEL:]
    inner = [IfFlag(rebuild_flag, rebuild)] if tn.nested_rebuild else rebuild
    start = [IfFlag(relabel_flag, inner + relabel)]
    return GranularPlan(start=start, judge=granular_kernels.make_rebuild_decision(prec),
                        check=Launch(kernels.check, n, gin), **common)


def node_ranges(points, D, shape: str, precision: str, device) -> np.ndarray:
    """(N, 4) int32 range (x0, x1, y0, y1) of grid nodes that each point's stencil reaches now,
    in device order (indices of one grid layer): what the interaction graph's pre-task compares
    (any mode)."""
    n = len(points.x)
    out = wp.empty(n, dtype=wp.vec4i, device=device)
    wp.launch(granular_kernels.make_node_ranges(shape, precision), n, inputs=[points, D, out], device=device)
    return host_copy(out)
