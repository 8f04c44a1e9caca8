"""The kernels of the interaction graph of one variant, by name (``GranularKernels``)."""

import functools
from dataclasses import dataclass

import warp as wp

from .cells import make_cells
from .labels import make_label_kernels
from .layers import make_assign
from .reuse import make_check
from .search import make_search_kernels

__all__ = ["GranularKernels", "make_granular_kernels"]


@dataclass(frozen=True)
class GranularKernels:
    """The kernels of ``make_granular_kernels``, read by name (``mpmdem.sim.granular_state``)."""

    check: wp.Kernel | None  # ``reuse``; None for deforming domains
    prepare: wp.Kernel  # ``search``
    place: wp.Kernel  # ``search``
    link: wp.Kernel  # ``search``
    settle: wp.Kernel | None  # ``labels``; None for deforming domains
    relink: wp.Kernel  # ``labels``
    label: wp.Kernel  # ``labels``
    assign: wp.Kernel | None  # ``layers``; the tent outside staged scenes, None else


@functools.cache
def make_granular_kernels(shape: str, precision: str, staged: bool = False,
                          link_lanes: int = 1, relink_lanes: int = 1, check_capped: bool = True,
                          moves: bool = False) -> GranularKernels:
    """The check, prepare, place, link, settle, relink, label and assign kernels of the interaction
    graph (``GranularKernels``).

    Launch each with dim = number of points and inputs ``[P, G, D, materials, S, status, clock]``.
    A step that relabels (``FLAG_RELABEL``, set by the previous step's ``judge``,
    ``make_rebuild_decision``; every step for deforming domains) runs, if it also rebuilds
    (``FLAG_REBUILD``), ``search.make_reset_search`` (over the nodes of one layer), ``prepare``, the
    three scans of ``S.count`` (``kernels.scan``), ``place``, ``link`` and ``settle``, then
    ``relink`` (which frees the copies of the last claims), ``label`` and ``assign``. ``check`` runs after
    the step's last G2P, then ``judge`` as the step's last kernel (``check`` and ``settle`` are None
    for deforming domains, which rebuild every step, list no pairs and have no ``judge``). S is an
    ``Interaction`` (``make_interaction_struct``): cells of ``S.count`` are indexed like ``Grid.mass``
    (column-major over the node lattice of one layer); ``S.ext_max`` holds for shapes outside
    DEFORMING_DOMAINS a constant set by the host in slot 0, else ``reset_search`` zeroes it and
    ``prepare`` fills it. ``count`` starts zeroed and ``label`` zeroes the counts it used. ``assign``
    (the tent outside staged scenes; None else) runs over the nodes of one layer and gives out the
    grid copies there, instead of the claims in P2G. staged: points not yet released
    (``P.release`` ahead of ``clock[CLOCK_T]``) stay single components, in no cell. link_lanes:
    ``link`` takes that many threads a point (launch it over points × link_lanes;
    ``make_search_kernels``); relink_lanes: ``relink`` takes that many (domains that do not deform;
    ``make_label_kernels``; deforming ones list no pairs: give 1). check_capped:
    ``check`` at ``reuse.CHECK_REGISTERS`` registers a thread on CUDA; moves: the scene's
    ``Interaction.moves`` (``make_check``).
    """
    cells = make_cells(shape, precision, staged)
    prepare, place, link = make_search_kernels(shape, precision, staged, link_lanes)
    settle, relink, label = make_label_kernels(shape, precision, staged, 1 if cells.deforming else relink_lanes)
    check = None
    assign = None
    if cells.deforming:
        settle = None
    else:
        check = make_check(shape, precision, staged, check_capped, moves)
    if cells.tent_cells:
        assign = make_assign(shape, precision, staged)
    return GranularKernels(check=check, prepare=prepare, place=place, link=link, settle=settle, relink=relink,
                           label=label, assign=assign)
