"""The run-file format: names, keys and layout of what ``FrameWriter`` writes and ``RunFile`` reads.

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
* ``/diagnostics/<name>``: one float64 scalar per frame (energies, momenta, dt, ...): a virtual
  dataset, column ``k`` of ``/diagnostic_values`` (older files: a plain dataset each);
* ``/diagnostic_values``: the diagnostics of every frame, shape (n_frames, n_diagnostics), float64,
  its attribute ``names`` naming the columns in order (written as one row per frame; a plain
  dataset, for tools built on HDF5 1.8, which cannot read virtual datasets);
* ``/xdmf/...``: what the XDMF sidecars point at (per-frame virtual views of the fields, the
  bodies' world outlines, connectivities; see ``mpmdem.io.xdmf``); readers of the run ignore it;
* root attributes: every entry of the writer's ``attrs`` as a JSON string, plus ``format``
  and, once the run ends, ``status`` and ``status_message`` (plain strings).

The file is flushed after every frame and is never opened with the SWMR / "latest" file format,
so a writer that crashes or is killed leaves a file that ``RunFile`` (or any HDF5 tool) reads up
to the last complete frame. Next to it the writer keeps the XDMF 3 sidecars ``<name>.xdmf`` (the
particles, when N > 0) and ``<name>_bodies.xdmf`` (the bodies' outlines, when M > 0), rewritten
atomically at most every ``sidecar_interval`` seconds (1 s by default) and when the run ends, which
ParaView (Xdmf3 and legacy XDMF readers) and meshio's ``TimeSeriesReader`` open as time series; a
writer killed before its end leaves sidecars that may miss the frames of its last interval.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BODY_GEOMETRY_KEYS", "DIAGNOSTIC_TABLE", "FORMAT", "GEOMETRY_DTYPES", "MOTION_FIXED", "MOTION_FREE",
           "MOTION_KINEMATIC", "PLAIN_ATTRS", "PRECISIONS", "default_body_field_specs", "default_field_specs"]

FORMAT = "mpmdem-1"
"""Value of the root attribute ``format`` of every run file this module writes."""

DIAGNOSTIC_TABLE = "diagnostic_values"
"""Root dataset of the per-frame diagnostics (frames × names); ``/diagnostics/<name>`` are its columns."""

#: Root attributes stored as plain strings, not JSON.
PLAIN_ATTRS = ("format", "status", "status_message")

#: ``attrs["precision"]`` → the dtype of the "float" fields.
PRECISIONS = {"f32": np.float32, "f64": np.float64}


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
GEOMETRY_DTYPES = {
    "vertex_start": np.int32,
    "vertex_count": np.int32,
    "vertices": np.float64,
    "radius": np.float64,
    "motion": np.int32,
    "mass": np.float64,
}

#: Body motion codes of ``body_geometry["motion"]``.
MOTION_FREE, MOTION_FIXED, MOTION_KINEMATIC = 0, 1, 2
