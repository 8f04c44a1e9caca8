"""The typed contracts between the stages (issue 47 item 3).

* One plan function per stress-update order (``mpmdem.sim.mpm_orders``): every order of
  ``SolverConfig`` has one, and each strings P2G, grid update and G2P in the order that defines it
  ("Motion integration" §3.4: USF updates the stress before the force P2G, USL after the grid
  update from its velocities, MUSL from velocities re-mapped from the updated points, USAVG half
  before and half after). Reference: those definitions, read off the recorded calls.
* The coupled stage sees the points, the grid and the bodies through ``mpmdem.sim.views`` only: an
  AST scan of ``mpmdem/sim/coupling.py`` lists every attribute it reads of the two stages; arrays
  come only through the views (the stages' own methods and the shared clock stay allowed).
* Granular mode: the MPM stage owns one ``GranularPlan`` whose start plan launches the kernels of
  its ``GranularKernels`` by name, and the sums of the points leave the stage untouched (they
  return the obstacles' impulse mark instead of writing it).
"""

import ast

import numpy as np
import pytest
from helpers import ROOT

from mpmdem import LinearElastic, Scene, SolverConfig, disk
from mpmdem.model.config import STRESS_UPDATES
from mpmdem.sim import diagnostics
from mpmdem.sim.granular_state import GranularPlan
from mpmdem.sim.launch_plan import IfFlag, Launch, plan_kernels
from mpmdem.sim.mpm import MPMSolver
from mpmdem.sim.mpm_orders import AFTER_FORCE_UPDATE, ORDER_PLANS, StepPieces
from mpmdem.sim.mpm_roles import GridUpdate, launches

SIM = ROOT / "mpmdem" / "sim"


def test_every_stress_update_has_one_plan_function():
    """Verify ORDER_PLANS names exactly the orders SolverConfig accepts."""
    assert set(ORDER_PLANS) == set(STRESS_UPDATES)


def _recording_pieces(**facts) -> StepPieces:
    """Pieces whose launches name the pass and its flags: ("p2g", flags), ("grid", flags), ("g2p", flags)."""
    def p2g(**flags):
        return [Launch(("p2g", flags), 1, [])]

    def grid(**flags):
        def make(**options):
            return ("grid", {**flags, **options})
        return [GridUpdate(Launch(make(), 1, []), make, remap=bool(flags.get("remap")))]

    def g2p(**flags):
        return [Launch(("g2p", flags), 1, [])]

    def fold(**flags):
        return [Launch(("fold", flags), 1, [])]

    return StepPieces(p2g=p2g, grid=grid, g2p=g2p, xpic=lambda: [], fold=fold, **facts)


def _passes(order: str, **facts) -> list[tuple[str, dict]]:
    out = []
    for item in launches(ORDER_PLANS[order](_recording_pieces(**facts))):
        out.append(item.kernel if isinstance(item, Launch) else ("extension", {"name": item.name}))
    return out


def test_usf_updates_the_stress_before_the_force_p2g():
    """Verify USF: P2G of momentum, the stress from the nodal velocities, then the force P2G, the
    grid update and a G2P that moves the points without touching the stress."""
    names = [(name, flags.get("stress", flags.get("force"))) for name, flags in _passes("USF")]
    assert names == [("p2g", False), ("grid", False), ("g2p", "v"), ("p2g", True), ("grid", True), ("g2p", "none")]


def test_usl_updates_the_stress_last_from_the_updated_velocities():
    """Verify USL: one P2G of mass, momentum and forces, one grid update, one G2P with stress "vt";
    the fused variant keeps that order, and Liu et al.'s exchange sits between update and G2P."""
    for fused in (False, True):
        passes = _passes("USL", fused=fused)
        assert [name for name, _ in passes] == ["p2g", "grid", "g2p"]
        assert passes[0][1]["force"] and passes[2][1]["stress"] == "vt"
        assert bool(passes[0][1].get("fused_impulse")) == fused
    passes = _passes("USL", liu=True)
    assert passes[2] == ("extension", {"name": AFTER_FORCE_UPDATE})


@pytest.mark.parametrize("remap_in_g2p", [False, True])
def test_musl_and_usavg_update_the_stress_from_remapped_velocities(remap_in_g2p):
    """Verify MUSL: the velocity G2P, the re-mapping (a P2G of momentum, or the folds of a G2P that
    re-maps itself) with the update before it zeroing the re-mapped momentum, a re-mapping grid
    update, then a G2P with stress "vm" and the whole update; USAVG: a first half "v" before the
    force P2G (as USF), the second half "vm", the halves summing to one."""
    for order, first in (("MUSL", []), ("USAVG", [0.5])):
        passes = _passes(order, remap_in_g2p=remap_in_g2p)
        stress = [(flags["stress"], flags.get("stress_fraction")) for name, flags in passes if name == "g2p"]
        assert [s for s, _ in stress] == (["v"] if first else []) + ["none", "vm"]
        fractions = [f for s, f in stress if s in ("v", "vm")]
        assert sum(fractions) == 1.0 and fractions[:-1] == first
        velocity_g2p = next(k for k, (name, flags) in enumerate(passes) if name == "g2p" and flags["velocity"])
        assert passes[velocity_g2p][1].get("remap", False) == remap_in_g2p
        before = [flags for name, flags in passes[:velocity_g2p] if name == "grid"]
        assert before[-1].get("zero_remap") is True
        remap = passes[velocity_g2p + 1]
        assert remap[0] == ("fold" if remap_in_g2p else "p2g") and remap[1]["remap"] and remap[1]["momentum"]
        assert passes[velocity_g2p + 2][0] == "grid" and passes[velocity_g2p + 2][1]["remap"]


