"""Motion integration: accuracy, cost and stability of every transfer scheme and update order.

For each case (``rotating-disk``: a free spinning elastic disk; ``bouncing-disk``: an elastic
disk dropped on a rigid floor) it runs every transfer scheme of ``mpmdem.TRANSFER_SCHEMES``
(read at run time; XPIC runs as XPIC(2) and XPIC(4) when ``SolverConfig`` has ``xpic_order``)
× every stress-update order of ``mpmdem.STRESS_UPDATES`` × CFL factors κ × resolutions.

- κ is the factor of the device time-step policy dt = κ h / max_p(c_p + |v_p|), so κ = dt/dt_CFL
  (``cfl_measured`` is the median of dt/dt_bound over the frames). κ > 1 is past the Courant
  bound: those runs pass ``allow_unstable=True`` when ``SolverConfig`` has that field, and are
  skipped with a printed note otherwise.
- Resolutions are the case's own cell sizes: ``quick`` (its ``--quick`` build) and ``default``.
  Both run the same simulated time, the quick build's end time (× ``--end-time-scale``), so the
  errors of the two resolutions measure the same thing. Frames scale with the end time.
- error: rotating disk |1 − L_final/L_0| (angular momentum); bouncing disk |1 − e| with e the
  first rebound ratio (|1 − E_final/E_0| when there is no rebound; ``error_kind`` says which);
  any other case (``--cases sulsky-disks``) the energy error. ``energy_error`` is
  |1 − E_final/E_0| (the case's own figure when it reports one, else the frame diagnostics).
- A run that raises ``BlowUpError`` is unstable (``reason`` = its keyword); an ``InputError``
  is recorded as ``rejected``; any other exception as ``error`` with its message. No run stops
  the sweep.
- ``wall_seconds`` times ``Simulation.run`` only, less the seconds spent inside the HDF5 frame
  writer (``write_seconds``): when a case's ``summarize`` reads the run file (bouncing-disk's
  does), its runs write one to a temporary folder (found out per case by calling ``summarize``
  on a short run without a file). One untimed warm-up run (a few steps) per (case, scheme, order, resolution) loads, and
  the first time compiles, the kernels first; its time is ``warmup_seconds``. On CUDA the
  graph capture of each run's Simulation is inside ``wall_seconds`` (a few ms).

Default sweep size: 2 cases × 14 scheme variants (12 + XPIC(2), XPIC(4)) × 4 orders × 6 κ at the
quick resolution, plus κ = 0.5 and 1.0 at the default resolution (``--default-cfl``; ``all`` for
every κ): 896 runs. The default resolution has 4x the points and 2x the steps, so each of its
runs costs ~4-8x a quick one, and κ = 0.1 alone would cost more than the rest of its row; the
two κ at the bound and half of it give each scheme a second resolution on the Pareto chart at
about a sixth of the cost of all κ (past the bound, runs mostly blow up within a few steps anyway).
Measured on 2 CPU cores: 9.0 min with the default ``--jobs 2`` on a CPU (one process per core:
Warp's CPU kernels are single-threaded; each run is timed inside its own process), kernels
compiled; 22.6 min with one process on a first run that also compiled the kernels and wrote
frames for both cases (about a quarter of its time went to the writes). The
first compile of each new kernel variant adds ~1-5 s (``warmup_seconds``). ``--smoke`` runs
2 schemes × 2 orders × κ 0.5, 2.5 × quick only (~6 s) and writes ``cpu_smoke*`` files.

Writes one JSON line per run to stdout and ``--out``, a Pareto chart (error vs wall time of the
stable runs, each scheme's Pareto front highlighted; per case one panel for its own error and one for
|1 − E/E₀|, never mixed; one colour family per scheme family of Table 1, a marker per scheme; κ ≤ 1
filled and its band of wall times shaded as the stable region) to ``--pareto`` and a stability map
(fraction of stable runs per scheme and κ) to ``--stability``.

    python bench/motion_integration.py --smoke                    # ~6 s on a CPU
    python bench/motion_integration.py                            # the full sweep, cpu, ~9 min
    python bench/motion_integration.py --device cuda --default-cfl all \
        --out bench/results/motion_integration/h100.jsonl \
        --pareto bench/results/motion_integration/h100_pareto.png \
        --stability bench/results/motion_integration/h100_stability.png
    python bench/motion_integration.py --replot bench/results/motion_integration/cpu.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import importlib
import json
import math
import os
import tempfile
import time
import traceback
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

import mpmdem
import mpmdem.io
from mpmdem import BlowUpError, InputError, Simulation, SolverConfig
from mpmdem.sim.mpm import initial_dt_bound
from mpmdem.study.cluster import map_tasks
from mpmdem.study.runner import make_case_parser

RESULTS = Path(__file__).resolve().parent / "results"
DEFAULT_CASES = ("rotating-disk", "bouncing-disk")
DEFAULT_CFL = "0.1,0.25,0.5,1.0,1.5,2.5"
DEFAULT_RES_CFL = "0.5,1.0"
XPIC_ORDERS = (2, 4)
#: errors below this are drawn at it on the log axis (f32 round-off is ~1e-7)
ERROR_FLOOR = 1e-10
#: warm-up run length, in initial CFL steps at κ = 0.5
WARMUP_STEPS = 3


# -- cases ------------------------------------------------------------------------------------------
def load_case(name: str):
    """The module of a case by its CLI name, or None when it is not there (yet)."""
    try:
        from mpmdem.study.runner import case_module

        return case_module(name)
    except (InputError, ImportError):
        pass
    try:
        return importlib.import_module(f"mpmdem.cases.{name.replace('-', '_')}")
    except ImportError:
        return None


def build_setup(module, resolution: str):
    """CaseSetup at the case's quick or default resolution (flags filled in by its parser)."""
    args = make_case_parser(module).parse_args(["--quick"] if resolution == "quick" else [])
    return args, module.build(args)


