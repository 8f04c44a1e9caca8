"""What μ(I) costs against Drucker–Prager per step (issue μ(I) §5), measured side by side in one call.

Scenes:

- ``flowing-column`` of ``granular_overhead.py`` (a column W × 2W that has collapsed for 0.03 s,
  2 × 2 points per cell, Granular MPM, fixed dt), at each size, once with Drucker–Prager and once
  with μ(I) of the same elasticity, density and critical density: the material law is the only
  difference, so the ratio of the step times is what the μ(I) return costs in a dense flow.
- ``silo``: `silo-discharge` (D0 = 4 cm, --cell-size, 0.3 s) with --material drucker-prager and
  --material mu-i: µs a step from each run's own step count and loop time.

Prints one JSON line per run (``--out`` appends them to a file); ``ratio`` = μ(I) / Drucker–Prager.
"""

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import warp as wp
from granular_overhead import DT_FACTOR, FLOW_TIME, WARMUP_STEPS, dense_column, time_mode

from mpmdem import DruckerPrager, MuI, SolverConfig
from mpmdem.sim.mpm import initial_dt_bound

E, NU, RHO, RHO_CR = 1.0e7, 0.3, 1500.0, 0.99 * 1500.0
LAWS = {
    "drucker-prager": DruckerPrager(E, NU, RHO, 30.0, 0.0, critical_density=RHO_CR),
    "mu-i": MuI(E, NU, RHO, mu_s=math.tan(math.radians(20.9)), mu_2=math.tan(math.radians(32.76)), i0=0.279,
                grain_diameter=1.0e-3, grain_density=RHO / 0.6, critical_density=RHO_CR),
}


def column_rows(particles: int, steps: int, device) -> list[dict]:
    rows = []
    for law, material in LAWS.items():
        scene = dense_column(particles, material)
        dt = DT_FACTOR * initial_dt_bound(scene)
        config = SolverConfig(granular=True, shape="bspline2", transfer="APIC", precision="f32", dt=dt)
        r = time_mode(scene, config, steps, device, warmup=WARMUP_STEPS + math.ceil(FLOW_TIME / dt))
        rows.append(dict(scene="flowing-column", law=law, particles=len(scene.particles()["mass"]), steps=steps,
                         seconds_per_step=r["seconds_per_step"], finite=r["finite"],
                         device_name=wp.get_device(device).name))
    rows[1]["ratio"] = rows[1]["seconds_per_step"] / rows[0]["seconds_per_step"]
    return rows


def silo_rows(cell_size: float, device: str) -> list[dict]:
    rows = []
    for law in LAWS:
        with tempfile.TemporaryDirectory() as out:
            cmd = [sys.executable, "-m", "mpmdem.cli", "run", "silo-discharge", "--material", law, "--device", device,
                   "--cell-size", str(cell_size), "--end-time", "0.3", "--frames", "3", "--out", out, "--quiet"]
            subprocess.run(cmd, check=True)
            s = json.loads((Path(out) / "summary.json").read_text())
        rows.append(dict(scene="silo", law=law, particles=s["particles"], steps=s["steps"], cell_size=cell_size,
                         seconds_per_step=s["wall_seconds"] / s["steps"], device_name=str(device)))
    rows[1]["ratio"] = rows[1]["seconds_per_step"] / rows[0]["seconds_per_step"]
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda")
    p.add_argument("--sizes", default="262144,1048576")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--silo-cell-size", type=float, default=0.0025)
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    rows = [r for n in a.sizes.split(",") for r in column_rows(int(n), a.steps, a.device)]
    rows += silo_rows(a.silo_cell_size, a.device)
    for r in rows:
        line = json.dumps(r)
        print(line, flush=True)
        if a.out:
            with open(a.out, "a") as f:
                f.write(line + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
