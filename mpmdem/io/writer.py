"""The HDF5 frame writer of a run file (format: ``mpmdem.io.format``).

Every frame is appended to every dataset and the file is flushed, so a writer that crashes or is
killed leaves a file readable up to its last complete frame; beside it the CSV energy log
(``mpmdem.io.csv``) is kept up to date frame by frame and the XDMF sidecars (``mpmdem.io.xdmf``) at
most ``sidecar_interval`` seconds of wall time behind (rewriting their whole text every frame cost a
batched study's writer threads most of their time, issue 46), and complete once the run's status is
set or the writer closed.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from h5py import h5d, h5p, h5s, h5t

from ..errors import InputError
from .closing import ClosesOnExit
from .csv import EnergyLog
from .format import (
    BODY_GEOMETRY_KEYS,
    DIAGNOSTIC_TABLE,
    FORMAT,
    GEOMETRY_DTYPES,
    MOTION_FIXED,
    MOTION_FREE,
    MOTION_KINEMATIC,
    PLAIN_ATTRS,
    PRECISIONS,
    default_body_field_specs,
    default_field_specs,
)
from .xdmf import XdmfSidecars, bodies_xdmf_path, particles_xdmf_path

__all__ = ["FrameWriter"]


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


class _Appender:
    """Appends frames to one frame-stacked dataset (first axis: frames) with h5py's low-level calls:
    the same bytes as ``ds.resize`` and ``ds[i] = value``, without their selection machinery
    (about 80 µs a call, which a frame of ~100 diagnostics paid twice each: most of a small scene's
    frame writing, docs/bench-history.md). The memory type and the file dataspace are made once and
    reused (``write`` would derive the same type from the array, and ``get_space`` give a new space
    of the same extent, each call: most of a scalar append's time). A dataset chunked a frame at a
    time, unfiltered, of a native numeric type (the particle and body fields) takes each frame as one
    chunk written straight to the file (``write_direct_chunk``: the same bytes, without the chunk
    cache, which the file's flush after every frame otherwise writes out)."""

    def __init__(self, ds: h5py.Dataset):
        self.id = ds.id
        self.frame = tuple(ds.shape[1:])
        self.dtype = ds.dtype
        self.memory = h5s.create_simple((1, *self.frame))
        self.memory_type = h5t.py_create(self.dtype)
        self.file_space = self.id.get_space()
        self.max_shape = (h5s.UNLIMITED, *self.frame)
        self.origin = tuple(0 for _ in self.frame)
        self.direct = (ds.chunks == (1, *self.frame) and ds.id.get_create_plist().get_nfilters() == 0
                       and self.dtype.kind in "iuf" and self.dtype.isnative)

    def append(self, i: int, value) -> None:
        """Grow the dataset to i + 1 frames and write frame i (``value``, shaped as one frame)."""
        shape = (i + 1, *self.frame)
        self.id.set_extent(shape)
        if self.direct:
            self.id.write_direct_chunk((i, *self.origin), np.ascontiguousarray(value, dtype=self.dtype))
            return
        self.file_space.set_extent_simple(shape, self.max_shape)
        self.file_space.select_hyperslab((i, *self.origin), (1, *self.frame))
        self.id.write(self.memory, self.file_space, np.ascontiguousarray(value, dtype=self.dtype),
                      mtype=self.memory_type)


def _diagnostic_table(file: h5py.File, group: h5py.Group, names: list[str]) -> h5py.Dataset:
    """``/diagnostic_values`` (frames × diagnostics, float64; attribute ``names``) and, in ``group``
    (``/diagnostics``), one virtual dataset per name: its column, for every frame the table has (an
    unlimited mapping: the view grows with the table and stores nothing). A frame's diagnostics are
    then one append instead of one per name (most of a small scene's frame writing, issue 46)."""
    count = len(names)
    table = file.create_dataset(DIAGNOSTIC_TABLE, shape=(0, count), maxshape=(None, count),
                                chunks=(max(1, 4096 // count), count), dtype=np.float64)
    table.attrs["names"] = np.array(names, dtype=h5py.string_dtype("utf-8"))
    memory_type = h5t.py_create(np.dtype(np.float64), logical=1)
    for k, name in enumerate(names):
        view = h5s.create_simple((0,), (h5s.UNLIMITED,))
        view.select_hyperslab((0,), (h5s.UNLIMITED,), (1,), (1,))
        column = h5s.create_simple((0, count), (h5s.UNLIMITED, count))
        column.select_hyperslab((0, k), (h5s.UNLIMITED, 1), (1, 1), (1, 1))
        dcpl = h5p.create(h5p.DATASET_CREATE)
        dcpl.set_fill_value(np.array([np.nan]))
        dcpl.set_virtual(view, b".", f"/{DIAGNOSTIC_TABLE}".encode(), column)
        h5d.create(group.id, name.encode("utf-8"), memory_type, view, dcpl=dcpl)
    return table


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
        if key in GEOMETRY_DTYPES:
            dtype = np.dtype(GEOMETRY_DTYPES[key])
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


class FrameWriter(ClosesOnExit):
    """Write a run frame by frame to HDF5, with an XDMF sidecar and an optional energy CSV.

    Every call of ``write_frame`` appends one frame to every particle and body dataset (and its
    XDMF views), one value to every diagnostic, and flushes the HDF5 file and the CSV; a run that
    dies keeps every frame written before. The XDMF sidecar files are rewritten after a frame when
    ``sidecar_interval`` seconds of wall time have passed since their last rewrite (and after the
    first frame), and by ``set_status`` and ``close`` when they lag: a run that dies without either
    has sidecars that may miss the frames of its last ``sidecar_interval`` seconds (the HDF5 file
    has them all).

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
        sidecar_interval: Least wall time between two rewrites of the XDMF sidecars by
            ``write_frame`` [s], >= 0; 0 rewrites them after every frame.

    Raises:
        ValueError: particle_count or body_count is negative, precision is unknown, a field spec
            is invalid or body_geometry is missing or inconsistent.
        InputError: sidecar_interval is negative or not finite (a ValueError).
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
        sidecar_interval: float = 1.0,
    ) -> None:
        for what, count in (("particle_count", particle_count), ("body_count", body_count)):
            if int(count) != count or count < 0:
                raise ValueError(f"{what} must be a non-negative integer, got {count!r}")
        try:
            interval = float(sidecar_interval)
        except (TypeError, ValueError):
            interval = math.nan
        if not (math.isfinite(interval) and interval >= 0):
            raise InputError("sidecar_interval", sidecar_interval, "a finite number of seconds >= 0 (0: every frame)")
        self.sidecar_interval = interval
        self.path = Path(path)
        self.xdmf_path = particles_xdmf_path(self.path)
        self.bodies_xdmf_path = bodies_xdmf_path(self.path)
        self.csv_path = Path(csv_path) if csv_path is not None else None
        self.particle_count = int(particle_count)
        self.body_count = int(body_count)
        precision = attrs.get("precision", "f32")
        if precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
        float_dtype = PRECISIONS[precision]
        specs = default_field_specs() if field_specs is None else field_specs
        self._specs = _parse_specs(specs, float_dtype, "field")
        body_specs = default_body_field_specs() if body_field_specs is None else body_field_specs
        self._body_specs = _parse_specs(body_specs, float_dtype, "body field", reserved=("geometry",))
        geometry = _normalize_geometry(body_geometry, self.body_count)
        # Encode attrs before touching the disk so a bad value leaves nothing half-written.
        encoded = {
            str(k): json.dumps(v, default=_json_default) for k, v in attrs.items() if k not in PLAIN_ATTRS
        }

        self.path.parent.mkdir(parents=True, exist_ok=True)
        # Sidecars left by an earlier run of the same name would describe frames that no longer exist.
        self.xdmf_path.unlink(missing_ok=True)
        self.bodies_xdmf_path.unlink(missing_ok=True)
        self._frames = 0
        self._times: list[float] = []
        self._sidecar_frames = 0  # the frames the sidecars list
        self._sidecar_written = -math.inf  # time.monotonic() of their last rewrite [s]
        self._diag_names: list[str] | None = None
        self._csv = EnergyLog(self.csv_path) if self.csv_path is not None else None
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
            # (the frame appenders of the particle and body fields, the time and the diagnostics)
            self._appenders = ({name: _Appender(ds) for name, ds in self._datasets.items()},
                               {name: _Appender(ds) for name, ds in self._body_datasets.items()})
            self._time_appender = _Appender(self._time_ds)
            self._diag_group = self._file.create_group("diagnostics", track_order=True)
            self._diag_table: _Appender | None = None  # (made at the first frame, which names the diagnostics)
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
        for appenders, values in zip(self._appenders, (arrays, body_arrays), strict=True):
            for name, a in values.items():
                appenders[name].append(i, a)
        if self._diag_names is None:
            self._diag_names = list(diag)
            if self._diag_names:
                self._diag_table = _Appender(_diagnostic_table(self._file, self._diag_group, self._diag_names))
        if self._diag_table is not None:
            self._diag_table.append(i, np.array([diag[k] for k in self._diag_names], dtype=np.float64))
        self._xdmf.add_frame(i, bodies=body_arrays)
        self._time_appender.append(i, time)
        self._file.flush()
        self._frames = i + 1
        self._times.append(time)

        if self._csv is not None:
            self._csv.write_row(time, diag)
        if _clock() - self._sidecar_written >= self.sidecar_interval:
            self._write_xdmf()

    def set_status(self, status: str, message: str = "") -> None:
        """Mark how the run ended ("completed", "blown-up", "interrupted", ...), flush, and bring the
        XDMF sidecars up to every frame written.

        Args:
            status: Short status word, stored as root attribute "status".
            message: Human-readable detail, stored as root attribute "status_message".
        """
        if self._closed:
            raise RuntimeError(f"FrameWriter for {self.path} is closed")
        self._file.attrs["status"] = str(status)
        self._file.attrs["status_message"] = str(message)
        self._file.flush()
        self._catch_up_sidecars()

    def close(self) -> None:
        """Bring the XDMF sidecars up to every frame written, flush and close the HDF5 file and the
        CSV; closing twice is harmless."""
        if self._closed:
            return
        self._closed = True
        try:
            self._catch_up_sidecars()
        finally:
            try:
                if self._csv is not None:
                    self._csv.close()
            finally:
                self._file.close()

    # ------------------------------------------------------------------ sidecars

    def _write_xdmf(self) -> None:
        """Rewrite the XDMF sidecars for all frames so far (see ``mpmdem.io.xdmf``)."""
        self._xdmf.write(self._times)
        self._sidecar_frames = len(self._times)
        self._sidecar_written = _clock()

    def _catch_up_sidecars(self) -> None:
        """Rewrite the XDMF sidecars if they miss frames (none without frames, as before any)."""
        if self._sidecar_frames < len(self._times):
            self._write_xdmf()


def _clock() -> float:
    """Monotonic wall time [s] that the sidecar interval is measured in."""
    return time.monotonic()
