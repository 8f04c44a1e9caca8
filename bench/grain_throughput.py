"""Disk-grain throughput: grain-steps/s of the DEM with the disk–disk pass and with the general search,
beside the reference disk probe (../shared/bench/warp_dem2d.py) run in the same process.

The pack, the probe's as far as our model allows: n sphero-disks of radius R = 0.5 m (0 % polydispersity
by default) on a hexagonal lattice of pitch 2R (1 + 1e-4) — apart, none overlapping — with the bottom
row on the floor and side walls (fixed bodies), under gravity, each grain given a random velocity
of up to 0.1 m/s a component (the probe's jitter); k_n = 1e6 N/m per m, the probe's dashpot ratio
ζ = 0.3, μ = 0.5, ρ = 1000 kg/m³, dt = 0.05 sqrt(m/k_n) (the probe's). The lattice has no gap to fall
into, but at this k_n a column of rows is soft under its own weight: the rows above the compression
wave (c ≈ 2R sqrt(k_n/m) ≈ 36 m/s) move down together, and the lists are rebuilt every few steps
(``steps_per_rebuild``; the probe rebuilds its grid every 10). f32, one step recorded as a CUDA
graph. Each size and path is settled for --warmup steps (untimed), then timed.

``--polydispersity p``: radii R (1 − p u), u uniform in [0, 1), on the same lattice (gaps the grains
settle into). Ours runs every feature the probe leaves out: tangential history per pair, Verlet
lists rebuilt on the device when needed, walls as bodies, energy and dissipation booked.

Prints one JSON line per size and path (``path``: "disk-pass" or "general", ``mpmdem.Tuning.disk_pairs``)
and per probe run; ``--out FILE`` appends them to FILE.
Usage: python bench/grain_throughput.py --sizes 10000,100000,1000000 --probe ../shared/bench/warp_dem2d.py
"""

from __future__ import annotations

import argparse
import ast
import gc
import importlib.util
import json
import math
import sys
import time

import numpy as np
import warp as wp
from dem_throughput import timed_window  # (a script beside this one)

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, Tuning
from mpmdem.model.grains import GrainSet

R = 0.5  # m, grain radius (the probe's)
RHO, KN, MU, G, ZETA, JITTER = 1000.0, 1.0e6, 0.5, 9.81, 0.3, 0.1
GAP = 1.0e-4  # lattice pitch 2R (1 + GAP): apart, not overlapping


def lattice_pack(n: int, polydispersity: float = 0.0, seed: int = 0) -> tuple[Scene, float]:
    """n disk grains on a hexagonal lattice resting on the floor of a box about as tall as wide (see
    the module docstring); returns (scene, the probe's dt [s])."""
    rng = np.random.default_rng(seed)
    pitch = 2.0 * R * (1.0 + GAP)
    row = pitch * math.sqrt(3.0) / 2.0
    cols = max(1, int(math.ceil(math.sqrt(n * row / pitch))))
    k = np.arange(n)
    r_idx, c_idx = k // cols, k % cols
    pos = np.column_stack([0.5 * pitch + pitch * c_idx + 0.5 * pitch * (r_idx % 2), 0.5 * pitch + row * r_idx])
    width = pitch * (cols + 0.5)
    height = 1.5 * (pos[:, 1].max() + pitch)
    radius = R * (1.0 - polydispersity * rng.uniform(0.0, 1.0, n))
    e = math.exp(-ZETA * math.pi / math.sqrt(1.0 - ZETA**2))  # the probe's dashpot 0.3 · 2 sqrt(k m)
    scene = Scene(domain=((0.0, 0.0), (width, height)), gravity=(0.0, -G), contact=ContactLaw(KN, restitution=e))
    scene.add_walls(("left", "right", "bottom"), friction=MU, thickness=2.0)
    two_pi = 2.0 * math.pi
    scene.add_grain_set(GrainSet("lattice", "disk", R, polydispersity, RHO, MU, pos, np.zeros(n), radius,
                                 np.zeros((n, 1, 2)), 0.5 * radius * radius * two_pi, 0.25 * radius**4 * two_pi,
                                 np.zeros(n)))
    return scene, 0.05 * math.sqrt(RHO * math.pi * R * R / KN)


