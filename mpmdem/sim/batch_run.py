"""BatchedSimulation: independent runs of one kind advanced as one simulation (one set of launches
per step), each world written and checked as if it ran alone.

The worlds are tiled along x in one grid (``mpmdem.sim.batch_scene``). Each world gets its own
HDF5 file, energy.csv and diagnostics, in its own coordinates (the offset taken off), through the
same writer as a lone run (``mpmdem.io.writer``); ``WorldView`` gives a case's ``summarize`` what
it reads of a Simulation, for one world. Which diagnostics are per world, and which are the
batch's: ``mpmdem.sim.world_diagnostics``.

One dt for the batch: the smallest of the worlds' bounds, as the device reduces it over every
point. With a fixed dt (``SolverConfig.dt``) world 0 is, on the CPU, bit for bit its lone run, and
world w bit for bit the lone run of its scene translated by X_w on the batch's grid.

A blow-up stops one world, not the batch: the device's checks (NaN/inf, points leaving the
domain) and, at each frame, the energy check of each world and a check that its points stay
inside its own domain, name the world; its file is marked "blown-up" with the message, and the
batch starts again from t = 0 without it (the other worlds' files are written again, the same
frames as they would be without the failed world). Checks that no point can be traced to a world
(a granular node out of layers, overflowing contact lists) fail every world still running, marked
``batch_wide`` (``RunResult.extra``): a study runs each of them again alone.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import BlowUpError, InputError
from ..model.config import SolverConfig
from ..model.scene import Scene
from .batch_scene import STENCIL_CELLS, World, combine_scenes
from .diagnostics import EnergyBalance, check_energy
from .simulation import RunResult, Simulation, frame_time
from .tuning import Tuning
from .world_diagnostics import (
    HostArrays,
    WorldPoints,
    body_rows,
    frame_arrays,
    launch_point_sums,
    world_diagnostics,
)

__all__ = ["LEFT_TILE", "BatchedSimulation", "WorldView"]

#: what the message of a world whose points left its own domain says
LEFT_TILE = "left the world's domain"


class WorldView:
    """What a case's ``summarize(sim, result, args)`` reads of a Simulation, for one world of a
    batch: its scene, config, device, counts, and its point and body fields in its own coordinates."""

    def __init__(self, batch: BatchedSimulation, world: World):
        self._batch, self.world = batch, world
        sim = batch.sim
        self.scene, self.config, self.device, self.tuning = world.scene, sim.config, sim.device, sim.tuning
        self.model = world.scene
        self.coupling = sim.coupling
        self.particle_count = world.points.stop - world.points.start
        self.body_count = len(world.bodies)
        self.last_diagnostics: dict[str, float] = {}

    def fields(self) -> dict[str, np.ndarray]:
        """Host copies of the world's per-point fields (its own coordinates and body indices)."""
        if self.particle_count == 0:
            raise InputError("fields", "points", "a scene with material points (use body_fields for rigid bodies)")
        return self._batch.point_fields(self.world)

    def body_fields(self) -> dict[str, np.ndarray]:
        """Host copies of the world's per-body fields (its own coordinates, its scene's order)."""
        if self.body_count == 0:
            raise InputError("body_fields", "bodies", "a scene with rigid bodies")
        return self._batch.body_fields(self.world)

    def diagnostics(self) -> dict[str, float]:
        """The world's diagnostics at its last frame."""
        return dict(self.last_diagnostics)

    @property
    def time(self) -> float:
        """The batch's time [s]."""
        return self._batch.sim.time


def _geometry(geo: dict, idx: np.ndarray, prefix: str) -> dict:
    """The static body data of ``DEMSolver.scene_geometry`` for the bodies ``idx`` (names unprefixed)."""
    start, count = geo["vertex_start"][idx], geo["vertex_count"][idx]
    out = {"vertex_start": np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int32), "vertex_count": count,
           "vertices": np.concatenate([geo["vertices"][s:s + c] for s, c in zip(start, count, strict=True)]
                                      or [np.zeros((0, 2))])}
    for key in ("radius", "motion", "mass", "grain"):
        if key in geo:
            out[key] = geo[key][idx]
    out["name"] = [geo["name"][k].removeprefix(prefix) for k in idx]
    return out


