"""Reading a run file (format: ``mpmdem.io.format``), also one left by a crashed or running writer."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .closing import ClosesOnExit
from .format import DIAGNOSTIC_TABLE, MOTION_FIXED, MOTION_FREE, MOTION_KINEMATIC, PLAIN_ATTRS

__all__ = ["RunFile"]


class RunFile(ClosesOnExit):
    """Read-only access to a run file written by ``FrameWriter`` (also one left by a crashed run).

    Args:
        path: The HDF5 run file.

    Raises:
        FileNotFoundError: the file does not exist.
        OSError: the file is not a readable HDF5 file.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise FileNotFoundError(f"no run file at {self.path}")
        try:
            self._file = h5py.File(self.path, "r")
        except OSError:
            # A live writer in another process holds the HDF5 file lock; its flushed frames
            # are still readable without locking.
            self._file = h5py.File(self.path, "r", locking=False)
        self._attrs: dict[str, Any] = {}
        for k, v in self._file.attrs.items():
            if isinstance(v, bytes):
                v = v.decode("utf-8")
            if isinstance(v, str) and k not in PLAIN_ATTRS:
                try:
                    v = json.loads(v)
                except json.JSONDecodeError:
                    pass
            elif isinstance(v, np.generic):
                v = v.item()
            self._attrs[k] = v
        t = self._file["time"][()] if "time" in self._file else np.zeros(0)
        lengths = [len(t)]
        lengths += [ds.shape[0] for ds in self._particle_datasets().values()]
        lengths += [ds.shape[0] for ds in self._body_datasets().values()]
        # A writer killed mid-frame may have grown some datasets but not /time: count complete frames.
        self._frames = min(lengths)
        self._times = np.asarray(t[: self._frames], dtype=np.float64)

    # ------------------------------------------------------------------ metadata

    @property
    def attrs(self) -> dict[str, Any]:
        """Root attributes, JSON-decoded (format/status/status_message stay plain strings)."""
        return dict(self._attrs)

    @property
    def times(self) -> np.ndarray:
        """Simulated time of every frame [s], float64, shape (frame_count,)."""
        return self._times.copy()

    @property
    def frame_count(self) -> int:
        """Number of complete frames in the file."""
        return self._frames

    def _particle_datasets(self) -> dict[str, h5py.Dataset]:
        """The per-frame particle datasets (none in a bodies-only file); looked up once (a writer adds
        no dataset after its first frame, and the frames counted are fixed at opening)."""
        if getattr(self, "_particles", None) is None:
            parts = self._file.get("particles")
            self._particles = ({} if parts is None else
                               {k: v for k, v in parts.items() if isinstance(v, h5py.Dataset)})
        return self._particles

    def _body_datasets(self) -> dict[str, h5py.Dataset]:
        """The per-frame body datasets (none in a file without bodies); looked up once."""
        if getattr(self, "_bodies", None) is None:
            bodies = self._file.get("bodies")
            self._bodies = ({} if bodies is None else
                            {k: v for k, v in bodies.items() if isinstance(v, h5py.Dataset)})
        return self._bodies

    @property
    def particle_count(self) -> int:
        """N, the number of particles per frame (0 for a run of bodies only)."""
        parts = self._particle_datasets()
        if not parts:
            return 0
        return int(next(iter(parts.values())).shape[1])

    @property
    def fields(self) -> list[str]:
        """Names of the particle fields stored per frame ([] when there are no particles)."""
        return list(self._particle_datasets()) if self.particle_count > 0 else []

    @property
    def body_count(self) -> int:
        """M, the number of rigid DEM bodies (0 for files without bodies, including older ones)."""
        if getattr(self, "_body_count", None) is None:
            geo = self._file.get("bodies/geometry")
            if geo is not None and "vertex_count" in geo:
                self._body_count = int(geo["vertex_count"].shape[0])
            else:
                bodies = self._body_datasets()
                self._body_count = int(next(iter(bodies.values())).shape[1]) if bodies else 0
        return self._body_count

    @property
    def body_fields(self) -> list[str]:
        """Names of the body fields stored per frame (x, angle, v, omega, force, torque, ...)."""
        return list(self._body_datasets()) if self.body_count > 0 else []

    @property
    def status(self) -> str | None:
        """How the run ended ("completed", "blown-up", "interrupted"), None while unknown."""
        return self._attrs.get("status")

    def field(self, name: str, frame: int) -> np.ndarray:
        """One particle field at one frame.

        Args:
            name: Field name (x, v, stress, volume, mass, F, body, ...).
            frame: Frame index; negative counts from the end as in Python.

        Returns:
            Array of shape (N, *shape) in the stored dtype.

        Raises:
            KeyError: no such field.
            IndexError: frame out of range.
        """
        if name not in self.fields:
            raise KeyError(f"no particle field {name!r} in {self.path}; fields: {', '.join(self.fields)}")
        return self._particle_datasets()[name][self._frame_index(frame)]

    def body_field(self, name: str, frame: int) -> np.ndarray:
        """One body field at one frame.

        Args:
            name: Body field name (x [m], angle [rad], v [m/s], omega [rad/s], force [N/m],
                torque [N·m/m], ...).
            frame: Frame index; negative counts from the end as in Python.

        Returns:
            Array of shape (M, *shape) in the stored dtype.

        Raises:
            KeyError: no such body field (or no bodies).
            IndexError: frame out of range.
        """
        if name not in self.body_fields:
            raise KeyError(f"no body field {name!r} in {self.path}; body fields: {', '.join(self.body_fields)}")
        return self._body_datasets()[name][self._frame_index(frame)]

    def body_geometry(self) -> dict[str, Any]:
        """The static per-body data of /bodies/geometry.

        Returns:
            vertex_start (M,) int32, vertex_count (M,) int32, vertices (total_vertices, 2) float64
            body-frame core vertices [m], radius (M,) float64 [m], motion (M,) int32 (0 free,
            1 fixed, 2 kinematic), mass (M,) float64 [kg/m], name (list of M str), plus any extra
            per-body arrays the writer stored. Empty arrays (and no names) when there are no bodies.
        """
        out: dict[str, Any] = {
            "vertex_start": np.zeros(0, np.int32),
            "vertex_count": np.zeros(0, np.int32),
            "vertices": np.zeros((0, 2), np.float64),
            "radius": np.zeros(0, np.float64),
            "motion": np.zeros(0, np.int32),
            "mass": np.zeros(0, np.float64),
            "name": [],
        }
        geo = self._file.get("bodies/geometry")
        if geo is None:
            return out
        for key, ds in geo.items():
            if not isinstance(ds, h5py.Dataset):
                continue
            if key == "name" or h5py.check_string_dtype(ds.dtype) is not None:
                out[key] = [str(v) for v in ds.asstr()[()]]
            else:
                out[key] = ds[()]
        return out

    def _frame_index(self, frame: int) -> int:
        """A frame index in range(frame_count); negative counts from the end."""
        f = self._frames
        k = int(frame)
        if k < 0:
            k += f
        if not 0 <= k < f:
            raise IndexError(f"frame {frame} out of range for {f} frame(s)")
        return k

    @property
    def diagnostics(self) -> dict[str, np.ndarray]:
        """Per-frame diagnostic scalars: name → float64 array of length frame_count."""
        table = self._file.get(DIAGNOSTIC_TABLE)
        if table is not None:  # (one read for every name: ``/diagnostics/<name>`` are its columns)
            values = np.asarray(table[: self._frames], dtype=np.float64)
            names = [n.decode() if isinstance(n, bytes) else str(n) for n in table.attrs["names"]]
            return {k: values[:, j].copy() for j, k in enumerate(names)}
        g = self._file.get("diagnostics")
        if g is None:
            return {}
        return {k: np.asarray(g[k][: self._frames], dtype=np.float64) for k in g}

    def summary(self) -> str:
        """Multi-line human-readable description of the run."""
        a = self._attrs
        config = a.get("config") if isinstance(a.get("config"), dict) else {}

        def meta(key: str) -> Any:
            return a.get(key, config.get(key, "?"))

        lines = [
            f"file:        {self.path}",
            f"format:      {a.get('format', '?')}",
            f"version:     {meta('version')}",
            f"device:      {meta('device')}",
            f"precision:   {meta('precision')}",
            f"frames:      {self._frames}",
        ]
        if self._frames:
            lines.append(f"time:        {self._times[0]:.6g} .. {self._times[-1]:.6g} s")
        else:
            lines.append("time:        (no frames)")
        lines.append(f"particles:   {self.particle_count}")

        def describe(datasets: dict[str, h5py.Dataset]) -> str:
            desc = []
            for k, ds in datasets.items():
                shape = "x".join(str(s) for s in ds.shape[2:]) or "scalar"
                desc.append(f"{k} ({shape}, {ds.dtype})")
            return ", ".join(desc)

        if self.fields:
            lines.append(f"fields:      {describe(self._particle_datasets())}")
        m = self.body_count
        if m:
            motion = np.asarray(self.body_geometry()["motion"])
            if len(motion) == m:
                kinds = [f"{int(np.sum(motion == c))} {w}" for c, w in
                         ((MOTION_FREE, "free"), (MOTION_FIXED, "fixed"), (MOTION_KINEMATIC, "kinematic"))]
                lines.append(f"bodies:      {m} ({', '.join(kinds)})")
            else:
                lines.append(f"bodies:      {m}")
            if self.body_fields:
                lines.append(f"body fields: {describe(self._body_datasets())}")
        else:
            lines.append("bodies:      0")
        diags = self.diagnostics
        if diags and self._frames:
            lines.append(f"diagnostics at the last frame (t = {self._times[-1]:.6g} s):")
            width = max(len(k) for k in diags)
            for k, v in diags.items():
                val = v[-1]
                lines.append(f"  {k:<{width}}  {val:.6g}" if math.isfinite(val) else f"  {k:<{width}}  {val}")
        if "status" in a:
            msg = a.get("status_message", "")
            lines.append(f"status:      {a['status']}" + (f": {msg}" if msg else ""))
        else:
            lines.append("status:      (not set: running, or the writer died)")
        return "\n".join(lines)

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Close the file; closing twice is harmless."""
        if self._file.id.valid:
            self._file.close()

    def __repr__(self) -> str:
        return (
            f"RunFile({str(self.path)!r}, frames={self._frames}, particles={self.particle_count}, "
            f"bodies={self.body_count})"
        )
