"""The results table of a study folder: ``results.jsonl`` (a row appended per finished run),
``results.csv`` (written at the end) and ``study.json`` (what the folder's rows were run with).

The JSON lines file is the record: each row is flushed to disk when its run ends, so a killed study
loses no finished run; a line cut short by the kill is skipped when read back. A run listed twice
(re-run after a failure) counts with its last row.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

from ..errors import InputError

__all__ = ["ResultsTable"]


class ResultsTable:
    """Rows of the runs of one output folder."""

    def __init__(self, out: Path):
        self.out = Path(out)
        self.jsonl = self.out / "results.jsonl"
        self.csv = self.out / "results.csv"
        self.spec_file = self.out / "study.json"

    def check_spec(self, spec: dict) -> None:
        """Raise InputError when the folder holds rows of another case or other fixed flags
        (a grown grid is fine: its new runs are added)."""
        try:
            old = json.loads(self.spec_file.read_text())
        except (OSError, ValueError):
            return
        for key in ("case", "fixed"):
            if old.get(key) != spec.get(key):
                raise InputError("--out", str(self.out), f"a folder of this study; it holds runs with {key} = "
                                 f"{old.get(key)!r}, this study has {spec.get(key)!r} (use another --out)")

    def write_spec(self, spec: dict) -> None:
        self.out.mkdir(parents=True, exist_ok=True)
        self.spec_file.write_text(json.dumps(spec, indent=2, default=str) + "\n")

    def latest(self) -> dict[str, dict]:
        """The last row of every run id in ``results.jsonl``."""
        rows = {}
        try:
            lines = self.jsonl.read_text().splitlines()
        except OSError:
            return rows
        for line in lines:
            try:
                row = json.loads(line)
            except ValueError:
                continue  # cut short by a kill
            if isinstance(row, dict) and "id" in row:
                rows[row["id"]] = row
        return rows

    def append(self, row: dict) -> None:
        """Add one row and push it to the disk."""
        self.out.mkdir(parents=True, exist_ok=True)
        with self.jsonl.open("a+b") as f:
            if f.seek(0, os.SEEK_END) > 0:
                f.seek(-1, os.SEEK_END)
                if f.read(1) != b"\n":
                    f.write(b"\n")  # after a line cut short by a kill
            f.write((json.dumps(row, default=str) + "\n").encode())
            f.flush()
            os.fsync(f.fileno())

    def write_csv(self, rows: list[dict]) -> None:
        """``results.csv``: one line per row, the columns in order of first appearance."""
        columns = list(dict.fromkeys(k for row in rows for k in row))
        with self.csv.open("w", newline="") as f:
            writer = csv.DictWriter(f, columns, restval="")
            writer.writeheader()
            writer.writerows(rows)
