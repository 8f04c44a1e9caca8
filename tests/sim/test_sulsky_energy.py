"""Sulsky disks ("MPM notes"): momentum to round-off and the energy behaviour of each transfer."""

import numpy as np
import pytest

from mpmdem import NeoHookean, Scene, Simulation, SolverConfig, disk

MAT = NeoHookean(1000.0, 0.3, 1000.0)  # "MPM notes": E = 1000 Pa, ν = 0.3, ρ = 1000 kg/m³


def asymmetric_disks():
    """Two colliding disks with unequal speeds, so total momentum is not zero by symmetry."""
    # free sides: the disks pass within 1.5 cells of the walls, where a wall would act on them
    # through the grid ("MPM notes": the disks problem needs no boundary condition)
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1.0 / 16,
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    scene.add_mpm_body(disk(center=(0.25, 0.25), radius=0.2), MAT, velocity=(0.1, 0.1))
    scene.add_mpm_body(disk(center=(0.75, 0.75), radius=0.2), MAT, velocity=(-0.05, -0.12))
    return scene


@pytest.fixture(scope="module")
def runs():
    out = {}
    for transfer in ("PIC", "APIC", "FLIP"):
        sim = Simulation(asymmetric_disks(), SolverConfig(transfer=transfer, precision="f64"), device="cpu")
        out[transfer] = sim.run(2.5, frames=10)
    return out


@pytest.mark.parametrize("transfer", ["PIC", "APIC", "FLIP"])
def test_momentum_conserved_through_collision(runs, transfer):
    """Verify Σ m v stays at its initial value through the collision (no wall touched)."""
    d = runs[transfer].diagnostics
    p0 = np.array([d["momentum_x"][0], d["momentum_y"][0]])
    drift = np.hypot(d["momentum_x"] - p0[0], d["momentum_y"] - p0[1]).max()
    # f64 with ~130 steps of ~250 points: round-off is ~1e-15 per operation; 1e-11 relative to
    # the momentum scale Σ m|v| is far below any physical effect and far above round-off.
    scale = d["mass"][0] * 0.1
    assert drift < 1e-11 * scale


def test_energy_ordering_pic_apic_flip(runs):
    """Verify PIC dissipates most and FLIP least; none creates energy (MPM notes, Motion integration §4)."""
    e = {k: r.diagnostics["energy_total"][-1] / r.diagnostics["energy_total"][0] for k, r in runs.items()}
    assert e["PIC"] < e["APIC"] < e["FLIP"]
    # measured with 16 cells: PIC 0.46, APIC 0.70, FLIP 0.87; the collision is elastic, so the
    # losses are numerical, and an explicit step may not create energy: bound FLIP by 1.02.
    assert e["FLIP"] < 1.02
    assert e["PIC"] < 0.8
