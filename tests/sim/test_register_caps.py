"""The granular grid update's batch of copies (``Tuning.grid_update_copies``) and the register caps
of it and of G2P (``Tuning.grid_update_registers``, ``Tuning.g2p_registers``) choose how the kernels
run, not what they compute.

A dispersed cloud of single-point components puts up to thirteen copies on a node, so the batches
of four and two go round more than once and end part-full. Each thread updates its copies in the
same order with the same operations whatever the batch, so on a CPU every run gives the same bits.
On CUDA (deterministic mode) the compiler may contract a multiply and an add differently under
another register cap or batch: the runs agree to a few f32 roundings a step (rtol 1e-5 over 30 steps).
"""

import numpy as np
import pytest
import warp as wp

import mpmdem as M
from mpmdem.kernels import grid as grid_kernels
from mpmdem.kernels import transfer

H = 0.01  # m, cell size
SPACING = 0.65  # cells between the cloud's points (their domains, half a cell wide, stay apart)
END = 0.0015  # s: 30 steps of 50 µs


def _cloud(seed: int = 3) -> M.Scene:
    """A 12 × 12 cloud of separate points with random velocities of about 1 m/s in a slip box."""
    rng = np.random.default_rng(seed)
    side = 12
    jj, ii = np.meshgrid(np.arange(side), np.arange(side))
    x = np.column_stack([jj.ravel(), ii.ravel()]) * SPACING * H + 0.1
    x += rng.uniform(-0.05 * H, 0.05 * H, x.shape)
    speed = rng.uniform(0.5, 1.5, len(x))
    angle = rng.uniform(0.0, 2.0 * np.pi, len(x))
    scene = M.Scene(domain=((0.0, 0.0), (0.3, 0.3)), cell_size=H, gravity=(0.0, -9.81),
                    boundaries={s: "slip" for s in ("left", "right", "bottom", "top")})
    mat = M.MohrCoulomb(1.0e7, 0.3, 2250.0, 30.0, 0.0, critical_density=2235.0)
    scene.add_points(x, mat, size=0.5 * H, velocity=np.column_stack([speed * np.cos(angle), speed * np.sin(angle)]))
    return scene


def _run(tuning: M.Tuning, device: str = "cpu") -> tuple[dict, int]:
    """The points' state at END, and the deepest node's copy count at the last step."""
    config = M.SolverConfig(granular=True, shape="linear", transfer="PIC", update="USL", deterministic=True)
    sim = M.Simulation(_cloud(), config, device=device, tuning=tuning)
    assert sim.advance_to(END)[1] >= 20
    P = sim.mpm.P
    state = {name: getattr(P, name).numpy().copy() for name in ("x", "v", "F", "stress", "vol")}
    return state, int(sim.mpm.G.depth.numpy().max())


def _same(state: dict, reference: dict, device: str, what: str) -> None:
    for name, value in reference.items():
        if device == "cpu":
            np.testing.assert_array_equal(state[name], value, err_msg=f"{name} {what}")
        else:
            np.testing.assert_allclose(state[name], value, rtol=1e-5, atol=1e-9, err_msg=f"{name} {what}")


@pytest.mark.parametrize("copies", [1, 2])
def test_copies_in_flight_give_the_same_state(device, copies):
    reference, depth = _run(M.Tuning(), device)
    assert depth > 4, "the cloud must put more than one batch of four copies on a node"
    state, _ = _run(M.Tuning(grid_update_copies=copies), device)
    _same(state, reference, device, f"with {copies} copies at a time")


@pytest.mark.cuda
@pytest.mark.skipif(not wp.get_cuda_device_count(), reason="a register cap is a CUDA matter: no CUDA device here")
def test_the_register_cap_changes_no_result():
    device = "cuda"
    reference, _ = _run(M.Tuning(), device)
    state, _ = _run(M.Tuning(grid_update_registers=None, grid_update_copies=2), device)
    _same(state, reference, device, "uncapped, two copies at a time")


@pytest.mark.cuda
@pytest.mark.skipif(not wp.get_cuda_device_count(), reason="a register cap is a CUDA matter: no CUDA device here")
def test_a_g2p_register_cap_changes_no_result():
    device = "cuda"
    reference, _ = _run(M.Tuning(g2p_registers=None), device)
    state, _ = _run(M.Tuning(g2p_registers=64, g2p_registers_points=0), device)
    _same(state, reference, device, "G2P capped at 64 registers")


def test_g2p_is_capped_from_its_size_on():
    """The cap pays in large scenes and costs small ones: it applies from ``g2p_registers_points`` on."""
    config = M.SolverConfig(granular=True, shape="linear", transfer="PIC", update="USL")
    n = 12 * 12  # the cloud's points
    caps = {points: M.Simulation(_cloud(), config, device="cpu",
                                 tuning=M.Tuning(g2p_registers_points=points)).mpm.g2p_registers
            for points in (n, n + 1)}
    assert caps == {n: 64, n + 1: None}
    assert M.Simulation(_cloud(), config, device="cpu").mpm.g2p_registers is None  # (the default: 524288 points)


@pytest.mark.parametrize("copies", [0, 3, 8])
def test_copies_outside_one_two_four_is_an_input_error(copies):
    with pytest.raises(M.InputError, match="grid_update_copies"):
        M.Tuning(grid_update_copies=copies)


def test_each_batch_compiles_for_sm90(tmp_path):
    """Every batch size, capped and not, in CUDA code (NVRTC, no GPU needed)."""
    done = 0
    for copies in (1, 2, 4):
        for registers in (48, None):  # (the default cap, and none)
            k = grid_kernels.make_grid_update("f32", velocity=False, force=False, fused_impulse=True, layered=True,
                                              clear=True, copies=copies, max_registers=registers)
            paths = wp.compile_aot_module(k.module, arch=90, module_dir=str(tmp_path))
            assert paths and all(p.exists() for p in paths)
            done += 1
    assert done == 6


def test_a_capped_g2p_compiles_for_sm90(tmp_path):
    """G2P capped (plain and granular, with a plastic law), in CUDA code."""
    for layered in (False, True):
        k = transfer.make_g2p("linear", "none", 0.0, "pic", "f32", (2,), velocity=True, position=True, stress="vt",
                              layered=layered, max_registers=64)
        paths = wp.compile_aot_module(k.module, arch=90, module_dir=str(tmp_path))
        assert paths and all(p.exists() for p in paths)
