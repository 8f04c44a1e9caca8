"""Run files: the HDF5 frame writer, its XDMF sidecar and CSV energy log, and a reader.

A run file (format ``mpmdem-1``) is one HDF5 file holding, for a fixed particle count N >= 0 and a
fixed count M >= 0 of rigid DEM bodies (spheropolygons):

* ``/particles/<name>``: one resizable dataset per particle field, shape (n_frames, N, *shape),
  chunked one frame at a time; absent when N == 0 (older files may hold empty ones);
* ``/bodies/<name>``: one resizable dataset per body field (x, angle, v, omega, force, torque by
  default), shape (n_frames, M, *shape), chunked one frame at a time; absent when M == 0;
* ``/bodies/geometry/<name>``: static per-body data written once: vertex_start (M,) int32,
  vertex_count (M,) int32, vertices (total_vertices, 2) float64 body-frame core vertices [m],
  radius (M,) float64 sphero radius [m], motion (M,) int32 (0 free, 1 fixed, 2 kinematic),
  mass (M,) float64 [kg/m], name (M,) variable-length UTF-8 strings, plus any extra per-body
  arrays the writer was given;
* ``/time``: the simulated time of each frame [s], float64;
* ``/diagnostics/<name>``: one float64 scalar per frame (energies, momenta, dt, ...);
* ``/xdmf/...``: what the XDMF sidecars point at (per-frame virtual views of the fields, the
  bodies' world outlines, connectivities; see ``mpmdem.xdmf``); readers of the run ignore it;
* root attributes: every entry of the writer's ``attrs`` as a JSON string, plus ``format``
  and, once the run ends, ``status`` and ``status_message`` (plain strings).

The file is flushed after every frame and is never opened with the SWMR / "latest" file format,
so a writer that crashes or is killed leaves a file that ``RunFile`` (or any HDF5 tool) reads up
to the last complete frame. Next to it the writer keeps the XDMF 3 sidecars ``<name>.xdmf`` (the
particles, when N > 0) and ``<name>_bodies.xdmf`` (the bodies' outlines, when M > 0), rewritten
atomically after every frame, which ParaView (Xdmf3 and legacy XDMF readers) and meshio's
``TimeSeriesReader`` open as time series.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import numpy as np

from .xdmf import XdmfSidecars, bodies_xdmf_path, particles_xdmf_path

__all__ = ["BODY_GEOMETRY_KEYS", "FORMAT", "FrameWriter", "RunFile", "default_body_field_specs",
           "default_field_specs"]

FORMAT = "mpmdem-1"
"""Value of the root attribute ``format`` of every run file this module writes."""

#: Root attributes stored as plain strings, not JSON.
_PLAIN_ATTRS = ("format", "status", "status_message")

_PRECISIONS = {"f32": np.float32, "f64": np.float64}


def default_field_specs() -> dict[str, tuple[tuple[int, ...], str]]:
    """The per-particle fields of a run file: name → (per-particle shape, dtype name).

    The dtype name "float" stands for the run's precision (float32 or float64).

    Returns:
        A fresh dict that callers may extend, e.g. with ``("C", ((2, 2), "float"))``.
    """
    return {
        "x": ((2,), "float"),
        "v": ((2,), "float"),
        "stress": ((2, 2), "float"),
        "volume": ((), "float"),
        "mass": ((), "float"),
        "F": ((2, 2), "float"),
        "body": ((), "int32"),
    }


def default_body_field_specs() -> dict[str, tuple[tuple[int, ...], str]]:
    """The per-body fields of a run file: name → (per-body shape, dtype name).

    x: centroid [m]; angle: rotation of the body frame [rad]; v: centroid velocity [m/s];
    omega: angular velocity [rad/s]; force: total contact force [N/m]; torque: total contact
    torque about the centroid [N·m/m]. "float" stands for the run's precision.

    Returns:
        A fresh dict that callers may extend.
    """
    return {
        "x": ((2,), "float"),
        "angle": ((), "float"),
        "v": ((2,), "float"),
        "omega": ((), "float"),
        "force": ((2,), "float"),
        "torque": ((), "float"),
    }


#: Keys every ``body_geometry`` must have (extra per-body numeric arrays are allowed and stored too).
BODY_GEOMETRY_KEYS = ("vertex_start", "vertex_count", "vertices", "radius", "motion", "mass", "name")

#: Dtypes of the geometry arrays as stored.
_GEOMETRY_DTYPES = {
    "vertex_start": np.int32,
    "vertex_count": np.int32,
    "vertices": np.float64,
    "radius": np.float64,
    "motion": np.int32,
    "mass": np.float64,
}

#: Body motion codes of ``body_geometry["motion"]``.
MOTION_FREE, MOTION_FIXED, MOTION_KINEMATIC = 0, 1, 2


def _parse_specs(
    specs: Mapping[str, tuple[tuple[int, ...], str]], float_dtype: type, what: str, reserved: tuple[str, ...] = ()
) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """Validate field specs (name → (shape, dtype name)) and resolve their dtypes."""
    out: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
    for name, spec in specs.items():
        try:
            shape, dtype_name = spec
            shape = tuple(int(n) for n in shape)
        except (TypeError, ValueError):
            raise ValueError(f"{what} spec {name!r}: expected (shape tuple, dtype name), got {spec!r}") from None
        if not isinstance(name, str) or not name or "/" in name or name in reserved:
            raise ValueError(f"invalid {what} name {name!r}")
        if any(n < 1 for n in shape):
            raise ValueError(f"{what} spec {name!r}: shape {shape} has a zero or negative extent")
        out[name] = (shape, _resolve_dtype(dtype_name, float_dtype))
    return out


def _check_frame_fields(
    given: Mapping[str, np.ndarray] | None,
    specs: Mapping[str, tuple[tuple[int, ...], np.dtype]],
    count: int,
    what: str,
) -> dict[str, np.ndarray]:
    """Validate one frame's arrays against the specs and cast them; {} when count == 0.

    With count == 0 the frame may be None, empty, or exactly the spec names with zero-length arrays
    (nothing is stored then).
    """
    if count == 0 and not given:
        return {}
    given = {} if given is None else given
    missing = [k for k in specs if k not in given]
    unknown = [k for k in given if k not in specs]
    if missing or unknown:
        raise ValueError(f"frame {what}s must be exactly {sorted(specs)}; missing {missing}, unknown {unknown}")
    arrays = {}
    for name, (shape, dtype) in specs.items():
        a = np.asarray(given[name])
        if a.shape != (count, *shape):
            none = f" (this run has no {'bodies' if 'body' in what else 'particles'})" if count == 0 else ""
            raise ValueError(f"{what} {name!r}: expected shape {(count, *shape)}{none}, got {a.shape}")
        arrays[name] = a.astype(dtype, copy=False)
    return arrays if count > 0 else {}


def _normalize_geometry(geometry: Mapping[str, Any] | None, m: int) -> dict[str, Any]:
    """Validate a ``body_geometry`` dict for M bodies; returns the arrays to store (names as list[str])."""
    if m == 0:
        if geometry and any(np.size(v) for v in geometry.values()):
            raise ValueError("body_geometry given but body_count is 0")
        return {}
    if geometry is None:
        raise ValueError(f"body_geometry is required when body_count > 0 (keys {', '.join(BODY_GEOMETRY_KEYS)})")
    missing = [k for k in BODY_GEOMETRY_KEYS if k not in geometry]
    if missing:
        raise ValueError(f"body_geometry is missing {missing}; required keys: {', '.join(BODY_GEOMETRY_KEYS)}")
    out: dict[str, Any] = {}
    for key, value in geometry.items():
        if not isinstance(key, str) or not key or "/" in key:
            raise ValueError(f"invalid body_geometry key {key!r}")
        if key == "name":
            names = [str(v) for v in value]
            if len(names) != m:
                raise ValueError(f"body_geometry 'name': expected {m} names, got {len(names)}")
            out[key] = names
            continue
        a = np.asarray(value)
        if key in _GEOMETRY_DTYPES:
            dtype = np.dtype(_GEOMETRY_DTYPES[key])
            if dtype.kind == "i" and a.dtype.kind not in "biu" and not np.all(np.mod(a, 1) == 0):
                raise ValueError(f"body_geometry {key!r} must hold integers")
            expected = (None, 2) if key == "vertices" else (m,)
            if a.ndim != len(expected) or any(e is not None and e != d for e, d in zip(expected, a.shape, strict=True)):
                shape_txt = "(total_vertices, 2)" if key == "vertices" else f"({m},)"
                raise ValueError(f"body_geometry {key!r}: expected shape {shape_txt}, got {a.shape}")
            a = a.astype(dtype)
        else:
            if a.ndim < 1 or a.shape[0] != m or a.dtype.kind not in "biuf":
                raise ValueError(f"extra body_geometry {key!r} must be a numeric per-body array of length {m}")
        out[key] = a
    start, count, verts = out["vertex_start"], out["vertex_count"], out["vertices"]
    if np.any(count < 1) or np.any(start < 0) or np.any(start.astype(np.int64) + count > len(verts)):
        raise ValueError(
            f"body_geometry vertex_start/vertex_count must give non-empty ranges inside vertices ({len(verts)} rows)"
        )
    if not np.all(np.isfinite(verts)):
        raise ValueError("body_geometry 'vertices' must be finite")
    if not np.all(np.isfinite(out["radius"])) or np.any(out["radius"] < 0):
        raise ValueError("body_geometry 'radius' must be finite and non-negative")
    if not np.all(np.isin(out["motion"], (MOTION_FREE, MOTION_FIXED, MOTION_KINEMATIC))):
        raise ValueError("body_geometry 'motion' must be 0 (free), 1 (fixed) or 2 (kinematic)")
    return out


def _json_default(obj: Any) -> Any:
    """Make numpy values, paths and sets JSON-serialisable."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    raise TypeError(f"attribute value of type {type(obj).__name__} is not JSON-serialisable")


