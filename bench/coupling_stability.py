"""Coupled MPM–DEM stability map: does the time step need a term for the point masses on k_n?

MPM-SDEM eq. 51 sets the coupled step from the grid and the DEM bodies only,

    dt51 = min(κ1 h / c_max, 2π κ2 sqrt(m_min / k_n)),  κ1 = 0.8, κ2 = 0.1,

with m_min the smallest DEM body mass. A material point on a contact spring k_n is a much lighter
oscillator than any body, so eq. 51 may be too large when k_n is large against the point masses.
mpmdem.sim.coupling adds that term (dt ≤ π κ2 × the contact bound 2 sqrt(m_p,min / k) (sqrt(1+ζ²) − ζ)
with m_p,min the smallest POINT mass). This bench maps where fixed-dt runs turn unstable and which
mass — the point's m_p or a node's ρh² — sets that edge.

Scenes (built here; sizes are flags; the paper's Table 1 hard material, scaled down for a CPU):

- ``disk-drop``: an elastic MPM disk (LinearElastic, K = 5e3 kPa, G = 3.7e3 kPa, so E = 8.9 MPa,
  ν = 0.20, c = 70 m/s; ρ = 2000 kg/m³; R = 2 cm, h = R/4) falling under gravity, 0.5 m/s at the
  start, from just above a fixed spheropolygon floor (``rounded_rectangle``, motion="fixed")
  through impact and rebound. There is no free DEM body, so eq. 51 has no DEM term here:
  dt51 = κ1 h / c_max (c_max the material's plane-strain P-wave speed sqrt((K + 4G/3) / ρ)).
- ``hard-exchange``: the same disk at 2 m/s hits an equal free DEM disk (``sphero_disk``, same
  radius and density) head-on, no gravity: dt51 = min(κ1 h / c_max, 2π κ2 sqrt(m_disk / k_n)).
- ``lone-point`` (not in the default sweep): one material point alone on its nodes dropped on the
  floor — a point-mass spring, as a grain that left a granular mass. Undamped, its measured energy
  swings by O(ω dt) within each contact (the staggered v and x), so nearly every run of it is
  classed "energy gain"; read its blow-ups and ``final_energy_change`` instead.

The front material point sits on the disk's axis, so one point meets the body first. All grid
boundaries are "free". Contact: restitution e = 1 (no contact damping; ``--restitution``),
k_t = k_n / 20 and μ = 0.1 (the paper's ratios). f64, APIC, quadratic B-splines, USL (defaults).

Sweep: dt = factor × dt51 (fixed: ``SolverConfig(dt=..., allow_unstable=True, cfl=0.8)``) for
factors 0.0625..2 (ratio √2) × k_n = k* × 10^(j/2), j = -1..5, where k* = 4 m_p / (κ1 h / c)² is
the k_n at which the point-mass bound 2 sqrt(m_p / k_n) equals eq. 51's grid term × r_p / h at two
places in eq. 45's interval (h / sqrt(n), h) × n = ppc² points per cell, ppc = 2 and 4 (the nodal
to point mass ratio is n, so the two candidate bounds differ by ppc). Then one more run per map
column at the geometric mean of its last stable and first non-stable factor (``--no-refine``).
Each run is classified:

- ``blown up``: ``Simulation.run`` raised ``mpmdem.BlowUpError`` (non-finite values, points or
  the body leaving the domain, energy growth past ``blowup_energy_factor`` = 1 × the solver's
  energy scale);
- ``energy gain``: it finished but the total energy (kinetic + gravity + strain + contact of
  points and bodies) rose at some frame (40 per run) by more than 0.5 % of the scale E_kin(0) + the
  largest released gravitational energy max_t (E_grav(0) − E_grav(t));
- ``stable`` otherwise (``error``, if the library raised anything else: recorded, never fatal).

Each run records dt over our contact bound (point mass), over a nodal-mass bound
2 sqrt(ρ h² / k_n) (sqrt(1+ζ²) − ζ), over h / c, and k_n dt² / m_p (an undamped point-mass spring
is stable for k_n dt² / m_p < 4), so the map shows which bound predicts the edge.

Writes one JSON line per run to stdout; to --out a JSON {meta, edges, runs} (``edges``: per map
column its last stable and first non-stable run in the units of every bound); to --png the map:
one panel per scene × ppc × r_p / h, dt / dt51 against k_n, marker and colour by class, with the
curves dt = point-mass bound, dt = nodal-mass bound, dt = h / c and dt = dt51; on the right every
column's edge in units of the point-mass bound and of the nodal-mass bound against k_n / k*.
The default sweep (2 scenes × 2 ppc × 2 r_p × 7 k_n × 11 dt + 56 refinements = 672 runs) takes
about 3 min on 2 CPU cores (``--jobs 2``, one process per core); ``--quick`` (2 × 1 × 1 × 4 × 5
+ refinements) about 15 s.

    python bench/coupling_stability.py           # default sweep, cpu, writes bench/results/coupling_stability/
    python bench/coupling_stability.py --quick --out /tmp/cs.json --png /tmp/cs.png
    python bench/coupling_stability.py --scenes lone-point --ppc 2 --out /tmp/lp.json --png /tmp/lp.png
    python bench/coupling_stability.py --device cuda --cells-per-radius 8 --ppc 2,4,6
    python bench/coupling_stability.py --replot bench/results/coupling_stability/cpu.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpmdem.study.cluster import map_tasks

RESULTS = Path(__file__).resolve().parent / "results"
SCENES = ("disk-drop", "hard-exchange", "lone-point")
DEFAULT_SCENES = "disk-drop,hard-exchange"
KAPPA1, KAPPA2 = 0.8, 0.1  # MPM-SDEM eq. 51
GAIN = 0.005  # energy rise, of the scale, that makes a run "energy gain"
DEFAULT_FACTORS = "0.0625,0.088,0.125,0.177,0.25,0.354,0.5,0.707,1.0,1.41,2.0"  # ratio √2
DEFAULT_KN_EXPONENTS = "-1,0,1,2,3,4,5"  # k_n = k* × 10^(j/2)
DEFAULT_RP = "0.25,0.75"  # position s in eq. 45's interval: r_p = h n^(-1/2) × n^(s/2)
DEFAULT_PPC = "2,4"  # points per cell per direction: the nodal / point mass ratio is ppc²
QUICK = dict(factors="0.125,0.25,0.5,1.0,2.0", kn="-1,1,3,5", rp="0.5", ppc="2")


# -- scenes ---------------------------------------------------------------------------------------
@dataclass
class Sizes:
    """The scene sizes shared by all runs (SI, per metre of thickness)."""

    radius: float = 0.02  # disk radius [m] (paper: 2 cm)
    cells_per_radius: int = 4  # R / h (paper: 2 cm / 0.3 cm ≈ 6.7)
    ppc: int = 2  # points per cell per direction (n = ppc²)
    density: float = 2000.0  # ρ [kg/m³] (paper: 2 g/cm² per unit thickness)
    bulk: float = 5.0e6  # K [Pa] (paper's hard material: 5e3 kPa)
    shear: float = 3.7e6  # G [Pa] (3.7e3 kPa)
    restitution: float = 1.0
    drop_speed: float = 0.5  # m/s, the drop's initial downward speed
    impact_speed: float = 2.0  # m/s, hard exchange
    gap: float = 0.05  # initial gap between the front point's contact disk and the body, of h
    precision: str = "f64"
    frames: int = 40

    @property
    def h(self) -> float:
        return self.radius / self.cells_per_radius

    def material(self):
        from mpmdem import LinearElastic

        k, g = self.bulk, self.shear
        return LinearElastic(9.0 * k * g / (3.0 * k + g), (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g)), self.density)

    @property
    def wave_speed(self) -> float:
        """c_max of eq. 51: the plane-strain P-wave speed sqrt((K + 4G/3) / ρ) [m/s]."""
        return math.sqrt((self.bulk + 4.0 * self.shear / 3.0) / self.density)

    @property
    def point_mass(self) -> float:
        return self.density * (self.h / self.ppc) ** 2

    @property
    def node_mass(self) -> float:
        return self.density * self.h * self.h

    @property
    def disk_mass(self) -> float:
        return self.density * math.pi * self.radius**2

    @property
    def dt_cfl51(self) -> float:
        """Eq. 51's grid term κ1 h / c_max [s]."""
        return KAPPA1 * self.h / self.wave_speed

    @property
    def k_star(self) -> float:
        """k_n [N/m per m] at which 2 sqrt(m_p / k_n) equals κ1 h / c_max."""
        return 4.0 * self.point_mass / self.dt_cfl51**2

    def rp_interval(self) -> tuple[float, float]:
        """Eq. 45: h / sqrt(n) < r_p < h, n = ppc² points per cell."""
        return self.h / self.ppc, self.h

    def rp_from_position(self, s: float) -> float:
        lo, hi = self.rp_interval()
        return lo * (hi / lo) ** s

    def damping_factor(self) -> float:
        from mpmdem import ContactLaw

        zeta = ContactLaw(1.0, restitution=self.restitution).damping_ratio
        return math.sqrt(1.0 + zeta * zeta) - zeta

    def dt51(self, scene: str, kn: float) -> float:
        if scene in ("disk-drop", "lone-point"):
            return self.dt_cfl51  # no free DEM body: eq. 51's DEM term is absent
        return min(self.dt_cfl51, 2.0 * math.pi * KAPPA2 * math.sqrt(self.disk_mass / kn))

    def point_bound(self, kn: float) -> float:
        return 2.0 * math.sqrt(self.point_mass / kn) * self.damping_factor()

    def nodal_bound(self, kn: float) -> float:
        return 2.0 * math.sqrt(self.node_mass / kn) * self.damping_factor()


