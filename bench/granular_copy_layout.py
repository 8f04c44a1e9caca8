"""Micro-benchmark: what the layout of the granular grid copies costs a G2P-like gather and a
P2G-like scatter.

Steps the ``dispersed-cloud`` of granular_overhead.py (tent, granular mode) 60 times, reads back its
real components and the layer each point's four stencil copies got, then times (mean of 50
launches) a four-copy gather of a vec2 field and a four-copy scatter (a float and a vec2 atomic per
copy) over the same points and nodes, for four layouts:

- ``plain``: every copy in layer 0 (what plain MPM reads);
- ``slab``: the copies where the greedy per-node claim put them (layer slabs, as the solver does);
- ``hybrid``: copy 0 in the dense layer, copies 1… node-major (16 per node, contiguous);
- ``colour``: one layer per component, from a greedy colouring (on the host) of the components that
  share a node: the paper's task 2–3, layer slabs.

One JSON line per layout (case, device, size, layout, gather_us, scatter_us, colours).

    python bench/granular_copy_layout.py 1048576 cuda:0
    python bench/granular_copy_layout.py 4096 cpu
"""
import json
import sys
import time

import numpy as np
import warp as wp

sys.path.insert(0, "bench")
import granular_overhead as go  # noqa: E402

from mpmdem import Simulation, SolverConfig  # noqa: E402
from mpmdem.sim.mpm import initial_dt_bound  # noqa: E402

n = int(sys.argv[1]) if len(sys.argv) > 1 else 1048576
wp.init()
scene = go.dispersed_cloud(n)
dt = go.DT_FACTOR * initial_dt_bound(scene)
cfg = SolverConfig(shape="linear", transfer="PIC", update="USL", precision="f32", granular=True, dt=dt,
                   cuda_graph=False)
DEV = sys.argv[2] if len(sys.argv) > 2 else "cuda:0"
sim = Simulation(scene, cfg, device=DEV)
m = sim.mpm
sim.advance_to(1e-12)
m.set_stop_time(1e9)
sim.advance(60)
wp.synchronize()
L, R = m.D.layers, m.D.layer_rows
own = m.G.owner.numpy().reshape(L, R, -1)
C = own.shape[2]
x = m.P.x.numpy().astype(np.float64)
comp = m.P.comp.numpy()
origin = np.array([float(v) for v in m.D.origin])
c = np.floor((x - origin) / float(m.D.h)).astype(np.int64)
NI = np.stack([c[:, 0], c[:, 0], c[:, 0] + 1, c[:, 0] + 1], 1)
NJ = np.stack([c[:, 1], c[:, 1] + 1, c[:, 1], c[:, 1] + 1], 1)
S = np.full(NI.shape, -1, np.int64)
for s in range(L):
    hit = (own[s][NI, NJ] == comp[:, None]) & (S < 0)
    S[hit] = s
unfound = int((S < 0).sum())  # points that changed cells in the last step's move
S[S < 0] = 0

# greedy colouring of the components that share a node (host, for the experiment only)
used = own >= 0
pairs = []
for a in range(L):
    for b in range(a + 1, L):
        both = used[a] & used[b]
        pairs.append(np.stack([own[a][both], own[b][both]], 1))
pairs = np.concatenate(pairs)
pairs = np.unique(np.sort(pairs, 1), axis=0)
roots = np.unique(comp)
index = -np.ones(n + 1, np.int64)
index[roots] = np.arange(len(roots))
a, b = index[pairs[:, 0]], index[pairs[:, 1]]
order = np.argsort(np.concatenate([a, b]), kind="stable")
src = np.concatenate([a, b])[order]
dst = np.concatenate([b, a])[order]
start = np.searchsorted(src, np.arange(len(roots) + 1))
colour = -np.ones(len(roots), np.int64)
deg = start[1:] - start[:-1]
for v in np.argsort(-deg, kind="stable"):
    taken = set(colour[dst[start[v]:start[v + 1]]].tolist())
    k = 0
    while k in taken:
        k += 1
    colour[v] = k
colours = int(colour.max()) + 1
Scol = np.repeat(colour[index[comp]][:, None], 4, 1)
Scol = np.minimum(Scol, L - 1)  # (timing only: a colouring past the grid layers is clamped)

E = 16


def pack(s):
    return (s[:, 0] | (s[:, 1] << 8) | (s[:, 2] << 16) | (s[:, 3] << 24)).astype(np.int32)


