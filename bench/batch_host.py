"""A batch's frames on the host with the device played by sleeps (issue 46): what the writer thread
and the main thread cost each other, on a CPU.

``--worlds`` run files (``mpmdem.io.FrameWriter``: ``--points`` points, ``--bodies`` bodies,
``--diagnostics`` diagnostics, the coupled runs' particle fields) written through
``BackgroundFrameWriter``s sharing one thread, as ``BatchedSimulation`` writes a batch's worlds.
Per frame the main thread does what a batched run's does, with the device's part replaced:
``--record-ms`` of Python without a pause (the frame's sums and checks, the device idle), the
frame handed to the writers (each waits for its world's previous frame), then ``--step-ms`` of
waiting for the device in ``--launches`` sleeps with Python's lock released (the next frame's graph
launches and clock reads). The arrays are made before the clock starts.

One JSON line: ``seconds_per_frame`` (wall, over ``--frames`` frames and the close), its floor
``floor_s_per_frame`` (record + step: the writers hidden), ``switch_interval`` (``sys.setswitchinterval``
during the frames; default Python's, 5 ms) and ``tag``. Nothing is asserted.

    python bench/batch_host.py --worlds 16 --switch-interval 0.0005
    PYTHONPATH=OLD_TREE python bench/batch_host.py --worlds 16 --tag base
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from frame_writing import frame_data, geometry  # (a script beside this one)

from mpmdem.io import FrameWriter, default_field_specs
from mpmdem.io.background import BackgroundFrameWriter
from mpmdem.io.writer_process import WriterProcess


def busy(seconds: float) -> None:
    """Run Python without a pause for ``seconds``."""
    end = time.perf_counter() + seconds
    n = 0
    while time.perf_counter() < end:
        n += 1


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worlds", type=int, default=16)
    p.add_argument("--points", type=int, default=8192)
    p.add_argument("--bodies", type=int, default=5)
    p.add_argument("--diagnostics", type=int, default=45)
    p.add_argument("--frames", type=int, default=30)
    p.add_argument("--record-ms", type=float, default=15.0, help="the main thread's Python per frame [ms]")
    p.add_argument("--step-ms", type=float, default=70.0, help="the device's steps per frame [ms]")
    p.add_argument("--launches", type=int, default=20, help="waits the steps are cut in")
    p.add_argument("--switch-interval", type=float, default=None, help="[s] (default Python's)")
    p.add_argument("--processes", type=int, default=0, help="the frames written by N child processes "
                   "(mpmdem.io.writer_process, worlds dealt in turn), not a thread of this one (0)")
    p.add_argument("--sidecar-interval", type=float, default=1.0,
                   help="[s] least wall time between two rewrites of one file's XDMF sidecars (FrameWriter's)")
    p.add_argument("--tag", default="")
    p.add_argument("--out", type=Path, default=None, help="append the JSON line here")
    args = p.parse_args()
    data = frame_data(args.points, args.bodies, args.diagnostics, args.frames, contact_force=True)
    # (the points' fields in f32, as an f32 run hands them over; the bodies' stay f64)
    data = [(t, {k: v.astype(np.float32) if v.dtype == np.float64 else v for k, v in fields.items()}, diag, bodies)
            for t, fields, diag, bodies in data]
    specs = {**default_field_specs(), "contact_force": ((2,), "float")}
    switch = sys.getswitchinterval()
    with tempfile.TemporaryDirectory() as tmp:
        pool = ThreadPoolExecutor(max_workers=1)
        children = [WriterProcess() for _ in range(args.processes)]
        kwargs = [{"particle_count": args.points, "attrs": {"precision": "f32"},
                   "csv_path": Path(tmp) / f"w{k}" / "e.csv", "body_count": args.bodies, "field_specs": specs,
                   "body_geometry": geometry(args.bodies), "sidecar_interval": args.sidecar_interval}
                  for k in range(args.worlds)]
        for k in range(args.worlds):
            (Path(tmp) / f"w{k}").mkdir()
        writers = ([children[k % len(children)].open(Path(tmp) / f"w{k}" / "run.h5", **kwargs[k])
                    for k in range(args.worlds)] if children else
                   [BackgroundFrameWriter(FrameWriter(Path(tmp) / f"w{k}" / "run.h5", **kwargs[k]), pool=pool)
                    for k in range(args.worlds)])
        if args.switch_interval:
            sys.setswitchinterval(args.switch_interval)
        try:
            start = time.perf_counter()
            for t, fields, diag, body_fields in data:
                busy(1e-3 * args.record_ms)
                for w in writers:
                    w.write_frame(t, fields, diag, body_fields=body_fields)
                for _ in range(args.launches):
                    time.sleep(1e-3 * args.step_ms / args.launches)
            for w in writers:
                w.set_status("completed")
                w.close()
            wall = time.perf_counter() - start
        finally:
            sys.setswitchinterval(switch)
            pool.shutdown(wait=True)
            for child in children:
                child.close()
    row = {"bench": "batch_host", "tag": args.tag,
           "writer": f"{args.processes} processes" if args.processes else "thread", "worlds": args.worlds,
           "points": args.points,
           "bodies": args.bodies, "diagnostics": args.diagnostics, "frames": args.frames,
           "record_ms": args.record_ms, "step_ms": args.step_ms, "launches": args.launches,
           "switch_interval": args.switch_interval or switch, "sidecar_interval": args.sidecar_interval,
           "seconds_per_frame": wall / args.frames,
           "floor_s_per_frame": 1e-3 * (args.record_ms + args.step_ms)}
    print(json.dumps(row), flush=True)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "a") as f:
            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