def _lattice(origin: float, h: float, ppc: int, near: float) -> float:
    """The sub-cell centre (a point position of ``seed_points``) closest to ``near``, at or above it."""
    step = h / ppc
    return origin + (math.ceil((near - origin) / step - 0.5 - 1e-9) + 0.5) * step


def build(name: str, sz: Sizes, kn: float, rp: float):
    """(scene, end time [s], initial gap [m]): the front point of the disk on its axis, ``gap`` from
    contact; the run ends after the contact and the rebound / separation."""
    from mpmdem import ContactLaw, Scene, disk, rounded_rectangle, sphero_disk

    R, h, ppc = sz.radius, sz.h, sz.ppc
    eps = 0.01 * h / ppc  # the front point lies just inside the disk outline
    law = ContactLaw(kn, tangential_stiffness=0.05 * kn, restitution=sz.restitution)
    free = {s: "free" for s in ("left", "right", "bottom", "top")}
    gap = sz.gap * h
    # the contact lasts about the disk's own elastic response (a few wave passes, ~ 8 R / c) plus
    # the half period of the whole disk on the spring, π sqrt(M / k_n) (long for soft contacts)
    contact = 1.2 * (8.0 * R / sz.wave_speed + math.pi * math.sqrt(sz.disk_mass / kn))
    mat = sz.material()
    if name == "lone-point":
        # one material point alone on its nodes: the nodal masses are its own, so the contact is
        # exactly a point-mass spring (as for a grain detached from a granular mass)
        contact = 6.0 * math.pi * math.sqrt(sz.point_mass / kn) + 2.0 * R / sz.wave_speed
    if name in ("disk-drop", "lone-point"):
        width, height = 8 * R, 4 * R
        cx = _lattice(0.0, h, ppc, 0.5 * width)
        low = _lattice(0.0, h, ppc, 3.0 * h)  # front (lowest) point
        floor_top = low - rp - gap
        scene = Scene(domain=((0.0, 0.0), (width, height)), cell_size=h, gravity=(0.0, -9.81), boundaries=free,
                      contact=law)
        scene.add_rigid_body(rounded_rectangle(width, 2.0 * h), density=sz.density,
                             position=(0.5 * width, floor_top - h), motion="fixed", friction=0.1, name="floor")
        if name == "disk-drop":
            scene.add_mpm_body(disk((cx, low + R - eps), R), mat, points_per_cell=ppc, velocity=(0.0, -sz.drop_speed),
                           contact_radius=rp)
        else:
            scene.add_points([[cx, low]], mat, size=h / ppc, velocity=(0.0, -sz.drop_speed), contact_radius=rp)
        v = sz.drop_speed
        t_gap = (math.sqrt(v * v + 2.0 * 9.81 * gap) - v) / 9.81
    elif name == "hard-exchange":
        v = sz.impact_speed
        t_gap = gap / v
        end_guess = t_gap + contact
        cy = _lattice(0.0, h, ppc, R + 2.0 * h)
        front = _lattice(0.0, h, ppc, 2 * R + 3.0 * h)
        xb = front + rp + gap + R
        width = xb + R + 2.0 * h + v * end_guess
        scene = Scene(domain=((0.0, 0.0), (width, cy + R + 2.0 * h)), cell_size=h, gravity=(0.0, 0.0),
                      boundaries=free, contact=law)
        scene.add_mpm_body(disk((front - R + eps, cy), R), mat, points_per_cell=ppc, velocity=(v, 0.0),
                       contact_radius=rp)
        scene.add_rigid_body(sphero_disk(R), density=sz.density, position=(xb, cy), friction=0.1, name="disk")
    else:
        raise ValueError(f"unknown scene {name!r}; one of {', '.join(SCENES)}")
    return scene, t_gap + contact, gap


