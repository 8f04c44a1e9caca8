"""Per-world diagnostics of a batched run (``mpmdem.sim.batch_run``): the sums a lone run of each
world would report, from the batch's device arrays, at output frames only.

Per world and exact (on the CPU, bit for bit the lone run's for world 0: the same kernels over the
world's points, in the same relative order): the points' energies (kinetic, strain, gravity),
momenta, mass and mass probes. Per world to round-off (host sums in float64): the free bodies'
and grains' energies, momenta and mass, their contact energy, the point–body contact energy and
its damping and friction works, the bodies' mass probes, the DEM bodies' dissipated works and the
work of driven bodies. Per world to round-off with walled tiles (``World.tile``: each tile's
contributions in its own share of the works' slots, ``kernels.grid.work_slot``), else batch-wide:
the grid's works (walls, damping, plasticity, inflow) and the forces on obstacles. Batch-wide (the
sum over every world, as the device reduces it): list rebuilds and counters, granular components
and layers, and dt (one step for the whole batch).

Translation: x is shifted back by the world's offset X, so the angular momentum about the origin
and a gravity with an x component are corrected (Σ m ((x − X) v_y − y v_x) = L − X Σ m v_y).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels import dem as dem_kernels
from ..kernels import grid as grid_kernels
from ..kernels import reductions as reduction_kernels
from .batch_scene import World
from .host_copy import host_copies, host_copy

__all__ = ["HostArrays", "WorldPoints", "body_rows", "body_sums", "frame_arrays", "imp_sums", "launch_point_sums",
           "point_sums", "world_diagnostics"]


class HostArrays:
    """The device arrays a frame's per-world sums read, each copied to the host once per frame and
    shared by every world (a fresh object each frame). Once ``seal``-ed (the next frame's steps have
    been launched, and the device arrays no longer hold this frame) it refuses a name it has not read."""

    def __init__(self):
        self._arrays: dict[str, np.ndarray] = {}
        self._sealed = False

    def __call__(self, name: str, array) -> np.ndarray:
        """``array`` on the host, read back at the first call of this frame under ``name``."""
        if name not in self._arrays:
            if self._sealed:
                raise RuntimeError(f"HostArrays: {name!r} was not read back before the next steps were launched "
                                   "(add it to frame_arrays)")
            self._arrays[name] = host_copy(array)
        return self._arrays[name]

    def seal(self) -> None:
        """No more reads from the device: every array the frame's sums need is on the host. A CPU
        array's host copy is the array itself (``host_copy``): it is copied now, so that steps run
        after the seal do not change the frame's values."""
        self._sealed = True
        for name, values in self._arrays.items():
            if not values.flags.owndata:
                self._arrays[name] = values.copy()

    def prefetch(self, named: dict) -> None:
        """Read back every array of ``named`` (name → device array) not read yet this frame, with
        one wait for them all (``host_copies``)."""
        missing = [(k, a) for k, a in named.items() if k not in self._arrays]
        for (k, _), values in zip(missing, host_copies([a for _, a in missing]), strict=True):
            self._arrays[k] = values


