"""MPM–DEM coupling overhead: step time of a coupled scene against the same points alone.

Scene (``bed``): a sand column W × W (Mohr–Coulomb, 2 × 2 points per cell) resting on a bed of
fixed rounded square blocks (edge 4h, gaps 2h) that covers the floor, with a row of free blocks of
the same size lying on top of the column; both rows of blocks start just touching the points
(overlap 0.1 % of a + r_p). So about 2/3 of the column's bottom row and its whole top row are in
contact, and the free blocks are integrated. The "plain" run is
the same points, material and fixed dt with no rigid bodies (the MPM floor holds the column
instead). Reported: seconds per step of both, ``overhead`` = coupled / plain, the point–body pairs
listed and in contact, and the list rebuilds over the timed steps.

Both runs use the same fixed dt (a quarter of the smaller of the Courant bound and the coupled
contact bound), warm-up excluded (compilation, CUDA-graph capture, a few steps), then ``--steps``
steps between two device synchronisations. One JSON line per (size, mode) on stdout
(``--out FILE`` appends them). Nothing about time is asserted.

    python bench/coupling_overhead.py --device cpu --sizes 4096 --steps 5
    python bench/coupling_overhead.py --device cuda --out bench/results/coupling_overhead/h100.jsonl
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

from mpmdem import ContactLaw, MohrCoulomb, Scene, Simulation, SolverConfig, rectangle
from mpmdem.model.spheropolygons import rounded_rectangle
from mpmdem.sim.coupling import contact_time_step_bound
from mpmdem.sim.mpm import initial_dt_bound

MATERIAL = MohrCoulomb(1.0e7, 0.3, 2000.0, 30.0, 0.0)
LAW = ContactLaw(1.0e7, restitution=0.3)
WIDTH = 1.0  # m, column width
BLOCK = 4  # block edge [cells]
GAP = 2  # gap between bed blocks [cells]
WARMUP_STEPS = 5
GPU_SIZES = (262144, 1048576)
CPU_SIZES = (4096,)


def build(particles: int, coupled: bool) -> tuple[Scene, int]:
    """The bed scene of about ``particles`` points; returns (scene, rigid bodies)."""
    cells = max(4, round(math.sqrt(particles / 4)))  # column width in cells
    h = WIDTH / cells
    bed = BLOCK * h
    width = 3 * cells * h
    height = (cells + 3 * BLOCK + 4) * h
    scene = Scene(domain=((0.0, 0.0), (width, height)), cell_size=h, gravity=(0.0, -9.81), contact=LAW,
                  boundaries={"bottom": "fixed", "left": "slip", "right": "slip", "top": "slip"})
    x0 = cells * h
    y0 = (BLOCK + 1) * h  # on a cell line: the points' rows sit at y0 + (k + 1/4) h, (k + 3/4) h
    body = scene.add_mpm_body(rectangle(x0, y0, x0 + cells * h, y0 + cells * h), MATERIAL, points_per_cell=2)
    n = 0
    if coupled:
        a = 0.1 * bed
        block = rounded_rectangle(bed, bed, a)
        pitch = (BLOCK + GAP) * h
        touch = (a + body.contact_radius) * (1.0 - 1.0e-3)  # centre-to-core distance of a touching point
        half_core = 0.5 * bed - a
        for k in range(int(width / pitch)):
            y = y0 + 0.25 * h - touch - half_core
            scene.add_rigid_body(block, density=2500.0, position=((k + 0.5) * pitch, y), motion="fixed", friction=0.5)
            n += 1
        top = y0 + cells * h - 0.25 * h + touch + half_core
        for k in range(int(cells * h / pitch)):
            scene.add_rigid_body(block, density=2500.0, position=(x0 + (k + 0.5) * pitch, top), friction=0.5)
            n += 1
    return scene, n


def time_run(scene: Scene, config: SolverConfig, steps: int, device: str) -> dict:
    sim = Simulation(scene, config, device=device)
    sim.advance_to(1.0e-12)  # modules, CUDA graph, one step
    sim.stage.set_stop_time(1.0e9)
    sim.advance(WARMUP_STEPS)
    wp.synchronize_device(device)
    before = sim.stage.read_clock()[3]
    rebuilds = sim.diagnostics().get("imp_rebuilds", 0.0) if sim.coupling else 0.0
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    t, dt, bound, after, status = sim.stage.read_clock()
    if after - before != steps:
        raise RuntimeError(f"took {after - before} of {steps} steps")
    sim.stage.check_status(t, dt, bound, status)
    out = dict(seconds=seconds, seconds_per_step=seconds / steps, particles=sim.particle_count,
               bodies=sim.body_count, cuda_graph=sim._graph is not None)
    if sim.coupling:
        d = sim.diagnostics()
        out.update(imp_pairs=d["imp_pairs"], imp_contacts=d["imp_contacts"],
                   imp_rebuilds=d["imp_rebuilds"] - rebuilds)
    del sim
    gc.collect()
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default=None)
    p.add_argument("--sizes", type=int, nargs="*", default=None)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    sizes = args.sizes or (GPU_SIZES if device.startswith("cuda") else CPU_SIZES)
    lines = []
    for size in sizes:
        plain_scene, _ = build(size, False)
        coupled_scene, _ = build(size, True)
        mass = float(np.min(coupled_scene.particles()["mass"]))
        dt = 0.25 * min(initial_dt_bound(plain_scene), contact_time_step_bound(coupled_scene, mass))
        config = SolverConfig(transfer="PIC", shape="bspline2", dt=dt)
        runs = {}
        for mode, scene in (("plain", plain_scene), ("coupled", coupled_scene)):
            r = time_run(scene, config, args.steps, device)
            runs[mode] = r
            line = dict(case="coupling-overhead", mode=mode, device=str(wp.get_device(device)), size=size,
                        steps=args.steps, dt=dt, particle_updates_per_second=r["particles"] * args.steps / r["seconds"],
                        **r)
            if mode == "coupled":
                line["overhead"] = r["seconds_per_step"] / runs["plain"]["seconds_per_step"]
            lines.append(line)
            print(json.dumps(line), flush=True)
    if args.out:
        with Path(args.out).open("a") as f:
            for line in lines:
                f.write(json.dumps(line) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
