"""What the stages of a step share: the typed host side of the device clock, and the ``Stage``
protocol the coordinator (``mpmdem.sim.simulation.Simulation``) drives.

The clock is one float64 array on the device (slots ``CLOCK_*`` of ``mpmdem.kernels.clock``)
and a step counter. The coordinator owns one ``Clock`` and passes it to every stage it builds,
so coupled stages step on one time by construction; a stage built on its own (tests, benches)
makes its own. The stage that launches a step's dt kernel sets the dt policy (fixed dt, factor,
initial bound) with ``Clock.set_policy`` once, before the first step.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np
import warp as wp

from ..kernels.clock import (
    CLOCK_BOUND,
    CLOCK_BOUND_NEXT,
    CLOCK_BOUND_TAKEN,
    CLOCK_DT_FACTOR,
    CLOCK_DT_FIXED,
    CLOCK_DT_TAKEN,
    CLOCK_SIZE,
    CLOCK_T,
    CLOCK_T_STOP,
)
from .host_copy import host_copy

__all__ = ["Clock", "ClockReading", "ClockedStage", "Stage"]


class ClockReading(NamedTuple):
    """The clock at one host sync: t, dt, bound [s], the steps taken and, read by a stage
    (``ClockedStage.read_clock``), its status counters (None from ``Clock.read``)."""

    t: float
    dt: float
    bound: float
    steps: int
    status: np.ndarray | None = None


class Clock:
    """Host handle of the device clock of one run.

    Args:
        device: Warp device of the stages that read it.

    Attributes:
        values: float64[CLOCK_SIZE] device array that every kernel of a step reads (slots
            ``mpmdem.kernels.clock``); all zero until ``set_policy``.
        steps: int64[1] device array, the explicit steps taken.
    """

    def __init__(self, device):
        self.device = wp.get_device(device)
        self.values = wp.zeros(CLOCK_SIZE, dtype=wp.float64, device=self.device)
        self.steps = wp.zeros(1, dtype=wp.int64, device=self.device)
        self._land = None

    def set_policy(self, *, dt_fixed: float | None, factor: float, bound: float = 0.0, land=None) -> None:
        """The dt rule of the stage that steps: ``dt_fixed`` [s] (None: dt = factor × bound), the
        factor (CFL κ, or π κ2 of MPM-SDEM eq. 51) and the initial bound [s]; ``land()`` launches
        the kernel that sets the next step's dt after the host moved t_stop (``kernels.clock``)."""
        host = np.zeros(CLOCK_SIZE)
        host[CLOCK_BOUND] = host[CLOCK_BOUND_NEXT] = host[CLOCK_BOUND_TAKEN] = bound
        host[CLOCK_DT_FIXED] = dt_fixed or 0.0
        host[CLOCK_DT_FACTOR] = factor
        self.values.assign(host)
        self._land = land

    def set_stop_time(self, t_stop: float) -> None:
        """Steps run until t reaches t_stop [s]; later steps do nothing (no host sync). The next
        step's dt is set again to land on it (steps end on a frame's time: ``kernels.clock.land``)."""
        wp.copy(self.values, wp.array([t_stop], dtype=wp.float64, device="cpu"), dest_offset=CLOCK_T_STOP, count=1)
        if self._land is not None:
            self._land()

    def read(self) -> ClockReading:
        """(t, dt, bound, steps) of the last step taken: one host sync."""
        c = host_copy(self.values)
        return ClockReading(float(c[CLOCK_T]), float(c[CLOCK_DT_TAKEN]), float(c[CLOCK_BOUND_TAKEN]),
                            int(host_copy(self.steps)[0]))

    @property
    def time(self) -> float:
        """t [s] (one host sync)."""
        return float(host_copy(self.values)[CLOCK_T])


class ClockedStage:
    """``set_stop_time`` and ``read_clock`` of a stage that holds ``sim_clock`` and says how to
    read its status counters (``status_counts``)."""

    sim_clock: Clock

    def status_counts(self) -> np.ndarray:
        """The stage's device status counters, on the host (read with the clock)."""
        raise NotImplementedError

    def set_stop_time(self, t_stop: float) -> None:
        """Steps run until the clock reaches t_stop [s]; later steps do nothing."""
        self.sim_clock.set_stop_time(t_stop)

    def read_clock(self) -> ClockReading:
        """The clock with the stage's status counters: one host sync."""
        return self.sim_clock.read()._replace(status=self.status_counts())


@runtime_checkable
class Stage(Protocol):
    """What the coordinator needs of the stage that runs a step (MPM, DEM or both coupled).

    ``step`` launches one explicit step and never syncs with the host (a CUDA graph records it);
    everything else is called between batches of steps or at output frames.
    """

    #: Diagnostics that are works done on the system, for the energy balance.
    WORK_TERMS: tuple[str, ...]
    #: The clock the stage steps on.
    sim_clock: Clock

    def step(self) -> None:
        """Launch one explicit step (dt from the device clock)."""

    def set_stop_time(self, t_stop: float) -> None:
        """Steps run until the clock reaches t_stop [s]."""

    def read_clock(self) -> ClockReading:
        """(t, dt, dt_bound, steps, status counts) by name: one host sync."""

    def check_status(self, t: float, dt: float, bound: float, status: np.ndarray) -> None:
        """Raise BlowUpError when the status counters read with the clock show one."""

    def diagnostics(self) -> dict[str, float]:
        """Energies, momenta, mass and works of the stage now."""

    def state_arrays(self) -> dict[str, wp.array]:
        """Every time-varying device array by a stable name (what a checkpoint holds)."""

    def likely_cause(self, dt: float, bound: float) -> str:
        """What most likely made a blow-up at this dt and bound (for the messages)."""
