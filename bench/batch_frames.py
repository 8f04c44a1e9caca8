"""Where a batched study's time goes (issue 46): compilation, stepping, and the frames.

For one grid of the Beverloo study (five silo worlds, D0 = 2 ... 6 cm, ``--cell-size``), or with
``--case sand-blocks`` the block impact's ensemble (``--worlds`` starts, ``--ensemble-seed`` 1 ... N),
one JSON line with:
- ``import_s``: importing Warp and mpmdem; ``build_s``: building the BatchedSimulation;
- ``first_step_s``: the first step, which loads (and, with a cold kernel cache, compiles) every
  module (on CUDA with the graphs recorded: ``Simulation._capture``; ``--load-workers``: the
  threads that compile them); ``cold``: whether the cache was empty (``--cold`` points Warp at a
  fresh folder);
- ``steps_s``: stepping to the end time frame by frame as a run does (``advance_to`` per frame),
  with no frame written;
- ``run_s``: the whole ``BatchedSimulation.run`` with its frames and files, on a fresh batch;
- ``frames_s`` = run_s - steps_s: what the frames add (``--no-files``: their reads and checks alone);
- with ``--profile``, the 25 functions of the run with the most cumulative time (cProfile).
Nothing is asserted.

    python bench/batch_frames.py --device cuda --cell-size 0.0025 --cold --profile
    python bench/batch_frames.py --device cpu --cell-size 0.01 --end-time 0.05 --frames 5
    python bench/batch_frames.py --device cuda --case sand-blocks --worlds 16 --cell-size 0.003125
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ORIFICES = (0.02, 0.03, 0.04, 0.05, 0.06)  # [m] the Beverloo study's grid
#: the flags of world k of each case's batch
WORLD_FLAGS = {"silo-discharge": lambda k: ["--orifice", str(ORIFICES[k])],
               "sand-blocks": lambda k: ["--ensemble-seed", str(k + 1)]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None)
    p.add_argument("--case", default="silo-discharge", choices=sorted(WORLD_FLAGS))
    p.add_argument("--worlds", type=int, default=None, help="worlds in the batch (silo: at most 5, its default)")
    p.add_argument("--cell-size", type=float, default=0.0025)
    p.add_argument("--end-time", type=float, default=None, help="[s] (default the case's)")
    p.add_argument("--frames", type=int, default=None, help="(default the case's)")
    p.add_argument("--cold", action="store_true", help="compile into a fresh kernel cache")
    p.add_argument("--profile", action="store_true", help="cProfile the run with frames")
    p.add_argument("--kernels", type=int, default=0, metavar="STEPS",
                   help="also time STEPS eager steps per kernel (Warp's activity timing) at a quarter of the end time")
    p.add_argument("--load-workers", type=int, default=None,
                   help="Tuning.module_load_workers (default the Tuning's): threads compiling the modules")
    p.add_argument("--switch-interval", type=float, default=None,
                   help="Tuning.writer_switch_interval [s] (default the Tuning's; 0: Python's own, 5 ms)")
    p.add_argument("--writer-processes", type=int, default=None,
                   help="Tuning.batch_writer_processes: the frames written by N child processes (0: a thread)")
    p.add_argument("--no-files", action="store_true",
                   help="run without files (outs None): the frame's reads and checks without the writers")
    p.add_argument("--tuning", action="append", default=[], metavar="KNOB=VALUE",
                   help="any other Tuning knob (Python literal), e.g. launch_ahead_fraction=0.9")
    p.add_argument("--label", default="", help="a label for the row (e.g. which tree ran)")
    p.add_argument("--out", type=Path, default=None, help="append the JSON line here")
    args = p.parse_args(argv)
    start = time.perf_counter()
    import warp as wp

    if args.cold:
        wp.config.kernel_cache_dir = tempfile.mkdtemp(prefix="warp-cold-")
    wp.init()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from small_scenes import commit

    import mpmdem
    from mpmdem.sim.batch_run import BatchedSimulation
    from mpmdem.sim.tuning import Tuning
    from mpmdem.study.runner import case_module, config_from_args, make_case_parser

    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    import_s = time.perf_counter() - start
    module = case_module(args.case)
    worlds = args.worlds or len(ORIFICES)

    extra_knobs = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in args.tuning)}

    def batch():
        built = []
        for k in range(worlds):
            a = make_case_parser(module).parse_args(["--device", device, "--quiet", *WORLD_FLAGS[args.case](k),
                                                     "--cell-size", str(args.cell_size)])
            setup = module.build(a)
            built.append((setup, config_from_args(setup, module, a)))
        knobs = {k: v for k, v in (("module_load_workers", args.load_workers),
                                    ("writer_switch_interval", args.switch_interval),
                                    ("batch_writer_processes", args.writer_processes)) if v is not None}
        knobs.update(extra_knobs)
        tuning = Tuning(**knobs)
        return (BatchedSimulation([s.scene for s, _ in built], built[0][1], device=device, tuning=tuning),
                built[0][0])

    t0 = time.perf_counter()
    b, setup = batch()
    build_s = time.perf_counter() - t0
    end = args.end_time or setup.end_time
    frames = args.frames or setup.frames
    t0 = time.perf_counter()
    if b.sim.config.cuda_graph and device != "cpu":
        b.sim._capture()  # (the modules loaded, then the graphs recorded, as a run's first frame does)
    else:
        b.sim.stage.set_stop_time(0.0)
        b.sim.stage.step()
    wp.synchronize_device(device)
    first_step_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for k in range(1, frames + 1):
        b.sim.advance_to(end * k / frames)
    wp.synchronize_device(device)
    steps_s = time.perf_counter() - t0
    steps = b.sim.stage.read_clock().steps
    kernels = None
    if args.kernels:
        from collections import defaultdict

        b3, _ = batch()
        b3.sim.advance_to(end / 4)
        wp.synchronize_device(device)
        wp.timing_begin(cuda_filter=wp.TIMING_KERNEL | wp.TIMING_MEMSET | wp.TIMING_MEMCPY)
        for _ in range(args.kernels):
            b3.sim.stage.step()
        per = defaultdict(lambda: [0, 0.0])
        for r in wp.timing_end():
            per[r.name][0] += 1
            per[r.name][1] += 1e3 * r.elapsed / args.kernels  # ms -> µs per step
        kernels = sorted(([k.replace("forward kernel ", ""), n / args.kernels, round(us, 2)]
                          for k, (n, us) in per.items()), key=lambda row: -row[2])
        del b3
    b2, _ = batch()
    out = Path(tempfile.mkdtemp(prefix="batch-frames-"))
    outs = [None if args.no_files else out / f"w{k}" for k in range(worlds)]
    profiler = None
    if args.profile:
        import cProfile

        profiler = cProfile.Profile()
        profiler.enable()
    t0 = time.perf_counter()
    results = b2.run(end, outs=outs, frames=frames, names="run")
    run_s = time.perf_counter() - t0
    if profiler is not None:
        import io
        import pstats

        profiler.disable()
        s = io.StringIO()
        pstats.Stats(profiler, stream=s).sort_stats("cumulative").print_stats(int(os.environ.get("PROFILE_ROWS", "25")))
        print(s.getvalue(), file=sys.stderr)
    row = {"bench": "batch_frames", "label": args.label, "package": str(Path(mpmdem.__file__).parent.parent),
           "case": args.case, "worlds": worlds, "cell_size": args.cell_size,
           "points": b.sim.particle_count, "end_time": end, "frames": frames, "steps": steps,
           "cold": args.cold, "load_workers": args.load_workers, "switch_interval": args.switch_interval,
           "writer_processes": args.writer_processes, "tuning": extra_knobs, "files": not args.no_files,
           "import_s": round(import_s, 2),
           "build_s": round(build_s, 2),
           "first_step_s": round(first_step_s, 2), "steps_s": round(steps_s, 2), "run_s": round(run_s, 2),
           "frames_s": round(run_s - steps_s, 2), "profiled": args.profile,
           "kernel_us_per_step": round(sum(k[2] for k in kernels), 1) if kernels else None, "kernels": kernels,
           "status": sorted({r.status for r in results}),
           "device": str(wp.get_device(device).name if device != "cpu" else "cpu"), "commit": commit(),
           "pid_cpus": len(os.sched_getaffinity(0))}
    print(json.dumps(row), flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("a") as f:
            f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
