"""XDMF 3 sidecars of a run file, for ParaView (both XDMF readers) and meshio.

Beside ``<run>.h5`` the writer keeps two small XML files, rewritten atomically (``XdmfSidecars.write``)
when ``FrameWriter`` asks: after a frame at most every ``sidecar_interval`` seconds, and when the run
ends:

* ``<run>.xdmf`` (when the run has particles): a temporal collection "particles" of uniform grids,
  one per frame: Polyvertex topology (N elements of one node, connectivity 0..N-1), XYZ geometry
  (z = 0) and every particle field as a node attribute: scalars as Scalar, (d,) fields with d <= 3
  as Vector (padded to 3 components with 0), (a, b) fields with a, b <= 3 as Tensor (3 x 3, row
  major, padded with 0), any other shape as one Scalar per component (``name_i_j``).
* ``<run>_bodies.xdmf`` (when the run has rigid bodies with a centroid field x): a temporal
  collection "bodies": each body's dilated outline as a closed Polyline of K + 1 nodes (K points,
  the same count for every body, and the first again); every body field and the static radius,
  motion and mass as cell attributes, one value per body.
* ``<run>_grains.xdmf`` (when the run has grains: ``/bodies/geometry/grain`` marks them; they are the
  last bodies): a temporal collection "grains", the grains as points (Polyvertex, XYZ geometry from
  their centroids) with every body field and the static radius and mass as node attributes; a
  million grains cost one row each, not an outline. The bodies sidecar then holds the other bodies.

Every DataItem names a whole HDF5 dataset of exactly its dimensions (no HyperSlab: ParaView's Xdmf3
reader crashes on one, and meshio reads none). The frame-stacked datasets ``/particles/<f>`` and
``/bodies/<f>`` (n_frames, count, ...) are exposed per frame as HDF5 virtual datasets
``/xdmf/<group>/frame_<k>/<f>`` (particles, grains), which store no data, only the mapping; the
outlined bodies' are copies ``/xdmf/bodies/frame_<k>/<f>`` (a plain dataset is a quarter of a
virtual one's cost to create, and a few bytes a body beside its outline), and their world outlines
real datasets ``/xdmf/bodies/frame_<k>/outline`` (M K, 3) [m]. The connectivities are written
once. The views are made with each frame, before its flush; the sidecar text lists only flushed
frames, so the sidecars are valid whenever the run stops (and list every frame once it ended).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import h5py
import numpy as np
from h5py import h5d, h5g, h5p, h5s, h5t

from ..model.outlines import outline_rings, place_rings

__all__ = ["GROUP", "XdmfSidecars", "bodies_xdmf_path", "grains_xdmf_path", "particles_xdmf_path"]

GROUP = "xdmf"
"""HDF5 group holding the per-frame views and outlines the sidecars point at."""

#: Static per-body arrays of /bodies/geometry given to every bodies grid as cell attributes.
_STATIC_BODY_ATTRS = ("radius", "motion", "mass")


def particles_xdmf_path(h5_path: str | os.PathLike) -> Path:
    """The particles sidecar of a run file: ``run.h5`` → ``run.xdmf``."""
    return Path(h5_path).with_suffix(".xdmf")


def grains_xdmf_path(h5_path: str | os.PathLike) -> Path:
    """The grains sidecar of a run file: ``run.h5`` → ``run_grains.xdmf``."""
    p = Path(h5_path)
    return p.with_name(p.stem + "_grains.xdmf")


def bodies_xdmf_path(h5_path: str | os.PathLike) -> Path:
    """The bodies sidecar of a run file: ``run.h5`` → ``run_bodies.xdmf``."""
    p = Path(h5_path)
    return p.with_name(p.stem + "_bodies.xdmf")


def _number_type(dtype: np.dtype) -> tuple[str, int]:
    """XDMF NumberType and Precision of a numpy dtype."""
    kinds = {"f": "Float", "u": "UInt", "i": "Int", "b": "Int"}
    if dtype.kind not in kinds:
        raise ValueError(f"dtype {dtype} cannot be described in XDMF")
    return kinds[dtype.kind], dtype.itemsize


def _views(name: str, shape: tuple[int, ...]) -> list[tuple[str, str, tuple[int, ...], list]]:
    """How a field of per-item ``shape`` is shown: (attribute name, AttributeType, per-item view shape,
    [(view columns, source index)]), a source index selecting from one item's value."""
    if shape == ():
        return [(name, "Scalar", (), [((), ())])]
    if len(shape) == 1 and shape[0] <= 3:
        return [(name, "Vector", (3,), [((slice(0, shape[0]),), (slice(None),))])]
    if len(shape) == 2 and max(shape) <= 3:
        rows = [((slice(3 * i, 3 * i + shape[1]),), (i, slice(None))) for i in range(shape[0])]
        return [(name, "Tensor", (9,), rows)]
    return [(name + "_" + "_".join(str(i) for i in idx), "Scalar", (), [((), idx)]) for idx in np.ndindex(*shape)]


