"""Fingerprints of short CPU runs: one SHA-256 per case over every dataset of its HDF5 file.

A refactor that must keep behaviour bit for bit (issue 28) runs this before and after and
compares the lines: ``python bench/fingerprint.py > before.jsonl``, change the code, then
``python bench/fingerprint.py --compare before.jsonl``. Each run is a case's ``--quick`` size
cut to a short end time, so the whole set takes a minute or two on two cores once the kernels
are compiled. Only datasets are hashed (attributes hold dates), less the wall-time
diagnostic and the counts of list rebuilds and relabels (``*_rebuilds``, ``*_relabels``): how often
a step rebuilt what it reuses is how it was computed, not what it computed, and a change of the
reuse that keeps every result (the node-range moves of Granular MPM) changes them. Fingerprints
taken before that rule (``results/fingerprint/cpu_d0820bc.jsonl``) hash them too.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

# (label, case, extra flags): every stage and variant the suite's cases use
RUNS = [
    ("sulsky-disks", "sulsky-disks", ["--end-time", "0.2"]),
    ("sulsky-disks-flip-usf", "sulsky-disks", ["--end-time", "0.1", "--transfer", "FLIP",
                                               "--update", "USF", "--shape", "cpgimp"]),
    ("sulsky-disks-xpic-f64", "sulsky-disks", ["--end-time", "0.1", "--transfer", "XPIC",
                                               "--precision", "f64", "--shape", "bspline3"]),
    ("axial-bar", "axial-bar", ["--end-time", "0.2"]),
    ("disk-collision", "disk-collision", ["--end-time", "0.05"]),
    ("pentagon-pile", "pentagon-pile", ["--end-time", "0.1"]),
    ("domino", "domino", ["--end-time", "0.1"]),
    ("disconnection-1d", "disconnection-1d", []),
    ("slope-flow", "slope-flow", ["--end-time", "0.1"]),
    ("silo-filling", "silo-filling", ["--end-time", "0.4"]),
    ("column-collapse", "column-collapse", ["--end-time", "0.05"]),
    ("disk-drop", "disk-drop", ["--end-time", "0.05"]),
    ("normal-force", "normal-force", ["--end-time", "0.01"]),
    ("friction-force", "friction-force", ["--end-time", "0.01"]),
    ("disk-drop-liu", "disk-drop", ["--end-time", "0.05", "--coupling", "liu"]),
    ("disk-drop-grid", "disk-drop", ["--end-time", "0.05", "--coupling", "grid"]),
    ("momentum-exchange", "momentum-exchange", ["--end-time", "0.01"]),
    ("sand-blocks", "sand-blocks", ["--end-time", "0.03"]),
    ("silo-discharge", "silo-discharge", ["--end-time", "0.03"]),
    ("granular-matrix", "granular-matrix", ["--end-time", "0.005"]),
]


#: Datasets left out of the hash (see the module docstring)
SKIPPED = ("wall_time", "_rebuilds", "_relabels", "diagnostic_values")


def hash_h5(path: Path) -> str:
    """SHA-256 over the names, dtypes, shapes and bytes of every dataset in the file."""
    digest = hashlib.sha256()
    with h5py.File(path, "r") as f:
        names: list[str] = []
        f.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
        for name in sorted(names):
            if name.endswith(SKIPPED):
                continue  # the host clock, different every run; how often the reuse rebuilt; the
                # diagnostics' table, whose columns are hashed one by one as /diagnostics/<name>
            data = np.ascontiguousarray(f[name][()])
            digest.update(name.encode())
            digest.update(str(data.dtype).encode() + str(data.shape).encode())
            # object arrays (strings) hold pointers: hash their values instead
            digest.update(repr(data.tolist()).encode() if data.dtype == object else data.tobytes())
    return digest.hexdigest()


def fingerprint(label: str, case: str, flags: list[str], workdir: Path) -> dict:
    """Run one short CPU case and return its label, exit code and dataset hash."""
    out = workdir / label
    cmd = [sys.executable, "-m", "mpmdem.cli", "run", case, "--quick", "--device", "cpu",
           "--quiet", "--frames", "2", "--out", str(out), *flags]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    files = sorted(out.glob("*.h5"))
    row = {"run": label, "rc": proc.returncode}
    if files:
        row["sha256"] = {f.name: hash_h5(f)[:16] for f in files}
    if proc.returncode != 0:
        row["stderr"] = proc.stderr[-400:]
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="a previous output to compare against")
    parser.add_argument("--only", nargs="*", help="labels to run (default: all)")
    args = parser.parse_args()
    before = {}
    if args.compare:
        before = {r["run"]: r for r in map(json.loads, args.compare.read_text().splitlines())}
    differ = 0
    with tempfile.TemporaryDirectory() as tmp:
        for label, case, flags in RUNS:
            if args.only and label not in args.only:
                continue
            row = fingerprint(label, case, flags, Path(tmp))
            if args.compare:
                old = before.get(label)
                same = old is not None and old.get("sha256") == row.get("sha256") and old["rc"] == row["rc"]
                row["same"] = same
                differ += not same
            print(json.dumps(row), flush=True)
    if args.compare and differ:
        sys.exit(f"{differ} run(s) differ from {args.compare}")


if __name__ == "__main__":
    main()
