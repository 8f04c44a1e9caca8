"""The block-impact studies' analysis: event times against MPM-SDEM §6 under both readings of
"lands" (first touch of the floor, the paper's "touches the ground"; at rest on a face), the blocks'
final poses, block 2's orientation history, each run's wall time against its largest event-time
error, and, for an ensemble (several starts per grid), each event's median and spread and the
distribution of final poses.

The readings are recomputed from each run's tracks with ``mpmdem.study.references.block_impact.readings`` (times,
lowest point, angle), so runs written before the two readings existed are read the same way.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np

from ..references.block_impact import T_PAPER, readings

#: the events of a run: the flow's arrival, and each free block's first touch and rest [s]
EVENTS = ("reach", "block2_touch", "block2_rest", "block1_touch", "block1_rest")
BLOCKS = ("block2", "block1")


def label(run: dict) -> str:
    """What distinguishes a run: grid, friction set, rounding, coupling and MPM variant (and its start)."""
    gran = "granular" if run.get("granular") else "plain MPM"
    seed = run.get("ensemble_seed")
    start = f", start {seed}" if seed is not None else ""
    return (f"h {1000 * run['cell_size']:.3g} mm, μ {run['friction_set']}, r {1000 * run['sphero_radius']:.3g} mm, "
            f"{run['coupling']}, {gran}{start}")


def run_events(run: dict) -> dict:
    """A completed run's events [s] (``EVENTS``; None where it did not happen) and its blocks' final
    poses, from its tracks."""
    events = {"reach": run.get("reach_time")}
    poses = {}
    for n in BLOCKS:
        r = readings(run["times"], run[f"{n}_lowest_point_m"], run[f"{n}_angle_deg"])
        events[f"{n}_touch"], events[f"{n}_rest"] = r["touch"], r["rest"]
        poses[n] = r["pose"]
    return {"events_s": events, "poses": poses}


def spread(values: list[float | None]) -> dict:
    """Median, quartiles, min and max of the values that exist [s], and how many did not."""
    v = np.array([x for x in values if x is not None], dtype=float)
    out = {"n": len(values), "missing": len(values) - len(v)}
    if len(v):
        q25, med, q75 = np.percentile(v, [25, 50, 75])
        out.update(median=float(med), q25=float(q25), q75=float(q75), min=float(v.min()), max=float(v.max()))
    return out


def ensemble(runs: list[dict]) -> list[dict]:
    """The completed runs grouped by grid and friction set: per group, each event's ``spread`` (and
    its median's distance to the paper where the paper gives the event: the touch reading) and the
    count of each final pose per block."""
    groups: dict[tuple, list[dict]] = {}
    for r in runs:
        if r.get("status") == "completed":
            groups.setdefault((r["cell_size"], r["friction_set"]), []).append(r)
    out = []
    for (h, friction), members in sorted(groups.items()):
        read = [run_events(r) for r in members]
        events = {}
        for e in EVENTS:
            s = spread([x["events_s"][e] for x in read])
            if e in T_PAPER and "median" in s:
                s["paper"] = T_PAPER[e]
                s["median_minus_paper"] = s["median"] - T_PAPER[e]
            events[e] = s
        poses = {n: dict(Counter(x["poses"][n] for x in read).most_common()) for n in BLOCKS}
        out.append({"cell_size": h, "friction_set": friction, "starts": len(members), "events_s": events,
                    "final_poses": poses})
    return out


def analyze(runs: list[dict], out: Path, title: str) -> dict:
    """Writes OUT/block_impact.json (events and poses per run, and the ensemble summary per grid) and
    OUT/block_impact_orientation.png, OUT/block_impact_speed_accuracy.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    table = []
    for r in runs:
        row = {"run": r.get("run"), "status": r.get("status"), "message": r.get("message", ""),
               "wall_seconds": r.get("wall_seconds"), "points": r.get("points"), "steps": r.get("steps")}
        if r.get("status") == "completed":
            ev = run_events(r)
            errors = {k: (ev["events_s"][k] - t) if ev["events_s"][k] is not None else None for k, t in T_PAPER.items()}
            known = [abs(v) for v in errors.values() if v is not None]
            row.update(label=label(r), events_s=ev["events_s"], errors_s=errors, final_poses=ev["poses"],
                       max_error_s=max(known) if len(known) == len(errors) else None,
                       deepest_penetration_m=r["deepest_penetration_m"],
                       block2_final_orientation_deg=r["block2_final_orientation_deg"])
        table.append(row)
    report = {"paper_s": T_PAPER, "readings": {"touch": "first frame with the lowest point within 1 mm of the "
                                                         "floor (the paper's 'touches the ground')",
                                               "rest": "on a face on the floor from that frame to the end"},
              "runs": table, "ensemble": ensemble(runs)}
    (out / "block_impact.json").write_text(json.dumps(report, indent=2, default=float) + "\n")

    done = [r for r in runs if r.get("status") == "completed"]
    fig, (a2, a1) = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    colours = plt.cm.tab10(np.linspace(0, 1, 10))
    many = len(done) > 10
    for k, r in enumerate(done):
        for ax, n in ((a2, "block2"), (a1, "block1")):
            ax.plot(r["times"], r[f"{n}_orientation_deg"], color=colours[k % 10], lw=0.6 if many else 1.2,
                    alpha=0.5 if many else 1.0, label=None if many else label(r))
    for ax, n in ((a2, "block2"), (a1, "block1")):
        ax.axvline(T_PAPER["reach"], color="k", ls=":", lw=1, label="paper: sand reaches the blocks")
        ax.axvline(T_PAPER[f"{n}_touch"], color="k", ls="--", lw=1, label=f"paper: {n} touches the ground")
        ax.axhline(0.0, color="grey", lw=0.5)
        ax.set(xlabel="t [s]", title=f"{n} ({'middle' if n == 'block2' else 'top'}): orientation, 90° upright")
        ax.grid(alpha=0.3)
    a2.set_ylabel("orientation [deg]")
    a2.legend(fontsize=6, loc="lower left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out / "block_impact_orientation.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, row in enumerate(table):
        t = row.get("wall_seconds")
        if t is None:
            continue
        err = row.get("max_error_s")
        if err is None:
            ax.plot(t, 0.3, "x", color="red", ms=9)
            ax.annotate(str(row.get("status")), (t, 0.3), fontsize=6, color="red")
        else:
            ax.plot(t, max(err, 1e-3), "o", color=colours[k % 10], label=None if many else row["label"])
    ax.axhline(0.025, color="k", ls=":", lw=1, label="the paper's reading resolution (±0.025 s)")
    ax.set(xscale="log", yscale="log", xlabel="wall time of the run [s]",
           ylabel="largest |event time − paper| [s] (first touch)", title=f"{title}: speed × accuracy")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / "block_impact_speed_accuracy.png", dpi=120)
    plt.close(fig)
    return report