class BatchedSimulation:
    """Advance the worlds ``scenes`` (one SolverConfig) as one simulation.

    Args:
        scenes: the worlds; they must share what the kernels specialise on (``batch_scene.batch_key``).
        config, device, tuning: as ``Simulation``'s, for every world.
        offsets: X_w [m] per world (default ``batch_scene.tile_offsets``).
    """

    def __init__(self, scenes: list[Scene], config: SolverConfig | None = None, *, device: str | None = None,
                 tuning: Tuning | None = None, offsets: list[float] | None = None):
        self.scenes = list(scenes)
        self.config = config or SolverConfig()
        self.combined, self.layout = combine_scenes(self.scenes, [self.config] * len(self.scenes), offsets=offsets)
        self.sim = Simulation(self.combined, self.config, device=device, tuning=tuning)
        self._points = ({w.index: WorldPoints(self.sim.mpm, w) for w in self.layout.worlds}
                        if self.sim.mpm is not None else {})
        self._body_rows = ({w.index: body_rows(self.sim.dem, w) for w in self.layout.worlds}
                           if self.sim.dem is not None else {})
        self._frame_fields: dict | None = None
        self._frame_bodies: dict | None = None

    @property
    def worlds(self) -> tuple[World, ...]:
        """The worlds, in order."""
        return self.layout.worlds

    def view(self, k: int) -> WorldView:
        """World k as a Simulation-like view for ``summarize``."""
        return WorldView(self, self.layout.worlds[k])

    # -- per-world fields ------------------------------------------------------------------------
    def point_fields(self, world: World, copy: bool = True) -> dict[str, np.ndarray]:
        """World's point fields, in its own coordinates (copied once per frame from the device).
        ``copy=False``: views of this frame's host copy where the values need no change (the frame's
        writing and checks, which only read them)."""
        out = {k: v[world.points].copy() if copy else v[world.points] for k, v in self._batch_points().items()}
        out["x"] = out["x"].copy() if not copy else out["x"]  # (x changes: never a view)
        out["x"][:, 0] -= world.offset
        out["body"] = out["body"] - sum(len(w.scene.bodies) for w in self.worlds[:world.index])
        return out

    def body_fields(self, world: World) -> dict[str, np.ndarray]:
        """World's body fields, in its own coordinates and its scene's order."""
        out = {k: v[world.bodies] for k, v in self._batch_bodies().items()}  # (copies: ``bodies`` is an index array)
        out["x"][:, 0] -= world.offset
        return out

    def _batch_points(self) -> dict[str, np.ndarray]:
        """This frame's point fields of the whole batch, in its coordinates (read from the device once a frame)."""
        if self._frame_fields is None:
            self._frame_fields = self.sim.mpm.fields()
        return self._frame_fields

    def _batch_bodies(self) -> dict[str, np.ndarray]:
        """This frame's body fields of the whole batch, in its coordinates (read from the device once a frame)."""
        if self._frame_bodies is None:
            self._frame_bodies = self.sim.dem.fields()
        return self._frame_bodies

    def _fresh_frame(self) -> None:
        self._frame_fields = self._frame_bodies = None

    # -- checks -----------------------------------------------------------------------------------
    def stray_worlds(self, fresh: bool = True, time: float | None = None) -> dict[int, str]:
        """World → why it failed, for worlds with non-finite points or bodies, points that left their
        own domain or, without walls between the tiles (``WorldLayout.walls``), came within
        ``STENCIL_CELLS`` cells of its left or right wall, or free bodies whose centroid left it.
        ``fresh``: read the device again (False: the fields of the frame just written, at ``time``
        [s]; None: the device's)."""
        if fresh:
            self._fresh_frame()
        now = self.sim.time if time is None else time
        bad = {}
        for w in self.worlds:
            (x0, y0), (x1, y1) = w.domain
            if self.sim.mpm is not None and w.points.stop > w.points.start:
                # (views of the frame's fields, in the batch's coordinates: x shifted by the world's
                # offset, whose finiteness is x's)
                points = self._batch_points()
                xs, v = points["x"][w.points], points["v"][w.points]
                if self.sim.mpm.staged:  # (points not released yet are written as NaN)
                    live = ~(self.sim.mpm.release_times[w.points] > now)
                    xs, v = xs[live], v[live]
                if not (np.isfinite(xs).all() and np.isfinite(v).all()):
                    bad[w.index] = f"{int((~np.isfinite(xs).all(1)).sum())} points have NaN/inf values"
                    continue
                # (a wall acts on the nodes of its side: a point whose stencil reaches them feels it,
                # which is right only where the tile has the world's walls)
                reach = 0.0 if self.layout.walls else STENCIL_CELLS * self.combined.cell_size
                lo = x0 + (reach if w.scene.boundaries["left"].kind != "free" else 0.0)
                hi = x1 - (reach if w.scene.boundaries["right"].kind != "free" else 0.0)
                out = (xs[:, 0] < lo) | (xs[:, 0] > hi) | (xs[:, 1] < y0) | (xs[:, 1] > y1)
                if out.any():
                    bad[w.index] = (f"{int(out.sum())} points {LEFT_TILE}" if self.layout.walls else
                                    f"{int(out.sum())} points {LEFT_TILE} or came within {STENCIL_CELLS} cells of "
                                    "its left or right wall (a batch of worlds of different widths has no walls "
                                    "between them: run it alone)")
                    continue
            if self.sim.dem is not None and len(w.bodies):
                # (the batch's coordinates, as for the points)
                b = {k: self._batch_bodies()[k][w.bodies] for k in ("x", "v", "angle", "omega")}
                if not all(np.isfinite(values).all() for values in b.values()):
                    bad[w.index] = "a rigid body has NaN/inf values"
                    continue
                free = np.array([r.motion == "free" for r in w.scene.rigid_bodies]
                                + [True] * sum(len(g) for g in w.scene.grains), bool)
                xb = b["x"][free]
                gone = (xb[:, 0] < x0) | (xb[:, 0] > x1) | (xb[:, 1] < y0) | (xb[:, 1] > y1)
                if gone.any():
                    bad[w.index] = f"{int(gone.sum())} free bodies {LEFT_TILE}"
        return bad

    def _beyond_tile(self, why: str) -> bool:
        """Whether a world failed for what only the batch lacks (``stray_worlds``' reason ``why``): its
        points left its tile without walls between the tiles (alone, its walls would have held
        them). With walls, a world whose points leave its domain fails alone too."""
        return LEFT_TILE in why and not self.layout.walls

    # -- running ----------------------------------------------------------------------------------
    def run(self, end_time: float, *, outs: list[str | Path | None] | None = None, frames: int = 20,
            names: list[str] | str = "run", attrs: dict | None = None,
            progress: Callable[[float, float], None] | None = None) -> list[RunResult]:
        """Run every world to ``end_time`` [s] with ``frames`` frames; world k writes ``outs[k]/<name>.h5``
        and ``energy.csv`` as a lone run does. Returns one RunResult per world ("completed" or
        "blown-up" with its message; never raises BlowUpError). A KeyboardInterrupt marks the files of
        the worlds still running "interrupted" and is re-raised; the files of finished worlds stay."""
        if not (isinstance(end_time, (int, float)) and math.isfinite(end_time) and end_time > 0):
            raise InputError("end_time", end_time, "a positive time in seconds")
        if not (isinstance(frames, int) and frames >= 1):
            raise InputError("frames", frames, "an integer >= 1")
        n = len(self.worlds)
        outs = list(outs) if outs is not None else [None] * n
        names = [names] * n if isinstance(names, str) else list(names)
        if len(outs) != n or len(names) != n:
            raise InputError("outs", len(outs), f"one output folder and name per world ({n})")
        results: dict[int, RunResult] = {}
        live = list(range(n))
        batch = self
        offsets = [w.offset for w in self.worlds]
        while True:
            failed = batch._attempt(end_time, [outs[k] for k in live], frames, [names[k] for k in live], attrs,
                                    progress, results, live)
            if not failed:
                break
            live = [k for k in live if k not in failed]
            if not live:
                break
            batch = BatchedSimulation([self.scenes[k] for k in live], self.config, device=self.sim.device,
                                      tuning=self.sim.tuning, offsets=[offsets[k] for k in live])
        #: the batch of the last pass, and each world's view in it (for ``summarize``)
        self.last_batch = batch
        self.views = {k: batch.view(j) for j, k in enumerate(live)}
        for k, view in self.views.items():
            view.last_diagnostics = {name: float(v[-1]) for name, v in results[k].diagnostics.items() if len(v)}
        return [results[k] for k in range(n)]

    def _writer(self, world: World, out, name: str, end_time: float, attrs: dict | None, pool=None, child=None):
        """World ``world``'s writer: a ``BackgroundFrameWriter`` on ``pool``, or a file of ``child``
        (a ``WriterProcess``)."""
        from ..io import FrameWriter, default_field_specs
        from ..io.background import BackgroundFrameWriter

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        sim = self.sim
        meta = {"version": __version__, "device": sim.device, "precision": self.config.precision,
                "scene": world.scene.to_dict(), "config": self.config.to_dict(), "end_time": end_time,
                **(attrs or {}), "batch": {"world": world.index, "worlds": len(self.worlds), "offset": world.offset}}
        specs = {**default_field_specs(), "contact_force": ((2,), "float")} if sim.coupling is not None else None
        geometry = None
        if sim.dem is not None:
            geometry = _geometry(sim.dem.scene_geometry(), world.bodies, f"w{world.index}_")
        kwargs = {"particle_count": world.points.stop - world.points.start, "attrs": meta,
                  "csv_path": out / "energy.csv", "body_count": len(world.bodies), "field_specs": specs,
                  "body_geometry": geometry, "sidecar_interval": self.sim.tuning.batch_sidecar_interval}
        if child is not None:
            return child.open(out / f"{name}.h5", **kwargs)
        return BackgroundFrameWriter(FrameWriter(out / f"{name}.h5", **kwargs), pool=pool)

    def _attempt(self, end_time, outs, frames, names, attrs, progress, results, ids) -> set[int]:
        """One pass from t = 0 over the worlds of this batch (``ids``: their numbers in the caller's
        batch); fills ``results`` for the worlds that end; returns those (by caller's number) that failed.
        The worlds' frames are written in one shared thread (``BackgroundFrameWriter``'s pool), or with
        ``Tuning.batch_writer_processes`` by child processes (``mpmdem.io.writer_process``), world k's
        by child k mod N."""
        from ..io.background import thread_switch_interval

        writing = sum(o is not None for o in outs)
        processes = min(self.sim.tuning.batch_writer_processes, writing)
        if processes:
            from contextlib import ExitStack

            from ..io.writer_process import WriterProcess

            with ExitStack() as stack:
                # (their feeder threads get Python's lock back sooner from a busy main thread, as the
                # writer thread does)
                stack.enter_context(thread_switch_interval(self.sim.tuning.writer_switch_interval))
                children = [stack.enter_context(WriterProcess()) for _ in range(processes)]
                self.sim._capture()  # (the kernels load and the graphs are recorded while the children start)
                return self._attempt_in(children, end_time, outs, frames, names, attrs, progress, results, ids)
        pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mpmdem-batch-frames")
        # (the writer thread gets Python's lock back sooner from a busy main thread: io.background)
        switch = self.sim.tuning.writer_switch_interval if writing else 0.0
        try:
            with thread_switch_interval(switch):
                return self._attempt_in(pool, end_time, outs, frames, names, attrs, progress, results, ids)
        finally:
            pool.shutdown(wait=True)

    def _attempt_in(self, pool, end_time, outs, frames, names, attrs, progress, results, ids) -> set[int]:
        sim = self.sim
        worlds = self.worlds

        def where(k: int) -> dict:  # (``pool``: a thread pool, or the writer processes, dealt in turn)
            return {"child": pool[k % len(pool)]} if isinstance(pool, list) else {"pool": pool}

        writers = {w.index: self._writer(w, outs[w.index], names[w.index], end_time, attrs, **where(k))
                   if outs[w.index] is not None else None for k, w in enumerate(worlds)}
        paths = {w.index: Path(outs[w.index]) / f"{names[w.index]}.h5" if outs[w.index] is not None else None
                 for w in worlds}
        balances = {w.index: EnergyBalance(sim.stage.WORK_TERMS) for w in worlds}
        history = {w.index: {} for w in worlds}
        times: list[float] = []
        start_wall = _time.perf_counter()
        views = {w.index: WorldView(self, w) for w in worlds}
        failed: dict[int, str] = {}

        def fail(k: int, message: str, t: float, left_tile: bool = False, batch_wide: bool = False) -> None:
            failed[k] = message
            if writers[k] is not None:
                writers[k].set_status("blown-up", message)
                writers[k].close()
            h = history[k]
            results[ids[k]] = RunResult(paths[k], np.array(times[:len(h.get("dt", []))]),
                                        {key: np.array(v) for key, v in h.items()}, "blown-up",
                                        int(h["steps"][-1]) if h.get("steps") else 0, message,
                                        extra={"left_tile": left_tile, "batch_wide": batch_wide})

        def record(t: float, steps: int, dt: float, bound: float, t_next: float | None) -> None:
            # (every device read first: the batch's sums, the arrays of each world's sums and the
            # fields, at the frame's time t; then the next frame's first steps go, and the host sums
            # each world's diagnostics from its copies (``HostArrays``, sealed: no read after the
            # launch), checks and writes the frame while they run. A world that fails the checks ends
            # this pass, whose device state is dropped: the next pass starts again from t = 0,
            # without it.)
            self._fresh_frame()
            batch_d = sim.stage.diagnostics()
            for w in worlds if sim.mpm is not None else ():
                launch_point_sums(sim.mpm, self._points[w.index], t)
            host = HostArrays()  # (each device array read back once this frame, for every world,
            host.prefetch(frame_arrays(sim, worlds, self._points))  # all after one wait)
            # (read for the stray-world check below too, with or without files)
            frame = {w.index: (self.point_fields(w, copy=False) if sim.mpm else {},
                               self.body_fields(w) if sim.dem else None) for w in worlds}
            host.seal()
            if t_next is not None:
                sim.launch_ahead(t, t_next, dt)
            sums = {w.index: world_diagnostics(sim, w, self._points.get(w.index), batch_d, host, t,
                                               launched=sim.mpm is not None, bodies=self._body_rows.get(w.index))
                    for w in worlds}
            diags, failures = {}, {}
            for w in worlds:
                d = balances[w.index].update(sums[w.index])
                d.update(dt=dt, dt_bound=bound, steps=float(steps), wall_time=_time.perf_counter() - start_wall)
                diags[w.index] = d
                try:
                    check_energy(w.scene, self.config, t, d, balances[w.index].initial,
                                 lambda: sim.stage.likely_cause(dt, bound))
                except BlowUpError as e:
                    failures[w.index] = (f"world {ids[w.index]}: {e}", False)
            for k, why in self.stray_worlds(fresh=False, time=t).items():
                if k not in failures:
                    failures[k] = (f"world {ids[k]}: {why} at t = {t:.6g} s", self._beyond_tile(why))
            times.append(t)
            for w in worlds:
                d = diags[w.index]
                views[w.index].last_diagnostics = d
                for key, v in d.items():
                    history[w.index].setdefault(key, []).append(v)
                if writers[w.index] is not None:
                    fields, body_fields = frame[w.index]
                    writers[w.index].write_frame(t, fields, d, body_fields=body_fields)
            for k, (message, left_tile) in failures.items():
                fail(k, message, t, left_tile=left_tile)

        ended = False
        try:
            start = sim.stage.read_clock()
            t_start = start.t
            record(start.t, start.steps, *sim.initial_step(), frame_time(t_start, end_time, 1, frames))
            for k in range(1, frames + 1):
                if failed:
                    break
                try:
                    t, steps = sim.advance_to(frame_time(t_start, end_time, k, frames), on_batch=progress)
                except BlowUpError as e:
                    stray = self.stray_worlds()
                    for j, why in stray.items():
                        fail(j, f"world {ids[j]}: {why}", e.time, left_tile=self._beyond_tile(why))
                    if not stray:  # (a check of the whole batch that no world can be named for)
                        for w in worlds:
                            fail(w.index, f"the batch of {len(worlds)} worlds (world {ids[w.index]} is one): {e}",
                                 e.time, batch_wide=True)
                    break
                clock = sim.stage.read_clock()
                record(t, steps, clock.dt, clock.bound,
                       frame_time(t_start, end_time, k + 1, frames) if k < frames else None)
            else:
                ended = True
        except KeyboardInterrupt as e:
            for k, writer in writers.items():
                if writer is not None and k not in failed:
                    writer.set_status("interrupted", str(e) or "stopped by the user (Ctrl-C)")
                    writer.close()
            raise
        except BaseException:
            for k, writer in writers.items():
                if writer is not None and k not in failed:
                    writer.close()
            raise
        if failed and not ended:
            for k, writer in writers.items():  # (written again by the next pass)
                if writer is not None and k not in failed:
                    writer.close()
            return {ids[k] for k in failed}
        for w in worlds:
            if w.index in failed:
                continue
            if writers[w.index] is not None:
                writers[w.index].set_status("completed", "")
                writers[w.index].close()
            h = history[w.index]
            results[ids[w.index]] = RunResult(paths[w.index], np.array(times),
                                              {key: np.array(v) for key, v in h.items()}, "completed",
                                              int(h["steps"][-1]), "")
        return set()