def measure(scene: Scene, dt: float, n: int, disk_pass: bool, steps: int, warmup: int, device: str,
            seed: int = 0, kernel_steps: int = 0, tune: dict | None = None) -> dict:
    """Grain-steps/s of ``scene`` with the disk–disk pass on or off (see the module docstring);
    ``tune``: other ``Tuning`` fields."""
    t0 = time.perf_counter()
    sim = Simulation(scene, SolverConfig(precision="f32", dt=dt), device=device,
                     tuning=Tuning(disk_pairs=disk_pass, **(tune or {})))
    setup = time.perf_counter() - t0
    dem = sim.dem
    if dem.disk_pairs != disk_pass:
        raise RuntimeError(f"the disk–disk pass is {'off' if disk_pass else 'on'}: expected {disk_pass}")
    free = int(np.count_nonzero(dem.motion == 0))
    v = dem.B.v.numpy()
    v[:free] = np.random.default_rng(seed).uniform(-JITTER, JITTER, (free, 2))  # (free bodies first)
    dem.B.v.assign(v)
    w = timed_window(sim, dt, steps, warmup)
    seconds, contacts, rebuilds = w["seconds"], w["contacts"], w["rebuilds"]
    row = {
        "case": "disk-grains", "impl": "mpmdem", "path": "disk-pass" if disk_pass else "general",
        "device": str(sim.device), "grains": n, "steps": steps, "seconds": seconds,
        "grain_steps_per_s": n * steps / seconds, "us_per_step": 1e6 * seconds / steps,
        "simulated_seconds": w["simulated_seconds"], "contacts_per_grain": contacts / n,
        "listed_pairs_per_grain": float(dem.C.count.numpy().sum()) / n, "rebuilds": rebuilds,
        "steps_per_rebuild": steps / max(1, rebuilds), "slots": dem.slots, "cuda_graph": sim._graph is not None,
        "split_search": dem.split is not None, "energy_residual_over_kinetic": w["energy_residual_over_kinetic"],
        "setup_seconds": setup, "steps_total": w["steps_taken"] + warmup, "warp": wp.__version__,
        "tune": tune or {},
    }
    if kernel_steps:  # (µs per step of each kernel, launched one by one under Warp's activity timing)
        from collections import defaultdict

        wp.synchronize_device(device)
        wp.timing_begin(cuda_filter=wp.TIMING_KERNEL | wp.TIMING_MEMSET | wp.TIMING_MEMCPY)
        for _ in range(kernel_steps):
            sim.stage.step()
        per = defaultdict(lambda: [0, 0.0])
        for r in wp.timing_end():
            per[r.name][0] += 1
            per[r.name][1] += 1e3 * r.elapsed / kernel_steps
        row["kernels"] = sorted(([k.replace("forward kernel ", ""), n_ / kernel_steps, round(us, 2)]
                                 for k, (n_, us) in per.items()), key=lambda x: -x[2])
    del sim, dem
    gc.collect()
    return row


def run_probe(path: str, n: int, steps: int, device: str) -> dict:
    """The probe's disk row at n bodies (its own pack, hash grid and driver)."""
    spec = importlib.util.spec_from_file_location("warp_dem2d", path)
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    row = probe.run("disk", n, steps, device)
    row["case"] = "probe-disk"
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None)
    p.add_argument("--sizes", default="10000,100000,1000000")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--warmup", type=int, default=200)
    p.add_argument("--paths", default="disk-pass,general", help="disk-pass, general, or both (comma-separated)")
    p.add_argument("--polydispersity", type=float, default=0.0, help="radii R (1 - p u), u in [0, 1)")
    p.add_argument("--probe", default=None, help="path of warp_dem2d.py: its disk row at each size, same process")
    p.add_argument("--kernels", type=int, default=0, metavar="STEPS",
                   help="also time STEPS eager steps per kernel after the timed window (CUDA)")
    p.add_argument("--tune", action="append", default=[], metavar="FIELD=VALUE",
                   help="a Tuning field for our rows (repeatable; VALUE as a Python literal, e.g. 40 or None)")
    p.add_argument("--out", default=None, help="append the JSON lines to this file")
    args = p.parse_args(argv)
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    paths = [s.strip() for s in args.paths.split(",") if s.strip()]
    if not paths or any(s not in ("disk-pass", "general") for s in paths):
        p.error(f"--paths {args.paths!r}: disk-pass, general, or both")
    tune = {}
    for item in args.tune:
        field, _, value = item.partition("=")
        tune[field.strip()] = ast.literal_eval(value.strip())
    lines = []

    def emit(row):
        lines.append(row)
        print(json.dumps(row), flush=True)

    for n in (int(s) for s in args.sizes.split(",")):
        ref = None
        if args.probe:
            ref = run_probe(args.probe, n, args.steps, device)
            emit(ref)
        scene, dt = lattice_pack(n, args.polydispersity)
        for path in paths:
            row = measure(scene, dt, n, path == "disk-pass", args.steps, args.warmup, device, kernel_steps=args.kernels,
                          tune=tune)
            if ref is not None:
                row["probe_grain_steps_per_s"] = ref["body_steps_per_s"]
                row["ratio_to_probe"] = row["grain_steps_per_s"] / ref["body_steps_per_s"]
            emit(row)
    if args.out:
        with open(args.out, "a") as f:
            for row in lines:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
