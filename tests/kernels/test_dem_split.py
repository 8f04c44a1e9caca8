"""The DEM pair search split over candidate vertices (``kernels.dem_split``, large scenes on CUDA).

Three kernels (candidate vertices, their feature tests, the pairs' sums) replace the one-thread-a-
pair search of ``contact_forces``. They must compute what it computes: the touches are added
through the same function in the same order, so on the CPU a pack's trajectory, forces and contact
history are the same bits after many steps, with the records big enough and with every overflow
path taken (pairs past the records, a full candidate list, more touches than a pair's records),
where the pair is searched whole. Reference: the one-kernel search, itself tested against a
brute-force shapely search and the contact laws in tests/sim/test_dem.py.
"""

import numpy as np
import pytest

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, Tuning
from mpmdem.kernels import dem_split
from mpmdem.model.spheropolygons import random_convex_polygon, regular_polygon, rod, rounded_rectangle, sphero_disk

STEPS = 150


def pack(seed: int = 5) -> Scene:
    """36 bodies thrown into a box with walls: polygons of 3-7 vertices, rounded squares (face-on-face
    contacts of 2-4 touches), disks (one vertex) and rods (two): contacts made, held with history,
    and ended."""
    rng = np.random.default_rng(seed)
    scene = Scene(domain=((0.0, 0.0), (1.2, 1.2)), gravity=(0.0, -9.81), contact=ContactLaw(1e5, restitution=0.3))
    scene.add_walls(("left", "right", "bottom"), friction=0.4)
    size = 1.2 / 6
    for i in range(6):
        for j in range(6):
            if (i + j) % 4 == 0:
                shape = rounded_rectangle(0.6 * size, 0.6 * size, 0.05 * size)
            elif (i + 2 * j) % 7 == 1:
                shape = sphero_disk(0.3 * size)
            elif (i + 2 * j) % 7 == 3:
                shape = rod(0.7 * size, 0.1 * size)
            else:
                shape = random_convex_polygon(rng, int(rng.integers(3, 8)), 0.3 * size, radius=0.1 * size)
            scene.add_rigid_body(shape, density=1000.0, position=((i + 0.5) * size, (j + 0.5) * 0.8 * size),
                                 angle=float(rng.uniform(0, 2 * np.pi)), velocity=tuple(rng.normal(0, 0.3, 2)),
                                 friction=0.5)
    return scene


def split_tuning(split: bool, **records) -> Tuning:
    """The split search on every device from one body on (``split``), else never; ``records``: more
    ``Tuning`` fields (its records and threads)."""
    return Tuning(split_search_bodies=1 if split else 10**9, split_search_devices=("cpu", "cuda"), **records)


def run(device, split: bool, **records):
    sim = Simulation(pack(), SolverConfig(precision="f64"), device=device, tuning=split_tuning(split, **records))
    assert (sim.dem.split is not None) == split
    worst = {"touches": 0, "whole": 0}
    sim.stage.set_stop_time(1e30)
    for _ in range(STEPS):
        sim.advance(1)
        if split:
            _, S, _ = sim.dem.split
            worst["touches"] = max(worst["touches"], int(S.touches.numpy().max()))
            worst["whole"] = max(worst["whole"], int(S.whole.numpy().max()))
    C = sim.dem.C
    state = {**sim.body_fields(), "key": C.key.numpy(), "slip": C.slip.numpy(), "energy": C.energy.numpy(),
             "dissipated": C.dissipated.numpy()}
    return state, sim.diagnostics(), worst


@pytest.mark.parametrize("records", [
    {},  # records for every pair and touch
    {"split_cpu_threads": 3},  # candidates taken out of order: touches recorded out of order
    {"split_pairs_per_body": 1, "split_candidates_per_body": 2, "split_hits_per_pair": 1},  # overflows: whole
], ids=["fits", "unordered", "overflows"])
def test_split_search_is_the_one_kernel_search(device, records):
    """Verify the split search gives the one-kernel search's trajectory, forces and history: the same
    bits on the CPU; on a GPU both sum the bodies' forces with atomics in varying order, so they
    agree to round-off grown over the steps (1e-9 m on positions of order 1 m, in f64)."""
    ref, ref_diag, _ = run(device, False)
    got, diag, worst = run(device, True, **records)
    assert (ref["key"] >= 0).sum() > 20  # contacts with history: the comparison means something
    if "split_hits_per_pair" in records:
        assert worst["whole"] == 1 and worst["touches"] > 1  # the overflow paths were taken
    if device == "cpu":
        for name in ("x", "angle", "v", "omega", "force", "torque", "key", "slip", "energy", "dissipated"):
            np.testing.assert_array_equal(got[name], ref[name], err_msg=name)
    else:
        np.testing.assert_allclose(got["x"], ref["x"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(got["omega"], ref["omega"], rtol=0, atol=1e-6)


def test_split_search_only_where_it_applies():
    """Verify the one-kernel search stays for deterministic runs, small scenes and cores of more than
    MAX_VERTICES vertices."""
    split, whole = split_tuning(True), split_tuning(False)
    assert Simulation(pack(), SolverConfig(), device="cpu", tuning=split).dem.split is not None
    assert Simulation(pack(), SolverConfig(deterministic=True), device="cpu", tuning=split).dem.split is None
    assert Simulation(pack(), SolverConfig(), device="cpu", tuning=whole).dem.split is None
    many = pack()  # (one core of MAX_VERTICES + 1 vertices, above the pack)
    many.add_rigid_body(regular_polygon(dem_split.MAX_VERTICES + 1, 0.04, 0.01), density=1000.0, position=(0.6, 1.08))
    assert Simulation(many, SolverConfig(), device="cpu", tuning=split).dem.split is None
