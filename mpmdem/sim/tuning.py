"""Tuning: every performance knob of the stages, in one frozen, validated object.

A knob chooses how a step is computed (which kernel variant, how many threads, which launches
are fused, when a block is laid in line), never what it computes beyond round-off: the same
scene and ``SolverConfig`` give the same results under any valid ``Tuning``, to round-off on a
GPU (atomics summed in another order) and mostly to the bit on a CPU. The defaults are the
fastest measured; the measurements behind them are in docs/benchmarks.md, "Tuning constants and
their measured reasons".

``Simulation(scene, config, device=..., tuning=Tuning(disk_pairs=False))`` passes it to the
stages it builds; tests and bench scripts choose a path the same way. What a run computes
(scheme, stress update, precision, time step) is the ``SolverConfig``'s, not this object's.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..errors import InputError

__all__ = ["DEVICE_KINDS", "Tuning"]

#: The device kinds a ``*_devices`` field may name.
DEVICE_KINDS = ("cpu", "cuda")


def _knob(default, low=None, high=None):
    """A field of ``Tuning`` with its default and, for numbers, the closed range it must lie in."""
    return dataclasses.field(default=default, metadata={"low": low, "high": high})


@dataclass(frozen=True)
class Tuning:
    """Performance knobs of the MPM, DEM and coupled stages and of the coordinator (one field a knob,
    grouped by stage; the measured reasons: docs/benchmarks.md, "Tuning constants and their
    measured reasons"). A bad value raises ``InputError`` naming the field."""

    # -- MPM stage: P2G variants (mpmdem.sim.mpm)
    tiled_p2g_points: int = _knob(65536, 0)
    """From this many points on CUDA, P2G sums each block's points in a shared-memory tile first
    (``MPMSolver.p2g_tile``); below it a step is latency-bound and the tile's barriers only add."""
    tiled_p2g_block: int = _knob(64, 4, 1024)
    """Threads (cell-sorted points) per block of the tiled P2G."""
    tiled_p2g_granular: bool = True
    """The tiled P2G in granular mode too: the tile holds the nodes' first copies, a term for another
    copy takes the global atomic (``kernels.p2g.make_p2g``'s ``tile`` with ``layered``). Timed with
    ``bench/step_profile.py --silo-batches`` (docs/benchmarks.md's tuning table)."""
    tiled_p2g_layers: int = _knob(1, 1, 8)
    """Copies of a node the granular tile holds (``make_p2g``'s ``tile_layers``): 1, the first copy
    (a dense flow's); more for scenes of many small components (a dispersed cloud puts terms on up to
    nine copies of a node), each copy a TX × TY tile more of shared memory. Timed in
    ``bench/tile_layers_gpu.sh``: four help a cloud by 3 % and cost a dense body 2-4 %."""
    grid_update_registers: int | None = _knob(48, 16, 255)
    """Registers per thread of the granular (layered) grid update on CUDA (``kernels.grid.make_grid_update``'s
    ``max_registers``; None: the compiler's choice)."""
    grid_update_copies: int = _knob(4, 1, 4)
    """Copies of a node the granular grid update loads at once before updating them (1, 2 or 4): more
    loads in flight, more registers live."""
    g2p_registers: int | None = _knob(64, 16, 255)
    """Registers per thread of G2P on CUDA in scenes of at least ``g2p_registers_points`` points
    (``kernels.g2p.make_g2p``'s ``max_registers``; None: the compiler's choice, about 70 with a
    plastic law, which leaves 37.5 % occupancy)."""
    g2p_registers_points: int = _knob(524288, 0)
    """Scenes of fewer points keep the compiler's choice for G2P: the cap pays where G2P streams
    many points (1M and 4M points 2-6 % faster a step) and costs the small, latency-bound scenes
    and the Beverloo batches 1-5 %."""
    row_p2g_points: int = _knob(16384, 0)
    """Scenes of fewer points run P2G a stencil row a thread (``kernels.p2g.make_p2g``'s
    ``rows``) on ``row_p2g_devices``, outside granular mode: their GPU is nearly idle and each
    kernel as long as one warp's chain of instructions."""
    row_p2g_devices: tuple[str, ...] = ("cuda",)
    """Device kinds ("cpu", "cuda") on which ``row_p2g_points`` applies (the CPU pays in work)."""
    # -- MPM stage: launches folded into other kernels
    mirror_in_g2p: bool = True
    """G2P reads the wall images (a ghost node's interior mirror, reflected) instead of a launch
    writing them after each grid update (``kernels.wall_images.make_mirrored_source``): one launch
    fewer per grid update in scenes with fixed or slip walls, the same bits."""
    fold_in_grid_update: bool = True
    """A grid update folds the wall images onto its own node first (``kernels.grid.make_grid_update``'s
    ``fold``) instead of a fold launch before it (the first grid update of MUSL, USF and USAVG, and
    the step's last, clearing one where G2P reads the images and every wall is fixed, slip or free):
    the same bits."""
    images_in_kernels_points: int = _knob(65536, 0)
    """``mirror_in_g2p`` and ``fold_in_grid_update`` only below this many points: they trade a launch
    (paid per launch in small scenes) for work over every point or node (paid in bandwidth in large
    ones)."""
    remap_in_g2p: bool = True
    """MUSL (and USAVG) re-map the new point velocities in the G2P that updates them
    (``make_g2p``'s ``remap``: the same terms in the same order per node) where P2G runs a thread a
    point, outside deterministic mode."""
    # -- MPM stage: Granular MPM (mpmdem.sim.granular_state, mpmdem.sim.block_layout)
    critical_band: float = _knob(2.0**-11, 2.0**-20, 0.25)
    """Overlap tests closer than this many cells to flipping are listed and re-tested every step
    instead of setting the margin of the label reuse (below the 1.7e-3 cells by which the paper's
    ρ_cr makes neighbouring domains of a dense packing overlap). At most ``wide_band_cap``."""
    wide_band_cap: float = _knob(0.25, 2.0**-20, 1.0)
    """The widest band of the pair lists [cells] (``kernels/granular``, WIDE_STEPS)."""
    nested_rebuild: bool = True
    """The rebuild sits in a conditional graph node of its own inside the relabel's (else its kernels
    are launched on every relabel and return at once when there is no rebuild)."""
    link_lanes: int = _knob(4, 1, 32)
    """Threads a point of the rebuild's ``link`` (and of the relabel's ``relink`` with
    ``relink_lanes``) in scenes of fewer than ``link_lanes_points`` points on ``link_lanes_devices``:
    a GPU idle at a few thousand points runs each point's pair tests and merges over the lanes."""
    link_lanes_points: int = _knob(65536, 0)
    """Scenes below this many points take ``link_lanes``; from it on, the rebuild decision's
    ``check`` is the capped variant."""
    link_lanes_devices: tuple[str, ...] = ("cuda",)
    """Device kinds on which ``link_lanes`` applies (the CPU, one core's work, keeps one thread)."""
    relink_lanes: int = _knob(8, 1, 32)
    """Threads a point of ``relink`` (domains that do not deform) where ``link`` takes
    ``link_lanes``: one a listed pair (a point lists at most ``kernels.granular.PAIR_SLOTS`` = 8)."""
    node_range_moves: bool = True
    """A point may change node ranges without a rebuild where no pair's pre-task can then change
    (``granular_state.make_interaction``); off, every new node range rebuilds: the same labels and
    results, at a rebuild's cost."""
    inline_above: float = _knob(0.6)
    """Fraction of a window's steps running a Granular block from which it is laid in line instead of
    in its conditional graph node (``BlockLayout``)."""
    conditional_below: float = _knob(0.3)
    """Fraction at or below which an inline block goes back to its conditional node (less than
    ``inline_above``: the gap keeps a rate near break-even from switching at every window)."""
    layout_window_steps: int = _knob(100, 1)
    """Fewest steps a block's rate is taken over (``BlockLayout``)."""
    # -- DEM stage (mpmdem.sim.dem)
    large_factor: float = _knob(4.0, 1.0)
    """Bodies larger than this many times the median bounding radius are "large" (walls, gates):
    not binned in cells; every small body tests them directly."""
    max_large: int = _knob(64, 0)
    """At most this many large bodies (the largest)."""
    disk_pairs: bool = True
    """Scenes with disk grains compute the pairs of two small sphero-disks in the disk–disk pass
    (``kernels.dem_disks``: no feature search, the same forces); False: the general search for
    every pair (bench/grain_throughput.py compares the two)."""
    split_search_bodies: int = _knob(65536, 0)
    """From this many bodies on ``split_search_devices``, outside deterministic mode, the pair search
    is split over candidate vertices (``kernels.dem_split``): the same bits as the one-kernel search."""
    split_search_devices: tuple[str, ...] = ("cuda",)
    """Device kinds on which ``split_search_bodies`` applies."""
    split_pairs_per_body: int = _knob(4, 1)
    """Listed pairs per body with records of the split search (a body lists about 2); a pair past
    them is searched whole."""
    split_candidates_per_body: int = _knob(16, 1)
    """Candidate vertices per body of the split search (about 4 a pair); past them, searched whole."""
    split_hits_per_pair: int = _knob(4, 1)
    """Touching feature pairs recorded per listed pair by the split search; past them, searched whole."""
    split_threads_per_sm: int = _knob(2048, 1)
    """Threads per SM, at least, of the split search's kernels on CUDA (they stride over the listed
    pairs or the candidates; a thread striding over several pairs runs them one after another)."""
    split_threads_per_body: int = _knob(4, 1)
    """Threads per body, at least, of the split search's kernels on CUDA: about a thread per listed
    pair (without the disk–disk pass; with it, the per-SM floor alone)."""
    split_assemble_registers: int | None = _knob(128, 16, 255)
    """Registers per thread of the split search's ``assemble`` on CUDA (None: the compiler's choice,
    which takes one block of 256 threads an SM)."""
    disk_force_registers: int | None = _knob(None, 16, 255)
    """Registers per thread of the disk–disk pass's force kernel on CUDA (``kernels.dem_disks``; None:
    the compiler's choice)."""
    list_build_registers: int | None = _knob(None, 16, 255)
    """Registers per thread of the DEM list build (``kernels.dem_lists.build_lists``) on CUDA (None:
    the compiler's choice)."""
    split_cpu_threads: int = _knob(4096, 1)
    """Threads of the split search's kernels on a CPU (they run one after another: fewer take the
    candidates out of order)."""
    # -- coupled stage (mpmdem.sim.coupling)
    imp_build_tile: int = _knob(32, 1, 1024)
    """Threads per body in the point–body list build (they share the cells the body covers)."""
    sifted_imp_points: int = _knob(65536, 0)
    """From this many points (not in deterministic mode) the listed points are sifted each step by a
    light kernel and the force search runs only over those near a body."""
    static_imp_bodies: int = _knob(8, 0)
    """With at most this many rigid bodies, below ``sifted_imp_points`` points, on
    ``static_imp_devices``, every point lists every body once and for all: no list check and no
    conditional rebuild in the step (both paths give the same forces)."""
    static_imp_devices: tuple[str, ...] = ("cuda",)
    """Device kinds on which ``static_imp_bodies`` applies (the CPU pays in work, not launches)."""
    # -- coordinator (mpmdem.sim.simulation, mpmdem.sim.auto_sort)
    steps_per_graph: int = _knob(16, 1)
    """Steps per launch of the multi-step CUDA graph (small scenes pay a graph launch per launch)."""
    auto_sort_drift: float = _knob(0.25, 0.0, 1.0)
    """Automatic re-sorting (``SolverConfig(sort_interval=None)``): re-sort when more than this
    fraction of consecutive point pairs sit in cells that are not neighbours."""
    auto_sort_min_points: int = _knob(65536, 0)
    """Fewest points for which the order is watched (below it points and grid fit in the L2 cache)."""
    auto_sort_check_steps: int = _knob(0, 0)
    """Fewest steps between two drift checks; 0: after every batch of ``advance_to``."""
    launch_ahead_fraction: float = _knob(0.5, 0.0, 0.95)
    """The share of a frame's steps a run launches before its host work on the frame before
    (``Simulation.launch_ahead``): more overlaps more of that work with the steps, but a dt that
    grows by more than 1/fraction - 1 within the frame carries the last of them past it, idle, and
    the frame's dt diagnostic then reads 0 (0.5: dt would have to double)."""
    module_load_workers: int = _knob(8, 0, 64)
    """Threads that compile (or load from Warp's cache) the step's kernel modules at once before the
    first step on CUDA (``wp.force_load``'s ``max_workers``; 0: one after another, as the first
    launches would). Each kernel is a module of its own, so a cold cache compiles dozens."""
    writer_switch_interval: float = _knob(0.0005, 0.0, 1.0)
    """Python's thread switch interval [s] while a run writes its frames in a worker thread
    (``mpmdem.io.background.thread_switch_interval``; 0: Python's own, 5 ms): how long the writer,
    having let Python's lock go around an HDF5 write, may wait for a busy main thread to give it back."""

    batch_sidecar_interval: float = _knob(4.0, 0.0)
    """Least wall time between two rewrites of one world's XDMF sidecars in a batch [s] (``FrameWriter``'s
    ``sidecar_interval``; a lone run's is 1 s): a batch's worlds share one writer, and each rewrite
    costs it the whole text again. A batch that ends, fails or is stopped brings them up to date; one
    killed outright may miss this long of frames in its sidecars (its HDF5 files have them all)."""
    batch_writer_processes: int = _knob(0, 0, 64)
    """Child processes that write a batch's frames (``mpmdem.io.writer_process``), the worlds dealt
    to them in turn; 0: one thread of the process that steps (``mpmdem.io.background``). A child's
    writing takes no Python time from the thread that reads the frames back and launches the steps,
    and several children write several worlds' files at once (h5py serialises a process's HDF5 calls)."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            kind = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
            if kind.startswith("tuple"):
                if isinstance(value, str) or not isinstance(value, (tuple, list)) or any(
                        d not in DEVICE_KINDS for d in value):
                    raise InputError(f.name, value, f"a tuple of device kinds from {DEVICE_KINDS}")
                object.__setattr__(self, f.name, tuple(value))
            elif kind == "bool":
                if not isinstance(value, bool):
                    raise InputError(f.name, value, "True or False")
            else:
                _check_number(f.name, value, kind, f.metadata.get("low"), f.metadata.get("high"))
        if not self.conditional_below < self.inline_above:
            raise InputError("conditional_below", self.conditional_below,
                             f"a fraction below inline_above={self.inline_above!r}")
        if self.grid_update_copies not in (1, 2, 4):
            raise InputError("grid_update_copies", self.grid_update_copies, "1, 2 or 4")
        if self.critical_band > self.wide_band_cap:
            raise InputError("critical_band", self.critical_band, f"at most wide_band_cap={self.wide_band_cap!r}")


def _check_number(name: str, value: object, kind: str, low, high) -> None:
    """InputError unless ``value`` is an integer (``kind`` "int", or "int | None" also None) or a
    finite real number ("float") in [low, high] (an open side where None)."""
    if value is None and "None" in kind:
        return
    integer = kind.startswith("int")
    if isinstance(value, bool) or not (isinstance(value, int) if integer else isinstance(value, (int, float))):
        ok = False
    else:
        ok = (math.isfinite(value) and (low is None or value >= low) and (high is None or value <= high))
    if not ok:
        rng = (f" in [{low:g}, {high:g}]" if low is not None and high is not None
               else f" >= {low:g}" if low is not None else f" <= {high:g}" if high is not None else "")
        what = "an integer" if integer else "a finite number"
        raise InputError(name, value, what + rng + (", or None" if "None" in kind else ""))