def _hyperslab(dims: tuple[int, ...], key: tuple) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(start, count) of the block that ``key`` (integers and unit-step slices, one per leading
    axis; the axes after them whole) selects from a dataspace of ``dims``."""
    start, count = [], []
    for axis, n in enumerate(dims):
        item = key[axis] if axis < len(key) else slice(None)
        if isinstance(item, slice):
            a, b, _ = item.indices(n)
            start.append(a)
            count.append(b - a)
        else:
            start.append(int(item))
            count.append(1)
    return tuple(start), tuple(count)


class XdmfSidecars:
    """Keep the XDMF sidecars of an HDF5 run file being written.

    Args:
        file: The run file, open for writing; its /particles and /bodies datasets must exist.
        particle_count: N (0: no particles sidecar).
        body_count: M (0: no bodies sidecar).
        body_geometry: The stored /bodies/geometry arrays (vertex_start, vertex_count, vertices,
            radius, ...); needed when M > 0.
        quad_segs: Segments per quarter circle of the bodies' rounded corners.
    """

    def __init__(self, file: h5py.File, *, particle_count: int, body_count: int = 0,
                 body_geometry: Mapping | None = None, quad_segs: int = 8) -> None:
        self._file = file
        self._h5 = Path(file.filename)
        self._n = int(particle_count)
        self._m = int(body_count)
        self._times: list[float] = []
        # per group: (the layout its frame blocks were made for, the blocks of frames 0, 1, ...): a
        # frame's text is made once, so a write costs the file, not every frame's text again
        self._blocks: dict[str, tuple[tuple, list[str]]] = {}
        # per group: (its source group, the source's member count, /xdmf/<group>, the view plan)
        self._plans: dict[str, tuple] = {}
        # (made once, copied or passed for every frame: see _add_views)
        self._dcpl = h5p.create(h5p.DATASET_CREATE)
        self._dcpl.set_layout(h5d.VIRTUAL)
        self._dcpl.set_fill_value(np.array([0]))
        self._lcpl = h5p.create(h5p.LINK_CREATE)
        self._lcpl.set_create_intermediate_group(True)
        self._lcpl.set_char_encoding(h5t.CSET_ASCII)
        self._gcpl = h5p.create(h5p.GROUP_CREATE)
        self._gcpl.set_obj_track_times(False)
        self._outline: tuple | None = None  # (creation list, type, dataspace) of the outlines
        bodies = file.get("bodies")
        has_x = self._m > 0 and bodies is not None and "x" in bodies
        # grains (the last bodies, ``grain`` 1): points of their own sidecar, not outlines
        grain = np.asarray(body_geometry.get("grain", ())) if body_geometry is not None else np.zeros(0)
        self._outlined = self._m - int(np.count_nonzero(grain)) if len(grain) else self._m
        self._has_grains = has_x and self._outlined < self._m
        self._has_bodies = has_x and self._outlined > 0
        root = file.require_group(GROUP)
        if self._n > 0:
            g = root.create_group("particles")
            g.create_dataset("connectivity", data=np.arange(self._n, dtype=np.int32).reshape(-1, 1))
        if self._has_bodies:
            m = self._outlined
            geometry = body_geometry if m == self._m else {
                k: (v if k == "vertices" else v[:m]) for k, v in body_geometry.items()}
            self._rings = outline_rings(geometry, quad_segs=quad_segs)
            k = self._rings.shape[1]
            ids = np.arange(m * k, dtype=np.int32).reshape(m, k)
            g = root.create_group("bodies")
            g.create_dataset("connectivity", data=np.concatenate([ids, ids[:, :1]], axis=1))
            if m < self._m:  # the static attributes of the outlined bodies only (no hyperslabs)
                for name in _STATIC_BODY_ATTRS:
                    if name in body_geometry:
                        g.create_dataset(f"static/{name}", data=np.asarray(body_geometry[name])[:m])
        if self._has_grains:
            count = self._m - self._outlined
            g = root.create_group("grains")
            g.create_dataset("connectivity", data=np.arange(count, dtype=np.int32).reshape(-1, 1))
            for name in ("radius", "mass"):
                if name in body_geometry:
                    g.create_dataset(f"static/{name}", data=np.asarray(body_geometry[name])[self._outlined:])

    @property
    def particles_path(self) -> Path:
        """The particles sidecar (``run.xdmf``)."""
        return particles_xdmf_path(self._h5)

    @property
    def grains_path(self) -> Path:
        """The grains sidecar (``run_grains.xdmf``)."""
        return grains_xdmf_path(self._h5)

    @property
    def bodies_path(self) -> Path:
        """The bodies sidecar (``run_bodies.xdmf``)."""
        return bodies_xdmf_path(self._h5)

    def add_frame(self, k: int, bodies: Mapping[str, np.ndarray] | None = None) -> None:
        """Create frame k's views (and the bodies' world outlines) in the HDF5 file; call before its flush.
        ``bodies``: frame k's body fields as stored (the outlines are placed from their x and angle;
        None: read back from the file)."""
        if self._n > 0:
            self._add_views("particles", k)
        if self._has_bodies:
            m = self._outlined
            if bodies is None:
                stored = self._file["bodies"]
                bodies = {name: ds[k] for name, ds in stored.items() if isinstance(ds, h5py.Dataset)}
            g = self._add_copies(k, bodies, m)
            x, angle = bodies["x"], bodies.get("angle")
            ring = place_rings(self._rings, x[:m], None if angle is None else angle[:m]).reshape(-1, 2)
            outline = np.column_stack([ring, np.zeros(len(ring))])
            if self._outline is None:  # (h5py makes the first; the later ones are made as it made that one)
                ds = h5py.Group(g).create_dataset("outline", data=outline)
                self._outline = (ds.id.get_create_plist(), ds.id.get_type(), ds.id.get_space())
            else:
                dcpl, stored_type, space = self._outline
                h5d.create(g, b"outline", stored_type, space, dcpl=dcpl, lcpl=self._lcpl).write(h5s.ALL, h5s.ALL,
                                                                                                 outline)
        if self._has_grains:
            self._add_views("grains", k, source="bodies", rows=(self._outlined, self._m))

    def _add_copies(self, k: int, values: Mapping[str, np.ndarray], count: int) -> h5g.GroupID:
        """Datasets /xdmf/bodies/frame_<k>/<view> holding what the views of ``_add_views`` would show
        of frame k's ``values`` (each /bodies/<field>'s frame, as stored), of its first ``count``
        items; returns the frame's group. For the outlined bodies: few items a frame, where a plain
        dataset costs a quarter of a virtual one's creation and its copy a few bytes a body."""
        parent, plan = self._copy_plan(count)
        out = h5g.create(parent.id, b"frame_%06d" % k, lcpl=self._lcpl, gcpl=self._gcpl)
        for view, stored_type, space, name, dtype, dims, parts in plan:
            block = np.zeros(dims, dtype)  # (the padding a view's unmapped elements read: its fill 0)
            source = np.asarray(values[name])
            for columns, index in parts:
                block[(slice(None), *columns)] = source[(slice(0, count), *index)]
            h5d.create(out, view, stored_type, space, lcpl=self._lcpl).write(h5s.ALL, h5s.ALL, block)
        return out

    def _copy_plan(self, count: int) -> tuple[h5py.Group, list]:
        """/xdmf/bodies and, per view of ``_views``, (name, file type, dataspace, source field, dtype,
        shape, [(view columns, source index)]); made at the first frame and again if /bodies changes."""
        cached = self._plans.get("bodies copies")
        if cached is not None and cached[0].get_num_objs() == cached[1]:
            return cached[2], cached[3]
        src = self._file["bodies"]
        plan = []
        for name, ds in src.items():
            if not isinstance(ds, h5py.Dataset):
                continue
            for view, _, shape, parts in _views(name, ds.shape[2:]):
                dims = (count, *shape)
                plan.append((view.encode("utf-8"), h5t.py_create(ds.dtype, logical=1), h5s.create_simple(dims), name,
                             ds.dtype, dims, parts))
        parent = self._file[GROUP]["bodies"]
        self._plans["bodies copies"] = (src.id, src.id.get_num_objs(), parent, plan)
        return parent, plan

    def _add_views(self, group: str, k: int, *, source: str | None = None,
                   rows: tuple[int, int] | None = None) -> h5g.GroupID:
        """Virtual datasets /xdmf/<group>/frame_<k>/<view> of frame k of every /<source>/<field>
        (source: ``group``), of its items rows[0] ≤ i < rows[1] (all when None); returns the frame's group.

        Made with h5py's low-level calls: the mappings ``h5py.VirtualLayout`` would store, without
        its per-slice copies of the source (a third of a small scene's frame writing); what does not
        depend on k is made once (``_view_plan``): the views' types, dataspaces and selections, a
        creation property list to copy (a new one and its fill value cost as much again), and the
        frame group's property lists (those ``h5py.Group.create_group`` makes for an ASCII name)."""
        parent, plan = self._view_plan(group, source or group, rows)
        out = h5g.create(parent.id, b"frame_%06d" % k, lcpl=self._lcpl, gcpl=self._gcpl)
        for view, memory_type, space, source_name, ds_id, parts in plan:
            frame = ds_id.get_space()  # (the frames written so far, count, ...)
            dcpl = self._dcpl.copy()
            for target, start, count in parts:
                frame.select_hyperslab((k, *start), (1, *count))
                dcpl.set_virtual(target, b".", source_name, frame)  # (copies the selection)
            h5d.create(out, view, memory_type, space, dcpl=dcpl)
        return out

    def _view_plan(self, group: str, source: str, rows: tuple[int, int] | None) -> tuple[h5py.Group, list]:
        """/xdmf/<group> and what its frames' views need besides the frame: per view (name, type,
        dataspace, source name, source dataset, [(target selection, the source block's start and count
        on the axes after the frame's)]);
        made at the first frame and again if the datasets of /<source> change."""
        cached = self._plans.get(group)
        if cached is not None and cached[0].get_num_objs() == cached[1]:
            return cached[2], cached[3]
        src = self._file[source]
        plan = []
        for name, ds in src.items():
            if not isinstance(ds, h5py.Dataset):
                continue
            first, last = rows if rows is not None else (0, ds.shape[1])
            for view, _, shape, parts in _views(name, ds.shape[2:]):
                dims = (last - first, *shape)
                targets = []
                for columns, index in parts:
                    target = h5s.create_simple(dims)
                    target.select_hyperslab(*_hyperslab(dims, (slice(None), *columns)))
                    # (the source block of a frame: the frame's index, then these on the axes after it)
                    targets.append((target, *_hyperslab(ds.shape[1:], (slice(first, last), *index))))
                plan.append((view.encode("utf-8"), h5t.py_create(ds.dtype, logical=1), h5s.create_simple(dims),
                             ds.name.encode("utf-8"), ds.id, targets))
        parent = self._file[GROUP][group]
        self._plans[group] = (src.id, src.id.get_num_objs(), parent, plan)
        return parent, plan

    def write(self, times: list[float]) -> None:
        """Rewrite the sidecars for the frames at ``times`` [s] (temporary file, then ``os.replace``)."""
        if self._n > 0:
            _replace(self.particles_path, self._document("particles", times))
        if self._has_bodies:
            _replace(self.bodies_path, self._document("bodies", times))
        if self._has_grains:
            _replace(self.grains_path, self._document("grains", times))

    def _item(self, path: str, dims: tuple[int, ...], dtype: np.dtype) -> str:
        """A DataItem naming the whole dataset ``path`` of the run file."""
        number, precision = _number_type(np.dtype(dtype))
        return (f'<DataItem Dimensions="{" ".join(str(d) for d in dims)}" NumberType="{number}" '
                f'Precision="{precision}" Format="HDF">{escape(self._h5.name)}:{path}</DataItem>')

    def _document(self, group: str, times: list[float]) -> str:
        """XDMF 3 text of one temporal collection over frames 0..len(times)-1."""
        src = self._file["bodies" if group == "grains" else group]
        fields = {k: ds for k, ds in src.items() if isinstance(ds, h5py.Dataset)}
        base = f"/{GROUP}/{group}"
        conn = self._file[base]["connectivity"]
        if group in ("particles", "grains"):
            count, center = (self._n, "Node") if group == "particles" else (self._m - self._outlined, "Node")
            topology = f'<Topology TopologyType="Polyvertex" NumberOfElements="{count}" NodesPerElement="1">'
            geometry = ("x", (count, 3), fields["x"].dtype) if "x" in fields else None
        else:
            count, center = self._outlined, "Cell"
            topology = (f'<Topology TopologyType="Polyline" NumberOfElements="{count}" '
                        f'NodesPerElement="{conn.shape[1]}">')
            geometry = ("outline", (count * self._rings.shape[1], 3), np.dtype(np.float64))
        topology += self._item(f"{base}/connectivity", conn.shape, conn.dtype) + "</Topology>"
        attrs = []
        for name, ds in fields.items():
            for view, kind, shape, _ in _views(name, ds.shape[2:]):
                attrs.append((view, kind, (count, *shape), ds.dtype, None))
        if group != "particles":
            # the whole /bodies/geometry arrays, or their copies of the outlined bodies or the grains
            geo = self._file[base]["static"] if (group == "grains" or self._outlined < self._m) else src["geometry"]
            for name in _STATIC_BODY_ATTRS:
                if name in geo and name not in {a[0] for a in attrs}:
                    attrs.append((name, "Scalar", (count,), geo[name].dtype, geo[name].name))
        layout = (topology, geometry, tuple(attrs), center)
        made, blocks = self._blocks.get(group, (None, []))
        if made != layout:
            blocks = []  # (a field appeared: every frame's block anew)
        blocks = [b for b, _ in zip(blocks, times, strict=False)]
        for k in range(len(blocks), len(times)):
            frame = f"{base}/frame_{k:06d}"
            lines = [f'   <Grid Name="frame_{k:06d}" GridType="Uniform">', f'    <Time Value="{float(times[k])!r}"/>',
                     f"    {topology}"]
            if geometry is not None:
                gname, dims, dtype = geometry
                item = self._item(f"{frame}/{gname}", dims, dtype)
                lines.append(f'    <Geometry GeometryType="XYZ">{item}</Geometry>')
            for view, kind, dims, dtype, static in attrs:
                item = self._item(static or f"{frame}/{view}", dims, dtype)
                lines.append(f'    <Attribute Name={quoteattr(view)} AttributeType="{kind}" Center="{center}">'
                             f"{item}</Attribute>")
            lines.append("   </Grid>")
            blocks.append("\n".join(lines))
        self._blocks[group] = (layout, blocks)
        head = ['<?xml version="1.0" encoding="utf-8"?>', '<Xdmf Version="3.0">', " <Domain>",
                f'  <Grid Name="{group}" GridType="Collection" CollectionType="Temporal">']
        return "\n".join(head + blocks + ["  </Grid>", " </Domain>", "</Xdmf>", ""])


def _replace(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically: a temporary file beside it, then ``os.replace``."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)