# -- one run --------------------------------------------------------------------------------------
def run_one(task: dict) -> dict:
    """Build, run and classify one (scene, r_p, k_n, factor) run; never raises."""
    from mpmdem import BlowUpError, Simulation, SolverConfig

    sz = Sizes(**task["sizes"])
    name, kn, rp, factor = task["scene"], task["kn"], task["rp"], task["factor"]
    dt51 = sz.dt51(name, kn)
    dt = factor * dt51
    row = {"case": name, "scene": name, "device": task["device"], "factor": factor, "dt": dt, "dt51": dt51,
           "dt51_cfl_term": sz.dt_cfl51,
           "dt51_dem_term": None if name != "hard-exchange" else 2.0 * math.pi * KAPPA2 * math.sqrt(sz.disk_mass / kn),
           "kn": kn, "kn_over_kstar": kn / sz.k_star, "rp": rp, "rp_over_h": rp / sz.h, "h": sz.h, "ppc": sz.ppc,
           "point_mass": sz.point_mass, "node_mass": sz.node_mass, "restitution": sz.restitution,
           "refined": task.get("refined", False)}
    t0 = time.perf_counter()
    sim = None
    try:
        scene, end, gap = build(name, sz, kn, rp)
        config = SolverConfig(dt=dt, allow_unstable=True, cfl=0.8, precision=sz.precision, blowup_energy_factor=1.0)
        sim = Simulation(scene, config, device=task["device"])
        cb = sim.coupling.contact_bound
        row.update(size=sim.particle_count, end_time=end, gap=gap, contact_bound=cb,
                   coupling_dt_bound=sim.coupling.dt_bound,
                   nodal_bound=sz.nodal_bound(kn), dt_over_contact_bound=dt / cb,
                   dt_over_nodal_bound=dt / sz.nodal_bound(kn), kn_dt2_over_mp=kn * dt * dt / sz.point_mass,
                   kn_dt2_over_mnode=kn * dt * dt / sz.node_mass, dt_over_h_c=dt * sz.wave_speed / sz.h)
        result = sim.run(end, frames=sz.frames)
        d = result.diagnostics
        e = np.asarray(d["energy_total"], float)
        released = max(0.0, float(np.max(d["energy_gravity"][0] - d["energy_gravity"])))
        scale = float(d["energy_kinetic"][0]) + released
        gain = float(np.max(e - e[0]) / scale)
        row["class"] = "energy gain" if gain > GAIN else "stable"
        row.update(max_energy_gain=gain,
                   final_energy_change=float((e[-1] - e[0]) / scale), energy_scale=scale, steps=result.steps,
                   max_contact_energy=float(np.max(d["energy_contact"]) / scale), message="")
    except BlowUpError as err:
        row["class"] = "blown up"
        row.update(reason=err.reason, blowup_time=err.time, message=str(err),
                   steps=int(sim.stage.read_clock()[3]) if sim is not None else 0, max_energy_gain=None)
    except Exception as err:  # a library error must not stop the sweep: recorded, reported
        row["class"] = "error"
        row.update(message=f"{type(err).__name__}: {err}", steps=0, max_energy_gain=None)
    row["seconds"] = time.perf_counter() - t0
    row.setdefault("size", sim.particle_count if sim is not None else 0)
    return row


