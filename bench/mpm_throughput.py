"""MPM throughput: particle-updates per second of mpmdem against a minimal MLS-MPM reference.

Scene (the same for both): a Neo-Hookean block (E = 1e5 Pa, ν = 0.3, ρ = 1000 kg/m³) over
[0.25, 0.75] × [0.1, 0.6] in the unit square, 2 × 2 points per cell, gravity (0, −9.81) m/s²,
slip walls. The grid has n = sqrt(particles) cells per side, so the block holds n² points.

For every size the reference runs first, then mpmdem; each is warmed up (JIT and CUDA graph
capture excluded), then ``--steps`` steps are timed between two device synchronisations. One
JSON line per run goes to stdout (and is appended to ``--out``).

mpmdem is stepped (``--stepping``) either by ``Simulation.advance`` (a bare sequence of steps, no
host sync and no automatic re-sorting) or by ``Simulation.advance_to`` (what ``run`` does: batches
of steps with the stability check and, by default, the drift check of the automatic re-sorting,
so a re-sort it triggers is inside the timed window). ``--shuffle`` defaults to advance_to: it
then measures what a user gets from the default configuration once the points' order is lost.

The reference is a three-kernel MLS-MPM step (P2G with APIC, quadratic B-spline weights and the
Neo-Hookean stress fused; grid update; G2P), f32, fixed dt equal to mpmdem's first CFL step
(κ h / c). On CUDA its step is captured as a graph too, as mpmdem's is.

    python bench/mpm_throughput.py --device cpu
    python bench/mpm_throughput.py --device cuda --out bench/results/mpm_throughput/h100.jsonl
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import time
from pathlib import Path

import numpy as np
import warp as wp

from mpmdem import NeoHookean, Scene, Simulation, SolverConfig, rectangle
from mpmdem.sim.mpm import device_order

YOUNGS, POISSON, DENSITY = 1.0e5, 0.3, 1000.0
GRAVITY = (0.0, -9.81)
BLOCK = (0.25, 0.1, 0.75, 0.6)
POINTS_PER_CELL = 2
WARMUP_STEPS = 5
GPU_SIZES = (65536, 262144, 1048576, 4194304)
CPU_SIZES = (16384,)
STEPPINGS = ("advance", "advance_to")
#: default timed steps on CUDA by stepping: through advance_to, a drifted order is found at the
#: end of a batch (up to 400 steps; the first of a window is one step), and the window is long
#: enough for the batches' host checks to weigh as they do in a run
GPU_STEPS = {"advance": 200, "advance_to": 1000}
#: What the reference implements, for its rows.
REFERENCE_CONFIG = SolverConfig(shape="bspline2", transfer="APIC", update="USL", precision="f32")


def grid_cells(particles: int) -> int:
    """Cells per side n such that the block at 2 × 2 points per cell holds about ``particles``."""
    block_area = (BLOCK[2] - BLOCK[0]) * (BLOCK[3] - BLOCK[1])
    return max(4, round(math.sqrt(particles / (POINTS_PER_CELL**2 * block_area))))


def build_scene(n: int) -> Scene:
    """Build the benchmark scene on an n × n grid over the unit square."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1.0 / n, gravity=GRAVITY,
                  boundaries={side: "slip" for side in ("left", "right", "bottom", "top")})
    scene.add_mpm_body(rectangle(*BLOCK), NeoHookean(YOUNGS, POISSON, DENSITY), points_per_cell=POINTS_PER_CELL)
    return scene


# -- reference MLS-MPM ------------------------------------------------------------------------------
@wp.func
def quadratic_weights(xg: float):
    """Lowest node index and the three quadratic B-spline weights of a coordinate in grid units."""
    base = int(wp.floor(xg - 0.5))
    f = xg - float(base)
    a = 1.5 - f
    b = f - 1.0
    c = f - 0.5
    return base, wp.vec3(0.5 * a * a, 0.75 - b * b, 0.5 * c * c)