dev = DEV
bx = wp.array(c[:, 0].astype(np.int32), dtype=wp.int32, device=dev)
by = wp.array(c[:, 1].astype(np.int32), dtype=wp.int32, device=dev)
layers = {"plain": pack(np.zeros_like(S)), "slab": pack(S), "hybrid": pack(S), "colour": pack(Scol)}
slab = wp.ones((L * R, C), dtype=wp.vec2, device=dev)
slab_m = wp.zeros((L * R, C), dtype=wp.float32, device=dev)
dense = wp.ones((R, C), dtype=wp.vec2, device=dev)
dense_m = wp.zeros((R, C), dtype=wp.float32, device=dev)
extra = wp.ones(R * C * E, dtype=wp.vec2, device=dev)
extra_m = wp.zeros(R * C * E, dtype=wp.float32, device=dev)
out = wp.zeros(n, dtype=wp.vec2, device=dev)


@wp.kernel
def gather_slab(bx: wp.array(dtype=wp.int32), by: wp.array(dtype=wp.int32), packed: wp.array(dtype=wp.int32),
                slab: wp.array2d(dtype=wp.vec2), rows: int, out: wp.array(dtype=wp.vec2)):
    p = wp.tid()
    w = packed[p]
    v = wp.vec2()
    for k in range(4):
        s = (w >> (8 * k)) & 255
        v += slab[s * rows + bx[p] + k // 2, by[p] + k % 2]
    out[p] = v


@wp.kernel
def gather_hybrid(bx: wp.array(dtype=wp.int32), by: wp.array(dtype=wp.int32), packed: wp.array(dtype=wp.int32),
                  dense: wp.array2d(dtype=wp.vec2), extra: wp.array(dtype=wp.vec2), cols: int,
                  out: wp.array(dtype=wp.vec2)):
    p = wp.tid()
    w = packed[p]
    v = wp.vec2()
    for k in range(4):
        s = (w >> (8 * k)) & 255
        i = bx[p] + k // 2
        j = by[p] + k % 2
        if s == 0:
            v += dense[i, j]
        else:
            v += extra[(i * cols + j) * 16 + s - 1]
    out[p] = v


@wp.kernel
def scatter_slab(bx: wp.array(dtype=wp.int32), by: wp.array(dtype=wp.int32), packed: wp.array(dtype=wp.int32),
                 slab: wp.array2d(dtype=wp.vec2), slab_m: wp.array2d(dtype=wp.float32), rows: int):
    p = wp.tid()
    w = packed[p]
    for k in range(4):
        s = (w >> (8 * k)) & 255
        r = s * rows + bx[p] + k // 2
        j = by[p] + k % 2
        wp.atomic_add(slab_m, r, j, 0.25)
        wp.atomic_add(slab, r, j, wp.vec2(0.25, 0.5))


@wp.kernel
def scatter_hybrid(bx: wp.array(dtype=wp.int32), by: wp.array(dtype=wp.int32), packed: wp.array(dtype=wp.int32),
                   dense: wp.array2d(dtype=wp.vec2), dense_m: wp.array2d(dtype=wp.float32),
                   extra: wp.array(dtype=wp.vec2), extra_m: wp.array(dtype=wp.float32), cols: int):
    p = wp.tid()
    w = packed[p]
    for k in range(4):
        s = (w >> (8 * k)) & 255
        i = bx[p] + k // 2
        j = by[p] + k % 2
        if s == 0:
            wp.atomic_add(dense_m, i, j, 0.25)
            wp.atomic_add(dense, i, j, wp.vec2(0.25, 0.5))
        else:
            e = (i * cols + j) * 16 + s - 1
            wp.atomic_add(extra_m, e, 0.25)
            wp.atomic_add(extra, e, wp.vec2(0.25, 0.5))


def timed(kernel, inputs, reps=50):
    wp.launch(kernel, n, inputs=inputs, device=dev)
    wp.synchronize()
    t = time.perf_counter()
    for _ in range(reps):
        wp.launch(kernel, n, inputs=inputs, device=dev)
    wp.synchronize()
    return (time.perf_counter() - t) / reps * 1e6


for name, pk in layers.items():
    packed = wp.array(pk, dtype=wp.int32, device=dev)
    if name == "hybrid":
        g = timed(gather_hybrid, [bx, by, packed, dense, extra, C, out])
        s = timed(scatter_hybrid, [bx, by, packed, dense, dense_m, extra, extra_m, C])
    else:
        g = timed(gather_slab, [bx, by, packed, slab, R, out])
        s = timed(scatter_slab, [bx, by, packed, slab, slab_m, R])
    print(json.dumps(dict(case="dispersed-cloud", device=str(dev), size=n, layout=name, gather_us=g, scatter_us=s,
                          components=len(roots), colours=colours, max_layer=int(S.max()), unfound=unfound)))