def _number(v) -> float | None:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def energy_error(summary: dict, diagnostics: dict) -> float | None:
    """|1 − E_final/E_0|: the case's own ratio when it reports one, else the frame diagnostics."""
    for key in ("energy_total_final_over_initial", "total_energy_final_over_initial"):
        r = _number(summary.get(key))
        if r is not None:
            return abs(1.0 - r)
    e = diagnostics.get("energy_total")
    if e is None or len(e) < 2 or not np.isfinite(e).all() or e[0] == 0.0:
        return None
    return float(abs(1.0 - e[-1] / e[0]))


def case_error(case: str, summary: dict, e_err: float | None) -> tuple[float | None, str]:
    """(error, kind) of one completed run; see the module docstring."""
    if case == "rotating-disk":
        r = _number(summary.get("angular_momentum_final_over_initial"))
        if r is not None:
            return abs(1.0 - r), "angular-momentum"
    if case == "bouncing-disk":
        r = _number(summary.get("rebound_ratio_first"))
        if r is not None:
            return abs(1.0 - r), "rebound"
    return e_err, "energy"


# -- the sweep -------------------------------------------------------------------------------------
def scheme_variants(names: list[str] | None) -> list[tuple[str, int | None]]:
    """(scheme, xpic_order) pairs: every scheme once, XPIC once per order when it has one."""
    has_order = "xpic_order" in {f.name for f in dataclasses.fields(SolverConfig)}
    out = []
    for s in mpmdem.TRANSFER_SCHEMES:
        if names is not None and s not in names:
            continue
        if s == "XPIC" and has_order:
            out += [(s, m) for m in XPIC_ORDERS]
        else:
            out.append((s, None))
    return out


def label(scheme: str, xpic_order: int | None) -> str:
    return scheme if xpic_order is None else f"{scheme}({xpic_order})"


