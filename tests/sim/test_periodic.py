"""Periodic x boundary of the MPM grid (``boundaries={"left": "periodic", "right": "periodic"}``,
``kernels/periodic.py``), on the CPU in f64.

References (no number of ours):
* a rigidly translating block is an exact solution of every MPM transfer (the shape functions are a
  partition of unity), so crossing the seam must leave it translating at its velocity, positions
  wrapped by the period, to round-off;
* a periodic scene is translation invariant: a collision of two blocks across the seam is the same
  collision shifted by half a period into the interior, to round-off;
* with no wall and no gravity the total mass and momentum are conserved to round-off;
* a layer at rest on a no-slip floor under gravity is uniform in x: every column of points carries
  the same stress (the floor's wall images meet the periodic ghost columns at the corners).
"""

import numpy as np
import pytest

from mpmdem import LinearElastic, Scene, Simulation, SolverConfig, rectangle
from mpmdem.errors import InputError

H = 0.01  # m
L = 0.08  # m: the period, 8 cells
PERIODIC = {"left": "periodic", "right": "periodic", "bottom": "free", "top": "free"}
STEEL_ISH = LinearElastic(1.0e5, 0.3, 1000.0)


def wrapped(dx: np.ndarray) -> np.ndarray:
    """x displacements [m] taken into [−L/2, L/2)."""
    return (dx + 0.5 * L) % L - 0.5 * L


def config(**kw) -> SolverConfig:
    return SolverConfig(**{"shape": "bspline2", "transfer": "APIC", "precision": "f64", **kw})


@pytest.mark.parametrize("update, transfer", [("USL", "APIC"), ("MUSL", "FLIP"), ("USF", "PIC")])
def test_block_crosses_the_seam_unchanged(update, transfer, device):
    """Verify a translating block keeps its velocity and shape while it crosses x1 ≡ x0."""
    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, boundaries=PERIODIC)
    scene.add_mpm_body(rectangle(0.05, 0.02, 0.075, 0.04), STEEL_ISH, velocity=(0.5, 0.0), points_per_cell=2)
    sim = Simulation(scene, config(update=update, transfer=transfer), device=device)
    x0, d0 = sim.fields()["x"], sim.diagnostics()
    sim.advance_to(0.1)  # 5 cm: from [5, 7.5] cm to [10, 12.5] ≡ [2, 4.5] cm
    f, d = sim.fields(), sim.diagnostics()
    assert f["x"][:, 0].min() >= 0.0 and f["x"][:, 0].max() < L
    np.testing.assert_allclose(wrapped(f["x"][:, 0] - x0[:, 0]), 0.05 - L, atol=1e-12)
    np.testing.assert_allclose(f["x"][:, 1], x0[:, 1], atol=1e-12)
    np.testing.assert_allclose(f["v"], np.tile([0.5, 0.0], (len(f["v"]), 1)), atol=1e-12)
    assert d["mass"] == pytest.approx(d0["mass"], rel=1e-14)
    assert d["momentum_x"] == pytest.approx(d0["momentum_x"], rel=1e-12)


def collision(shift: float) -> dict:
    """Two blocks meeting head on at x = shift (mod L) at 1 m/s closing speed; fields at 20 ms."""
    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, boundaries=PERIODIC)
    for x_lo, v in ((-0.025, 0.5), (0.0, -0.5)):
        lo = (x_lo + 0.0025 + shift) % L  # (a hair apart, on the seeding lattice)
        scene.add_mpm_body(rectangle(lo, 0.02, lo + 0.0225, 0.04), STEEL_ISH, velocity=(v, 0.0), points_per_cell=2)
    sim = Simulation(scene, config(), device="cpu")
    d0 = sim.diagnostics()
    sim.advance_to(0.02)
    return {"fields": sim.fields(), "d0": d0, "d": sim.diagnostics()}