@wp.kernel
def ref_p2g(
    x: wp.array(dtype=wp.vec2),
    v: wp.array(dtype=wp.vec2),
    C: wp.array(dtype=wp.mat22),
    F: wp.array(dtype=wp.mat22),
    grid_m: wp.array2d(dtype=float),
    grid_p: wp.array2d(dtype=wp.vec2),
    h: float,
    dt: float,
    vol0: float,
    mass: float,
    mu: float,
    lam: float,
):
    """Scatter mass and momentum with the MLS force term: m v + (m C − dt V0 D⁻¹ τ)(x_i − x_p)."""
    p = wp.tid()
    inv_h = 1.0 / h
    xg = x[p] * inv_h
    bx, wx = quadratic_weights(xg[0])
    by, wy = quadratic_weights(xg[1])
    Fp = F[p]
    J = wp.determinant(Fp)
    tau = mu * (Fp * wp.transpose(Fp)) + (lam * wp.log(J) - mu) * wp.identity(n=2, dtype=float)
    # D⁻¹ = 4 / h² for the quadratic B-spline
    affine = mass * C[p] - (dt * vol0 * 4.0 * inv_h * inv_h) * tau
    mv = mass * v[p]
    for i in range(3):
        for j in range(3):
            w = wx[i] * wy[j]
            dx = (wp.vec2(float(bx + i), float(by + j)) - xg) * h
            wp.atomic_add(grid_m, bx + i, by + j, w * mass)
            wp.atomic_add(grid_p, bx + i, by + j, w * (mv + affine * dx))


@wp.kernel
def ref_grid(
    grid_m: wp.array2d(dtype=float), grid_p: wp.array2d(dtype=wp.vec2), dt: float, gravity: wp.vec2, n: int
):
    """Momentum → velocity (in place), gravity, and slip walls on the outer two node layers."""
    i, j = wp.tid()
    m = grid_m[i, j]
    if m <= 0.0:
        return
    vi = grid_p[i, j] / m + dt * gravity
    if (i < 2 and vi[0] < 0.0) or (i > n - 2 and vi[0] > 0.0):
        vi = wp.vec2(0.0, vi[1])
    if (j < 2 and vi[1] < 0.0) or (j > n - 2 and vi[1] > 0.0):
        vi = wp.vec2(vi[0], 0.0)
    grid_p[i, j] = vi


@wp.kernel
def ref_g2p(
    x: wp.array(dtype=wp.vec2),
    v: wp.array(dtype=wp.vec2),
    C: wp.array(dtype=wp.mat22),
    F: wp.array(dtype=wp.mat22),
    grid_v: wp.array2d(dtype=wp.vec2),
    h: float,
    dt: float,
):
    """Gather velocity and APIC matrix C = D⁻¹ Σ w v_i (x_i − x_p)ᵀ; move; F ← (I + dt C) F."""
    p = wp.tid()
    inv_h = 1.0 / h
    xg = x[p] * inv_h
    bx, wx = quadratic_weights(xg[0])
    by, wy = quadratic_weights(xg[1])
    vp = wp.vec2(0.0, 0.0)
    B = wp.mat22(0.0)
    for i in range(3):
        for j in range(3):
            w = wx[i] * wy[j]
            dx = wp.vec2(float(bx + i), float(by + j)) - xg  # in grid units
            vi = grid_v[bx + i, by + j]
            vp += w * vi
            B += w * wp.outer(vi, dx)
    Cp = (4.0 * inv_h) * B
    v[p] = vp
    C[p] = Cp
    x[p] = x[p] + dt * vp
    F[p] = (wp.identity(n=2, dtype=float) + dt * Cp) * F[p]


class Reference:
    """Minimal f32 MLS-MPM state of the benchmark scene on one device.

    Nodes sit at (i h, j h), i, j = 0..n; there is no bounds check, so points must stay more than
    a cell inside the unit square (the block does, for far longer than a benchmark runs).
    """

    def __init__(self, positions: np.ndarray, n: int, dt: float, device):
        self.device = device
        self.n = n
        self.h = 1.0 / n
        self.dt = dt
        count = len(positions)
        mat = NeoHookean(YOUNGS, POISSON, DENSITY)
        self.mu, self.lam = mat.shear_modulus, mat.lame_lambda
        self.vol0 = (self.h / POINTS_PER_CELL) ** 2
        self.mass = self.vol0 * DENSITY
        with wp.ScopedDevice(device):
            self.x = wp.array(positions.astype(np.float32), dtype=wp.vec2)
            self.v = wp.zeros(count, dtype=wp.vec2)
            self.C = wp.zeros(count, dtype=wp.mat22)
            self.F = wp.array(np.tile(np.eye(2, dtype=np.float32), (count, 1, 1)), dtype=wp.mat22)
            self.grid_m = wp.zeros((n + 1, n + 1), dtype=float)
            self.grid_p = wp.zeros((n + 1, n + 1), dtype=wp.vec2)
        self.count = count
        self._graph = None

    def step(self) -> None:
        """Launch one step (no synchronisation)."""
        with wp.ScopedDevice(self.device):
            self.grid_m.zero_()
            self.grid_p.zero_()
            wp.launch(ref_p2g, self.count, inputs=[self.x, self.v, self.C, self.F, self.grid_m, self.grid_p,
                                                   self.h, self.dt, self.vol0, self.mass, self.mu, self.lam])
            wp.launch(ref_grid, self.grid_m.shape,
                      inputs=[self.grid_m, self.grid_p, self.dt, wp.vec2(*GRAVITY), self.n])
            wp.launch(ref_g2p, self.count, inputs=[self.x, self.v, self.C, self.F, self.grid_p, self.h, self.dt])

    def prepare(self) -> None:
        """Load the modules; on CUDA record one step as a graph."""
        self.step()
        wp.synchronize_device(self.device)
        if wp.get_device(self.device).is_cuda:
            with wp.ScopedCapture(device=self.device) as cap:
                self.step()
            self._graph = cap.graph

    def advance(self, steps: int) -> None:
        """Launch ``steps`` steps (graph replays on CUDA)."""
        for _ in range(steps):
            if self._graph is not None:
                wp.capture_launch(self._graph)
            else:
                self.step()