def make_config(module, setup, scheme: str, xpic_order: int | None, update: str, cfl: float) -> SolverConfig:
    """Case defaults and build choices, then this run's scheme, order and κ."""
    fields = dict(getattr(module, "DEFAULTS", {}))
    fields.update(setup.config)
    fields.update(transfer=scheme, update=update, cfl=cfl)
    fields.pop("dt", None)
    if xpic_order is not None:
        fields["xpic_order"] = xpic_order
    if cfl > 1.0:
        fields["allow_unstable"] = True
    return SolverConfig(**fields)


def _short_run(module, setup, scheme, xpic_order, update, device, out):
    """A few steps at κ = 0.5: loads (the first time compiles) the kernels of this variant."""
    config = make_config(module, setup, scheme, xpic_order, update, 0.5)
    sim = Simulation(setup.scene, config, device=device)
    result = sim.run(WARMUP_STEPS * 0.5 * initial_dt_bound(setup.scene), frames=1, out=out)
    return sim, result


def needs_file(module, device: str) -> bool:
    """Whether the case's summarize reads the run's HDF5 file (it fails on a run without one)."""
    args, setup = build_setup(module, "quick")
    cfg = {**getattr(module, "DEFAULTS", {}), **setup.config}
    try:
        sim, result = _short_run(module, setup, cfg.get("transfer", "APIC"), None, cfg.get("update", "USL"),
                                 device, None)
    except Exception:
        return False
    try:
        module.summarize(sim, result, args)
    except Exception:
        return True
    return False


class _WriteTimer:
    """Swaps mpmdem.io.FrameWriter (Simulation.run imports it per call) for a subclass that adds
    the seconds spent writing frames to ``seconds``, so they can be kept out of wall_seconds."""

    def __init__(self):
        self.seconds = 0.0

    def __enter__(self):
        timer = self
        self.original = base = mpmdem.io.FrameWriter

        def timed(name):
            def method(self, *a, **k):
                start = time.perf_counter()
                try:
                    return getattr(base, name)(self, *a, **k)
                finally:
                    timer.seconds += time.perf_counter() - start

            return method

        mpmdem.io.FrameWriter = type("TimedFrameWriter", (base,), {
            name: timed(name) for name in ("__init__", "write_frame", "set_status", "close")})
        return self

    def __exit__(self, *exc):
        mpmdem.io.FrameWriter = self.original


def run_one(case: str, module, resolution: str, built, scheme: str, xpic_order: int | None, update: str,
            cfl: float, device: str, end_time: float, frames: int, with_file: bool) -> dict:
    """One timed run of ``built`` = (case args, CaseSetup) to ``end_time``; never raises."""
    row = dict(case=case, scheme=scheme, xpic_order=xpic_order, update=update, cfl=cfl, cfl_measured=None,
               resolution=resolution, h=None, particles=None, steps=None, end_time=end_time, frames=frames,
               wall_seconds=None, write_seconds=None, error=None, error_kind=None, energy_error=None,
               stable=False, status="error", reason=None, blowup_time=None, shape=None, precision=None,
               device=device, warmup_seconds=None)
    try:
        args, setup = built
        row.update(h=setup.scene.cell_size)
        config = make_config(module, setup, scheme, xpic_order, update, cfl)
        row.update(shape=config.shape, precision=config.precision)
        sim = Simulation(setup.scene, config, device=device)
        row.update(particles=sim.particle_count, device=sim.device)
        with tempfile.TemporaryDirectory(prefix="motion_integration_") as tmp:
            writes = _WriteTimer()
            start = time.perf_counter()
            try:
                with writes:
                    result = sim.run(end_time, frames=frames, out=tmp if with_file else None)
            finally:
                row["wall_seconds"] = time.perf_counter() - start - writes.seconds
                row["write_seconds"] = writes.seconds
            d = result.diagnostics
            ratio = d["dt"][1:] / np.maximum(d["dt_bound"][1:], 1e-300)
            row.update(steps=result.steps, stable=True, status="completed", cfl_measured=float(np.median(ratio)))
            try:
                summary = module.summarize(sim, result, args)
            except Exception as e:
                summary = {}
                row["reason"] = f"summarize failed: {type(e).__name__}: {e}"
        e_err = energy_error(summary, d)
        err, kind = case_error(case, summary, e_err)
        row.update(error=err, error_kind=kind, energy_error=e_err)
    except BlowUpError as e:
        row.update(stable=False, status="blown-up", reason=e.reason, blowup_time=e.time)
    except InputError as e:
        row.update(stable=False, status="rejected", reason=str(e))
    except Exception as e:
        row.update(stable=False, status="error", reason=f"{type(e).__name__}: {e}")
        traceback.print_exc()
    return row