def test_collision_across_the_seam_is_translation_invariant():
    """Verify a collision at the seam equals the same collision half a period inside, momentum kept."""
    seam, inside = collision(0.0), collision(0.5 * L)
    moved = wrapped(seam["fields"]["x"][:, 0] + 0.5 * L - inside["fields"]["x"][:, 0])
    np.testing.assert_allclose(moved, 0.0, atol=1e-9 * L)
    np.testing.assert_allclose(seam["fields"]["v"], inside["fields"]["v"], atol=1e-9)
    np.testing.assert_allclose(seam["fields"]["stress"], inside["fields"]["stress"], atol=1e-9 * 1.0e5, rtol=1e-9)
    # the blocks met: the stress wave ran through them (else the comparison would be trivial)
    assert np.abs(seam["fields"]["stress"]).max() > 1.0e3
    for run in (seam, inside):
        assert run["d"]["mass"] == pytest.approx(run["d0"]["mass"], rel=1e-14)
        assert abs(run["d"]["momentum_x"] - run["d0"]["momentum_x"]) < 1e-12 * 0.5 * run["d0"]["mass"]
        assert abs(run["d"]["momentum_y"]) < 1e-12 * 0.5 * run["d0"]["mass"]


def test_layer_on_a_floor_is_uniform_in_x():
    """Verify a periodic layer settling on a no-slip floor has the same stress in every column."""
    scene = Scene(domain=((0.0, 0.0), (L, 0.05)), cell_size=H, gravity=(0.0, -9.81),
                  boundaries={**PERIODIC, "bottom": "fixed"})
    scene.add_mpm_body(rectangle(0.0, 0.0, L, 0.03), STEEL_ISH, points_per_cell=2)
    sim = Simulation(scene, config(), device="cpu")
    sim.advance_to(0.02)
    f = sim.fields()
    syy = f["stress"][:, 1, 1]
    rows = np.round(f["x"][:, 1] / (0.25 * H)).astype(int)
    assert np.abs(syy).max() > 10.0  # (it is loaded: ρ g H ≈ 300 Pa at the floor)
    for r in np.unique(rows):
        s = syy[rows == r]
        assert np.ptp(s) < 1e-9 * np.abs(syy).max(), r
    assert np.ptp(f["v"][:, 0]) < 1e-12


@pytest.mark.parametrize("boundaries, parameter", [
    ({"left": "periodic", "right": "slip"}, "boundaries['right']"),
    ({"left": "free", "right": "periodic"}, "boundaries['left']"),
    ({**PERIODIC, "top": "periodic"}, "boundaries['top']"),
])
def test_periodic_sides_come_in_pairs(boundaries, parameter):
    with pytest.raises(InputError, match=parameter.replace("[", r"\[")):
        Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, boundaries=boundaries)


def test_period_is_whole_cells():
    with pytest.raises(InputError, match="domain"):
        Scene(domain=((0.0, 0.0), (L + 0.3 * H, 0.06)), cell_size=H, boundaries=PERIODIC)


def periodic_layer() -> Scene:
    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, boundaries=PERIODIC)
    scene.add_mpm_body(rectangle(0.0, 0.0, L, 0.02), STEEL_ISH)
    return scene


def test_periodic_scene_rejects_rigid_bodies_obstacles_and_granular_mode():
    """Verify what knows no periodic image is an InputError before any kernel runs."""
    from mpmdem import sphero_disk

    scene = periodic_layer()
    scene.add_rigid_body(sphero_disk(0.005), density=1000.0, position=(0.04, 0.04))
    with pytest.raises(InputError, match="rigid bodies"):
        Simulation(scene, config(), device="cpu")
    scene = periodic_layer()
    scene.add_obstacle(rectangle(0.0, 0.03, 0.02, 0.04))
    with pytest.raises(InputError, match="obstacles"):
        Simulation(scene, config(), device="cpu")
    with pytest.raises(InputError, match="granular"):
        Simulation(periodic_layer(), config(granular=True), device="cpu")