# -- timing ---------------------------------------------------------------------------------------
def time_reference(positions: np.ndarray, n: int, dt: float, steps: int, device) -> tuple[float, bool]:
    """Seconds for ``steps`` reference steps, and whether the positions stayed finite."""
    ref = Reference(positions, n, dt, device)
    ref.prepare()
    ref.advance(WARMUP_STEPS)
    wp.synchronize_device(device)
    start = time.perf_counter()
    ref.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    return seconds, bool(np.isfinite(ref.x.numpy()).all())


def time_mpmdem(scene: Scene, config: SolverConfig, steps: int, device, shuffle: bool = False,
                stepping: str = "advance") -> tuple[float, bool, int, float, int]:
    """Time mpmdem's steps: (seconds, whether the positions stayed finite, steps taken, drift after,
    automatic re-sorts in the timed window).

    shuffle: put the points in a random memory order after the warm-up (what a long flow does to
    them), so the effect of ``sort_interval`` shows.
    stepping: "advance" times exactly ``steps`` steps of ``Simulation.advance``; "advance_to"
    times ``Simulation.advance_to`` up to the time ``steps`` steps of the current dt reach, which
    includes its host checks and any automatic re-sort (the CFL dt varies a little, so the steps
    taken are counted on the device and returned).
    The drift after is the fraction [-] of consecutive points in cells that are not neighbours
    (``MPMSolver.order_drift``), read after the timed window.
    """
    sim = Simulation(scene, config, device=str(device))
    sim.advance_to(1.0e-12)  # loads the modules, records the CUDA graph, takes one step
    sim.mpm.set_stop_time(1.0e9)
    sim.advance(WARMUP_STEPS)
    if shuffle:
        sim.mpm.shuffle_points()
    wp.synchronize_device(device)
    t_before, dt, _, steps_before, _ = sim.mpm.read_clock()
    sorts_before = sim._auto_sort.sorts if sim._auto_sort is not None else 0
    start = time.perf_counter()
    if stepping == "advance_to":
        sim.advance_to(t_before + steps * dt)
    else:
        sim.mpm.set_stop_time(1.0e9)
        sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    taken = sim.mpm.read_clock()[3] - steps_before
    if stepping == "advance" and taken != steps:
        raise RuntimeError(f"mpmdem took {taken} of {steps} timed steps (stop time reached?)")
    sorts = (sim._auto_sort.sorts if sim._auto_sort is not None else 0) - sorts_before
    return seconds, bool(np.isfinite(sim.mpm.P.x.numpy()).all()), taken, sim.mpm.order_drift(), sorts


def row(impl: str, device, config: SolverConfig, particles: int, n: int, steps: int, seconds: float,
        ratio_to: float | None, finite: bool, shuffled: bool = False, **extra) -> dict:
    """One JSON record; ``ratio_to`` is the reference pups an mpmdem row is divided by; ``extra``
    keys (stepping, drift_after on mpmdem rows) are appended."""
    pups = particles * steps / seconds
    return dict(case="neo-hookean-block", impl=impl, device=str(device), precision=config.precision,
                shape=config.shape, transfer=config.transfer, update=config.update, particles=particles,
                grid=n, steps=steps, seconds=seconds, pups=pups,
                ratio=None if ratio_to is None else pups / ratio_to, finite=finite,
                sort_interval=config.sort_interval, shuffled=shuffled, **extra)