@functools.cache
def _built(case: str, resolution: str):
    return build_setup(load_case(case), resolution)


def run_group(task: dict) -> list[dict]:
    """Warm-up, then the timed runs of one (case, resolution, scheme, order) at every κ of the task."""
    case, resolution, scheme, m, update = (task[k] for k in ("case", "resolution", "scheme", "xpic_order", "update"))
    module = load_case(case)
    built = _built(case, resolution)
    start = time.perf_counter()
    broken = None
    try:
        with tempfile.TemporaryDirectory(prefix="motion_integration_") as tmp:
            _short_run(module, built[1], scheme, m, update, task["device"], tmp if task["with_file"] else None)
    except (BlowUpError, InputError):
        pass  # the timed runs record these
    except Exception as e:  # a broken kernel variant: its timed runs are not attempted
        broken = f"{type(e).__name__}: {e}"
    warm = time.perf_counter() - start
    rows = []
    for cfl in task["cfls"]:
        if broken:
            row = dict(case=case, scheme=scheme, xpic_order=m, update=update, cfl=cfl, resolution=resolution,
                       h=built[1].scene.cell_size, stable=False, status="error", reason=f"warm-up failed: {broken}",
                       device=task["device"], error=None, energy_error=None, wall_seconds=None)
        else:
            row = run_one(case, module, resolution, built, scheme, m, update, cfl, task["device"],
                          task["end_time"], task["frames"], task["with_file"])
        row["warmup_seconds"] = warm
        rows.append(row)
    return rows


def plan(args) -> list[dict]:
    """The groups of runs of the sweep, quick resolution first (its warm-ups compile the kernels)."""
    has_unstable = "allow_unstable" in {f.name for f in dataclasses.fields(SolverConfig)}
    cfls = sorted(float(c) for c in args.cfl.split(","))
    if not has_unstable and any(c > 1.0 for c in cfls):
        skipped = [c for c in cfls if c > 1.0]
        print(f"note: SolverConfig has no allow_unstable field, so κ = {', '.join(map(str, skipped))} "
              "(past the Courant bound) are skipped", flush=True)
        cfls = [c for c in cfls if c <= 1.0]
    if args.default_cfl.strip().lower() == "all":
        default_cfls = cfls
    else:
        wanted = {float(c) for c in args.default_cfl.split(",")}
        default_cfls = [c for c in cfls if c in wanted]
    variants = scheme_variants(_subset(args.schemes, mpmdem.TRANSFER_SCHEMES, "scheme"))
    updates = _subset(args.updates, mpmdem.STRESS_UPDATES, "update") or list(mpmdem.STRESS_UPDATES)
    resolutions = [r.strip() for r in args.resolutions.split(",")]
    for r in resolutions:
        if r not in ("quick", "default"):
            raise SystemExit(f"--resolutions: unknown resolution {r!r}; allowed: quick, default")
    tasks = []
    for case in [c.strip() for c in args.cases.split(",")]:
        module = load_case(case)
        if module is None:
            print(f"note: case {case!r} not found (no mpmdem.cases module); skipped", flush=True)
            continue
        _, quick = build_setup(module, "quick")
        end_time = quick.end_time * args.end_time_scale
        frames = max(2, round(quick.frames * args.end_time_scale))
        with_file = needs_file(module, args.device)
        if with_file:
            print(f"note: {case}'s summarize reads the run file, so its runs write one to a temporary folder "
                  "(the seconds spent writing are write_seconds, not in wall_seconds)", flush=True)
        for resolution in resolutions:
            res_cfls = default_cfls if resolution == "default" else cfls
            if not res_cfls:
                continue
            for scheme, m in variants:
                for update in updates:
                    tasks.append(dict(case=case, resolution=resolution, scheme=scheme, xpic_order=m, update=update,
                                      cfls=res_cfls, device=args.device, end_time=end_time, frames=frames,
                                      with_file=with_file))
    order = {"quick": 0, "default": 1}
    return sorted(tasks, key=lambda t: order[t["resolution"]])  # stable: cases keep their order


