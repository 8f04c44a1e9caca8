"""Cost against size: µs per step against points (or grains) for plain MPM, Granular MPM, DEM grains
and coupled MPM–DEM, with each method's launch floor and memory roofline (issue 46 item 4).

The scenes are those of the throughput benches, so their rows can be read beside them:

- ``mpm``: bench/mpm_throughput.py's Neo-Hookean block (bspline2, APIC, USL, f32, CFL step);
- ``granular``: bench/granular_overhead.py's dense column at rest, Granular MPM (linear, PIC, f32,
  a fixed dt of a quarter of the Courant bound);
- ``grains``: bench/dem_throughput.py's box of sphero-disk grains (``Scene.add_grains``, radius
  0.5 m ± 15 %, f32, the probe's dt), settled for ``--warmup`` steps before timing;
- ``coupled``: bench/coupled_throughput.py's sand with pentagons mixed in, one pentagon per
  ``POINTS_PER_BODY`` points (1M points: 10k pentagons, its issue's scene).

For each method and size: build, capture the step's CUDA graph, take ``--warmup`` steps, then time
``Simulation.advance`` over a window of about ``WINDOW_S`` seconds (at least ``MIN_STEPS``) between two
device synchronisations.

The two lines drawn under each method (``--plot``):

- **launch floor** [µs/step]: the kernels, memsets and copies one step launches (counted with
  Warp's activity timing over eager steps of the method's smallest size) times the µs a node of a
  chain of point-sized no-op kernels costs in a CUDA graph (bench/launch_floor.py's ``points``
  chain, measured in the same call). No step of the method can be faster, whatever its size.
- **memory roofline** [µs/step]: 2 × the bytes of the state every step must read and write (every
  array of the points' struct ``P`` and the bodies' ``B``) over the device's copy bandwidth,
  measured in the same call (a device-to-device copy of ``COPY_BYTES``). The grid (``G``) is left
  out: Granular MPM allocates grid layers a dense scene never touches, so counting them would put
  the bound above the measured step. A step that read and wrote the points' and bodies' state once
  at full bandwidth would take this long; a real step also reads the grid and reads some arrays
  several times, so this is a lower bound, not a model.

One JSON line per (method, size) and one per measured constant; ``--out`` appends them.
``--plot FILE.jsonl`` draws the chart from such a file instead of measuring.

    python bench/cost_vs_size.py --device cuda --out bench/results/cost_vs_size/h100.jsonl
    python bench/cost_vs_size.py --plot bench/results/cost_vs_size/h100.jsonl --chart docs/img/cost_vs_size.png
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coupled_throughput  # noqa: E402
import dem_throughput  # noqa: E402
import granular_overhead  # noqa: E402
import launch_floor  # noqa: E402
import mpm_throughput  # noqa: E402
from small_scenes import commit  # noqa: E402

from mpmdem import Simulation, SolverConfig  # noqa: E402
from mpmdem.mpm import initial_dt_bound  # noqa: E402

METHODS = ("mpm", "granular", "grains", "coupled")
GPU_SIZES = (1_000, 3_000, 10_000, 30_000, 100_000, 300_000, 1_000_000, 3_000_000, 10_000_000)
CPU_SIZES = (1_000, 3_000, 10_000)
POINTS_PER_BODY = 100
WINDOW_S = 0.3  # timed window [s]
MIN_STEPS = 20
MAX_STEPS = 5000
COPY_BYTES = 1 << 30
FLOOR_NODES = 200  # nodes of the no-op chain timed for the floor
EAGER_STEPS = 5  # eager steps whose launches are counted


def build(method: str, n: int) -> tuple:
    """(scene, config, size actually built) of one method at about n points or grains."""
    if method == "mpm":
        scene = mpm_throughput.build_scene(mpm_throughput.grid_cells(n))
        config = SolverConfig(shape="bspline2", transfer="APIC", update="USL", precision="f32")
        return scene, config, len(scene.particles()["mass"])
    if method == "granular":
        scene = granular_overhead.dense_column(n)
        dt = granular_overhead.DT_FACTOR * initial_dt_bound(scene)
        config = SolverConfig(shape="linear", transfer="PIC", update="USL", precision="f32", granular=True, dt=dt)
        return scene, config, len(scene.particles()["mass"])
    if method == "grains":
        scene, dt = dem_throughput.grain_pack(n)
        return scene, SolverConfig(precision="f32", dt=dt), scene.dem_body_count - len(scene.rigid_bodies)
    if method == "coupled":
        case = coupled_throughput.build(n, max(1, n // POINTS_PER_BODY))
        scene = coupled_throughput.make_scene(case, True, False)
        mass = float(np.min(scene.particles()["mass"]))
        from mpmdem.coupling import contact_time_step_bound
        from mpmdem.dem import dem_time_step_bound
        dt = coupled_throughput.DT_FACTOR * min(initial_dt_bound(scene), contact_time_step_bound(scene, mass),
                                                dem_time_step_bound(scene))
        config = SolverConfig(transfer="PIC", shape="bspline2", dt=dt)
        return scene, config, len(scene.particles()["mass"])
    raise ValueError(method)


def state_bytes(sim: Simulation) -> dict[str, int]:
    """Bytes of the device arrays of the points' (P), grid's (G) and bodies' (B) structs of the stages."""
    total = {"P": 0, "G": 0, "B": 0}
    for stage in (getattr(sim, "mpm", None), getattr(sim, "dem", None)):
        for name in total:
            struct = getattr(stage, name, None) if stage is not None else None
            if struct is None:
                continue
            for attr in dir(struct):
                value = None if attr.startswith("_") else getattr(struct, attr, None)
                if isinstance(value, wp.array):
                    total[name] += value.capacity
    return total


