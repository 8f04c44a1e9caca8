"""Run files: the HDF5 frame writer, its XDMF sidecar and CSV energy log, and a reader.

A run file (format ``mpmdem-1``) is one HDF5 file holding, for a fixed particle count N:

* ``/particles/<name>``: one resizable dataset per particle field, shape (n_frames, N, *shape),
  chunked one frame at a time;
* ``/time``: the simulated time of each frame [s], float64;
* ``/diagnostics/<name>``: one float64 scalar per frame (energies, momenta, dt, ...);
* root attributes: every entry of the writer's ``attrs`` as a JSON string, plus ``format``
  and, once the run ends, ``status`` and ``status_message`` (plain strings).

The file is flushed after every frame and is never opened with the SWMR / "latest" file format,
so a writer that crashes or is killed leaves a file that ``RunFile`` (or any HDF5 tool) reads up
to the last complete frame. Next to it the writer keeps ``<name>.xdmf`` (rewritten atomically
after every frame) so ParaView can open the run as a time series of point clouds.
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
from xml.sax.saxutils import quoteattr

import h5py
import numpy as np

__all__ = ["FORMAT", "FrameWriter", "RunFile", "default_field_specs"]

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


def _component_suffixes(shape: tuple[int, ...]) -> list[tuple[str, tuple[int, ...]]]:
    """Names and index tuples of the scalar components of a per-particle shape.

    (2,) → _x, _y; (2, 2) → _xx, _xy, _yx, _yy; other shapes → _i_j... by index.
    """
    if shape == ():
        return [("", ())]
    if all(n <= 3 for n in shape):
        axes = "xyz"
        return [("_" + "".join(axes[i] for i in idx), idx) for idx in np.ndindex(*shape)]
    return [("_" + "_".join(str(i) for i in idx), idx) for idx in np.ndindex(*shape)]


def _xdmf_number_type(dtype: np.dtype) -> tuple[str, int]:
    """XDMF NumberType and Precision of a numpy dtype."""
    if dtype.kind == "f":
        return "Float", dtype.itemsize
    if dtype.kind == "u":
        return "UInt", dtype.itemsize
    if dtype.kind in "ib":
        return "Int", dtype.itemsize
    raise ValueError(f"dtype {dtype} cannot be described in XDMF")


class FrameWriter:
    """Write a run frame by frame to HDF5, with an XDMF sidecar and an optional energy CSV.

    Every call of ``write_frame`` appends one frame to every particle dataset, one value to
    every diagnostic, flushes the HDF5 file and the CSV, and rewrites the XDMF sidecar; a run
    that dies keeps every frame written before.

    Args:
        path: The HDF5 file to create (overwritten if it exists).
        particle_count: N, the number of particles; fixed for the whole run.
        attrs: Run metadata (scene, config, version, device, precision, ...): JSON-serialisable
            values (numpy scalars/arrays and paths are converted). ``attrs["precision"]``
            ("f32" or "f64", default "f32") sets the dtype of the "float" fields.
        field_specs: Particle fields, name → (per-particle shape, dtype name), where the dtype
            name is "float" (the run precision) or a numpy dtype name. None gives
            ``default_field_specs()``: x, v, stress, volume, mass, F, body.
        csv_path: Where to keep the diagnostics as CSV (header ``time,<names...>``, one row per
            frame); None writes no CSV.

    Raises:
        ValueError: particle_count is negative, precision is unknown or a field spec is invalid.
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
    ) -> None:
        if int(particle_count) != particle_count or particle_count < 0:
            raise ValueError(f"particle_count must be a non-negative integer, got {particle_count!r}")
        self.path = Path(path)
        self.xdmf_path = self.path.with_suffix(".xdmf")
        self.csv_path = Path(csv_path) if csv_path is not None else None
        self.particle_count = int(particle_count)
        precision = attrs.get("precision", "f32")
        if precision not in _PRECISIONS:
            raise ValueError(f"precision must be one of {', '.join(_PRECISIONS)}, got {precision!r}")
        float_dtype = _PRECISIONS[precision]
        specs = dict(default_field_specs() if field_specs is None else field_specs)
        self._specs: dict[str, tuple[tuple[int, ...], np.dtype]] = {}
        for name, spec in specs.items():
            try:
                shape, dtype_name = spec
                shape = tuple(int(n) for n in shape)
            except (TypeError, ValueError):
                raise ValueError(
                    f"field spec {name!r}: expected (shape tuple, dtype name), got {spec!r}"
                ) from None
            if not name or "/" in name:
                raise ValueError(f"invalid field name {name!r}")
            if any(n < 1 for n in shape):
                raise ValueError(f"field spec {name!r}: shape {shape} has a zero or negative extent")
            self._specs[name] = (shape, _resolve_dtype(dtype_name, float_dtype))
        # Encode attrs before touching the disk so a bad value leaves nothing half-written.
        encoded = {
            str(k): json.dumps(v, default=_json_default) for k, v in attrs.items() if k not in _PLAIN_ATTRS
        }

        self.path.parent.mkdir(parents=True, exist_ok=True)
        # A sidecar left by an earlier run of the same name would describe frames that no longer exist.
        self.xdmf_path.unlink(missing_ok=True)
        self._frames = 0
        self._times: list[float] = []
        self._diag_names: list[str] | None = None
        self._csv_file = None
        self._csv_writer = None
        self._closed = False
        self._file = h5py.File(self.path, "w")
        try:
            for k, v in encoded.items():
                self._file.attrs[k] = v
            self._file.attrs["format"] = FORMAT
            n = self.particle_count
            chunk_n = max(n, 1)
            group = self._file.create_group("particles")
            self._datasets: dict[str, h5py.Dataset] = {}
            for name, (shape, dtype) in self._specs.items():
                self._datasets[name] = group.create_dataset(
                    name,
                    shape=(0, n, *shape),
                    maxshape=(None, n if n > 0 else None, *shape),
                    chunks=(1, chunk_n, *shape),
                    dtype=dtype,
                )
            self._time_ds = self._file.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64)
            self._diag_group = self._file.create_group("diagnostics")
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

    # ------------------------------------------------------------------ writing

    def write_frame(
        self, time: float, fields: Mapping[str, np.ndarray], diagnostics: Mapping[str, float]
    ) -> None:
        """Append one frame: every particle field, the time and every diagnostic; then flush.

        Args:
            time: Simulated time of the frame [s].
            fields: One array per field of the field specs, shape (N, *shape); values are cast
                to the field's dtype.
            diagnostics: Scalar per-frame values (energies [J/m], momenta, dt, ...). The first
                frame fixes the set of names; later frames must give the same names.

        Raises:
            ValueError: a field is missing, unknown or has the wrong shape, or the diagnostic
                names differ from the first frame's.
            RuntimeError: the writer is closed.
        """
        if self._closed:
            raise RuntimeError(f"FrameWriter for {self.path} is closed")
        n = self.particle_count
        missing = [k for k in self._specs if k not in fields]
        unknown = [k for k in fields if k not in self._specs]
        if missing or unknown:
            raise ValueError(
                f"frame fields must be exactly {sorted(self._specs)}; missing {missing}, unknown {unknown}"
            )
        arrays = {}
        for name, (shape, dtype) in self._specs.items():
            a = np.asarray(fields[name])
            if a.shape != (n, *shape):
                raise ValueError(f"field {name!r}: expected shape {(n, *shape)}, got {a.shape}")
            arrays[name] = a.astype(dtype, copy=False)
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
        # Particle data and diagnostics first, the time last: a reader counts frames by /time,
        # so a frame interrupted half-way is never seen.
        for name, a in arrays.items():
            ds = self._datasets[name]
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
        """Rewrite the XDMF sidecar for all frames so far (tmp file + os.replace)."""
        text = _xdmf_document(self.path.name, self.particle_count, self._times, self._specs)
        tmp = self.xdmf_path.with_name(self.xdmf_path.name + ".tmp")
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, self.xdmf_path)