def _resolve_dtype(name: str, float_dtype: type) -> np.dtype:
    """Map a field-spec dtype name ("float" or any numpy dtype name) to a numpy dtype."""
    if name == "float":
        return np.dtype(float_dtype)
    try:
        return np.dtype(name)
    except TypeError:
        raise ValueError(
            f"unknown dtype {name!r} in field_specs; use 'float' or a numpy dtype name"
        ) from None


class FrameWriter:
    """Write a run frame by frame to HDF5, with an XDMF sidecar and an optional energy CSV.

    Every call of ``write_frame`` appends one frame to every particle and body dataset, one value
    to every diagnostic, flushes the HDF5 file and the CSV, and rewrites the XDMF sidecar; a run
    that dies keeps every frame written before.

    Args:
        path: The HDF5 file to create (overwritten if it exists).
        particle_count: N, the number of MPM particles; fixed for the whole run. 0 for a run of
            bodies only: no /particles datasets are created then.
        attrs: Run metadata (scene, config, version, device, precision, ...): JSON-serialisable
            values (numpy scalars/arrays and paths are converted). ``attrs["precision"]``
            ("f32" or "f64", default "f32") sets the dtype of the "float" fields.
        field_specs: Particle fields, name → (per-particle shape, dtype name), where the dtype
            name is "float" (the run precision) or a numpy dtype name. None gives
            ``default_field_specs()``: x, v, stress, volume, mass, F, body.
        csv_path: Where to keep the diagnostics as CSV (header ``time,<names...>``, one row per
            frame); None writes no CSV.
        body_count: M, the number of rigid DEM bodies; fixed for the whole run. 0 (default)
            creates no /bodies group.
        body_field_specs: Per-frame body fields, name → (per-body shape, dtype name), as for
            field_specs ("geometry" is reserved). None gives ``default_body_field_specs()``:
            x [m], angle [rad], v [m/s], omega [rad/s], force [N/m], torque [N·m/m].
        body_geometry: Static per-body data, written once under /bodies/geometry; required when
            body_count > 0. Keys (see ``BODY_GEOMETRY_KEYS``): vertex_start (M,) int,
            vertex_count (M,) int >= 1, vertices (total_vertices, 2) body-frame core vertices [m],
            radius (M,) sphero radius [m] >= 0, motion (M,) int (0 free, 1 fixed, 2 kinematic),
            mass (M,) [kg/m], name (M strings). Extra keys holding numeric per-body arrays
            (leading dimension M) are stored as given.

    Raises:
        ValueError: particle_count or body_count is negative, precision is unknown, a field spec
            is invalid or body_geometry is missing or inconsistent.
        TypeError: an attrs value cannot be JSON-encoded.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        particle_count: int,
        attrs: Mapping[str, Any],
        field_specs: Mapping[str, tuple[tuple[int, ...], str]] | None = None,
        csv_path: str | os.PathLike | None = None,
        body_count: int = 0,
        body_field_specs: Mapping[str, tuple[tuple[int, ...], str]] | None = None,
        body_geometry: Mapping[str, Any] | None = None,
    ) -> None:
        for what, count in (("particle_count", particle_count), ("body_count", body_count)):
            if int(count) != count or count < 0:
                raise ValueError(f"{what} must be a non-negative integer, got {count!r}")
        self.path = Path(path)
        self.xdmf_path = particles_xdmf_path(self.path)
        self.bodies_xdmf_path = bodies_xdmf_path(self.path)
        self.csv_path = Path(csv_path) if csv_path is not None else None
        self.particle_count = int(particle_count)
        self.body_count = int(body_count)
        precision = attrs.get("precision", "f32")
        if precision not in _PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(_PRECISIONS)}, got {precision!r}")
        float_dtype = _PRECISIONS[precision]
        specs = default_field_specs() if field_specs is None else field_specs
        self._specs = _parse_specs(specs, float_dtype, "field")
        body_specs = default_body_field_specs() if body_field_specs is None else body_field_specs
        self._body_specs = _parse_specs(body_specs, float_dtype, "body field", reserved=("geometry",))
        geometry = _normalize_geometry(body_geometry, self.body_count)
        # Encode attrs before touching the disk so a bad value leaves nothing half-written.
        encoded = {
            str(k): json.dumps(v, default=_json_default) for k, v in attrs.items() if k not in _PLAIN_ATTRS
        }

        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Sidecars left by an earlier run of the same name would describe frames that no longer exist.
        self.xdmf_path.unlink(missing_ok=True)
        self.bodies_xdmf_path.unlink(missing_ok=True)
        self._frames = 0
        self._times: list[float] = []
        self._diag_names: list[str] | None = None
        self._csv_file = None
        self._csv_writer = None
        self._closed = False
        self._datasets: dict[str, h5py.Dataset] = {}
        self._body_datasets: dict[str, h5py.Dataset] = {}
        self._geometry_dtypes: dict[str, np.dtype] = {}
        self._file = h5py.File(self.path, "w")
        try:
            for k, v in encoded.items():
                self._file.attrs[k] = v
            self._file.attrs["format"] = FORMAT
            n, m = self.particle_count, self.body_count
            if n > 0:
                group = self._file.create_group("particles", track_order=True)
                for name, (shape, dtype) in self._specs.items():
                    self._datasets[name] = group.create_dataset(
                        name, shape=(0, n, *shape), maxshape=(None, n, *shape), chunks=(1, n, *shape), dtype=dtype
                    )
            if m > 0:
                bodies = self._file.create_group("bodies", track_order=True)
                for name, (shape, dtype) in self._body_specs.items():
                    self._body_datasets[name] = bodies.create_dataset(
                        name, shape=(0, m, *shape), maxshape=(None, m, *shape), chunks=(1, m, *shape), dtype=dtype
                    )
                geo = bodies.create_group("geometry")
                for key, value in geometry.items():
                    if key == "name":
                        ds = geo.create_dataset(key, data=value, dtype=h5py.string_dtype("utf-8"))
                    else:
                        ds = geo.create_dataset(key, data=value)
                    self._geometry_dtypes[key] = ds.dtype
            self._xdmf = XdmfSidecars(self._file, particle_count=n, body_count=m, body_geometry=geometry)
            self._time_ds = self._file.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64)
            self._diag_group = self._file.create_group("diagnostics", track_order=True)
            self._diag_ds: dict[str, h5py.Dataset] = {}
            self._file.flush()
        except BaseException:
            self._file.close()
            raise

    # ------------------------------------------------------------------ properties

    @property
    def frame_count(self) -> int:
        """Number of frames written so far."""
        return self._frames

    @property
    def field_specs(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """The particle fields: name → (per-particle shape, numpy dtype)."""
        return dict(self._specs)

    @property
    def body_field_specs(self) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        """The per-frame body fields: name → (per-body shape, numpy dtype)."""
        return dict(self._body_specs)

    # ------------------------------------------------------------------ writing

    def write_frame(
        self,
        time: float,
        fields: Mapping[str, np.ndarray] | None,
        diagnostics: Mapping[str, float],
        body_fields: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        """Append one frame: every particle and body field, the time and every diagnostic; then flush.

        Args:
            time: Simulated time of the frame [s].
            fields: One array per particle field of the field specs, shape (N, *shape); values are
                cast to the field's dtype. With N == 0: None, {} or zero-length arrays.
            diagnostics: Scalar per-frame values (energies [J/m], momenta, dt, ...). The first
                frame fixes the set of names; later frames must give the same names.
            body_fields: One array per body field of the body field specs, shape (M, *shape);
                with M == 0: None, {} or zero-length arrays.

        Raises:
            ValueError: a field is missing, unknown or has the wrong shape, or the diagnostic
                names differ from the first frame's. Nothing is written then.
            RuntimeError: the writer is closed.
        """
        if self._closed:
            raise RuntimeError(f"FrameWriter for {self.path} is closed")
        arrays = _check_frame_fields(fields, self._specs, self.particle_count, "field")
        body_arrays = _check_frame_fields(body_fields, self._body_specs, self.body_count, "body field")
        diag = {str(k): float(v) for k, v in diagnostics.items()}
        if self._diag_names is None:
            for k in diag:
                if not k or "/" in k:
                    raise ValueError(f"invalid diagnostic name {k!r}")
        elif set(diag) != set(self._diag_names):
            raise ValueError(
                f"diagnostics must have the names of the first frame {self._diag_names}; got {sorted(diag)}"
            )
        time = float(time)

        i = self._frames
        # Particle and body data and diagnostics first, the time last: a reader counts frames by
        # /time, so a frame interrupted half-way is never seen.
        for datasets, values in ((self._datasets, arrays), (self._body_datasets, body_arrays)):
            for name, a in values.items():
                ds = datasets[name]
                ds.resize(i + 1, axis=0)
                ds[i] = a
        if self._diag_names is None:
            self._diag_names = list(diag)
            for k in self._diag_names:
                self._diag_ds[k] = self._diag_group.create_dataset(
                    k, shape=(0,), maxshape=(None,), chunks=(1024,), dtype=np.float64
                )
        for k in self._diag_names:
            ds = self._diag_ds[k]
            ds.resize(i + 1, axis=0)
            ds[i] = diag[k]
        self._xdmf.add_frame(i)
        self._time_ds.resize(i + 1, axis=0)
        self._time_ds[i] = time
        self._file.flush()
        self._frames = i + 1
        self._times.append(time)

        if self.csv_path is not None:
            self._write_csv_row(time, diag)
        self._write_xdmf()

    def set_status(self, status: str, message: str = "") -> None:
        """Mark how the run ended ("completed", "blown-up", "interrupted", ...) and flush.

        Args:
            status: Short status word, stored as root attribute "status".
            message: Human-readable detail, stored as root attribute "status_message".
        """
        if self._closed:
            raise RuntimeError(f"FrameWriter for {self.path} is closed")
        self._file.attrs["status"] = str(status)
        self._file.attrs["status_message"] = str(message)
        self._file.flush()

    def close(self) -> None:
        """Flush and close the HDF5 file and the CSV; closing twice is harmless."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._csv_file is not None:
                self._csv_file.close()
        finally:
            self._file.close()

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------------ sidecars

    def _write_csv_row(self, time: float, diag: dict[str, float]) -> None:
        """Append one CSV row (and the header on the first frame), then flush."""
        assert self.csv_path is not None and self._diag_names is not None
        if self._csv_file is None:
            self.csv_path.parent.mkdir(parents=True, exist_ok=True)
            self._csv_file = open(self.csv_path, "w", newline="", encoding="utf-8")  # noqa: SIM115
            self._csv_writer = csv.writer(self._csv_file)
            self._csv_writer.writerow(["time", *self._diag_names])
        self._csv_writer.writerow([repr(time), *(repr(diag[k]) for k in self._diag_names)])
        self._csv_file.flush()

    def _write_xdmf(self) -> None:
        """Rewrite the XDMF sidecars for all frames so far (see ``mpmdem.xdmf``)."""
        self._xdmf.write(self._times)


class RunFile:
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
            if isinstance(v, str) and k not in _PLAIN_ATTRS:
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
        """The per-frame particle datasets (none in a bodies-only file)."""
        parts = self._file.get("particles")
        if parts is None:
            return {}
        return {k: v for k, v in parts.items() if isinstance(v, h5py.Dataset)}

    def _body_datasets(self) -> dict[str, h5py.Dataset]:
        """The per-frame body datasets (none in a file without bodies)."""
        bodies = self._file.get("bodies")
        if bodies is None:
            return {}
        return {k: v for k, v in bodies.items() if isinstance(v, h5py.Dataset)}

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
        geo = self._file.get("bodies/geometry")
        if geo is not None and "vertex_count" in geo:
            return int(geo["vertex_count"].shape[0])
        bodies = self._body_datasets()
        if not bodies:
            return 0
        return int(next(iter(bodies.values())).shape[1])

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
        return self._file["particles"][name][self._frame_index(frame)]

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
        return self._file["bodies"][name][self._frame_index(frame)]

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

    def __enter__(self) -> RunFile:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f"RunFile({str(self.path)!r}, frames={self._frames}, particles={self.particle_count}, "
            f"bodies={self.body_count})"
        )
