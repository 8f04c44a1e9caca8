"""Grid convergence of the hard-disk momentum exchange (MPM-SDEM §5.1.1, Table 1).

The case ``momentum-exchange`` (cases/momentum_exchange.py) at finer and finer grids: the elastic
MPM disk (R = 2 cm, 2 m/s) hits the equal DEM disk at rest; what speed does the DEM disk leave with,
and how much of the kinetic energy does it take? The paper reports 1.992 m/s (99.2 %); our issue
asks ≥ 1.95 m/s. Everything but the grid is Table 1's (k_n, k_t, μ, densities, K and G, e = 1);
the transfer is FLIP, f64, USL, with B-spline shape functions and 2 × 2 points per cell, r_p the
middle of eq. 45's interval (h/√2). One JSON line per grid size (``--out`` appends).

    python bench/momentum_exchange_grid.py --device cpu --cells 3e-3
    python bench/momentum_exchange_grid.py --device cuda --cells 1e-3,7.5e-4,5e-4,3.75e-4,2.5e-4
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

from mpmdem import Simulation, SolverConfig

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from cases import momentum_exchange as case  # noqa: E402


def run(h: float, material: str, device: str) -> dict:
    """One run at cell size h [m]; the DEM disk's final speed and the energy split."""
    case.GRID, case.POINTS_PER_CELL, case.R_P = h, 2, h * 2.0**-0.5
    args = argparse.Namespace(quick=False, material=material, speed=case.SPEED)
    setup = case.build(args)
    config = SolverConfig(**{**case.DEFAULTS, "shape": "bspline2"})
    sim = Simulation(setup.scene, config, device=device)
    start = time.perf_counter()
    result = sim.run(setup.end_time, frames=20)
    seconds = time.perf_counter() - start
    v = float(sim.body_fields()["v"][0, 0])
    d = result.diagnostics
    e0 = float(d["energy_total"][0])
    m_body = float(d["bodies_mass"][0])
    m_pts = float(d["points_mass"][0])
    # what stays in the MPM disk beyond its centroid's motion: vibration (kinetic + strain)
    centroid = 0.5 * (float(d["points_momentum_x"][-1]) ** 2 + float(d["points_momentum_y"][-1]) ** 2) / m_pts
    internal = float(d["points_energy_kinetic"][-1]) - centroid + float(d["energy_strain"][-1])
    return dict(case="momentum-exchange-grid", material=material, device=device, cell_size=h,
                points=sim.particle_count, steps=int(result.steps) if hasattr(result, "steps") else None,
                seconds=seconds, dem_speed_final=v, paper=case.PAPER_SPEED[material],
                kinetic_energy_taken=0.5 * m_body * v**2 / e0, vibration_left_in_mpm_disk=internal / e0,
                energy_drift=float((d["energy_total"][-1] - e0) / e0),
                finite=bool(np.isfinite(v)))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default=None)
    p.add_argument("--cells", default="3e-3", help="comma-separated cell sizes [m]")
    p.add_argument("--material", default="hard", choices=("hard", "soft"))
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    for h in (float(c) for c in args.cells.split(",")):
        line = json.dumps(run(h, args.material, device))
        print(line, flush=True)
        if args.out:
            with args.out.open("a") as f:
                f.write(line + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