def sweep(args) -> list[dict]:
    """Run every group (in ``--jobs`` processes); print and write one JSON line per run."""
    tasks = plan(args)
    runs = sum(len(t["cfls"]) for t in tasks)
    print(f"sweep: {len(tasks)} groups, {runs} runs, {args.jobs} process(es)", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    start = time.perf_counter()
    with args.out.open("w") as out:
        def emit(group: list[dict]) -> None:
            for row in group:
                rows.append(row)
                line = json.dumps(row)
                print(line, flush=True)
                out.write(line + "\n")
            out.flush()

        # the study runner's clusters (mpmdem.study.cluster): --jobs CPU processes, --gpus pinned GPU
        # workers or --scheduler; a group's rows as soon as it ends
        for group in map_tasks(run_group, tasks, workers=args.jobs, gpus=args.gpus, scheduler=args.scheduler):
            emit(group)
    print(f"\nsweep: {len(rows)} runs in {time.perf_counter() - start:.1f} s", flush=True)
    return rows


def _subset(text: str | None, allowed, what: str) -> list[str] | None:
    if not text:
        return None
    names = [t.strip().upper() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in allowed]
    if bad:
        raise SystemExit(f"--{what}s: unknown {what} {', '.join(bad)}; allowed: {', '.join(allowed)}")
    return names


# -- reporting -------------------------------------------------------------------------------------
def _labels(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(label(r["scheme"], r.get("xpic_order")) for r in rows))


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Points (seconds, error) not beaten on both by another, in order of seconds."""
    front, best = [], math.inf
    for s, e in sorted(points):
        if e < best:
            front.append((s, e))
            best = e
    return front


STYLES = "os^Dv<>pPX*hH8d"

#: "Motion integration" Table 1's families, one colour family each (schemes not listed: greys)
FAMILIES = {
    "PIC": (("PIC", "TPIC", "APIC"), "Blues"),
    "FLIP": (("FLIP", "TFLIP", "AFLIP", "NFLIP", "ANFLIP"), "Reds"),
    "FLIPX": (("FLIPX", "AFLIPX", "NFLIPX", "ANFLIPX"), "Greens"),
    "XPIC": (("XPIC",), "Purples"),
}
#: each error kind of a case, drawn in a panel of its own: the case's own measure and the energy
#: error are never mixed in one panel (a run without a rebound has only the energy error)
CASE_METRIC = {"rotating-disk": ("angular-momentum", "|1 − L/L₀|"), "bouncing-disk": ("rebound", "|1 − rebound ratio|")}


def scheme_style(labels: list[str]) -> dict[str, tuple]:
    """label → (colour, marker): the colour's hue says the family, its shade the member; every
    label has its own marker."""
    out = {}
    members: dict[str, list[str]] = {}
    for lab in labels:
        base = lab.split("(")[0]
        fam = next((f for f, (names, _) in FAMILIES.items() if base in names), "other")
        members.setdefault(fam, []).append(lab)
    k = 0
    for fam, labs in members.items():
        cmap = plt.get_cmap(FAMILIES[fam][1] if fam in FAMILIES else "Greys")
        for i, lab in enumerate(labs):
            shade = 0.45 + 0.5 * (i / max(len(labs) - 1, 1)) if len(labs) > 1 else 0.75
            out[lab] = (cmap(shade), STYLES[k % len(STYLES)])
            k += 1
    return out


def plot_pareto(rows: list[dict], path: Path) -> None:
    """Per case (columns) and error measure (rows: the case's own, then |1 − E/E₀|): error against
    wall seconds (log-log) of the stable runs, each scheme's Pareto front drawn. Runs within the
    Courant bound (κ ≤ 1) are filled, stable runs past it open; the band of wall times the κ ≤ 1
    runs span is shaded (where stability is expected, not luck)."""
    cases = list(dict.fromkeys(r["case"] for r in rows))
    labels = _labels(rows)
    style = scheme_style(labels)
    ncase = max(1, len(cases))
    fig, axes = plt.subplots(2, ncase, figsize=(6.0 * ncase + 2.2, 9.0), squeeze=False, constrained_layout=True)
    handles = {}
    for col, case in enumerate(cases):
        kind, what = CASE_METRIC.get(case, ("energy", "|1 − E/E₀|"))
        panels = [(kind, what), ("energy", "|1 − E/E₀|")] if kind != "energy" else [("energy", what)]
        for row, (metric, ylabel) in enumerate(panels):
            ax = axes[row][col]

            def err(r, metric=metric):
                v = r.get("energy_error") if metric == "energy" else (r.get("error") if r.get("error_kind") == metric
                                                                      else None)
                return None if v is None else max(v, ERROR_FLOOR)

            sel = [r for r in rows
                   if r["case"] == case and r["stable"] and r.get("wall_seconds") and err(r) is not None]
            inside = [r["wall_seconds"] for r in sel if r["cfl"] <= 1.0]
            if inside:
                ax.axvspan(min(inside), max(inside), color="#e8f4e8", zorder=0,
                           label="wall times of κ ≤ 1 runs" if (row, col) == (0, 0) else None)
            for lab in labels:
                mine = [r for r in sel if label(r["scheme"], r.get("xpic_order")) == lab]
                if not mine:
                    continue
                color, marker = style[lab]
                for within in (True, False):
                    pts = [(r["wall_seconds"], err(r)) for r in mine if (r["cfl"] <= 1.0) == within]
                    if pts:
                        ax.scatter(*zip(*pts, strict=False), s=16, marker=marker, alpha=0.45, zorder=2,
                                   facecolors=color if within else "none", edgecolors=color, linewidths=0.6)
                front = pareto_front([(r["wall_seconds"], err(r)) for r in mine])
                (h,) = ax.plot(*zip(*front, strict=False), marker=marker, color=color, lw=1.4, ms=6, zorder=3,
                               markeredgecolor="k", markeredgewidth=0.4, drawstyle="steps-post", label=lab)
                handles[lab] = h
            ax.set_xscale("log")
            ax.set_yscale("log")
            # 1-2-5 labels on the time axis: the runs span about one decade, too few for decade labels
            ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.yaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel("wall seconds of Simulation.run")
            ax.set_ylabel(f"error {ylabel}")
            device = ", ".join(sorted({str(r.get("device")) for r in rows if r["case"] == case}))
            ax.set_title(f"{case} ({device}): {ylabel}", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
        for row in range(len(panels), 2):
            axes[row][col].set_visible(False)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    keys = [lab for lab in labels if lab in handles]
    extra = [Patch(color="#e8f4e8", label="stable region: wall times of κ ≤ 1 runs"),
             Line2D([], [], ls="", marker="o", color="0.3", label="κ ≤ 1 (filled)"),
             Line2D([], [], ls="", marker="o", mfc="none", color="0.3", label="κ > 1, stable (open)")]
    fig.legend([handles[k] for k in keys] + extra, keys + [e.get_label() for e in extra],
               loc="outside right center", fontsize=8,
               title="scheme (hue: family of\n'Motion integration' Table 1)\nlines: Pareto fronts")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def stability_table(rows: list[dict], case: str, labels: list[str], cfls: list[float]):
    """(fraction stable, stable count, decided count) per scheme × κ; NaN where no run decided."""
    frac = np.full((len(labels), len(cfls)), np.nan)
    counts = {}
    for i, lab in enumerate(labels):
        for j, c in enumerate(cfls):
            sel = [r for r in rows if r["case"] == case and label(r["scheme"], r.get("xpic_order")) == lab
                   and r["cfl"] == c and r["status"] in ("completed", "blown-up")]
            if sel:
                n_ok = sum(r["stable"] for r in sel)
                frac[i, j] = n_ok / len(sel)
                counts[i, j] = (n_ok, len(sel))
    return frac, counts


def plot_stability(rows: list[dict], path: Path) -> None:
    """Per case: scheme × κ cells coloured by the fraction of stable runs (over orders, resolutions)."""
    cases = list(dict.fromkeys(r["case"] for r in rows))
    labels = _labels(rows)
    cfls = sorted({r["cfl"] for r in rows})
    cmap = plt.get_cmap("RdYlGn").copy()
    cmap.set_bad("0.85")
    ncase = max(1, len(cases))
    width = max(3.6, 0.75 * len(cfls) + 1.7) * ncase + 1.2
    fig, axes = plt.subplots(1, ncase, squeeze=False, constrained_layout=True,
                             figsize=(width, max(3.2, 1.5 + 0.42 * len(labels))))
    im = None
    for ax, case in zip(axes[0], cases, strict=False):
        frac, counts = stability_table(rows, case, labels, cfls)
        im = ax.imshow(np.ma.masked_invalid(frac), cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto")
        for i in range(len(labels)):
            for j in range(len(cfls)):
                if (i, j) in counts:
                    ok, n = counts[i, j]
                    ax.text(j, i, f"{frac[i, j]:.2f}\n{ok}/{n}", ha="center", va="center", fontsize=7.5,
                            linespacing=1.0, color="k" if 0.25 < frac[i, j] < 0.8 else "w")
                else:
                    ax.text(j, i, "n/a", ha="center", va="center", fontsize=6.5, color="0.35")
        ax.set_xticks(range(len(cfls)), [f"{c:g}" for c in cfls])
        ax.set_yticks(range(len(labels)), labels)
        over = [j for j, c in enumerate(cfls) if c > 1.0]
        if over and over[0] > 0:
            ax.axvline(over[0] - 0.5, color="k", lw=1.5, ls="--")
        ax.set_xlabel("κ = dt / dt_CFL")
        ax.set_title(case, fontsize=10)
    if im is not None:
        fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8, label="fraction of runs stable")
    fig.suptitle("stable runs / runs over update orders × resolutions; dashed: Courant bound κ = 1; "
                 "n/a: no run completed or blew up", fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(rows: list[dict]) -> str:
    """Per case and scheme: runs, stable, largest stable κ, best error and its run."""
    lines = []
    for case in dict.fromkeys(r["case"] for r in rows):
        lines.append(f"\n{case}")
        lines.append(f"{'scheme':>10} {'runs':>5} {'stable':>6} {'rej/err':>7} {'max κ':>6} {'best error':>11}"
                     f" {'at (update, κ, res, s)':>28} {'median error':>13}")
        for lab in _labels(rows):
            sel = [r for r in rows if r["case"] == case and label(r["scheme"], r.get("xpic_order")) == lab]
            if not sel:
                continue
            ok = [r for r in sel if r["stable"] and r.get("error") is not None]
            bad = sum(r["status"] in ("rejected", "error") for r in sel)
            ks = [r["cfl"] for r in sel if r["stable"]]
            if ok:
                best = min(ok, key=lambda r: r["error"])
                at = f"{best['update']}, {best['cfl']:g}, {best['resolution']}, {best['wall_seconds']:.2f}"
                med = float(np.median([r["error"] for r in ok]))
                lines.append(f"{lab:>10} {len(sel):5d} {sum(r['stable'] for r in sel):6d} {bad:7d} "
                             f"{max(ks):6g} {best['error']:11.3e} {at:>28} {med:13.3e}")
            else:
                lines.append(f"{lab:>10} {len(sel):5d} {0:6d} {bad:7d} {'-':>6} {'-':>11}")
    return "\n".join(lines)


def main(argv=None) -> None:
    """Parse the flags; run the sweep (or re-read a JSONL); print the table; draw both charts."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N (default cpu)")
    parser.add_argument("--cases", default=",".join(DEFAULT_CASES), help="comma-separated case names")
    parser.add_argument("--schemes", default=None, help="subset of transfer schemes (default: all)")
    parser.add_argument("--updates", default=None, help="subset of stress-update orders (default: all)")
    parser.add_argument("--cfl", default=DEFAULT_CFL, help=f"CFL factors κ = dt/dt_CFL (default {DEFAULT_CFL})")
    parser.add_argument("--resolutions", default="quick,default", help="quick, default or both")
    parser.add_argument("--default-cfl", default=DEFAULT_RES_CFL,
                        help=f"κ values also run at the default resolution (default {DEFAULT_RES_CFL}; 'all')")
    parser.add_argument("--jobs", type=int, default=None,
                        help="worker processes, each running whole groups (default 1 on a GPU, 2 on a CPU "
                             "with 2 or more cores: Warp's CPU kernels use one core)")
    parser.add_argument("--gpus", type=int, default=0, help="one worker per GPU, pinned (the study runner's cluster)")
    parser.add_argument("--scheduler", default=None, help="a running Dask cluster's address (e.g. dask-jobqueue)")
    parser.add_argument("--end-time-scale", type=float, default=1.0, help="multiplies the cases' end times")
    parser.add_argument("--smoke", action="store_true",
                        help="2 schemes × 2 orders × κ 0.5, 2.5 × quick only (writes cpu_smoke* files)")
    parser.add_argument("--out", type=Path, default=None,
                        help="JSON lines file (default bench/results/motion_integration/cpu.jsonl)")
    parser.add_argument("--pareto", type=Path, default=None,
                        help="default bench/results/motion_integration/cpu_pareto.png")
    parser.add_argument("--stability", type=Path, default=None,
                        help="default bench/results/motion_integration/cpu_stability.png")
    parser.add_argument("--replot", type=Path, default=None, help="draw the charts from this JSONL; run nothing")
    args = parser.parse_args(argv)
    if args.jobs is None:
        args.jobs = min(2, os.cpu_count() or 1) if args.device == "cpu" else 1
    suffix = "_smoke" if args.smoke else ""
    args.out = args.out or RESULTS / "motion_integration" / f"cpu{suffix}.jsonl"
    args.pareto = args.pareto or RESULTS / "motion_integration" / f"cpu{suffix}_pareto.png"
    args.stability = args.stability or RESULTS / "motion_integration" / f"cpu{suffix}_stability.png"
    if args.smoke:
        names = list(mpmdem.TRANSFER_SCHEMES)
        args.schemes = args.schemes or ",".join([s for s in ("APIC", "FLIP") if s in names] or names[:2])
        orders = list(mpmdem.STRESS_UPDATES)
        args.updates = args.updates or ",".join([u for u in ("USL", "MUSL") if u in orders] or orders[:2])
        args.cfl = "0.5,2.5" if args.cfl == DEFAULT_CFL else args.cfl
        args.resolutions = "quick"

    if args.replot is not None:
        rows = [json.loads(line) for line in args.replot.read_text().splitlines() if line.strip()]
    else:
        rows = sweep(args)
    print(report(rows))
    if rows:
        plot_pareto(rows, args.pareto)
        plot_stability(rows, args.stability)
        print(f"\nlines: {args.out if args.replot is None else args.replot}\npareto: {args.pareto}"
              f"\nstability: {args.stability}")


if __name__ == "__main__":
    main()