def launches_per_step(sim: Simulation, device) -> float:
    """Kernels, memsets and copies one eager step launches (Warp's activity timing)."""
    if not wp.get_device(device).is_cuda:
        return float("nan")
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL | wp.TIMING_MEMSET | wp.TIMING_MEMCPY)
    for _ in range(EAGER_STEPS):
        sim.stage.step()
    results = wp.timing_end()
    return len(results) / EAGER_STEPS


def time_steps(sim: Simulation, device) -> tuple[float, int]:
    """(µs per step, steps) of ``Simulation.advance`` over a window of about WINDOW_S."""
    wp.synchronize_device(device)
    start = time.perf_counter()
    sim.advance(MIN_STEPS)
    wp.synchronize_device(device)
    probe = (time.perf_counter() - start) / MIN_STEPS
    steps = int(min(MAX_STEPS, max(MIN_STEPS, WINDOW_S / max(probe, 1e-9))))
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    return 1e6 * (time.perf_counter() - start) / steps, steps


def measure(method: str, n: int, warmup: int, device, count_launches: bool) -> dict:
    """One row: µs per step of a method at about n points (or grains), its state bytes and launches."""
    t0 = time.perf_counter()
    scene, config, built = build(method, n)
    sim = Simulation(scene, config, device=str(device))
    sim._capture()
    sim.stage.set_stop_time(1.0e30)
    sim.advance(warmup)
    setup = time.perf_counter() - t0
    us, steps = time_steps(sim, device)
    t, dt, bound, _, status = sim.stage.read_clock()
    sim.stage.check_status(t, dt, bound, status)
    row = dict(bench="cost_vs_size", method=method, device=wp.get_device(device).name, requested=n, size=built,
               bodies=sim.body_count, us_per_step=us, steps=steps, warmup=warmup, setup_seconds=setup,
               state_bytes=state_bytes(sim), cuda_graph=sim._graph is not None, precision=config.precision,
               granular=config.granular, commit=commit(), warp=wp.__version__)
    if count_launches:
        row["launches_per_step"] = launches_per_step(sim, device)
    del sim, scene
    gc.collect()
    return row


def copy_bandwidth(device) -> float:
    """Device-to-device copy bandwidth [B/s]: bytes read plus bytes written per second."""
    n = COPY_BYTES // 4
    a = wp.zeros(n, dtype=wp.float32, device=device)
    b = wp.empty(n, dtype=wp.float32, device=device)
    wp.copy(b, a)
    wp.synchronize_device(device)
    reps = 20
    start = time.perf_counter()
    for _ in range(reps):
        wp.copy(b, a)
    wp.synchronize_device(device)
    return 2.0 * COPY_BYTES * reps / (time.perf_counter() - start)


