"""The DEM's Verlet-list rebuild (``kernels.dem_lists``): the tangential history handed over in place.

At a rebuild every body lists its pairs anew, sorted by partner. A pair listed before and after must
keep its history (feature keys and δ_t, MPM-SDEM eq. 43) whatever slot it moves to, a new pair must
start without one, and a slot no longer used must be left clean. ``hand_over`` moves the histories in
place (no copy of the old slots), so the test makes lists in which pairs move both up and down
within one body's slots, and checks every slot against that definition, read on the host from the
lists before and after. f64 on the CPU, 81 disks, seconds once compiled.
"""

from __future__ import annotations

import math

import numpy as np

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, Tuning
from mpmdem.model.grains import GrainSet
from mpmdem.sim.launch_plan import run_plan

R = 0.01  # m, disk radius


def disks(side: int, seed: int) -> Scene:
    """side² disks of radius R on a square lattice of pitch 2.1 R (apart, each within the skin of its
    four neighbours), shuffled in index, in a domain with room around it."""
    k = np.random.default_rng(seed).permutation(side * side)
    pos = 0.2 + 2.1 * R * np.column_stack([k % side, k // side])
    n = len(pos)
    r = np.full(n, R)
    grains = GrainSet("disks", "disk", R, 0.0, 1000.0, 0.5, pos, np.zeros(n), r, np.zeros((n, 1, 2)),
                      0.5 * r * r * (2.0 * math.pi), 0.25 * r**4 * (2.0 * math.pi), np.zeros(n))
    scene = Scene(domain=((0.0, 0.0), (0.5, 0.5)), gravity=(0.0, 0.0), contact=ContactLaw(1e6, restitution=0.5))
    scene.add_grain_set(grains)
    return scene


def lists(dem) -> dict[int, list[int]]:
    """Each body's listed partners, in slot order."""
    K = dem.slots
    nbr = dem.C.nbr.numpy().reshape(-1, K)
    return {i: list(nbr[i, :c]) for i, c in enumerate(dem.C.count.numpy())}


def rebuild(sim) -> None:
    """One list rebuild, nothing else (the flag raised, the rebuild's conditional block run)."""
    dem = sim.dem
    dem.flags.fill_(1)
    run_plan(dem.contact_rebuild, dem.device)
    assert dem.flags.numpy()[0] == 0 and not dem.status.numpy().any()


def tag_move_rebuild_check(sim, rng) -> tuple[int, int, int]:
    """Tag every listed pair's history, move every other disk by up to 3 R, rebuild, and check every
    slot (see the test); returns how many kept pairs moved up and down a slot, and the new pairs."""
    dem = sim.dem
    K = dem.slots
    before = lists(dem)
    # tag every listed slot with its pair: keys (j, i, 7, 7), δ_t (i + j/1000, -j, 0, 0); energy and
    # dissipated work that the rebuild must reset and fold
    key = dem.C.key.numpy().reshape(-1, K, 4)
    slip = dem.C.slip.numpy().reshape(-1, K, 4)
    energy = dem.C.energy.numpy().reshape(-1, K)
    work = dem.C.dissipated.numpy().reshape(-1, K, 2)
    for i, partners in before.items():
        for s, j in enumerate(partners):
            key[i, s] = (j, i, 7, 7)
            slip[i, s] = (i + j / 1000.0, -j, 0.0, 0.0)
            energy[i, s] = 1.0 + j
            work[i, s] = (i + 1.0, 2.0 * j)
    for arr, host in ((dem.C.key, key), (dem.C.slip, slip), (dem.C.energy, energy), (dem.C.dissipated, work)):
        arr.assign(host.reshape(arr.shape + (() if host.ndim == 2 else host.shape[2:])))
    folded0 = dem.C.body_dissipated.numpy().copy()
    # move every other disk by up to 3 radii: pairs come, go and stay
    x = dem.B.x.numpy()
    x[::2] += rng.uniform(-3 * R, 3 * R, x[::2].shape)
    dem.B.x.assign(x)
    rebuild(sim)
    after = lists(dem)

    up = down = new = 0
    key = dem.C.key.numpy().reshape(-1, K, 4)
    slip = dem.C.slip.numpy().reshape(-1, K, 4)
    energy = dem.C.energy.numpy().reshape(-1, K)
    work = dem.C.dissipated.numpy().reshape(-1, K, 2)
    nbr = dem.C.nbr.numpy().reshape(-1, K)
    folded = dem.C.body_dissipated.numpy()
    for i, partners in after.items():
        assert partners == sorted(partners)
        old = before.get(i, [])
        for s, j in enumerate(partners):
            if j in old:
                o = old.index(j)
                up += o > s
                down += o < s
                assert tuple(key[i, s]) == (j, i, 7, 7), (i, s, j)
                assert tuple(slip[i, s]) == (i + j / 1000.0, -j, 0.0, 0.0), (i, s, j)
            else:
                new += 1
                assert tuple(key[i, s]) == (-1, -1, -1, -1) and not slip[i, s].any(), (i, s, j)
        assert not energy[i].any() and not work[i].any()
        assert (nbr[i, len(partners):] == -1).all() and (key[i, len(partners):] == -1).all()
        assert not slip[i, len(partners):].any()
        expected = folded0[i] + sum(((i + 1.0, 2.0 * j) for j in old), start=np.zeros(2))
        assert tuple(folded[i]) == tuple(expected), i
    return up, down, new


def test_rebuild_hands_each_pairs_history_to_its_new_slot():
    """Verify, after each of four rebuilds that move half the disks, that every pair listed before and after
    holds the keys and δ_t it held before (tagged by its two bodies), a new pair holds none, every
    listed pair's energy is 0, the unused slots are clean, and each body's folded dissipated work
    grew by exactly the sum of its old slots' (exact: the sums are of small integers)."""
    sim = Simulation(disks(9, seed=3), SolverConfig(precision="f64"), device="cpu", tuning=Tuning(disk_pairs=True))
    rebuild(sim)
    up = down = new = 0
    rng = np.random.default_rng(4)
    for _ in range(4):
        u, d, n = tag_move_rebuild_check(sim, rng)
        up, down, new = up + u, down + d, new + n
    # the rebuilds exercised every path of the hand-over
    assert up and down and new, (up, down, new)