def make_tasks(args) -> list[dict]:
    tasks = []
    for name in args.scenes.split(","):
        for ppc in args.ppc_list[:1] if name == "lone-point" else args.ppc_list:  # alike in units of m_p
            sz = Sizes(**dict(args.sizes, ppc=ppc))
            for s in (float(v) for v in args.rp.split(",")):
                rp = sz.rp_from_position(s)
                for j in (float(v) for v in args.kn.split(",")):
                    kn = sz.k_star * 10.0 ** (0.5 * j)
                    for f in (float(v) for v in args.factors.split(",")):
                        tasks.append(_task(args, name, ppc, kn, rp, f))
    return tasks


def _task(args, name: str, ppc: int, kn: float, rp: float, factor: float, refined: bool = False) -> dict:
    sizes = dict(args.sizes, ppc=ppc)
    cost = (1.0 if name == "disk-drop" else 1.5) * ppc / (factor * Sizes(**sizes).dt51(name, kn))  # ~ run time
    return dict(scene=name, kn=kn, rp=rp, factor=factor, device=args.device, sizes=sizes, cost=cost, refined=refined)


def _run_all(tasks: list[dict], args) -> list[dict]:
    """Every task on the study runner's clusters (mpmdem.study.cluster): ``--jobs`` CPU processes,
    ``--gpus`` pinned GPU workers or ``--scheduler``; one JSON line per run as it finishes."""
    tasks = sorted(tasks, key=lambda t: -t["cost"])  # longest first: the processes end together
    rows = []
    for row in map_tasks(run_one, tasks, workers=args.jobs, gpus=args.gpus, scheduler=args.scheduler):
        rows.append(row)
        print(json.dumps(row), flush=True)
    return rows


