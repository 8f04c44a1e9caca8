"""The block impact with DEM sand (`sand-blocks --sand dem`, issue 43): 8 grain packs (``--seed``) at two grain
sizes, r = 1 mm (the seed's r_p) and 0.5 mm. Per grain size, each event's median and spread against the
paper (MPM-SDEM §6) under both readings of "lands" and the final poses of the blocks, with the readings
of ``block_impact_analysis`` (the same tracks, the same rules as the MPM runs'): the grain-scale
reference the continuum's block-impact studies are compared with.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from mpmdem.study.study import Study

from ..references.block_impact import T_PAPER
from .block_impact_analysis import BLOCKS, EVENTS, run_events, spread
from .run_summaries import load_runs

SEEDS = tuple(range(1, 9))


def analyze(rows: list[dict], out: Path) -> dict:
    """Writes OUT/block_impact_dem.json: per grain radius, each event's ``spread`` [s], its median's
    distance to the paper's time, the count of each final pose per block, and the runs' cost."""
    out = Path(out)
    runs = [r for r in load_runs(out) if r.get("status") == "completed"]
    groups = {}
    for r in runs:
        groups.setdefault(r["grain_radius_m"], []).append(r)
    result = []
    for radius in sorted(groups):
        members = groups[radius]
        read = [run_events(r) for r in members]
        events = {e: spread([x["events_s"][e] for x in read]) for e in EVENTS}
        for e, t in T_PAPER.items():
            if "median" in events[e]:
                events[e]["median_minus_paper_s"] = events[e]["median"] - t
        poses = {n: dict(Counter(x["poses"][n] for x in read)) for n in BLOCKS}
        result.append({"grain_radius_m": radius, "grains": members[0]["grains"], "packs": len(members),
                       "events_s": events, "final_poses": poses,
                       "wall_seconds": [r.get("wall_seconds") for r in members],
                       "settle_wall_seconds": [r["settled"].get("wall_seconds") for r in members],
                       "packing_fraction": [r["settled"]["packing_fraction"] for r in members]})
    failed = [{"run": r["run"], "status": r.get("status")} for r in load_runs(out) if r.get("status") != "completed"]
    summary = {"paper_s": T_PAPER, "per_grain_radius": result, "failed": failed}
    (out / "block_impact_dem.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


STUDY = Study(
    name="block-impact-dem",
    case="sand-blocks",
    description="block impact with the sand as DEM grains (r = 1 and 0.5 mm), 8 packs each: event times and "
                "final poses against the paper, the reference for the continuum",
    grid={"--grain-radius": [0.001, 0.0005], "--seed": list(SEEDS)},
    fixed={"--sand": "dem"},
    analyze=analyze,
)
