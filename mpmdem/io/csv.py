"""The energy log of a run: its per-frame diagnostics as CSV, beside the HDF5 run file.

Header ``time,<names...>`` (the names of the first frame), one row per frame, every value written
with ``repr`` (no digits lost), flushed after every row so that a run that dies keeps its rows.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Mapping
from pathlib import Path

__all__ = ["EnergyLog"]


class EnergyLog:
    """Append the diagnostics of a run to a CSV file, one row per frame.

    The file is created (overwritten) on the first row, whose diagnostic names make the header.

    Args:
        path: The CSV file.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self._names: list[str] | None = None
        self._file = None
        self._writer = None

    def write_row(self, time: float, diagnostics: Mapping[str, float]) -> None:
        """Append one row (and the header on the first), then flush.

        Args:
            time: Simulated time of the frame [s].
            diagnostics: The frame's values; later rows must hold the first row's names.
        """
        if self._file is None:
            self._names = list(diagnostics)
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "w", newline="", encoding="utf-8")  # noqa: SIM115
            self._writer = csv.writer(self._file)
            self._writer.writerow(["time", *self._names])
        self._writer.writerow([repr(time), *(repr(diagnostics[k]) for k in self._names)])
        self._file.flush()

    def close(self) -> None:
        """Close the file (if a row was written); closing twice is harmless."""
        if self._file is not None:
            self._file.close()