def _column(r: dict) -> tuple:
    """The map column of a run: (scene, ppc, r_p / h, k_n)."""
    return r["scene"], r["ppc"], round(r["rp_over_h"], 6), r["kn"]


def refinements(args, rows: list[dict]) -> list[dict]:
    """One more dt per column, the geometric mean of its last stable and first non-stable dt."""
    out = []
    for e in edges(rows):
        a, b = e["last_stable"], e["first_unstable"]
        if a is None or b is None:
            continue
        r = next(r for r in rows if _column(r) == (e["scene"], e["ppc"], e["rp_over_h"], e["kn"]))
        out.append(_task(args, e["scene"], e["ppc"], e["kn"], r["rp"], math.sqrt(a["factor"] * b["factor"]),
                         refined=True))
    return out


def sweep(args) -> list[dict]:
    tasks = make_tasks(args)
    print(f"sweep: {len(tasks)} runs, then one refinement per map column at its edge; {args.jobs} process(es)",
          file=sys.stderr, flush=True)
    run_one(dict(tasks[-1], factor=2.0))  # compiles (or loads) the kernels once, before the workers share the cache
    rows = _run_all(tasks, args)
    if args.refine:
        rows += _run_all(refinements(args, rows), args)
    key = {n: i for i, n in enumerate(SCENES)}
    rows.sort(key=lambda r: (key.get(r["scene"], 9), r["ppc"], r["rp"], r["kn"], r["factor"]))
    return rows


# -- analysis -------------------------------------------------------------------------------------
EDGE_KEYS = ("factor", "class", "dt_over_contact_bound", "dt_over_nodal_bound", "kn_dt2_over_mp", "kn_dt2_over_mnode",
             "dt_over_h_c")


