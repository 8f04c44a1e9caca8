"""Re-sorting of the points that triggers itself as their memory order drifts (mpmdem.sim.auto_sort):
the drift measure, when the automatic re-sorting runs, and that it leaves the results alone."""

import numpy as np
import pytest
from helpers import free_disk_scene

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle
from mpmdem.sim.auto_sort import AutoSort, auto_sort_applies

H = 0.05  # a disk of radius 0.3 m at 2 × 2 points per cell of 0.05 m: about 450 points


def _cells(x: np.ndarray, scene) -> np.ndarray:
    """(cx, cy) of positions (N, 2) [m], computed in numpy (origin shifts by whole cells do not
    change cell differences)."""
    return np.floor((x - np.asarray(scene.domain[0])) / scene.cell_size).astype(np.int64)


def _far_pairs(cells: np.ndarray) -> np.ndarray:
    """For consecutive pairs (p − 1, p): True where the cells are not neighbours (a Δ above 1)."""
    return (np.abs(np.diff(cells, axis=0)) > 1).any(axis=1)


#: the default knobs of the automatic re-sorting
TUNING = m.Tuning()
DRIFT = TUNING.auto_sort_drift


def _sim(scene=None, tuning=None, **config):
    return m.Simulation(scene or free_disk_scene(cell_size=H), m.SolverConfig(precision="f64", **config),
                        device="cpu", tuning=tuning)


def test_drift_is_small_in_cell_order_and_matches_numpy_for_a_random_order():
    """Verify the drift kernel counts exactly the far pairs of numpy, is small in the starting
    (cell) order, and for a random permutation is close to 1 − the neighbour fraction of two
    points drawn at random (computed over all pairs in numpy, not from the kernel)."""
    sim = _sim()
    scene = sim.scene
    n = sim.particle_count
    assert 300 < n < 1000
    sorted_drift = sim.mpm.order_drift()
    cells = _cells(sim.mpm.P.x.numpy(), scene)
    assert sorted_drift == pytest.approx(_far_pairs(cells).sum() / (n - 1), abs=0)
    # cell order: only the pairs that step from one cell column to the next are far
    columns = len(np.unique(cells[:, 0]))
    assert sorted_drift <= (columns - 1) / (n - 1) + 1e-12
    assert sorted_drift < 0.1

    sim.mpm.shuffle_points(seed=3)
    drift = sim.mpm.order_drift()
    cells = _cells(sim.mpm.P.x.numpy(), scene)
    assert drift == pytest.approx(_far_pairs(cells).sum() / (n - 1), abs=0)
    # expectation for a uniformly random order: 1 − P(two distinct points are in neighbouring cells)
    d = np.abs(cells[:, None, :] - cells[None, :, :]).max(axis=2) <= 1
    neighbour_fraction = (d.sum() - n) / (n * (n - 1))
    expected = 1.0 - neighbour_fraction
    assert 0.6 < expected < 0.95  # a small scene: a random order is far from cell order, but not 1
    # a sum of n − 1 nearly independent Bernoulli(expected) terms: sd ≈ sqrt(e (1 − e) / n) ≈ 0.015
    assert drift == pytest.approx(expected, abs=0.06)
    assert drift > DRIFT


def test_auto_sort_re_sorts_a_shuffled_scene_and_keeps_its_points():
    """Verify that with the automatic re-sorting forced on (the CPU and a small scene allowed
    through the private ``_auto_sort``), a shuffled scene is re-sorted during ``run`` and its
    outputs, in scene order, are those of the unsorted run up to f64 round-off."""
    def run(auto: bool):
        scene = free_disk_scene(cell_size=H, angular_velocity=5.0, gravity=(0.0, -9.81))
        sim = _sim(scene)
        assert sim._auto_sort is None  # the CPU: off by default
        sim.mpm.shuffle_points(seed=1)
        if auto:
            sim._auto_sort = AutoSort(sim.mpm, DRIFT, check_steps=5)
        result = sim.run(0.05, frames=2)
        return sim, result

    plain, _ = run(False)
    auto, result = run(True)
    assert result.status == "completed" and result.steps >= 10
    assert auto._auto_sort.sorts >= 1
    assert auto.mpm.order_drift() < DRIFT
    assert plain.mpm.order_drift() > DRIFT  # nothing re-sorted the plain run
    pid = auto.mpm.P.pid.numpy()
    assert sorted(pid.tolist()) == list(range(auto.particle_count))
    a, b = plain.fields(), auto.fields()
    np.testing.assert_array_equal(b["mass"], a["mass"])
    np.testing.assert_array_equal(b["body"], a["body"])
    # only the summation order of the P2G atomics changed: f64 round-off
    for name in ("x", "v", "stress", "F"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-9, atol=1e-12 * (np.abs(a[name]).max() + 1e-300))


