"""The launch order of one MPM step, one plan function per stress-update order.

Each function strings the launch makers of one MPM stage (``StepPieces``: P2G, grid update, G2P,
XPIC's smoothing, the wall folds) together in the order of its stress update ("Motion integration"
§3.4) and returns the first plan of the step, launch roles (``mpmdem.sim.mpm_roles``) included;
``MPMSolver._build`` picks the function by ``SolverConfig.update`` (``ORDER_PLANS``) and then applies
the rewrites that do not depend on the order (the clearing update, the folds moved into updates).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .launch_plan import ExtensionPoint
from .mpm_roles import last_grid_update

__all__ = ["AFTER_FORCE_UPDATE", "ORDER_PLANS", "StepPieces", "plan_musl", "plan_usavg", "plan_usf", "plan_usl"]

#: Extension point of the step: after the grid's force update and before G2P (USL only). The
#: coupling's momentum exchange of Liu et al. runs there (``MPMSolver.extend``).
AFTER_FORCE_UPDATE = "after_force_update"


@dataclass(frozen=True)
class StepPieces:
    """The launch makers of one MPM stage, each returning a list of plan items.

    Attributes:
        p2g: ``p2g(mass=, momentum=, force=, [fused_impulse=, remap=])``: a P2G and the folds
            after it.
        grid: ``grid(velocity=, force=, [fused_impulse=, remap=])``: a grid update (a
            ``GridUpdate`` role) and the wall images of the fields it wrote.
        g2p: ``g2p(velocity=, position=, stress=, [stress_fraction=, remap=])``: one G2P.
        xpic: ``xpic()``: XPIC's smoothing of the nodal velocities (empty outside XPIC).
        fold: ``fold(mass=, momentum=, force=, [remap=])``: the folds of the wall and periodic
            images alone (``GridEdges.fold``).
        fused: USL with P2G and the grid update fused into one impulse pass (PIC, no XPIC, no
            damping: ``MPMSolver.fused``).
        liu: the coupling's exchange of Liu et al. runs after the force update (USL only).
        remap_in_g2p: MUSL's re-mapping P2G runs inside the velocity G2P (``tuning.remap_in_g2p``).
    """

    p2g: Callable[..., list]
    grid: Callable[..., list]
    g2p: Callable[..., list]
    xpic: Callable[[], list]
    fold: Callable[..., list]
    fused: bool = False
    liu: bool = False
    remap_in_g2p: bool = False


def plan_usl(pieces: StepPieces) -> list:
    """USL: P2G of mass, momentum and forces, the grid update, then G2P updates velocities,
    positions and the stress from the updated nodal velocities."""
    p = pieces
    if p.fused:
        seq = p.p2g(mass=True, momentum=True, force=True, fused_impulse=True)
        seq += p.grid(velocity=False, force=False, fused_impulse=True)
    else:
        seq = p.p2g(mass=True, momentum=True, force=True) + p.grid(velocity=True, force=True)
    if p.liu:
        seq += [ExtensionPoint(AFTER_FORCE_UPDATE)]  # mpmdem.sim.coupling: Liu et al.'s exchange
    return seq + p.xpic() + p.g2p(velocity=True, position=True, stress="vt")


def plan_usf(pieces: StepPieces) -> list:
    """USF: the stress first, from the nodal velocities of the mapped momentum; then the forces of
    the updated stress, the grid update and G2P of velocities and positions."""
    p = pieces
    seq = p.p2g(mass=True, momentum=True, force=False) + p.grid(velocity=True, force=False)
    seq += p.g2p(velocity=False, position=False, stress="v")
    seq += p.p2g(mass=False, momentum=False, force=True) + p.grid(velocity=False, force=True)
    return seq + p.xpic() + p.g2p(velocity=True, position=True, stress="none")


def _remapped_stress(pieces: StepPieces, seq: list, half: float) -> list:
    """MUSL's second part after the force update in ``seq``: G2P of the velocities, the re-mapping
    P2G of the updated momentum and its grid update, then G2P of positions and ``half`` [-] of the
    stress update from the re-mapped velocities."""
    p = pieces
    seq = seq + p.xpic() + p.g2p(velocity=True, position=False, stress="none", remap=p.remap_in_g2p)
    # the re-mapped momentum starts from zero: the grid update before clears it at the nodes
    # (copies) it visits, which are those the re-mapping P2G adds to (no memset of the grid)
    last = last_grid_update(seq)
    seq[last] = seq[last].remade(zero_remap=True)
    if p.remap_in_g2p:
        seq += p.fold(mass=False, momentum=True, force=False, remap=True)
    else:
        seq += p.p2g(mass=False, momentum=True, force=False, remap=True)
    seq += p.grid(velocity=False, force=False, remap=True)
    return seq + p.g2p(velocity=False, position=True, stress="vm", stress_fraction=half)


def plan_musl(pieces: StepPieces) -> list:
    """MUSL: as USL up to the velocity update, then the stress from velocities re-mapped from the
    updated points."""
    p = pieces
    seq = p.p2g(mass=True, momentum=True, force=True) + p.grid(velocity=True, force=True)
    return _remapped_stress(p, seq, 1.0)


def plan_usavg(pieces: StepPieces) -> list:
    """USAVG ("Motion integration" §3.4): half the stress update from the mapped velocities before
    the forces (as USF), the other half as MUSL's update from the re-mapped velocities."""
    p = pieces
    half = 0.5
    seq = p.p2g(mass=True, momentum=True, force=False) + p.grid(velocity=True, force=False)
    seq += p.g2p(velocity=False, position=False, stress="v", stress_fraction=half)
    seq += p.p2g(mass=False, momentum=False, force=True) + p.grid(velocity=False, force=True)
    return _remapped_stress(p, seq, half)


#: The plan function of each stress-update order (``SolverConfig.update``).
ORDER_PLANS: dict[str, Callable[[StepPieces], list]] = {
    "USL": plan_usl, "USF": plan_usf, "MUSL": plan_musl, "USAVG": plan_usavg}
