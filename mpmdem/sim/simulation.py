"""Simulation: the coordinator that advances a Scene in explicit steps and writes its results.

It finishes the scene first (``Scene.finalize``: the whole-scene checks, the seeded points and the
DEM bodies' columns, once) and builds its stages from that ``Model``.

A scene runs only the stages it uses: the MPM stage (material points on a grid; dt from the CFL
bound on the device), the DEM stage (rigid spheropolygons; dt from MPM-SDEM eq. 51's DEM term),
or both, coupled through identified material points (``mpmdem.sim.coupling``: DEM contacts and
point–body forces → MPM → rigid-body update in each step, one dt from eq. 51).

The Simulation owns the run's ``Clock`` and passes it to the stages it builds; it drives the
stage of a step through the ``Stage`` protocol (``mpmdem.sim.stage``). It prints nothing: progress
bars and Ctrl-C handling belong to the command line (``mpmdem.study.runner``, ``mpmdem.study.run_progress``).
"""

from __future__ import annotations

import contextlib
import json
import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import warp as wp

from .. import __version__
from ..errors import BlowUpError, InputError
from ..kernels.clock import ROUND_OFF
from ..model.config import SolverConfig
from ..model.scene import Scene
from . import device_turns
from .auto_sort import AutoSort, auto_sort_applies
from .dem import DEMSolver
from .diagnostics import EnergyBalance, check_energy
from .host_copy import host_copy
from .mpm import MPMSolver
from .stage import Clock, Stage
from .tuning import Tuning
from .warp_init import check_device, init_warp

__all__ = ["RunResult", "Simulation", "default_device"]


def frame_time(t_start: float, end_time: float, k: int, frames: int) -> float:
    """The time [s] of frame k of ``frames`` from t_start to end_time (the last one exactly end_time)."""
    return end_time if k == frames else t_start + (end_time - t_start) * k / frames


def default_device() -> str:
    """"cuda" when a CUDA device is present, else "cpu"."""
    init_warp()
    return "cuda" if wp.get_cuda_device_count() > 0 else "cpu"


@dataclass
class RunResult:
    """What ``Simulation.run`` returns.

    Attributes:
        path: the HDF5 file (None when no output directory was given).
        times: frame times [s].
        diagnostics: name → per-frame values (energies J/m, momenta, dt s, wall time s...).
        status: "completed", "blown-up" or "interrupted".
        steps: explicit steps taken.
    """

    path: Path | None
    times: np.ndarray
    diagnostics: dict[str, np.ndarray]
    status: str
    steps: int
    message: str = ""
    extra: dict = field(default_factory=dict)