def _xdmf_document(
    h5_name: str,
    n: int,
    times: list[float],
    specs: Mapping[str, tuple[tuple[int, ...], np.dtype]],
) -> str:
    """XDMF 2 text: a temporal collection of Polyvertex grids, one per frame.

    Geometry is the XY hyperslab of /particles/x; every field becomes Scalar attributes, one per
    component (v → v_x, v_y; stress → stress_xx, stress_xy, stress_yx, stress_yy).
    """
    n_frames = len(times)
    h5 = h5_name.replace("&", "&amp;").replace("<", "&lt;")

    def source(name: str, shape: tuple[int, ...], dtype: np.dtype) -> str:
        number, prec = _xdmf_number_type(dtype)
        dims = " ".join(str(d) for d in (n_frames, n, *shape))
        return (
            f'<DataItem Dimensions="{dims}" NumberType="{number}" Precision="{prec}" Format="HDF">'
            f"{h5}:/particles/{name}</DataItem>"
        )

    def slab(frame: int, idx: tuple[int, ...], src: str, count_tail: tuple[int, ...], out_dims: str) -> str:
        rank = 2 + len(idx)
        start = " ".join(str(v) for v in (frame, 0, *idx))
        stride = " ".join(["1"] * rank)
        count = " ".join(str(v) for v in (1, n, *count_tail))
        return (
            f'<DataItem ItemType="HyperSlab" Dimensions="{out_dims}" Type="HyperSlab">'
            f'<DataItem Dimensions="3 {rank}" Format="XML">{start} {stride} {count}</DataItem>'
            f"{src}</DataItem>"
        )

    # Per-field pieces that do not depend on the frame.
    x_shape, x_dtype = specs.get("x", ((2,), np.dtype(np.float32)))
    x_src = source("x", x_shape, x_dtype) if "x" in specs else None
    attr_parts: list[tuple[str, tuple[int, ...], str]] = []
    for name, (shape, dtype) in specs.items():
        src = source(name, shape, dtype)
        for suffix, idx in _component_suffixes(shape):
            attr_parts.append((name + suffix, idx, src))

    lines = [
        '<?xml version="1.0" encoding="utf-8"?>',
        '<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>',
        '<Xdmf Version="2.0" xmlns:xi="http://www.w3.org/2001/XInclude">',
        " <Domain>",
        '  <Grid Name="particles" GridType="Collection" CollectionType="Temporal">',
    ]
    for k, t in enumerate(times):
        lines.append(f'   <Grid Name="frame_{k:06d}" GridType="Uniform">')
        lines.append(f'    <Time Value="{t!r}"/>')
        lines.append(f'    <Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1"/>')
        if x_src is not None:
            lines.append(f'    <Geometry GeometryType="XY">{slab(k, (0,), x_src, (2,), f"{n} 2")}</Geometry>')
        for aname, idx, src in attr_parts:
            ones = tuple(1 for _ in idx)
            lines.append(
                f"    <Attribute Name={quoteattr(aname)} AttributeType=\"Scalar\" Center=\"Node\">"
                f"{slab(k, idx, src, ones, str(n))}</Attribute>"
            )
        lines.append("   </Grid>")
    lines += ["  </Grid>", " </Domain>", "</Xdmf>", ""]
    return "\n".join(lines)


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
        parts = self._file.get("particles")
        lengths = [len(t)]
        if parts is not None:
            lengths += [parts[k].shape[0] for k in parts]
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

    @property
    def particle_count(self) -> int:
        """N, the number of particles per frame."""
        parts = self._file.get("particles")
        if parts is None or len(parts) == 0:
            return 0
        return int(next(iter(parts.values())).shape[1])

    @property
    def fields(self) -> list[str]:
        """Names of the particle fields stored per frame."""
        parts = self._file.get("particles")
        return list(parts) if parts is not None else []

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
        parts = self._file.get("particles")
        if parts is None or name not in parts:
            raise KeyError(f"no particle field {name!r} in {self.path}; fields: {', '.join(self.fields)}")
        f = self._frames
        k = int(frame)
        if k < 0:
            k += f
        if not 0 <= k < f:
            raise IndexError(f"frame {frame} out of range for {f} frame(s)")
        return parts[name][k]

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
        parts = self._file.get("particles")
        if parts is not None and len(parts):
            desc = []
            for k in parts:
                ds = parts[k]
                shape = "x".join(str(s) for s in ds.shape[2:]) or "scalar"
                desc.append(f"{k} ({shape}, {ds.dtype})")
            lines.append(f"fields:      {', '.join(desc)}")
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
        return f"RunFile({str(self.path)!r}, frames={self._frames}, particles={self.particle_count})"
