"""DEM bodies and grains in a domain periodic in x (``kernels.dem_period``): the wrap of a centroid
and contacts across the seam, in the disk–disk pass and the general vertex–edge search.

The references are exact or a translation: a body alone moves as x + dt v, wrapped by the period;
a collision is invariant under a shift of both bodies, so one that straddles the seam must give
the velocities of the same collision in the interior, to round-off (the positions differ by
the shift, so their last bits do). f64 on the CPU, two or three bodies, seconds once compiled.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, Tuning, regular_polygon, sphero_disk
from mpmdem.errors import InputError
from mpmdem.model.grains import GrainSet

L = 0.05
PERIODIC = {"left": "periodic", "right": "periodic"}
DT = 1e-5
F64 = SolverConfig(precision="f64", dt=DT)
R = 0.002


def disks(positions, velocities, radius: float = R) -> GrainSet:
    """Disk grains of one radius [m] at ``positions``, each with its own velocity [m/s] (one set each)."""
    pos = np.asarray(positions, float).reshape(-1, 2)
    n = len(pos)
    r = np.full(n, radius)
    return [GrainSet(f"g{k}", "disk", radius, 0.0, 2500.0, 0.5, pos[k:k + 1], np.zeros(1), r[k:k + 1],
                     np.zeros((1, 1, 2)), math.pi * r[k:k + 1] ** 2, 0.5 * math.pi * r[k:k + 1] ** 4, np.zeros(1),
                     tuple(float(v) for v in velocities[k])) for k in range(n)]


def scene() -> Scene:
    return Scene(domain=((0.0, 0.0), (L, 0.02)), gravity=(0.0, 0.0), boundaries=PERIODIC,
                 contact=ContactLaw(1e5, restitution=0.5))


def run(s: Scene, steps: int, disk_pairs: bool = True, device: str = "cpu") -> dict:
    sim = Simulation(s, F64, device=device, tuning=Tuning(disk_pairs=disk_pairs))
    sim.stage.set_stop_time(1e30)
    sim.advance(steps)
    return sim.body_fields()


def test_disk_crossing_the_seam_comes_out_at_x_minus_L():
    """Verify a lone disk crossing the right side keeps its velocity to the bit and comes out at the
    left at x − L: the same floats as x += dt v with one wrap, done here in numpy."""
    s = scene()
    for g in disks([(L - 0.003, 0.01)], [(1.5, 0.25)]):
        s.add_grain_set(g)
    steps = 400  # (6 mm: it crosses at about step 200)
    f = run(s, steps)
    x = np.array([L - 0.003, 0.01])
    for _ in range(steps):
        x = x + DT * np.array([1.5, 0.25])
        if x[0] >= L:
            x[0] -= L
    assert np.array_equal(f["v"][0], [1.5, 0.25])
    assert np.array_equal(f["x"][0], x) and x[0] < 0.01


def test_disk_falling_along_x_keeps_the_energy_balance():
    """Verify the potential energy a disk brings across the seam (gravity along x) is booked as work
    (``work_driven``): total energy less that work stays at its start to the leapfrog's own error,
    m g² t dt / 2 for its half-step lag (without the booking it would be off by m g L per crossing)."""
    s = Scene(domain=((0.0, 0.0), (L, 0.02)), gravity=(9.81, 0.0), boundaries=PERIODIC, contact=ContactLaw(1e5))
    for g in disks([(0.01, 0.01)], [(0.0, 0.0)]):
        s.add_grain_set(g)
    sim = Simulation(s, F64, device="cpu")
    d0 = sim.diagnostics()
    sim.stage.set_stop_time(1e30)
    sim.advance(20000)  # 0.2 s: a fall of 0.196 m, four periods
    d = sim.diagnostics()
    m = d0["mass"]
    gained = d["energy_total"] - d0["energy_total"] - (d["work_driven"] - d0["work_driven"])
    assert abs(gained) <= 0.5 * m * 9.81**2 * 0.2 * DT * 1.01
    assert d["work_driven"] - d0["work_driven"] > 3.0 * m * 9.81 * L


def collision(offset: float, disk_pairs: bool, device: str) -> dict:
    """Two disks meeting obliquely (friction and rolling act), their contact point at x = offset [m]."""
    s = scene()
    at = [((offset - 1.2 * R) % L, 0.0095), ((offset + 1.2 * R) % L, 0.0105)]
    for g in disks(at, [(0.4, 0.0), (-0.4, 0.05)]):
        s.add_grain_set(g)
    return run(s, 300, disk_pairs, device)


@pytest.mark.parametrize("disk_pairs", [True, False])
def test_disk_collision_across_the_seam_is_the_interior_collision(disk_pairs, device):
    """Verify a two-disk collision straddling the seam (the disk–disk pass, and the general search)
    gives the interior collision's velocities and spins to round-off: tolerance 1e-9 of the
    impact speed, far above the ulps of the shifted positions (1e-17 m against overlaps of 1e-5 m)
    and far below the change the impact makes (the velocities turn by O(1))."""
    inside, seam = collision(0.5 * L, disk_pairs, device), collision(0.0, disk_pairs, device)
    assert np.abs(inside["v"] - np.array([[0.4, 0.0], [-0.4, 0.05]])).max() > 0.1  # (they met)
    assert np.abs(inside["omega"]).max() > 1.0
    np.testing.assert_allclose(seam["v"], inside["v"], rtol=0.0, atol=0.4e-9)
    np.testing.assert_allclose(seam["omega"], inside["omega"], rtol=0.0, atol=0.4e-9 / R)


def pentagons(offset: float, device: str) -> dict:
    """Two rounded pentagons meeting corner against face, their contact near x = offset [m]."""
    s = scene()
    shape = regular_polygon(5, 0.003, radius=0.0005)
    s.add_rigid_body(shape, density=2500.0, position=((offset - 0.0036) % L, 0.0095), velocity=(0.3, 0.0),
                     angular_velocity=2.0)
    s.add_rigid_body(shape, density=2500.0, position=((offset + 0.0036) % L, 0.0105), angle=0.3,
                     velocity=(-0.3, 0.02))
    return run(s, 400, device=device)


def test_pentagon_collision_across_the_seam_is_the_interior_collision(device):
    """Verify the vertex–edge path across the seam: the same collision of two pentagons in the interior
    and straddling the seam ends with the same velocities and spins (tolerance as for the disks)."""
    inside, seam = pentagons(0.5 * L, device), pentagons(0.0, device)
    assert np.abs(inside["v"] - np.array([[0.3, 0.0], [-0.3, 0.02]])).max() > 0.05  # (they met)
    np.testing.assert_allclose(seam["v"], inside["v"], rtol=0.0, atol=0.3e-9)
    np.testing.assert_allclose(seam["omega"], inside["omega"], rtol=0.0, atol=0.3e-9 / 0.003)


def landing(x: float) -> dict:
    """A disk dropped at x [m] onto a floor plate spanning the period (a large body, not in the cells)."""
    s = Scene(domain=((0.0, 0.0), (L, 0.02)), gravity=(0.0, -9.81), boundaries=PERIODIC,
              contact=ContactLaw(1e5, restitution=0.5))
    s.add_walls(("bottom",), thickness=0.004)
    for g in disks([(x, 0.004)], [(0.2, 0.0)]):
        s.add_grain_set(g)
    return run(s, 3000)


def test_disk_lands_on_a_floor_across_the_seam_as_inside():
    """Verify the large-body path (a floor plate, listed against the image of a body nearest it): a disk
    sliding across the seam lands and bounces on the floor as the same disk in the interior, to round-off
    (tolerance as for the collisions), and it did land (it moves up after 30 ms)."""
    inside, seam = landing(0.5 * L - 0.005), landing(L - 0.005)  # (on the floor from 20 ms, across at 25)
    disk = -1  # (the floor comes first, grains last)
    assert inside["v"][disk, 1] > 0.0 or abs(inside["x"][disk, 1] - R) < 1e-4, inside["x"]
    np.testing.assert_allclose(seam["v"], inside["v"], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(seam["x"][:, 1], inside["x"][:, 1], rtol=0.0, atol=1e-12)
    assert abs((seam["x"][disk, 0] - inside["x"][disk, 0]) % L - 0.5 * L) < 1e-12


def test_periodic_dem_bad_input():
    """Verify a period under three broad-phase cells, a periodic y and material points beside
    grains are InputErrors naming the parameter, before any kernel runs."""
    s = Scene(domain=((0.0, 0.0), (0.012, 0.02)), gravity=(0.0, -9.81), boundaries=PERIODIC,
              contact=ContactLaw(1e5))
    for g in disks([(0.006, 0.01)], [(0.0, 0.0)]):
        s.add_grain_set(g)
    with pytest.raises(InputError, match="period x1 - x0 of at least 3"):
        Simulation(s, F64, device="cpu")
    with pytest.raises(InputError, match=r"boundaries\['bottom'\]"):
        Scene(domain=((0.0, 0.0), (L, 0.02)), boundaries={"bottom": "periodic", "top": "periodic"})
    from mpmdem import LinearElastic, rectangle

    s = Scene(domain=((0.0, 0.0), (L, 0.02)), cell_size=0.0025, boundaries=PERIODIC, contact=ContactLaw(1e5))
    s.add_mpm_body(rectangle(0.0, 0.0, L, 0.005), LinearElastic(1e6, 0.3, 1000.0))
    s.add_rigid_body(sphero_disk(0.002), density=1000.0, position=(0.02, 0.01))
    with pytest.raises(InputError, match="rigid bodies beside material points"):
        Simulation(s, F64, device="cpu")
