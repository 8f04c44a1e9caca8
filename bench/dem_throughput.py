"""DEM throughput: body-steps and contacts per second for packs of random spheropolygon pentagons.

The pack is the one of the reference probe ../shared/bench/warp_dem2d.py (run it in the same
call with --probe PATH for the ratio): bodies of outer radius 0.5 m (pentagon core 0.4 m ⊕ disk
0.1 m) on a jittered lattice at 0.9 diameters under gravity, floor and side walls, k_n = 1e6,
μ = 0.5, dt = 0.05 sqrt(m/k_n). Ours runs every feature: random convex pentagons (not one shape),
tangential history per vertex–edge contact, Verlet lists rebuilt on the device when needed,
walls as fixed bodies, f32. Each size is settled for --warmup steps (untimed), then timed.

``--pack grains``: sphero-disk grains instead (radius 0.5 m on a hexagonal lattice at contact, resting on
the floor: ``grain_throughput.lattice_pack``; bench/grain_throughput.py compares the disk–disk pass
with the general search and the probe's disks).

Prints one JSON line per size (and per probe run); ``--out FILE`` appends them to FILE.
Usage: python bench/dem_throughput.py --device cuda --sizes 10000,100000,1000000 --probe PATH
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time

import numpy as np
import warp as wp

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, random_convex_polygon

R_OUT = 0.5  # m, outer radius (core circumradius + sphero radius), as the probe
A = 0.1  # m, sphero radius
RHO, KN, MU, G = 1000.0, 1.0e6, 0.5, 9.81
SHAPES = 64  # distinct random pentagons, shared by the bodies (building 1M shapely shapes takes long)


def pack(n: int, seed: int = 0) -> tuple[Scene, float]:
    """The probe's lattice pack of n random pentagons; returns (scene, the probe's dt)."""
    rng = np.random.default_rng(seed)
    side = int(math.ceil(math.sqrt(n)))
    gap = 2.0 * R_OUT * 0.9
    ii, jj = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    pos = np.stack([(ii.ravel() + 0.5) * gap, (jj.ravel() + 0.5) * gap + R_OUT], 1)[:n]
    pos += rng.uniform(-0.02, 0.02, pos.shape)
    width = side * gap
    height = 2.0 * (side * gap + R_OUT)
    # restitution of the probe's dashpot c = 0.3·2 sqrt(k m): ζ = 0.3
    zeta = 0.3
    e = math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta**2))
    scene = Scene(domain=((0.0, 0.0), (width, height)), gravity=(0.0, -G), contact=ContactLaw(KN, restitution=e))
    scene.add_walls(("left", "right", "bottom"), friction=MU, thickness=2.0)
    shapes = [random_convex_polygon(rng, 5, R_OUT - A, radius=A) for _ in range(SHAPES)]
    pick = rng.integers(0, SHAPES, n)
    angles = rng.uniform(0.0, 2.0 * np.pi, n)
    vel = rng.uniform(-0.1, 0.1, (n, 2))
    for k in range(n):
        scene.add_rigid_body(shapes[pick[k]], density=RHO, position=tuple(pos[k]), angle=float(angles[k]),
                             velocity=tuple(vel[k]), friction=MU)
    m = RHO * math.pi * R_OUT**2
    return scene, 0.05 * math.sqrt(m / KN)


def grain_pack(n: int, seed: int = 0) -> tuple[Scene, float]:
    """n sphero-disk grains of radius R_OUT on a hexagonal lattice at contact, resting on the floor
    between side walls (``grain_throughput.lattice_pack``); returns (scene, the probe's dt).

    The loose jittered lattice of ``add_grains`` used before (φ ≈ 0.65, in a box as tall as wide) was
    seen to blow up on a GPU (the cause was not recorded). Under gravity that column falls into its
    gaps, the upper grains landing on the compacted ones at several m/s (overlaps of a quarter radius
    at k_n = 1e6 after 0.5 s); the lattice at contact has no gap to fall into (it still compresses
    under its weight, the rows above the compression wave moving down together)."""
    from grain_throughput import lattice_pack  # (a script beside this one)

    return lattice_pack(n, seed=seed)


def timed_window(sim: Simulation, dt: float, steps: int, warmup: int) -> dict:
    """Capture the step's CUDA graph, take ``warmup`` steps, then time ``steps`` of the DEM stage between
    two device synchronisations: seconds, simulated seconds, steps taken, touching contacts after,
    list rebuilds in the window and the energy residual over the kinetic energy at its start.

    The graph comes first: its capture takes a step of dt = 0 to load the modules and leaves the stop
    time at the clock's (before 2026-11-26 the stop time was set first, so every GPU step after the
    capture had dt = 0: a pack that never moved and never rebuilt its lists)."""
    dem = sim.dem
    sim._capture()
    dem.set_stop_time(1e30)
    sim.advance(warmup)
    wp.synchronize_device(sim.device)
    d0 = sim.diagnostics()
    t0_sim, _, _, steps0, _ = dem.read_clock()
    t0 = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(sim.device)
    seconds = time.perf_counter() - t0
    t, _, bound, steps1, status = dem.read_clock()
    if not t > t0_sim:
        raise RuntimeError(f"the timed steps did not advance the clock (t = {t} s): nothing was simulated")
    d1 = sim.diagnostics()
    dem.check_status(t, dt, bound, status)
    works = sum(d1[k] - d0[k] for k in dem.WORK_TERMS)
    return {"seconds": seconds, "simulated_seconds": t - t0_sim, "steps_taken": steps1 - steps0,
            "contacts": int(np.count_nonzero(dem.C.energy.numpy() > 0.0)),
            "rebuilds": int(d1["list_rebuilds"] - d0["list_rebuilds"]),
            "energy_residual_over_kinetic": (d1["energy_total"] - d0["energy_total"] - works)
            / max(abs(d0["energy_kinetic"]), 1e-30)}


def measure(n: int, steps: int, warmup: int, device: str, grains: bool = False) -> dict:
    t0 = time.perf_counter()
    scene, dt = grain_pack(n) if grains else pack(n)
    n = scene.dem_body_count - len(scene.rigid_bodies) if grains else n
    build_scene = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim = Simulation(scene, SolverConfig(precision="f32", dt=dt), device=device)
    setup = time.perf_counter() - t0
    dem = sim.dem
    w = timed_window(sim, dt, steps, warmup)
    seconds, contacts, rebuilds = w["seconds"], w["contacts"], w["rebuilds"]
    return {
        "case": "disk-grains" if grains else "pentagon-pack", "impl": "mpmdem", "device": sim.device, "bodies": n,
        "steps": steps,
        "seconds": seconds, "body_steps_per_s": n * steps / seconds, "simulated_seconds": w["simulated_seconds"],
        "contacts_per_body": contacts / n, "contacts_per_s": contacts * steps / seconds,
        "listed_pairs_per_body": float(dem.C.count.numpy().sum()) / n,
        "rebuilds": rebuilds, "steps_per_rebuild": steps / max(1, rebuilds),
        "slots": dem.slots, "cuda_graph": sim._graph is not None,
        "energy_residual_over_kinetic": w["energy_residual_over_kinetic"],
        "setup_seconds": setup, "scene_seconds": build_scene, "steps_total": w["steps_taken"] + warmup,
        "warp": wp.__version__,
    }


def run_probe(path: str, n: int, steps: int, device: str) -> dict:
    spec = importlib.util.spec_from_file_location("warp_dem2d", path)
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    return probe.run("pentagon-pre", n, steps, device)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None)
    p.add_argument("--sizes", default="10000,100000,1000000")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--warmup", type=int, default=200)
    p.add_argument("--probe", default=None, help="path of warp_dem2d.py: run its pentagon-pre row at each size")
    p.add_argument("--out", default=None, help="append the JSON lines to this file")
    p.add_argument("--pack", default="pentagons", choices=("pentagons", "grains"),
                   help="random pentagons added one by one (default) or a grain set of sphero-disks")
    args = p.parse_args(argv)
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    lines = []
    for n in (int(s) for s in args.sizes.split(",")):
        row = measure(n, args.steps, args.warmup, device, grains=args.pack == "grains")
        if args.probe:
            ref = run_probe(args.probe, n, args.steps, device)
            ref["case"] = "probe-pentagon-pre"
            lines.append(ref)
            print(json.dumps(ref), flush=True)
            row["probe_body_steps_per_s"] = ref["body_steps_per_s"]
            row["ratio_to_probe"] = row["body_steps_per_s"] / ref["body_steps_per_s"]
        lines.append(row)
        print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "a") as f:
            for row in lines:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