class Simulation:
    """Advance a Scene with a SolverConfig on one device.

    Args:
        scene: what to simulate.
        config: discretisation choices (default SolverConfig()).
        device: "cpu", "cuda" or "cuda:N"; None picks the GPU when there is one.
        tuning: how the stages compute (kernel variants, thread counts, fused launches; default
            ``Tuning()``): the same results whatever it is, to round-off (``mpmdem.sim.tuning``).
    """

    def __init__(self, scene: Scene, config: SolverConfig | None = None, *, device: str | None = None,
                 tuning: Tuning | None = None):
        self.scene = scene
        self.config = config or SolverConfig()
        if tuning is not None and not isinstance(tuning, Tuning):
            raise InputError("tuning", tuning, "a mpmdem.Tuning, or None for the defaults")
        #: the performance knobs every stage reads
        self.tuning = tuning or Tuning()
        init_warp()
        device = device or default_device()
        check_device(device)
        try:
            wp.get_device(device)
        except Exception:
            allowed = ", ".join(str(d) for d in wp.get_devices())
            raise InputError("device", device, f"one of {allowed}") from None
        self.device = str(wp.get_device(device))
        #: the turns this run takes on its device beside other runs of this process (built inside
        #: ``DeviceTurns.turn``: ``mpmdem.sim.device_turns``), else None
        self.turns = device_turns.current(self.device)
        #: the finished scene every stage is built from: checked as a whole (points starting inside
        #: rigid bodies, overlapping bodies), points seeded and DEM bodies laid out, once, before any kernel
        self.model = model = scene.finalize()
        #: the time of the run, shared by every stage
        self.clock = Clock(self.device)
        self.mpm = (MPMSolver(model, self.config, self.device, clock=self.clock, tuning=self.tuning)
                    if model.has_mpm else None)
        self.dem = (DEMSolver(model, self.config, self.device, clock=self.clock, tuning=self.tuning)
                    if model.has_dem else None)
        # the dt policy of the stage that starts each step (with points, the MPM stage's CFL bound,
        # capped by the coupling's contact bound in a coupled step)
        (self.mpm or self.dem).start_clock(self.clock)
        self.coupling = None
        if self.mpm and self.dem:
            from .coupling import CoupledStage

            self.coupling = CoupledStage(model, self.config, self.device, self.mpm, self.dem, tuning=self.tuning)
        #: what one step runs
        self.stage: Stage = self.coupling or self.mpm or self.dem
        self._graph = None
        self._graph_many = None
        #: steps between two re-sorts of the points by cell in ``advance``; 0 when it never
        #: re-sorts on a schedule (sort_interval 0, or None: automatic)
        self.sort_interval = self.config.sort_interval or 0
        self._steps_since_sort = 0
        # sort_interval None: re-sort when the memory order has drifted, checked after the batches
        # of advance_to (mpmdem.sim.auto_sort; None where it does not apply: CPU, small or coupled scenes)
        tn = self.tuning
        self._auto_sort = AutoSort(self.mpm, tn.auto_sort_drift, tn.auto_sort_check_steps) if (
            self.mpm is not None and auto_sort_applies(self.config, tn, cuda=wp.get_device(self.device).is_cuda,
                                                       points=self.mpm.particle_count,
                                                       coupled=self.coupling is not None)) else None
        #: Granular MPM in CUDA graphs: the layouts of the relabel and rebuild blocks, conditional
        #: nodes or in line, chosen after the batches of advance_to from how often each runs
        #: (mpmdem.sim.block_layout); none elsewhere (every block runs in line)
        self.block_layouts = (self.mpm.block_layouts() if self.mpm is not None and self.config.cuda_graph
                              and wp.get_device(self.device).is_cuda and wp.is_conditional_graph_supported() else [])

    @property
    def particle_count(self) -> int:
        """Material points of the MPM stage (0 in a DEM-only scene)."""
        return self.mpm.particle_count if self.mpm else 0

    @property
    def body_count(self) -> int:
        """Rigid bodies of the DEM stage (0 in an MPM-only scene)."""
        return self.dem.body_count if self.dem else 0

    # -- stepping ---------------------------------------------------------------------------------
    def _capture(self) -> None:
        """Record one step, and ``tuning.steps_per_graph`` steps, as CUDA graphs (modules are loaded by
        a no-op step first). A step launches the same kernels whatever the state (its branches are on the
        device), so a graph of n copies replays exactly as n replays of the one-step graph, with one
        launch from the host instead of n."""
        if self._graph is not None or not self.config.cuda_graph or not wp.get_device(self.device).is_cuda:
            return
        t = self.stage.read_clock().t
        if self.tuning.module_load_workers:
            # (every module built so far, compiled side by side; one this step never launches may be
            # among them: if it cannot be built here, it is left for a launch, which says why)
            try:
                wp.force_load(self.device, max_workers=self.tuning.module_load_workers)
            except Exception:  # noqa: BLE001
                pass
        self.stage.set_stop_time(t)  # dt = 0: loads every module, changes nothing
        self.stage.step()
        if self.turns is not None:
            self.turns.wait()  # (this run's stream; the other runs' go on)
        else:
            wp.synchronize_device(self.device)
        self._record_graphs()

    def _record_graphs(self) -> None:
        """Record the one-step and the ``tuning.steps_per_graph``-step graphs (modules loaded); again
        when the step's layout changed (``block_layouts``): recording launches nothing."""
        with self.turns.capturing() if self.turns is not None else contextlib.nullcontext():
            with wp.ScopedCapture(device=self.device) as cap:
                self.stage.step()
            self._graph = cap.graph
            with wp.ScopedCapture(device=self.device) as cap:
                for _ in range(self.tuning.steps_per_graph):
                    self.stage.step()
            self._graph_many = cap.graph

    def advance(self, steps: int) -> None:
        """Launch ``steps`` explicit steps without any host synchronisation (with an explicit
        ``sort_interval`` N > 0, the points are re-sorted by cell every N steps, between two steps;
        the automatic re-sorting of the default runs only in ``advance_to``).

        A step past the stop time does nothing (the device's clock decides, without a host sync).
        The stop time is the last one ``advance_to``, ``run`` or ``launch_ahead`` set, or
        ``stage.set_stop_time``; a new Simulation has none ahead of its clock, so there ``advance`` alone
        moves nothing: call ``advance_to(t)`` to step to a time, or set a stop time first."""
        left = steps
        while left > 0:
            until_sort = self.sort_interval - self._steps_since_sort if self.mpm and self.sort_interval else left
            many = self.tuning.steps_per_graph
            if self._graph is not None and left >= many and until_sort >= many:
                wp.capture_launch(self._graph_many)
                n = many
            elif self._graph is not None:
                wp.capture_launch(self._graph)
                n = 1
            else:
                self.stage.step()
                n = 1
            left -= n
            self._steps_since_sort += n
            if self.mpm and self.sort_interval and self._steps_since_sort >= self.sort_interval:
                self.mpm.sort_points()
                self._steps_since_sort = 0

    def launch_ahead(self, t_now: float, t_stop: float, dt: float) -> int:
        """On a CUDA device: move the stop time to t_stop [s] and launch a share of the steps from
        t_now to it (``Tuning.launch_ahead_fraction`` of them; dt [s]: the last step's) without
        waiting for them, so that the host's work on the frame it has just read back runs while they
        do; ``advance_to(t_stop)`` goes on from where they end. The steps are the same as
        ``advance_to`` alone would take (a step's dt is set on the device; steps past t_stop do
        nothing). Returns the steps launched: 0 on the CPU, whose kernels run as they are launched."""
        if not wp.get_device(self.device).is_cuda or not (dt > 0.0 and t_stop > t_now):
            return 0
        self._capture()
        self.stage.set_stop_time(t_stop)
        steps = int(self.tuning.launch_ahead_fraction * (t_stop - t_now) / dt)
        if steps > 0:
            self.advance(steps)
        return steps

    def advance_to(self, t_stop: float, *, max_batch: int | None = None, on_batch=None) -> tuple[float, int]:
        """Step until the clock reaches t_stop [s]; checks stability after each batch of steps.

        With the automatic re-sorting (``mpmdem.sim.auto_sort``), also measures after a batch how far
        the points' memory order has drifted (after each batch, or at most every
        ``tuning.auto_sort_check_steps`` steps) and re-sorts them by cell when it passed ``tuning.auto_sort_drift``.

        Returns (time reached, steps taken). Raises BlowUpError on NaN/inf or escaped points.
        """
        self._capture()
        stage = self.stage
        stage.set_stop_time(t_stop)
        cuda = wp.get_device(self.device).is_cuda
        max_batch = max_batch or (400 if cuda else 25)
        clock = stage.read_clock()
        t, dt, steps = clock.t, clock.dt, clock.steps
        batch = 1
        while t < t_stop:
            self.advance(batch)
            if self.turns is not None:
                self.turns.wait()  # (the other runs of this process launch theirs meanwhile)
            clock = stage.read_clock()
            stage.check_status(clock.t, clock.dt, clock.bound, clock.status)
            t, dt, steps = clock.t, clock.dt, clock.steps
            if self._auto_sort is not None:
                self._auto_sort.after_batch(steps)
            if self._graph is not None and self.block_layouts:
                # (one copy of the counters they share; every layout reads its rate: no short-circuit)
                counts = host_copy(self.block_layouts[0].counters)
                if sum([layout.after_batch(steps, counts) for layout in self.block_layouts]):
                    self._record_graphs()
            if on_batch is not None:
                on_batch(t, dt)
            # the steps left, as the device counts them (kernels.clock.land): an idle
            # step past t_stop would leave dt = 0 in the frame's diagnostics
            est = (t_stop - t) / dt - ROUND_OFF if dt > 0 else 1
            batch = int(min(max_batch, max(1, math.ceil(est))))
            if dt <= 0.0 and t < t_stop:
                raise BlowUpError("stalled", f"time step became zero at t={t:.6g} s", t)
        return t, steps

    # -- running ----------------------------------------------------------------------------------
    def run(
        self,
        end_time: float,
        *,
        out: str | Path | None = None,
        frames: int = 20,
        progress: Callable[[float, float], None] | None = None,
        name: str = "run",
        attrs: dict | None = None,
    ) -> RunResult:
        """Run to ``end_time`` [s], writing ``frames`` frames (plus the initial one).

        With ``out``, writes OUT/<name>.h5 (+ the XDMF sidecars) and OUT/energy.csv frame by frame,
        flushed each frame (in a worker thread while the next frame's steps run: ``io.background``).
        A blow-up stops the run with BlowUpError after marking the file; a KeyboardInterrupt (Ctrl-C,
        or raised by ``progress``) marks the file "interrupted", closes it and is re-raised; any other
        error closes it and goes on. Either way the frames already written stay readable.

        The run prints nothing: ``progress(t, dt)`` [s], if given, is called after every batch of
        steps (several per frame), e.g. ``mpmdem.study.run_progress.Progress(end_time).update``.
        """
        if not (isinstance(end_time, (int, float)) and math.isfinite(end_time) and end_time > 0):
            raise InputError("end_time", end_time, "a positive time in seconds")
        if not (isinstance(frames, int) and frames >= 1):
            raise InputError("frames", frames, "an integer >= 1")
        writer = None
        path = None
        if out is not None:
            from ..io import FrameWriter
            from ..io.background import BackgroundFrameWriter

            out = Path(out)
            out.mkdir(parents=True, exist_ok=True)
            path = out / f"{name}.h5"
            meta = {
                "version": __version__, "device": self.device, "precision": self.config.precision,
                "scene": self.scene.to_dict(), "config": self.config.to_dict(), "end_time": end_time,
                **(attrs or {}),
            }
            specs = None
            if self.coupling is not None:
                from ..io import default_field_specs

                specs = {**default_field_specs(), "contact_force": ((2,), "float")}
            # (each frame is written in a worker thread while the next frame's steps run)
            writer = BackgroundFrameWriter(FrameWriter(
                path, particle_count=self.particle_count, attrs=meta, csv_path=out / "energy.csv",
                body_count=self.body_count, field_specs=specs,
                body_geometry=self.dem.scene_geometry() if self.dem else None))

        history: dict[str, list] = {}
        times: list[float] = []
        start_wall = _time.perf_counter()
        balance = EnergyBalance(self.stage.WORK_TERMS)

        def record(t: float, steps: int, dt: float, bound: float, t_next: float | None) -> None:
            # (everything read from the device and the energy checked first; then, unless the frame
            # blew up, the next frame's first steps go, and the host hands the frame to the writer
            # while they run: a blow-up leaves the device at its frame)
            d = balance.update(self.stage.diagnostics())
            d.update(dt=dt, dt_bound=bound, steps=float(steps), wall_time=_time.perf_counter() - start_wall)
            fields = body_fields = None
            if writer is not None:
                fields, body_fields = self.mpm.fields() if self.mpm else {}, self.dem.fields() if self.dem else None
            blow_up = None
            try:
                check_energy(self.model, self.config, t, d, balance.initial,
                             lambda: self.stage.likely_cause(dt, bound))
            except BlowUpError as e:
                blow_up = e
            if t_next is not None and blow_up is None:
                self.launch_ahead(t, t_next, dt)
            times.append(t)
            for k, v in d.items():
                history.setdefault(k, []).append(v)
            if writer is not None:
                writer.write_frame(t, fields, d, body_fields=body_fields)
            if blow_up is not None:
                raise blow_up

        from ..io.background import thread_switch_interval

        status, message = "completed", ""
        # (the writer thread gets Python's lock back sooner from a busy main thread: io.background)
        with thread_switch_interval(self.tuning.writer_switch_interval if writer is not None else 0.0):
            try:
                start = self.stage.read_clock()
                t_start = start.t
                if t_start >= end_time:
                    raise InputError("end_time", end_time, f"a time after the current time {t_start:g} s")
                record(t_start, start.steps, *self.initial_step(), frame_time(t_start, end_time, 1, frames))
                for k in range(1, frames + 1):
                    t, steps = self.advance_to(frame_time(t_start, end_time, k, frames), on_batch=progress)
                    clock = self.stage.read_clock()
                    record(t, steps, clock.dt, clock.bound,
                           frame_time(t_start, end_time, k + 1, frames) if k < frames else None)
            except BlowUpError as e:
                status, message = "blown-up", str(e)
                if writer is not None:
                    writer.set_status(status, message)
                    writer.close()
                raise
            except KeyboardInterrupt as e:
                # (mpmdem.study.signals.Interrupted names its signal: SIGTERM from a batch scheduler, or Ctrl-C)
                status, message = "interrupted", str(e) or "stopped by the user (Ctrl-C)"
                if writer is not None:
                    writer.set_status(status, message)
                    writer.close()
                raise
            except BaseException:
                if writer is not None:
                    writer.close()  # (the frames written so far stay readable; the error goes on)
                raise
            if writer is not None:
                writer.set_status(status, message)
                writer.close()
        return RunResult(path, np.array(times), {k: np.array(v) for k, v in history.items()}, status,
                         int(history["steps"][-1]), message)

    def initial_step(self) -> tuple[float, float]:
        """(dt, bound) [s] of the first step: what the first frame records, and what the command
        line plans a run with (``mpmdem.study.run_plan``), before any step has run."""
        if self.coupling:
            bound = min(self.mpm.dt_bound0, self.coupling.dt_bound)
            return self.config.dt or min(self.config.cfl * self.mpm.dt_bound0, self.coupling.dt_cap), bound
        if self.mpm:
            return self.config.dt or self.config.cfl * self.mpm.dt_bound0, self.mpm.dt_bound0
        return self.dem.dt_default, self.dem.dt_bound

    # -- checkpoints -------------------------------------------------------------------------------
    def save_checkpoint(self, path: str | Path) -> Path:
        """Write every time-varying device array (points or bodies, contact lists, clock, step
        count, CFL speeds) to an .npz file. Restoring it into a Simulation of the same scene and
        config on the same device continues bit for bit."""
        path = Path(path)
        arrays = {name: host_copy(a) for name, a in self.stage.state_arrays().items()}
        with open(path, "wb") as f:
            np.savez(f, **arrays, meta=np.array(json.dumps(
                {"version": __version__, "scene": self.scene.to_dict(), "config": self.config.to_dict()})))
        return path

    def load_checkpoint(self, path: str | Path) -> None:
        """Restore a checkpoint written by save_checkpoint for this scene and config."""
        with np.load(Path(path)) as data:
            meta = json.loads(str(data["meta"]))
            if meta["config"] != json.loads(json.dumps(self.config.to_dict())) or meta["scene"] != json.loads(
                json.dumps(self.scene.to_dict())
            ):
                raise InputError("checkpoint", str(path), "a checkpoint of this same scene and config")
            arrays = self.stage.state_arrays()
            for name, a in arrays.items():
                shape = tuple(a.shape) + tuple(getattr(a.dtype, "_shape_", ()))  # (vector and matrix elements)
                if name not in data.files or data[name].shape != shape:
                    found = "missing" if name not in data.files else f"of shape {data[name].shape}"
                    raise InputError("checkpoint", str(path), f"a checkpoint written by mpmdem {__version__} "
                                     f"(its array {name!r} is {found}, expected {shape})")
            for name, a in arrays.items():
                a.assign(data[name])
        if self.mpm is not None:
            self.mpm.invalidate_interactions()

    # -- state access -----------------------------------------------------------------------------
    def fields(self) -> dict[str, np.ndarray]:
        """Host copies of the per-point fields (x, v, stress, volume, mass, F, body)."""
        if self.mpm is None:
            raise InputError("fields", "points", "a scene with material points (use body_fields for rigid bodies)")
        return self.mpm.fields()

    def body_fields(self) -> dict[str, np.ndarray]:
        """Host copies of the per-body fields (x, angle, v, omega, force, torque), scene order."""
        if self.dem is None:
            raise InputError("body_fields", "bodies", "a scene with rigid bodies")
        return self.dem.fields()

    def diagnostics(self) -> dict[str, float]:
        """Current energies, momenta and mass of the points or bodies."""
        return self.stage.diagnostics()

    @property
    def time(self) -> float:
        """The time reached [s] (one host sync)."""
        return self.clock.time