def edges(rows: list[dict]) -> list[dict]:
    """Per map column (scene, ppc, r_p, k_n): its first non-stable dt and the largest stable dt
    below it, each in the units of every bound; ``monotone`` is False when a larger dt was stable
    again."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault(_column(r), []).append(r)
    out = []
    for (scene, ppc, rp_h, kn), rs in groups.items():
        rs = sorted(rs, key=lambda r: r["factor"])
        first_bad = next((r for r in rs if r["class"] != "stable"), None)
        ok = [r for r in rs if r["class"] == "stable" and (first_bad is None or r["factor"] < first_bad["factor"])]
        e = {"scene": scene, "ppc": ppc, "rp_over_h": rp_h, "kn": kn, "kn_over_kstar": rs[0]["kn_over_kstar"]}
        for tag, r in (("last_stable", ok[-1] if ok else None), ("first_unstable", first_bad)):
            e[tag] = None if r is None else {k: r.get(k) for k in EDGE_KEYS}
        e["monotone"] = first_bad is None or all(
            r["class"] != "stable" for r in rs if r["factor"] >= first_bad["factor"])
        out.append(e)
    return out


def print_edges(es: list[dict]) -> None:
    print(f"{'scene':14s} {'ppc':>3s} {'rp/h':>5s} {'kn/k*':>7s} | {'dt/dt51':>15s} | {'dt/bound_p':>15s} | "
          f"{'dt/bound_node':>15s} | {'kn dt²/m_p':>15s} | {'dt c/h':>13s}", file=sys.stderr)

    def pair(e, key):
        a, b = e["last_stable"], e["first_unstable"]
        return f"{format(a[key], '.3g') if a else '-':>7s}→{format(b[key], '.3g') if b else '-':<7s}"

    for e in es:
        print(f"{e['scene']:14s} {e['ppc']:3d} {e['rp_over_h']:5.2f} {e['kn_over_kstar']:7.3g} | "
              f"{pair(e, 'factor')} | {pair(e, 'dt_over_contact_bound')} | {pair(e, 'dt_over_nodal_bound')} | "
              f"{pair(e, 'kn_dt2_over_mp')} | {pair(e, 'dt_over_h_c')}{'' if e['monotone'] else '  (not monotone)'}",
              file=sys.stderr)


# -- plot -----------------------------------------------------------------------------------------
STYLE = {"stable": ("o", "#2a9d4b"), "energy gain": ("^", "#f0a500"), "blown up": ("X", "#c0392b"),
         "error": ("s", "#555555")}


def plot(rows: list[dict], es: list[dict], meta: dict, path: Path) -> None:
    """Map panels (rows: scene × ppc; columns: r_p / h) and, on the right, the edge of every
    column in the units of the point-mass and of the nodal-mass bound."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = [s for s in SCENES if any(r["scene"] == s for r in rows)]
    ppcs = sorted({r["ppc"] for r in rows})
    panel_rows = [(s, p) for s in scenes for p in ppcs if any(r["scene"] == s and r["ppc"] == p for r in rows)]
    ncols = max(len({round(r["rp_over_h"], 6) for r in rows if (r["scene"], r["ppc"]) == sp}) for sp in panel_rows)
    fig = plt.figure(figsize=(3.9 * ncols + 5.2, 3.2 * len(panel_rows) + 1.4))
    gs = fig.add_gridspec(len(panel_rows), ncols + 1, width_ratios=[1.0] * ncols + [1.35], wspace=0.28, hspace=0.38)
    kn_all = np.array(sorted({r["kn"] for r in rows}))
    kk = np.geomspace(kn_all.min() / 1.6, kn_all.max() * 1.6, 200)
    fmin = min(r["factor"] for r in rows) / 1.3
    fmax = max(r["factor"] for r in rows) * 1.3
    first = None
    curves = []
    for i, (scene, ppc) in enumerate(panel_rows):
        sz = Sizes(**dict(meta["sizes"], ppc=ppc))
        dt51 = np.array([sz.dt51(scene, k) for k in kk])
        curves = [
            (np.array([sz.point_bound(k) for k in kk]) / dt51, "-", "dt = point-mass bound 2√(m_p/k_n) (ours)"),
            (np.array([sz.nodal_bound(k) for k in kk]) / dt51, "--", "dt = nodal-mass bound 2√(ρh²/k_n)"),
            (sz.h / sz.wave_speed / dt51, ":", "dt = h / c"),
        ]
        rps = sorted({round(r["rp_over_h"], 6) for r in rows if r["ppc"] == ppc and r["scene"] == scene})
        for j, rp_h in enumerate(rps):
            ax = fig.add_subplot(gs[i, j], sharex=first, sharey=first)
            first = first or ax
            here = [r for r in rows if r["scene"] == scene and r["ppc"] == ppc and round(r["rp_over_h"], 6) == rp_h]
            for cls, (marker, colour) in STYLE.items():
                sel = [r for r in here if r["class"] == cls]
                if sel:
                    ax.scatter([r["factor"] for r in sel], [r["kn"] for r in sel], marker=marker, s=40, c=colour,
                               edgecolors="k", linewidths=0.4, zorder=3)
            for x, ls, _ in curves:
                ax.plot(x, kk, color="k", ls=ls, lw=1.0, zorder=2)
            ax.axvline(1.0, color="#3465a4", lw=1.2, zorder=1)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlim(fmin, fmax)
            ax.set_ylim(kk[0], kk[-1])
            ax.set_title(f"{scene}, {ppc}×{ppc} pts/cell, r_p/h = {rp_h:.2f}", fontsize=9.5)
            if i == len(panel_rows) - 1:
                ax.set_xlabel("dt / dt₅₁")
            if j == 0:
                ax.set_ylabel("k_n [N/m per m]")
            ax.grid(True, which="major", lw=0.3, alpha=0.5)

    # edge collapse: where each column turns unstable, in the units of each bound
    sub = gs[:, ncols].subgridspec(2, 1, hspace=0.3)
    colours = {p: c for p, c in zip(ppcs, ("#1f77b4", "#d62728", "#9467bd", "#8c564b", "#17becf"), strict=False)}
    markers = {"disk-drop": "o", "hard-exchange": "s", "lone-point": "^"}
    rps_all = sorted({e["rp_over_h"] for e in es})
    panels = (("dt_over_contact_bound", "point-mass bound 2√(m_p/k_n)", "our default dt: π κ2 × this bound"),
              ("dt_over_nodal_bound", "nodal-mass bound 2√(ρh²/k_n)", "π κ2 × this bound"))
    for k, (key, name, default) in enumerate(panels):
        ax = fig.add_subplot(sub[k])
        for e in es:
            a, b = e["last_stable"], e["first_unstable"]
            if a is None or b is None:
                continue
            shift = 1.0 + 0.05 * (rps_all.index(e["rp_over_h"]) - 0.5 * (len(rps_all) - 1))
            shift *= 1.0 + 0.12 * SCENES.index(e["scene"])
            x = e["kn_over_kstar"] * shift
            lo, hi = a[key], b[key]
            cfl_limited = b["dt_over_h_c"] > 0.7  # the MPM's own Courant edge, not the contact's
            c = colours[e["ppc"]]
            ax.plot([x, x], [lo, hi], color=c, lw=1.2, alpha=0.8)
            ax.scatter([x], [math.sqrt(lo * hi)], marker=markers.get(e["scene"], "D"), s=26,
                       facecolors="none" if cfl_limited else c, edgecolors=c, zorder=3)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.axhline(math.pi * KAPPA2, color="#3465a4", lw=1.0, ls="-.")
        ax.text(0.98, math.pi * KAPPA2 * 1.06, default, ha="right", color="#3465a4", fontsize=7.5,
                transform=ax.get_yaxis_transform())  # x in axes units, y in data units
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(0.12, 6.0)
        ticks = [0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0]
        ax.yaxis.set_major_locator(matplotlib.ticker.FixedLocator(ticks))
        ax.yaxis.set_major_formatter(matplotlib.ticker.FixedFormatter([f"{t:g}" for t in ticks]))
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("k_n / k*   (k*: 2√(m_p/k_n) = κ1 h/c)", fontsize=9)
        ax.set_ylabel(f"dt at the edge / {name}", fontsize=8.5)
        ax.grid(True, which="major", lw=0.3, alpha=0.4)
        ax.set_title(f"stability edge in units of the {name.split(' 2')[0]}", fontsize=9.5)
        if k == 0:
            hs = [plt.Line2D([], [], color=c, lw=1.2, label=f"{p}×{p} points/cell") for p, c in colours.items()]
            hs += [plt.Line2D([], [], marker=m, ls="", color="k", markerfacecolor="none", label=s)
                   for s, m in markers.items() if s in scenes]
            hs.append(plt.Line2D([], [], color="0.4", lw=1.2, label="bar: last stable → first unstable"))
            hs.append(plt.Line2D([], [], marker="o", ls="", color="0.4", markerfacecolor="none",
                                 label="hollow: dt c/h > 0.7 (Courant edge)"))
            ax.legend(handles=hs, fontsize=7.5, loc="upper left", ncol=2)

    handles = [plt.Line2D([], [], marker=m, ls="", color=c, markeredgecolor="k", label=k)
               for k, (m, c) in STYLE.items() if any(r["class"] == k for r in rows)]
    handles += [plt.Line2D([], [], color="k", ls=ls, label=lab) for _, ls, lab in curves]
    handles.append(plt.Line2D([], [], color="#3465a4", lw=1.2, label="dt = dt₅₁ (eq. 51: grid and DEM mass only)"))
    fig.legend(handles=handles, loc="lower center", ncol=4, frameon=False, fontsize=9)
    sz = Sizes(**meta["sizes"])
    fig.suptitle(f"Coupled MPM–DEM stability: elastic disk R = {sz.radius * 100:g} cm, h = R/{sz.cells_per_radius}, "
                 f"e = {sz.restitution:g}, {sz.precision}, device {meta.get('device', '')}", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.98, top=1.0 - 0.75 / fig.get_figheight(),
                        bottom=1.25 / fig.get_figheight())
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- main -----------------------------------------------------------------------------------------
def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N (default cpu)")
    p.add_argument("--quick", action="store_true", help=f"a small sweep ({QUICK}): ~15 s")
    p.add_argument("--scenes", default=DEFAULT_SCENES, help=f"among {', '.join(SCENES)} (default {DEFAULT_SCENES})")
    p.add_argument("--factors", default=None, help=f"dt / dt51 values (default {DEFAULT_FACTORS})")
    p.add_argument("--kn", default=None, help=f"exponents j of k_n = k* 10^(j/2) (default {DEFAULT_KN_EXPONENTS})")
    p.add_argument("--rp", default=None, help="positions s in eq. 45's interval, r_p = (h/√n) · n^(s/2) "
                                              f"(default {DEFAULT_RP})")
    p.add_argument("--ppc", default=None, help=f"points per cell per direction, a list (default {DEFAULT_PPC})")
    p.add_argument("--radius", type=float, default=Sizes.radius, help="disk radius [m]")
    p.add_argument("--cells-per-radius", type=int, default=Sizes.cells_per_radius, help="R / h")
    p.add_argument("--restitution", type=float, default=Sizes.restitution)
    p.add_argument("--precision", default=Sizes.precision, choices=("f32", "f64"))
    p.add_argument("--no-refine", dest="refine", action="store_false",
                   help="skip the extra run per column between its last stable and first non-stable dt")
    p.add_argument("--jobs", type=int, default=None, help="CPU processes (default: 2 on cpu, 1 on cuda)")
    p.add_argument("--gpus", type=int, default=0, help="one worker per GPU, pinned (the study runner's cluster)")
    p.add_argument("--scheduler", default=None, help="a running Dask cluster's address (e.g. dask-jobqueue)")
    p.add_argument("--out", type=Path, default=RESULTS / "coupling_stability" / "cpu.json")
    p.add_argument("--png", type=Path, default=RESULTS / "coupling_stability" / "cpu.png")
    p.add_argument("--replot", type=Path, default=None, help="draw the map from this JSON; run nothing")
    args = p.parse_args(argv)
    if args.replot:
        data = json.loads(args.replot.read_text())
        plot(data["runs"], data["edges"], data["meta"], args.png)
        print_edges(data["edges"])
        return 0
    args.factors = args.factors or (QUICK["factors"] if args.quick else DEFAULT_FACTORS)
    args.kn = args.kn or (QUICK["kn"] if args.quick else DEFAULT_KN_EXPONENTS)
    args.rp = args.rp or (QUICK["rp"] if args.quick else DEFAULT_RP)
    args.ppc_list = [int(v) for v in (args.ppc or (QUICK["ppc"] if args.quick else DEFAULT_PPC)).split(",")]
    if args.jobs is None:
        args.jobs = min(2, os.cpu_count() or 1) if args.device == "cpu" else 1
    args.sizes = dict(radius=args.radius, cells_per_radius=args.cells_per_radius, ppc=args.ppc_list[0],
                      restitution=args.restitution, precision=args.precision)
    t0 = time.perf_counter()
    rows = sweep(args)
    es = edges(rows)
    per_ppc = {}
    for ppc in args.ppc_list:
        sz = Sizes(**dict(args.sizes, ppc=ppc))
        per_ppc[str(ppc)] = {"point_mass": sz.point_mass, "k_star": sz.k_star, "rp_interval": sz.rp_interval()}
    sz = Sizes(**args.sizes)
    meta = {"device": args.device, "sizes": args.sizes, "ppc": args.ppc_list, "per_ppc": per_ppc,
            "kappa1": KAPPA1, "kappa2": KAPPA2, "gain_threshold": GAIN, "h": sz.h, "wave_speed": sz.wave_speed,
            "node_mass": sz.node_mass, "disk_mass": sz.disk_mass, "dt51_cfl_term": sz.dt_cfl51,
            "factors": args.factors, "kn_exponents": args.kn, "rp_positions": args.rp, "refine": args.refine,
            "seconds": time.perf_counter() - t0, "runs": len(rows),
            "notes": "dt51 = min(kappa1 h / c_max, 2 pi kappa2 sqrt(m_min / k_n)) with m_min the DEM disk mass; "
                     "disk-drop has no free DEM body, so dt51 = kappa1 h / c_max there. k_n = k* 10^(j/2), k* = "
                     "4 m_p / (kappa1 h / c)^2. Contact: e = restitution (1: no damping), k_t = k_n / 20, mu = 0.1. "
                     "'energy gain': max over frames of E(t) - E(0) > 0.5 % of E_kin(0) + the released gravity "
                     "energy; 'blown up': BlowUpError (blowup_energy_factor = 1). Edges: per column, the first "
                     "non-stable dt and the largest stable dt below it."}
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"meta": meta, "edges": es, "runs": rows}, indent=1) + "\n")
    if args.png:
        plot(rows, es, meta, args.png)
    print_edges(es)
    print(f"{len(rows)} runs in {meta['seconds']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