class WorldPoints:
    """The device indices of one world's points in the MPM stage's arrays (contiguous while the
    points keep the by-column order, which tiles along x preserve), and a ``Particles`` struct
    of views onto them for the stage's own reduction kernels."""

    def __init__(self, mpm, world: World):
        pid = host_copy(mpm.points.pid)
        self.index = np.flatnonzero((pid >= world.points.start) & (pid < world.points.stop))
        #: the same positions as a slice where they are one run (as tiles along x keep them): a view,
        #: where indexing by ``index`` copies
        contiguous = len(self.index) > 0 and int(self.index[-1]) + 1 - int(self.index[0]) == len(self.index)
        self.rows = slice(int(self.index[0]), int(self.index[-1]) + 1) if contiguous else self.index
        self.mpm = mpm
        self._struct = None
        self._pid_seen = None
        #: (t [s], impulses on the world's obstacles [N s/m]) at its last frame (``tile_works``)
        self.impulse_mark = (0.0, np.zeros_like(mpm.impulse_mark[1]))
        # the device arrays of ``point_sums``, made once (allocating and freeing them each frame
        # waits for the device, a batch's worlds after one another)
        self.diag = wp.zeros(len(reduction_kernels.DIAG_NAMES), dtype=wp.float64, device=mpm.device)
        X, probes = world.offset, world.scene.mass_probes
        self.probe_boxes = wp.array(np.array([[p.lo[0] + X, p.lo[1], p.hi[0] + X, p.hi[1]] for p in probes],
                                             np.float64).reshape(-1, 4), dtype=wp.vec4d, device=mpm.device)
        self.probe_mass = wp.zeros(max(1, len(probes)), dtype=wp.float64, device=mpm.device)

    def struct(self):
        """The world's ``Particles``: slices of the stage's arrays (a re-sort keeps each world's
        range: points are ordered by cell column and the worlds by x)."""
        if self._struct is None:
            points, n = self.mpm.points, self.mpm.particle_count
            lo, hi = int(self.index[0]), int(self.index[-1]) + 1
            if hi - lo != len(self.index):
                raise RuntimeError("a world's points are not contiguous on the device")
            P = points._cls()
            for name in points._cls.vars:
                a = getattr(points, name)
                setattr(P, name, a[lo:hi] if a.shape[0] == n and n > 1 else a)
            self._struct = P
        return self._struct


def launch_point_sums(mpm, wpts: WorldPoints, t_now: float) -> None:
    """Launch the reductions of one world's points at time ``t_now`` [s] into ``wpts.diag`` and
    ``wpts.probe_mass`` (read back by ``point_sums``; a batch launches every world's before it waits)."""
    P = wpts.struct()
    n = len(wpts.index)
    wpts.diag.zero_()
    wp.launch(mpm.diagnostics_kernel, n, inputs=[P, mpm.D, mpm.materials, wpts.diag, t_now], device=mpm.device)
    if wpts.probe_boxes.shape[0]:
        wpts.probe_mass.zero_()
        wp.launch(mpm.probe_mass_kernel, n, inputs=[P, wpts.probe_boxes, wpts.probe_mass, t_now], device=mpm.device)


def point_arrays(world: World, wpts: WorldPoints) -> dict:
    """The device arrays ``point_sums`` reads for ``world``, under their ``HostArrays`` names."""
    out = {f"diag/{world.index}": wpts.diag}
    if world.scene.mass_probes:
        out[f"probe_mass/{world.index}"] = wpts.probe_mass
    return out


def point_sums(mpm, wpts: WorldPoints, world: World, t_now: float, host: HostArrays | None = None,
               launched: bool = False) -> dict[str, float]:
    """Energies [J/m], momenta, mass [kg/m] and ``mass_<probe>`` of one world's points at time
    ``t_now`` [s] (the clock's: the frame's); ``launched``: its reductions were launched already
    (``launch_point_sums``); ``host``: this frame's read-backs (a fresh one if None)."""
    if not launched:
        launch_point_sums(mpm, wpts, t_now)
    host = host if host is not None else HostArrays()
    diag = host(f"diag/{world.index}", wpts.diag)
    out = {name: float(v) for name, v in zip(reduction_kernels.DIAG_NAMES, diag, strict=True)}
    X = world.offset
    probes = world.scene.mass_probes
    if probes:
        masses = host(f"probe_mass/{world.index}", wpts.probe_mass)
        out.update({f"mass_{p.name}": float(m) for p, m in zip(probes, masses, strict=True)})
    if X:
        out["momentum_angular"] -= X * out["momentum_y"]
        out["energy_gravity"] += world.scene.gravity[0] * X * out["mass"]
    return out


