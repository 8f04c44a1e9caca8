"""What writing a frame of a run file costs on the host (issue 46: a batched study's writer threads).

Writes ``--frames`` frames of ``--points`` MPM points (the default particle fields) and
``--bodies`` rigid bodies with ``--diagnostics`` scalar diagnostics through ``mpmdem.io.FrameWriter``
into a temporary folder, once per sidecar interval of ``--intervals`` (0: the XDMF sidecars are
rewritten after every frame; 1: at most once a second, the default), ``--writers`` writers at once,
each in its own thread as ``BackgroundFrameWriter`` does in a batched study. The arrays are made
before the clock starts; what is timed is ``write_frame`` of every frame and ``close``.

One JSON line per interval: points, bodies, diagnostics, frames, writers, sidecar_interval [s],
seconds_per_frame (wall time over the frames of one writer), cpu_seconds_per_frame (the CPU time of
its thread, less disturbed by other processes than the wall time), sidecar_rewrites (``XdmfSidecars.write``
calls of one writer), sidecar_seconds and append_seconds (the part of one writer's time in those
rewrites and in its dataset appends, ``_Appender.append``: one per diagnostic, particle field, body
field and the time per frame, timed by wrapping them), and main_wait_ms (mean, p95) with
main_wait_idle_ms: while the writers write, the main thread sleeps 1 ms at a time, as a run's main
thread waits for the device with Python's lock released, and records how much later than 1 ms it
runs again (the wait for the lock a writer holds), against the same before the writers start.
``--main busy``: the main thread instead runs Python without a pause until the writers end (as a
batch's main thread does while it reads a frame's sums and checks the worlds): h5py lets Python's
lock go around each HDF5 write, and a writer that wants it back waits for the busy thread to give
it up, at most ``sys.getswitchinterval()`` later (``--switch-interval``; Python's default 5 ms);
``main_busy_share`` is the busy thread's progress against its rate alone. The files are the same
whatever the flags. Nothing is asserted.

    python bench/frame_writing.py                              # 38k points, 80 frames, 90 diagnostics
    python bench/frame_writing.py --writers 5 --out bench/results/frame_writing/cpu.jsonl
    python bench/frame_writing.py --points 8192 --bodies 5 --diagnostics 45 --frames 60 --intervals 1 --main busy
"""

from __future__ import annotations

import argparse
import inspect
import json
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from mpmdem.io import FrameWriter, writer, xdmf


def frame_data(points: int, bodies: int, diagnostics: int, frames: int, contact_force: bool = False) -> list[tuple]:
    """Per frame (time [s], particle fields, diagnostics, body fields) of made-up values; with
    ``contact_force`` the coupled runs' extra particle field of that name."""
    rng = np.random.default_rng(0)
    out = []
    for k in range(frames):
        fields = {"x": rng.random((points, 2)), "v": rng.random((points, 2)), "stress": rng.random((points, 2, 2)),
                  "volume": rng.random(points), "mass": rng.random(points),
                  "F": rng.random((points, 2, 2)), "body": np.zeros(points, np.int32)}
        if contact_force:
            fields["contact_force"] = rng.random((points, 2))
        body_fields = {"x": rng.random((bodies, 2)), "angle": rng.random(bodies), "v": rng.random((bodies, 2)),
                       "omega": rng.random(bodies), "force": rng.random((bodies, 2)), "torque": rng.random(bodies)}
        diag = {f"diagnostic_{j:03d}": float(rng.random()) for j in range(diagnostics)}
        out.append((1e-3 * k, fields, diag, body_fields))
    return out


def geometry(bodies: int) -> dict:
    """Unit squares of radius 1 mm, free, 1 kg/m each."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return {"vertex_start": 4 * np.arange(bodies), "vertex_count": np.full(bodies, 4),
            "vertices": np.tile(square, (bodies, 1)), "radius": np.full(bodies, 1e-3),
            "motion": np.zeros(bodies, np.int32), "mass": np.ones(bodies), "name": [f"b{i}" for i in range(bodies)]}


class Timed:
    """Wraps ``owner.name`` so that its calls are counted and timed (per thread) while in use."""

    def __init__(self, owner: type, name: str) -> None:
        self.owner, self.name, self.original = owner, name, getattr(owner, name)
        self.local = threading.local()
        original, local = self.original, self.local

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                local.seconds = getattr(local, "seconds", 0.0) + time.perf_counter() - start
                local.calls = getattr(local, "calls", 0) + 1

        setattr(owner, name, timed)

    def take(self) -> tuple[int, float]:
        """(calls, seconds) of this thread so far, then zero."""
        out = (getattr(self.local, "calls", 0), getattr(self.local, "seconds", 0.0))
        self.local.calls, self.local.seconds = 0, 0.0
        return out

    def restore(self) -> None:
        setattr(self.owner, self.name, self.original)


def write_run(folder: Path, data: list[tuple], points: int, bodies: int, interval: float | None,
              timers: tuple[Timed, Timed], result: dict) -> None:
    """Write ``data`` as one run file in ``folder``; store its wall time and timer totals in ``result``."""
    kwargs = {} if interval is None else {"sidecar_interval": interval}
    w = FrameWriter(folder / "run.h5", particle_count=points, attrs={"precision": "f32"}, csv_path=folder / "e.csv",
                    body_count=bodies, body_geometry=geometry(bodies) if bodies else None, **kwargs)
    for timer in timers:
        timer.take()
    start, cpu = time.perf_counter(), time.thread_time()
    for t, fields, diag, body_fields in data:
        w.write_frame(t, fields, diag, body_fields if bodies else None)
    w.close()
    result["seconds"], result["cpu_seconds"] = time.perf_counter() - start, time.thread_time() - cpu
    (result["sidecar_rewrites"], result["sidecar_seconds"]), (_, result["append_seconds"]) = (
        timers[0].take(), timers[1].take())


def wake_delays(until) -> list[float]:
    """Sleep 1 ms at a time until ``until()`` is true; how much later than 1 ms each sleep returned [s]."""
    out = []
    while not until():
        start = time.perf_counter()
        time.sleep(1e-3)
        out.append(time.perf_counter() - start - 1e-3)
    return out


def spin(until) -> int:
    """Run Python without a pause until ``until()`` is true; the loop's count."""
    n = 0
    while not until():
        for _ in range(1000):
            n += 1
    return n