def plot(rows: list[dict], chart: Path) -> None:
    """µs per step against size per method, with its launch floor and roofline, log-log."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    consts = {r["constant"]: r["value"] for r in rows if "constant" in r}
    node_us, bandwidth = consts.get("us_per_node"), consts.get("copy_bandwidth")
    fig, ax = plt.subplots(figsize=(7.5, 5.2))
    colours = dict(zip(METHODS, ("tab:blue", "tab:orange", "tab:green", "tab:red"), strict=True))
    for method in METHODS:
        pts = sorted((r["size"], r["us_per_step"], r["state_bytes"]["P"] + r["state_bytes"]["B"],
                      r.get("launches_per_step"))
                     for r in rows if r.get("method") == method and "us_per_step" in r)
        if not pts:
            continue
        size, us, nbytes, launches = (np.array(c, dtype=float) for c in zip(*pts, strict=True))
        c = colours[method]
        ax.loglog(size, us, "o-", color=c, label=method)
        if bandwidth:
            ax.loglog(size, 1e6 * 2.0 * nbytes / bandwidth, ":", color=c, lw=1)
        known = launches[np.isfinite(launches)] if node_us else []
        if len(known):
            ax.axhline(known[0] * node_us, color=c, ls="--", lw=0.8)
    ax.plot([], [], "k--", lw=0.8, label="launch floor (launches × µs per graph node)")
    ax.plot([], [], "k:", lw=1, label="memory roofline (2 × state bytes / copy bandwidth)")
    ax.set_xlabel("points (MPM, granular, coupled) or grains (DEM)")
    ax.set_ylabel("µs per step")
    device = next((r["device"] for r in rows if "device" in r), "")
    ax.set_title(f"cost against size, {device}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    chart.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(chart, dpi=120)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None)
    p.add_argument("--methods", default=",".join(METHODS))
    p.add_argument("--sizes", default=None, help="comma-separated sizes (default 1e3..1e7 on cuda, 1e3..1e4 on cpu)")
    p.add_argument("--max-size", default="", help="per-method caps, e.g. grains=3000000,granular=3000000")
    p.add_argument("--warmup", type=int, default=20)
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--plot", type=Path, default=None, help="draw the chart from this .jsonl instead of measuring")
    p.add_argument("--chart", type=Path, default=Path("cost_vs_size.png"))
    args = p.parse_args(argv)
    if args.plot:
        plot([json.loads(line) for line in args.plot.read_text().splitlines() if line.strip()], args.chart)
        return 0
    wp.init()
    device = wp.get_device(args.device or ("cuda" if wp.get_cuda_device_count() else "cpu"))
    sizes = [int(float(s)) for s in args.sizes.split(",")] if args.sizes else list(
        GPU_SIZES if device.is_cuda else CPU_SIZES)
    caps = {k: int(float(v)) for k, v in (kv.split("=") for kv in args.max_size.split(",") if kv)}
    rows = []

    def emit(row):
        rows.append(row)
        print(json.dumps(row), flush=True)
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            with args.out.open("a") as f:
                f.write(json.dumps(row) + "\n")

    with wp.ScopedDevice(device):
        if device.is_cuda:
            emit(dict(bench="cost_vs_size", constant="copy_bandwidth", value=copy_bandwidth(device),
                      unit="B/s", device=device.name, commit=commit()))
            floor = launch_floor.measure("points", FLOOR_NODES, 1024, 50, str(device))
            emit(dict(bench="cost_vs_size", constant="us_per_node", value=floor["us_per_node"], unit="us",
                      device=device.name, source="launch_floor points chain, 1024 threads", commit=commit()))
        for method in [m.strip() for m in args.methods.split(",") if m.strip()]:
            for k, n in enumerate(s for s in sizes if s <= caps.get(method, sizes[-1])):
                try:
                    emit(measure(method, n, args.warmup, device, count_launches=k == 0))
                except Exception as exc:  # a size that does not fit is a row, not the end of the sweep
                    emit(dict(bench="cost_vs_size", method=method, requested=n, error=f"{type(exc).__name__}: {exc}"))
                    break
    if args.out:
        plot(rows, args.out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