def tile_works(mpm, wpts: WorldPoints, world: World, host: HostArrays, t_now: float) -> dict[str, float]:
    """The grid's works [J/m] and the forces on the obstacles [N/m] of one world's tile (walled tiles:
    ``kernels.grid.work_slot`` gives each tile its share of every term's slots), as
    ``diagnostics.point_diagnostics`` names them; the force is the impulse since the world's last
    frame (``WorldPoints.impulse_mark``) over the time since then."""
    sums = host("work", mpm.work).reshape(-1, grid_kernels.WORK_SLOTS)
    per = grid_kernels.WORK_SLOTS // mpm.model.wall_tiles.count
    sums = sums[:, world.tile * per:(world.tile + 1) * per].sum(axis=1)
    out = {name: float(w) for name, w in zip(grid_kernels.WORK_TERMS, sums, strict=False)}
    impulse = sums[grid_kernels.IMPULSE_BASE:]
    t_prev, i_prev = wpts.impulse_mark
    span = t_now - t_prev
    force = (impulse - i_prev) / span if span > 0.0 else np.zeros_like(impulse)
    for k, wall in enumerate(grid_kernels.WALLS if world.scene.obstacles else ()):
        out[f"force_{wall}_x"], out[f"force_{wall}_y"] = float(force[2 * k]), float(force[2 * k + 1])
    wpts.impulse_mark = (t_now, impulse)
    return out


def imp_sums(coupling, wpts: WorldPoints, host: HostArrays) -> dict[str, float]:
    """The point–body contact energy [J/m] and its damping and friction works of one world's points."""
    L = coupling.L
    e = host("L.energy", L.energy)[wpts.rows].astype(np.float64)
    lost = host("L.dissipated", L.dissipated)[wpts.rows]
    return {"energy_imp": float(e.sum()), "dissipated_imp_damping": float(lost[:, 0].sum()),
            "dissipated_imp_friction": float(lost[:, 1].sum())}


def body_rows(dem, world: World) -> np.ndarray:
    """The device rows of ``world``'s bodies, ascending (``dem.order`` is fixed for a run)."""
    return np.flatnonzero(np.isin(dem.order, world.bodies))


def body_sums(dem, world: World, host: HostArrays, rows: np.ndarray | None = None) -> dict[str, float]:
    """Energies [J/m], momenta and mass of one world's free bodies and grains, their contact energy,
    the works of its contacts' damping and friction and of its driven bodies (``DEMSolver.WORK_TERMS``),
    and ``mass_<probe>`` of its free bodies (float64 sums on the host)."""
    B, C = dem.B, dem.C
    idx = body_rows(dem, world) if rows is None else rows
    X = world.offset
    m, inertia = host("B.mass", B.mass)[idx].astype(float), host("B.inertia", B.inertia)[idx].astype(float)
    v, w = host("B.v", B.v)[idx].astype(float), host("B.omega", B.omega)[idx].astype(float)
    x = host("B.x", B.x)[idx].astype(float) - np.array([X, 0.0])
    free = host("B.motion", B.motion)[idx] == dem_kernels.FREE
    m, inertia, v, w, xf = m[free], inertia[free], v[free], w[free], x[free]
    g = np.asarray(world.scene.gravity)
    energy = host("C.energy", C.energy).reshape(-1, C.slots)[idx].astype(float).sum()
    # (what the diagnostics kernel sums: each body's dissipation in its slots and folded at rebuilds)
    lost = (host("C.dissipated", C.dissipated).reshape(-1, C.slots, 2)[idx].sum(axis=(0, 1))
            + host("C.body_dissipated", C.body_dissipated)[idx].sum(axis=0))
    work = host("B.work", B.work)[idx]
    driven = float(work[~free].sum() + (work[free].sum() if dem.model.periodic_x else 0.0))
    out = {"energy_kinetic": float(0.5 * (m * (v ** 2).sum(1) + inertia * w * w).sum()),
           "energy_gravity": float(-(m * (xf @ g)).sum()), "energy_contact": float(energy),
           "momentum_x": float((m * v[:, 0]).sum()), "momentum_y": float((m * v[:, 1]).sum()),
           "momentum_angular": float((m * (xf[:, 0] * v[:, 1] - xf[:, 1] * v[:, 0]) + inertia * w).sum()),
           "mass": float(m.sum()), "work_contact_damping": -float(lost[0]),
           "work_contact_friction": -float(lost[1]), "work_driven": driven}
    for p in world.scene.mass_probes:
        inside = ((xf[:, 0] >= p.lo[0]) & (xf[:, 1] >= p.lo[1]) & (xf[:, 0] < p.hi[0]) & (xf[:, 1] < p.hi[1]))
        out[f"mass_{p.name}"] = float(m[inside].sum())
    return out