def spin_rate(seconds: float = 0.3) -> float:
    """``spin``'s count per second with no other thread running."""
    start = time.perf_counter()
    return spin(lambda: time.perf_counter() > start + seconds) / (time.perf_counter() - start)


def main() -> None:
    """Parse the flags, write the runs, print (and append to --out) one JSON line per interval."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=38000)
    p.add_argument("--bodies", type=int, default=4)
    p.add_argument("--diagnostics", type=int, default=90)
    p.add_argument("--frames", type=int, default=80)
    p.add_argument("--writers", type=int, default=1, help="writers at once, one thread each")
    p.add_argument("--intervals", default="0,1", help="sidecar intervals [s], comma-separated")
    p.add_argument("--main", choices=("sleep", "busy"), default="sleep",
                   help="what the main thread does while the writers write: sleep 1 ms at a time, or run Python")
    p.add_argument("--switch-interval", type=float, default=None,
                   help="sys.setswitchinterval [s] while the writers write (default Python's)")
    p.add_argument("--tag", default="", help="a label stored in each line (the tree measured, say)")
    p.add_argument("--out", type=Path, help="append the JSON lines to this file")
    args = p.parse_args()
    has_interval = "sidecar_interval" in inspect.signature(FrameWriter).parameters
    intervals = [float(s) for s in args.intervals.split(",")] if has_interval else [None]
    data = frame_data(args.points, args.bodies, args.diagnostics, args.frames)
    timers = (Timed(xdmf.XdmfSidecars, "write"), Timed(writer._Appender, "append"))
    rows = []
    try:
        for interval in intervals:
            results = [{} for _ in range(args.writers)]
            with tempfile.TemporaryDirectory() as tmp:
                folders = [Path(tmp) / str(i) for i in range(args.writers)]
                for folder in folders:
                    folder.mkdir()
                threads = [threading.Thread(target=write_run, args=(folder, data, args.points, args.bodies, interval,
                                                                     timers, result))
                           for folder, result in zip(folders, results, strict=True)]
                stop = time.perf_counter() + 0.3
                idle = wake_delays(lambda stop=stop: time.perf_counter() > stop)
                rate = spin_rate() if args.main == "busy" else None
                switch = sys.getswitchinterval()
                if args.switch_interval is not None:
                    sys.setswitchinterval(args.switch_interval)
                started = time.perf_counter()
                for thread in threads:
                    thread.start()
                try:
                    if args.main == "busy":
                        spun = spin(lambda threads=threads: not any(t.is_alive() for t in threads))
                        busy = [0.0]
                    else:
                        busy = wake_delays(lambda threads=threads: not any(t.is_alive() for t in threads))
                    for thread in threads:
                        thread.join()
                finally:
                    sys.setswitchinterval(switch)
                share = spun / (time.perf_counter() - started) / rate if rate else None
            mean = {k: float(np.mean([r[k] for r in results])) for k in results[0]}
            rows.append({"bench": "frame_writing", "tag": args.tag, "points": args.points, "bodies": args.bodies,
                         "diagnostics": args.diagnostics, "frames": args.frames, "writers": args.writers,
                         "sidecar_interval": 0.0 if interval is None else interval,
                         "seconds_per_frame": mean["seconds"] / args.frames,
                         "cpu_seconds_per_frame": mean["cpu_seconds"] / args.frames,
                         "sidecar_rewrites": mean["sidecar_rewrites"], "sidecar_seconds": mean["sidecar_seconds"],
                         "append_seconds": mean["append_seconds"],
                         "main_wait_ms": [1e3 * float(np.mean(busy)), 1e3 * float(np.percentile(busy, 95))],
                         "main_wait_idle_ms": 1e3 * float(np.mean(idle)), "main": args.main,
                         "main_busy_share": share, "switch_interval": args.switch_interval or switch})
    finally:
        for timer in timers:
            timer.restore()
    for row in rows:
        line = json.dumps(row)
        print(line, flush=True)
        if args.out is not None:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            with open(args.out, "a") as f:
                f.write(line + "\n")


if __name__ == "__main__":
    main()