def measure(particles: int, config: SolverConfig, steps: int, device, shuffle: bool = False,
            stepping: str = "advance") -> list[dict]:
    """Time the reference, then mpmdem, at one size; return their two rows."""
    n = grid_cells(particles)
    scene = build_scene(n)
    positions = scene.particles()["x"]
    # the reference gets the points in the order mpmdem keeps them on the device, so the ratio
    # compares the two codes on the same memory layout
    positions = positions[device_order(positions, scene.domain[0], scene.cell_size)]
    count = len(positions)
    dt = config.cfl * scene.cell_size / scene.bodies[0].material.wave_speed
    ref_s, ref_ok = time_reference(positions, n, dt, steps, device)
    ref = row("reference", device, REFERENCE_CONFIG, count, n, steps, ref_s, None, ref_ok)
    s, ok, taken, drift, sorts = time_mpmdem(scene, config, steps, device, shuffle, stepping)
    return [ref, row("mpmdem", device, config, count, n, taken, s, ref["pups"], ok, shuffle, stepping=stepping,
                     drift_after=drift, auto_sorts=sorts)]


def run_probe(path: str, n_grid: int, steps: int, device: str, sort: bool) -> dict:
    """One row of the shared MLS-MPM probe (../shared/bench/warp_mlsmpm2d.py) on the same block."""
    spec = importlib.util.spec_from_file_location("warp_mlsmpm2d", path)
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    return probe.run(n_grid, steps, device, sort=sort)


def main(argv=None) -> None:
    """Parse the flags; time every size; print (and append) one JSON line per run."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present)")
    parser.add_argument("--sizes", default=None,
                        help=f"comma-separated particle counts (default {','.join(map(str, GPU_SIZES))} "
                             f"on cuda, {','.join(map(str, CPU_SIZES))} on cpu)")
    parser.add_argument("--steps", type=int, default=None,
                        help="timed steps (default on cuda: 200 with --stepping advance, 1000 with advance_to; "
                             "20 on cpu)")
    parser.add_argument("--shape", default="bspline2")
    parser.add_argument("--transfer", default="APIC")
    parser.add_argument("--update", default="USL")
    parser.add_argument("--precision", default="f32", choices=("f32", "f64"))
    parser.add_argument("--sort-interval", type=int, default=None,
                        help="steps between re-sorts of the points by cell; 0: never (default: automatic, "
                             "as the order drifts, which only --stepping advance_to does)")
    parser.add_argument("--shuffle", action="store_true",
                        help="randomise the points' memory order before timing (as a long flow would)")
    parser.add_argument("--stepping", choices=STEPPINGS, default=None,
                        help="how mpmdem is stepped in the timed window: advance (bare steps) or advance_to "
                             "(batches with host checks and automatic re-sorting, as run does); default: "
                             "advance_to with --shuffle, else advance")
    parser.add_argument("--probe", default=None,
                        help="path of the shared probe warp_mlsmpm2d.py: run it at each size in this process and "
                             "write probe_pups and ratio_to_probe on the mpmdem rows")
    parser.add_argument("--out", type=Path, default=None, help="also append the JSON lines to this .jsonl file")
    args = parser.parse_args(argv)

    wp.init()
    device = wp.get_device(args.device or ("cuda" if wp.get_cuda_device_count() > 0 else "cpu"))
    cuda = device.is_cuda
    sizes = [int(s) for s in args.sizes.split(",")] if args.sizes else list(GPU_SIZES if cuda else CPU_SIZES)
    stepping = args.stepping or ("advance_to" if args.shuffle else "advance")
    steps = args.steps or (GPU_STEPS[stepping] if cuda else 20)
    config = SolverConfig(shape=args.shape, transfer=args.transfer, update=args.update, precision=args.precision,
                          sort_interval=args.sort_interval)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    with wp.ScopedDevice(device):
        for particles in sizes:
            rows = measure(particles, config, steps, device, args.shuffle, stepping)
            if args.probe:
                probe = run_probe(args.probe, rows[0]["grid"], steps, str(device), sort=not args.shuffle)
                for row in rows:
                    if row["impl"] == "mpmdem":
                        row["probe_pups"] = probe["pups"]
                        row["ratio_to_probe"] = row["pups"] / probe["pups"]
                rows.append({"case": "probe-mlsmpm", **probe})
            for row in rows:
                line = json.dumps(row)
                print(line, flush=True)
                if args.out is not None:
                    with args.out.open("a") as f:
                        f.write(line + "\n")


if __name__ == "__main__":
    main()