def frame_arrays(sim, worlds, points: dict) -> dict:
    """Every device array the frame's ``world_diagnostics`` of ``worlds`` read, under their
    ``HostArrays`` names (``points``: world index → WorldPoints), for one ``HostArrays.prefetch``.
    An array left out is still read, at its first use, with a wait of its own."""
    out = {}
    if sim.mpm is not None:
        for w in worlds:
            out.update(point_arrays(w, points[w.index]))
        if any(w.tile is not None for w in worlds):
            out["work"] = sim.mpm.work
    if sim.dem is not None:
        B, C = sim.dem.B, sim.dem.C
        out.update({"B.mass": B.mass, "B.inertia": B.inertia, "B.v": B.v, "B.omega": B.omega, "B.x": B.x,
                    "B.motion": B.motion, "B.work": B.work, "C.energy": C.energy, "C.dissipated": C.dissipated,
                    "C.body_dissipated": C.body_dissipated})
        if sim.mpm is not None and sim.coupling is not None:
            out.update({"L.energy": sim.coupling.L.energy, "L.dissipated": sim.coupling.L.dissipated})
    return out


def world_diagnostics(sim, world: World, wpts: WorldPoints | None, batch: dict[str, float],
                      host: HostArrays | None, t_now: float, launched: bool = False,
                      bodies: np.ndarray | None = None) -> dict[str, float]:
    """One world's diagnostics under the names a lone run gives them: ``batch`` (the whole batch's,
    ``Stage.diagnostics``) with every per-world sum replaced (see the module's docstring). ``host``:
    this frame's read-backs, shared by its worlds (a fresh one if None); ``t_now``: the frame's time
    [s], the clock's (passed in: no clock read per world); ``launched``: the world's point reductions
    were launched already (``launch_point_sums``); ``bodies``: its bodies' device rows (``body_rows``,
    found once for a run; None: found now)."""
    host = host if host is not None else HostArrays()
    d = {k: v for k, v in batch.items() if not k.startswith("mass_")}
    m = point_sums(sim.mpm, wpts, world, t_now, host, launched) if sim.mpm is not None else None
    if m is not None and world.tile is not None:
        m.update(tile_works(sim.mpm, wpts, world, host, t_now))
    b = body_sums(sim.dem, world, host, bodies) if sim.dem is not None else None
    if m is not None and b is not None:
        imp = imp_sums(sim.coupling, wpts, host)
        d.update({k: v for k, v in m.items() if not k.startswith("mass_")})
        for name in ("energy_kinetic", "energy_gravity", "momentum_x", "momentum_y", "momentum_angular", "mass"):
            d[f"points_{name}"], d[f"bodies_{name}"] = m[name], b[name]
            d[name] = m[name] + b[name]
        d["energy_contact_bodies"] = b["energy_contact"]
        d["energy_contact_points"] = imp["energy_imp"]
        d["energy_contact"] = b["energy_contact"] + imp["energy_imp"]
        d["energy_total"] = d["energy_kinetic"] + d["energy_gravity"] + d["energy_strain"] + d["energy_contact"]
        d.update({k: b[k] for k in ("work_contact_damping", "work_contact_friction", "work_driven")})
        d["work_imp_damping"] = -imp["dissipated_imp_damping"]
        d["work_imp_friction"] = -imp["dissipated_imp_friction"]
        d.update({k: m[k] + b[k] for k in m if k.startswith("mass_")})
    elif m is not None:
        d.update(m)
        d["energy_total"] = d["energy_kinetic"] + d["energy_strain"] + d["energy_gravity"]
    else:
        d.update(b)
        d["energy_total"] = d["energy_kinetic"] + d["energy_gravity"] + d["energy_contact"]
    return d
