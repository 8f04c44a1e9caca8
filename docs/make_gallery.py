"""Regenerate the gallery pictures of the documentation site (docs/gallery/).

Each case of ``cases.CASES`` runs once with ``mpmdem run CASE --quick --device cpu --quiet --out
RUNS/CASE`` (one at a time, a time limit per run); then ``mpmdem animate``'s renderer draws a short
GIF of the run (a frame stride, small resolution) and, when that GIF is too big, ``mpmdem plot``
draws the last frame's snapshot, which is downscaled to a PNG. A case whose run fails or takes longer
than the limit gets a committed chart of ``bench/results/`` instead (``FALLBACKS``).
``docs/gallery/gallery.json`` records, per case, the command, its wall time, the run file drawn and
the picture.

    python docs/make_gallery.py                       # run every case, then draw
    python docs/make_gallery.py --cases domino,axial-bar
    python docs/make_gallery.py --skip-runs           # redraw from the runs already in RUNS
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "docs" / "gallery"
MAX_BYTES = 300_000
GIF_FRAMES = 12
GIF_DPI = 60
PNG_WIDTH = 640

# The run file to draw where a case writes several (a glob within the run's folder), and its field.
PREFERRED = {
    "sulsky-disks": ("*.h5", "speed"),
    "slope-flow": ("*granular*.h5", "speed"),
    "avalanche": ("*granular*.h5", "speed"),
    "rod-collision": ("*imp*.h5", "speed"),
}
# Committed charts for cases that cannot run in the time limit on a CPU (or that fail).
FALLBACKS = {
    "slope-flow": "bench/results/cases/slope_flow/cpu.png",
    "avalanche": "bench/results/cases/avalanche/cpu.png",
    "silo-filling": "bench/results/cases/silo_filling/cpu.png",
    "toyoura-flume": "bench/results/cases/toyoura_flume/cpu.png",
    "column-collapse": "bench/results/studies/column-collapse/column_collapse_runout.png",
    "sand-blocks": "bench/results/studies/block-impact/block_impact_orientation.png",
    "silo-discharge": "bench/results/studies/beverloo/beverloo_rate.png",
    "granular-matrix": "bench/results/granular_matrix/h200.png",
}


def run_case(case: str, runs: Path, limit: float) -> dict:
    """Run one case on the CPU with --quick; return its record (command, status, wall seconds)."""
    out = runs / case
    shutil.rmtree(out, ignore_errors=True)
    cmd = ["mpmdem", "run", case, "--quick", "--device", "cpu", "--quiet", "--out", str(out)]
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=limit)
        status = "completed" if proc.returncode == 0 else f"exit {proc.returncode}: {proc.stderr.strip()[-300:]}"
    except subprocess.TimeoutExpired:
        status = f"over the {limit:.0f} s limit"
    seconds = time.perf_counter() - start
    print(f"{case}: {status} in {seconds:.1f} s", flush=True)
    return {"case": case, "command": " ".join(cmd[:-1] + [f"/tmp/gallery/{case}"]), "status": status,
            "wall_seconds": round(seconds, 1)}


def pick_run_file(case: str, folder: Path) -> tuple[Path | None, str]:
    """The run file of a case to draw, and the colour field."""
    pattern, field = PREFERRED.get(case, ("*.h5", "speed"))
    files = sorted(folder.rglob(pattern)) or sorted(folder.rglob("*.h5"))
    return (files[0] if files else None), field


def frame_count(path: Path) -> int:
    from mpmdem.io import RunFile

    with RunFile(path) as rf:
        return rf.frame_count


def draw(case: str, run_file: Path, field: str, work: Path) -> tuple[Path, str]:
    """A GIF of the run (mpmdem animate) if small enough, else the last snapshot (mpmdem plot)."""
    from PIL import Image

    from mpmdem.io.animation import animate_run
    from mpmdem.io.plotting import plot_run

    work.mkdir(parents=True, exist_ok=True)
    n = frame_count(run_file)
    stride = max(1, -(-n // GIF_FRAMES))
    frames = ",".join(str(k) for k in dict.fromkeys([*range(0, n, stride), n - 1]))
    gif = animate_run(run_file, work / f"{case}.gif", field=field, fps=4, frames=frames, dpi=GIF_DPI)
    if gif.stat().st_size <= MAX_BYTES:
        return gif, f"mpmdem animate {run_file.name} --field {field} --frames {frames} (dpi {GIF_DPI})"
    pngs = plot_run(run_file, work / "plot", field=field, frames=[-1])
    snap = pngs[-1]
    with Image.open(snap) as im:
        scale = PNG_WIDTH / im.width
        small = im.convert("RGB").resize((PNG_WIDTH, round(im.height * scale)), Image.LANCZOS)
        png = work / f"{case}.png"
        small.quantize(colors=128).save(png, optimize=True)
    return png, f"mpmdem plot {run_file.name} --field {field} --frames -1 (downscaled to {PNG_WIDTH} px)"


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(ROOT))
    from cases import CASES

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated case names")
    parser.add_argument("--runs", default="/tmp/gallery", help="folder for the runs")
    parser.add_argument("--limit", type=float, default=90.0, help="seconds allowed per run")
    parser.add_argument("--skip-runs", action="store_true", help="draw from the runs already in --runs")
    args = parser.parse_args(argv)
    runs = Path(args.runs)
    GALLERY.mkdir(parents=True, exist_ok=True)
    index_path = GALLERY / "gallery.json"
    index = json.loads(index_path.read_text()) if index_path.is_file() else {}
    for case in args.cases.split(","):
        if case not in CASES:
            parser.error(f"unknown case {case!r}")
        if args.skip_runs:
            record = index.get(case) or {"case": case, "status": "completed"}
        else:
            record = run_case(case, runs, args.limit)
        for old in GALLERY.glob(f"{case}.*"):
            old.unlink()
        run_file, field = pick_run_file(case, runs / case)
        if record["status"] == "completed" and run_file is not None:
            picture, how = draw(case, run_file, field, runs / "_pictures" / case)
            target = GALLERY / picture.name
            shutil.copyfile(picture, target)
            record.update(picture=target.name, drawn_from=str(run_file.relative_to(runs / case)), how=how,
                          bytes=target.stat().st_size, fallback=None)
        else:
            record.update(picture=None, drawn_from=None, how=None, bytes=0, fallback=FALLBACKS.get(case))
        index[case] = record
        print(f"  {case}: {record.get('picture') or record['fallback']}", flush=True)
        index_path.write_text(json.dumps({k: index[k] for k in CASES if k in index}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