def test_block_falling_along_x_keeps_the_energy_balance():
    """Verify the potential energy a point brings across the seam is booked as work_inflow."""
    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, gravity=(9.81, 0.0), boundaries=PERIODIC)
    scene.add_mpm_body(rectangle(0.05, 0.02, 0.075, 0.04), STEEL_ISH, points_per_cell=2)
    sim = Simulation(scene, config(), device="cpu")
    x0, d0 = sim.fields()["x"], sim.diagnostics()
    sim.advance_to(0.2)  # a uniform fall by g t²/2 = 0.196 m: more than two periods
    f, d = sim.fields(), sim.diagnostics()
    # a uniformly accelerated block is exact in space (no strain): v = g t, every point moved alike,
    # by g t²/2 wrapped up to the time integration's lag g t dt / 2 (dt ≤ 0.4 h / c, the CFL step)
    np.testing.assert_allclose(f["v"][:, 0], 9.81 * 0.2, rtol=1e-12)
    moved = wrapped(f["x"][:, 0] - x0[:, 0] - 0.5 * 9.81 * 0.2**2)
    assert np.ptp(moved) < 1e-12
    assert abs(moved[0]) <= 0.5 * 9.81 * 0.2 * 0.4 * H / STEEL_ISH.wave_speed
    # the wrapped potential energy gives back m g L per period crossed, which work_inflow books: what
    # is left is the time integration's own error, m g² t dt / 2 for the lag above (without the
    # booking it would be 2 m g L = 0.8 J)
    gained = d["energy_total"] - d0["energy_total"] - (d["work_inflow"] - d0["work_inflow"])
    assert abs(gained) <= 0.5 * d0["mass"] * 9.81**2 * 0.2 * 0.4 * H / STEEL_ISH.wave_speed
    assert d["work_inflow"] - d0["work_inflow"] > 2.0 * d0["mass"] * 9.81 * L  # (it crossed twice)


def sliding_block(x_lo: float, **kw) -> dict:
    """A block sliding at 0.5 m/s on a no-slip floor under gravity, from x_lo [m]; fields at 50 ms."""
    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H, gravity=(0.0, -9.81),
                  boundaries={**PERIODIC, "bottom": "fixed"})
    scene.add_mpm_body(rectangle(x_lo, 0.0, x_lo + 0.025, 0.02), STEEL_ISH, velocity=(0.5, 0.0), points_per_cell=2)
    sim = Simulation(scene, config(**kw), device="cpu")
    sim.advance_to(0.05)
    return sim.fields()


@pytest.mark.parametrize("shape, update, transfer", [("bspline3", "USAVG", "APIC"), ("cpdi1", "USL", "TPIC"),
                                                     ("bspline2", "USL", "XPIC")])
def test_block_braked_by_a_floor_across_the_seam_is_translation_invariant(shape, update, transfer):
    """Verify the widest stencils, CPDI and XPIC see the same floor and seam as the interior."""
    seam = sliding_block(0.05, shape=shape, update=update, transfer=transfer)  # crosses x1 ≡ x0
    inside = sliding_block(0.01, shape=shape, update=update, transfer=transfer)  # 4 cells left: stays inside
    np.testing.assert_allclose(wrapped(seam["x"][:, 0] - 0.04 - inside["x"][:, 0]), 0.0, atol=1e-12)
    np.testing.assert_allclose(seam["v"], inside["v"], atol=1e-12)
    assert np.abs(seam["v"][:, 0] - 0.5).max() > 1e-3  # (the floor did brake it)


@pytest.mark.parametrize("update, transfer", [("USL", "APIC"), ("MUSL", "XPIC")])
def test_periodic_step_with_moving_walls_compiles_for_sm90(update, transfer, tmp_path):
    """Verify the CUDA code of a periodic step with moving walls compiles (NVRTC, no GPU needed)."""
    import warp as wp

    from mpmdem.model.boundaries import Boundary

    scene = Scene(domain=((0.0, 0.0), (L, 0.06)), cell_size=H,
                  boundaries={**PERIODIC, "bottom": Boundary("fixed", velocity=-0.1),
                              "top": Boundary("fixed", velocity=0.1)})
    scene.add_mpm_body(rectangle(0.0, 0.0, L, 0.06), STEEL_ISH)
    mpm = Simulation(scene, SolverConfig(update=update, transfer=transfer), device="cpu").mpm
    kernels = mpm.step_kernels()
    names = {k.key for k in kernels}
    assert any("periodic_fold" in n for n in names) and any("periodic_copy" in n for n in names)
    for k in kernels:
        paths = wp.compile_aot_module(k.module, arch=90, module_dir=str(tmp_path))
        assert paths and all(p.exists() for p in paths), k.key
