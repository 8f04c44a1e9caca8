"""The GPU variants of the kernels compile, even on a machine without a GPU.

Warp ships NVRTC, so the CUDA code of a kernel can be generated and compiled ahead of time for a
given architecture (sm_90, the H100 the benchmarks run on) without a driver. This catches device
code that the CPU path accepts but CUDA does not (atomics, loops with CAS, dynamic shapes) in the
granular and DEM stages while no GPU is at hand; on a machine with a GPU the other tests run the
kernels for real.
"""

import numpy as np
import warp as wp

import mpmdem as M
from mpmdem.kernels import granular as kgran


def _compile(kernels, tmp_path) -> int:
    done = 0
    for k in kernels:
        paths = wp.compile_aot_module(k.module, arch=90, module_dir=str(tmp_path))
        assert paths and all(p.exists() for p in paths), k.key
        done += 1
    return done



def test_granular_step_compiles_for_sm90(tmp_path):
    mat = M.MohrCoulomb(1e6, 0.3, 2000.0, 30.0, critical_density=1990.0)
    scene = M.Scene(domain=((0, 0), (0.3, 0.3)), cell_size=0.02, gravity=(0, -9.81))
    scene.add_obstacle(M.rectangle(-0.1, -0.1, 0.4, 0.02))
    scene.add_points(np.array([[0.1, 0.2], [0.12, 0.2]]), mat, size=0.01, release_time=[0.0, 0.01])
    config = M.SolverConfig(granular=True, shape="cpdi1", transfer="FLIP", update="MUSL", deterministic=True)
    m = M.Simulation(scene, config, device="cpu").mpm
    kernels = m.step_kernels()
    kernels += [m.diagnostics_kernel, kgran.make_granular_statistics(config.precision, m.staged)]
    assert _compile(kernels, tmp_path) >= 10


def test_granular_tent_step_compiles_for_sm90(tmp_path):
    """The tent's own path: the node threads that give out the copies (byte stores into the
    points' slots), the one-copy path and the register cap of the layered grid update."""
    mat = M.MohrCoulomb(1e6, 0.3, 2000.0, 30.0, critical_density=1990.0)
    scene = M.Scene(domain=((0, 0), (0.3, 0.3)), cell_size=0.02, gravity=(0, -9.81))
    scene.add_points(np.array([[0.1, 0.2], [0.12, 0.2]]), mat, size=0.01)
    m = M.Simulation(scene, M.SolverConfig(granular=True, shape="linear"), device="cpu").mpm
    kernels = m.step_kernels()
    assert any(k.key.endswith("assign") for k in kernels)
    assert _compile(kernels, tmp_path) >= 10


def test_tiled_granular_p2g_compiles_for_sm90(tmp_path):
    """The shared-memory P2G in granular mode (``Tuning.tiled_p2g_granular``): tile calls beside the
    copies' claims, for the passes of USL (fused) and MUSL (mass and momentum; force)."""
    from mpmdem.kernels import transfer

    tile = (64, 4, 22)
    kernels = [transfer.make_p2g("bspline2", "apic", "f32", layered=True, tile=tile, tile_layers=layers, **flags)
               for flags in (dict(mass=True, momentum=True, force=True, fused_impulse=True),
                             dict(mass=True, momentum=True, force=False),
                             dict(mass=False, momentum=False, force=True))
               for layers in (1, 4)]  # (``Tuning.tiled_p2g_layers``: the first copy, or four)
    assert _compile(kernels, tmp_path) == 6


def test_dem_step_compiles_for_sm90(tmp_path):
    scene = M.Scene(domain=((0, 0), (1, 1)), gravity=(0, -9.81), contact=M.ContactLaw(1e6, restitution=0.5))
    scene.add_walls(("left", "right", "bottom"), friction=0.5)
    for k in range(4):
        scene.add_rigid_body(M.regular_polygon(5, 0.04, radius=0.01), density=2600.0,
                             position=(0.3 + 0.12 * k, 0.5), friction=0.5)
    dem = M.Simulation(scene, M.SolverConfig(deterministic=True), device="cpu").dem
    kernels = [v for v in vars(dem.k).values() if isinstance(v, wp.Kernel)]
    assert _compile(kernels, tmp_path) >= 5


def test_periodic_dem_step_compiles_for_sm90(tmp_path):
    """The periodic DEM's kernels (``kernels.dem_period``: wrapped cells, minimum-image pairs in the
    disk–disk pass and the vertex–edge search, the wrap of the update) for CUDA."""
    from mpmdem.kernels import dem_disks, dem_lists
    from mpmdem.model.grains import place_grains

    scene = M.Scene(domain=((0, 0), (0.05, 0.05)), gravity=(0, -9.81), contact=M.ContactLaw(1e6, restitution=0.5),
                    boundaries={"left": "periodic", "right": "periodic"})
    scene.add_grain_set(place_grains([(0, 0), (0.05, 0), (0.05, 0.02), (0, 0.02)], radius=0.002, density=2600.0))
    scene.add_rigid_body(M.regular_polygon(5, 0.004, radius=0.001), density=2600.0, position=(0.02, 0.04))
    dem = M.Simulation(scene, M.SolverConfig(), device="cpu").dem
    assert dem.periodic and dem.disk_pairs
    lists = dem_lists.make_dem_lists("f32", False, True, True)
    disks = dem_disks.make_disk_pairs("f32", False, True)
    kernels = [dem.contact_kernel, dem.k.integrate, lists.bin_bodies, lists.build_lists, disks.disk_forces]
    assert _compile(kernels, tmp_path) == 5


def test_coupled_step_compiles_for_sm90(tmp_path):
    """The point–body lists, IMP forces, the grid scheme's scatter and Liu's exchange."""
    from mpmdem.model.spheropolygons import rounded_rectangle

    done = 0
    for scheme in ("imp", "grid", "liu"):
        scene = M.Scene(domain=((0, 0), (0.3, 0.3)), cell_size=0.02, gravity=(0, -9.81),
                        contact=M.ContactLaw(1e6, restitution=0.5))
        scene.add_mpm_body(M.disk(center=(0.15, 0.2), radius=0.04), M.LinearElastic(1e5, 0.3, 1000.0))
        scene.add_rigid_body(rounded_rectangle(0.25, 0.04, 0.005), density=1000.0, position=(0.15, 0.1),
                             motion="fixed")
        sim = M.Simulation(scene, M.SolverConfig(coupling=scheme, transfer="PIC", deterministic=True), device="cpu")
        cp = sim.coupling
        kernels = [v for v in vars(cp.k).values() if isinstance(v, wp.Kernel)]
        kernels += sim.mpm.step_kernels()
        if cp.liu is not None:
            kernels += [v for v in vars(cp.liu[0]).values() if isinstance(v, wp.Kernel)]
        done += _compile(kernels, tmp_path)
    assert done >= 20