# the attributes of the stages the coupling may read: their steps, status and output, the shared
# clock, and the views (``mpmdem.sim.views``); no array of theirs by another name
MPM_ALLOWED = {"points_view", "grid_view", "sim_clock", "clock", "steps", "tuning", "cap_time_step", "extend",
               "extensions", "run_sequence", "end_step", "start_plan", "status_counts", "check_status",
               "likely_cause", "diagnostics", "state_arrays", "WORK_TERMS"}
DEM_ALLOWED = {"sim_clock", "dt_bound", "contact_checks", "contact_forces", "body_update", "contact_rebuild",
               "status_counts", "check_status", "overlap_cause", "diagnostics", "state_arrays", "WORK_TERMS"}


def _stage_reads(tree: ast.AST) -> dict[str, set[str]]:
    """Attributes read of ``mpm``/``dem`` or ``self.mpm``/``self.dem`` in ``tree``."""
    reads = {"mpm": set(), "dem": set()}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute):
            continue
        v = node.value
        if isinstance(v, ast.Name) and v.id in reads:
            reads[v.id].add(node.attr)
        elif (isinstance(v, ast.Attribute) and v.attr in reads and isinstance(v.value, ast.Name)
              and v.value.id == "self"):
            reads[v.attr].add(node.attr)
    return reads


def test_the_coupling_reads_the_stages_arrays_through_the_views_only():
    """Verify the coupled stage reads of the MPM and DEM stages only their methods, the clock and
    the views: outside ``bodies_view`` (which builds the bodies' view once) no ``mpm.P``, ``mpm.G``,
    ``dem.B`` or other array of theirs."""
    tree = ast.parse((SIM / "coupling.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "bodies_view":
            tree.body.remove(node)
            break
    else:
        raise AssertionError("coupling.bodies_view is gone")
    reads = _stage_reads(tree)
    assert reads["mpm"] <= MPM_ALLOWED, reads["mpm"] - MPM_ALLOWED
    assert reads["dem"] <= DEM_ALLOWED, reads["dem"] - DEM_ALLOWED
    assert {"points_view", "grid_view"} <= reads["mpm"]


def _granular_stage(shape: str) -> MPMSolver:
    scene = Scene(domain=((0.0, 0.0), (0.1, 0.1)), cell_size=0.01, gravity=(0.0, -9.81))
    sand = LinearElastic(1.0e5, 0.3, 1500.0, critical_density=1400.0)
    scene.add_mpm_body(disk(center=(0.05, 0.04), radius=0.02), sand)
    config = SolverConfig(granular=True, shape=shape, precision="f64", dt=1.0e-5)
    return MPMSolver(scene.finalize(), config, "cpu")


@pytest.mark.parametrize("shape", ["linear", "cpdi1"])
def test_the_mpm_stage_owns_one_granular_plan_used_by_name(shape):
    """Verify a granular MPM stage holds one GranularPlan whose start plan launches only kernels of
    its GranularKernels (the reset of the search and the scan aside), the judge and the check where
    the domains do not deform (cpdi1's do: it rebuilds every step), and whose sums leave the stage's
    impulse mark to the stage."""
    m = _granular_stage(shape)
    plan = m.granular
    assert isinstance(plan, GranularPlan) and m.interaction is plan.interaction
    named = {k for k in vars(plan.kernels).values() if k is not None}
    started = set(plan_kernels(plan.start))
    assert {plan.kernels.prepare, plan.kernels.place, plan.kernels.link, plan.kernels.label} <= started
    assert len(started - named) <= 4  # (the reset of the search, the scan's levels)
    assert (plan.judge is None) == plan.deforming == (plan.check is None)
    assert any(isinstance(item, IfFlag) for item in plan.start) != plan.deforming
    mark = m.impulse_mark
    out, new_mark = diagnostics.point_diagnostics(m, mark)
    assert m.impulse_mark is mark and new_mark[0] == m.sim_clock.time
    assert out["components"] >= 1.0 and np.isfinite(out["energy_total"])


def test_a_plain_stage_has_no_granular_plan():
    """Verify a stage outside granular mode holds no GranularPlan, says which setting its granular
    inspection needs, and labels every point −1."""
    scene = Scene(domain=((0.0, 0.0), (0.1, 0.1)), cell_size=0.01)
    scene.add_mpm_body(disk(center=(0.05, 0.05), radius=0.02), LinearElastic(1.0e5, 0.3, 1500.0))
    m = MPMSolver(scene.finalize(), SolverConfig(), "cpu")
    assert m.granular is None and (m.components() == -1).all()
    with pytest.raises(Exception, match="granular"):
        m.granular_statistics()