def test_auto_sort_checks_at_most_every_check_steps():
    """Verify a check is skipped until ``check_steps`` steps passed since the last one, and that
    an order below the threshold is left alone."""
    sim = _sim()
    sorter = AutoSort(sim.mpm, DRIFT, check_steps=100)
    assert not sorter.after_batch(0)  # starting (cell) order: checked, below the threshold
    first = sorter.drift
    assert first is not None and first < sorter.threshold
    sim.mpm.shuffle_points(seed=2)
    assert not sorter.after_batch(99)  # too soon: not checked
    assert sorter.drift == first
    assert sorter.after_batch(100)  # checked, drifted: re-sorted
    assert sorter.sorts == 1 and sim.mpm.order_drift() < sorter.threshold


def test_auto_sort_applies_only_on_cuda_to_large_uncoupled_scenes():
    """Verify the rule: automatic only for sort_interval None, on CUDA, at ``auto_sort_min_points``
    points or more, without rigid bodies; and that a CPU run stays off even for a tiny minimum."""
    big = TUNING.auto_sort_min_points
    auto = m.SolverConfig()
    assert auto_sort_applies(auto, TUNING, cuda=True, points=big, coupled=False)
    assert not auto_sort_applies(auto, TUNING, cuda=True, points=big - 1, coupled=False)
    assert not auto_sort_applies(auto, TUNING, cuda=False, points=big, coupled=False)
    assert not auto_sort_applies(auto, TUNING, cuda=True, points=big, coupled=True)
    assert not auto_sort_applies(m.SolverConfig(sort_interval=0), TUNING, cuda=True, points=big, coupled=False)
    assert not auto_sort_applies(m.SolverConfig(sort_interval=50), TUNING, cuda=True, points=big, coupled=False)
    assert _sim(tuning=m.Tuning(auto_sort_min_points=1))._auto_sort is None  # CPU


def test_coupled_scene_runs_with_the_default_and_never_auto_sorts():
    """Verify a scene of points and rigid bodies builds and runs with sort_interval None (no error,
    the automatic re-sorting silently off), while an explicit interval is still refused."""
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e6))
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.5, 0.45), radius=0.1), mat)
    scene.add_rigid_body(rounded_rectangle(0.8, 0.1, 0.01), density=1000.0, position=(0.5, 0.2), motion="fixed")
    sim = m.Simulation(scene, m.SolverConfig(), device="cpu", tuning=m.Tuning(auto_sort_min_points=1))
    assert sim._auto_sort is None
    assert not auto_sort_applies(sim.config, sim.tuning, cuda=True, points=sim.particle_count, coupled=True)
    pid = sim.mpm.P.pid.numpy().copy()
    sim.advance_to(2.0e-4)
    np.testing.assert_array_equal(sim.mpm.P.pid.numpy(), pid)  # memory order untouched
    with pytest.raises(m.InputError, match="sort_interval"):
        m.Simulation(scene, m.SolverConfig(sort_interval=10), device="cpu")


def test_sort_interval_zero_never_sorts_and_n_sorts_every_n_steps():
    """Verify sort_interval=0 never re-sorts (a shuffled order stays shuffled through advance and
    advance_to) and N > 0 still re-sorts in ``advance`` every N steps."""
    never = _sim(sort_interval=0)
    assert never._auto_sort is None and never.sort_interval == 0
    never.mpm.shuffle_points(seed=4)
    pid = never.mpm.P.pid.numpy().copy()
    never.advance(10)
    never.advance_to(0.01)
    np.testing.assert_array_equal(never.mpm.P.pid.numpy(), pid)

    every = _sim(sort_interval=3)
    every.mpm.shuffle_points(seed=4)
    every.advance(2)
    assert every.mpm.order_drift() > DRIFT  # not yet
    every.advance(1)
    assert every.mpm.order_drift() < 0.1  # the third step re-sorted


def test_sort_interval_is_validated():
    """Verify sort_interval takes None, 0 or a positive integer, and names the choices otherwise."""
    assert m.SolverConfig().sort_interval is None
    for bad in (-1, 2.5, "10"):
        with pytest.raises(m.InputError, match="automatic"):
            m.SolverConfig(sort_interval=bad)
