"""Large coupled scenes sift the listed points before the IMP force search (``kernels.imp_sift``).

The sift ends the contacts of listed points that no body can reach this step (outside every
listed body's bounding circle) and packs the rest for the force kernel, which then searches only
those. It must change nothing a scene computes: on the CPU (points sifted in list order, so the
bodies' reactions are summed in the same order) the trajectory, the contact forces and the
bodies' motion are the same bits as with the unsifted force kernel. Reference: the unsifted
kernel, itself tested against the brute-force lists and contact laws in tests/sim/test_coupling.py.
"""

import numpy as np
import pytest

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle


def disk_onto_a_spinning_square(device, tuning=None):
    """A frictional, oblique disk–square impact (contacts made, held with history, and ended)."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.3, 0.45), radius=0.08), mat, points_per_cell=2, velocity=(2.0, 0.3))
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.01), density=1000.0, position=(0.55, 0.55), angle=0.3,
                         friction=0.5)
    return m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device=device, tuning=tuning)


def run(device, tuning=None):
    sim = disk_onto_a_spinning_square(device, tuning)
    sim.advance_to(0.1)  # contact from ~0.05 s to ~0.08 s: made, held and ended
    return sim, sim.fields(), sim.body_fields(), sim.diagnostics()


def test_sifted_force_search_changes_nothing(device):
    """Verify the sifted IMP forces give the unsifted run's trajectory (the same bits on the CPU)."""
    plain, fields, bodies, diag = run(device)
    assert not plain.coupling.sifted  # a small scene: the force kernel over every listed point
    sifted, s_fields, s_bodies, s_diag = run(device, m.Tuning(sifted_imp_points=0))
    assert sifted.coupling.sifted
    assert diag["work_imp_friction"] < -0.01  # the contact slid: history was made and used
    if device == "cpu":
        for name in ("x", "v", "contact_force"):
            np.testing.assert_array_equal(s_fields[name], fields[name], err_msg=name)
        for name in ("x", "v", "omega"):
            np.testing.assert_array_equal(s_bodies[name], bodies[name], err_msg=name)
        assert s_diag["work_imp_friction"] == diag["work_imp_friction"]
    else:
        # GPU atomics sum the reactions in another order in every run (sifted or not): f64
        # round-off, grown through one contact, stays far below 1e-6 m (5e-5 of a cell)
        np.testing.assert_allclose(s_fields["x"], fields["x"], rtol=0, atol=1e-6)
        np.testing.assert_allclose(s_bodies["omega"], bodies["omega"], rtol=1e-6)
        assert s_diag["work_imp_friction"] == pytest.approx(diag["work_imp_friction"], rel=1e-6)


# -- the sift's reach test against the force kernel's feature search ----------------------------

def _cores():
    """CCW cores: a convex pentagon, a non-convex L, a star-shaped dart (a kernel inside), a rod, a vertex."""
    ang = np.pi / 2 + 2 * np.pi * np.arange(5) / 5
    pentagon = np.c_[np.cos(ang), np.sin(ang)]
    ell = np.array([[0, 0], [2, 0], [2, 0.6], [0.6, 0.6], [0.6, 2], [0, 2]], float) - 0.8
    dart = np.array([[0, -1], [1.2, 1.0], [0, 0.2], [-1.2, 1.0]], float)
    rod = np.array([[-1.0, -0.3], [1.0, 0.4]])
    return [pentagon, ell, dart, rod, np.zeros((1, 2))]


def _outline_distance(x, core):
    """Distance of each point of x to the outline (segments) of a core, in numpy."""
    if len(core) == 1:
        return np.linalg.norm(x - core[0], axis=1)
    d = np.full(len(x), np.inf)
    for a, b in zip(core, np.roll(core, -1, axis=0), strict=True):
        e = b - a
        s = np.clip(((x - a) @ e) / (e @ e), 0.0, 1.0)
        d = np.minimum(d, np.linalg.norm(x - (a + s[:, None] * e), axis=1))
    return d


@pytest.mark.parametrize(("precision", "offset"), [("f64", 1e-9), ("f32", 3e-6)])
def test_reach_test_never_drops_a_touch_and_drops_the_far_points(precision, offset):
    """Verify ``within_reach`` (the sift's test) is True wherever the force kernel's feature search
    finds a touch, and False for points farther than reach + margin from a core's outline and
    outside it: random points and points set just inside and outside reach along every edge's
    normal and around every vertex, around convex, non-convex, rod and one-vertex cores, with the
    sift's margin 1e-5 (reach + |x| + core radius). Reference: the outline distance in numpy; the
    search is the one ``forces`` runs."""
    import warp as wp

    from mpmdem.kernels.contact_geometry import make_contact_geometry
    from mpmdem.kernels.types import scalar_types

    g = make_contact_geometry(precision)
    t = scalar_types(precision)
    T, vec2 = t.scalar, t.vec2

    @wp.kernel
    def probe(x: wp.array(dtype=vec2), world: wp.array(dtype=vec2), count: int, reach: T, core_radius: T,
              touch: wp.array(dtype=wp.int32), near: wp.array(dtype=wp.int32)):
        i = wp.tid()
        X = x[i]
        n_edges = g.edge_count(count)
        inside = count >= 3
        best_d = T(-1.0e30)
        best_f = int(-1)  # noqa: UP018 (a Warp variable the loop reassigns)
        best_n = vec2()
        for f in range(n_edges + count + 1):
            hit, N, d, key, inside, best_d, best_f, best_n = g.vertex_feature(
                X, world, 0, count, f, n_edges, count, reach, 0, 1, 0, inside, best_d, best_f, best_n)
            if hit:
                touch[i] = 1
        if g.within_reach(X, world, 0, count, reach, T(1.0e-5) * (reach + wp.length(X) + core_radius)):
            near[i] = 1

    rng = np.random.default_rng(7)
    reach = 0.3
    dtype = np.float32 if precision == "f32" else np.float64
    for core in _cores():
        pts = [rng.uniform(-2.5, 2.5, (20000, 2))]
        for a, b in zip(core, np.roll(core, -1, axis=0), strict=True):
            e = b - a
            if e @ e > 0:
                nrm = np.array([e[1], -e[0]]) / np.linalg.norm(e)
                s = rng.uniform(0, 1, 400)[:, None]
                for off in (reach - offset, reach + offset, -offset, offset):
                    pts.append(a + s * e + off * nrm)
            phi = rng.uniform(0, 2 * np.pi, 400)
            for rad in (reach - offset, reach + offset):
                pts.append(a + rad * np.c_[np.cos(phi), np.sin(phi)])
        x = np.vstack(pts).astype(dtype)
        core = core.astype(dtype)
        radius = float(np.linalg.norm(core, axis=1).max())
        touch = wp.zeros(len(x), dtype=wp.int32, device="cpu")
        near = wp.zeros(len(x), dtype=wp.int32, device="cpu")
        xs, cores = wp.array(x, dtype=vec2, device="cpu"), wp.array(core, dtype=vec2, device="cpu")
        wp.launch(probe, len(x), inputs=[xs, cores, len(core), reach, radius, touch, near], device="cpu")
        touch, near = touch.numpy().astype(bool), near.numpy().astype(bool)
        assert touch.sum() > 500, len(core)
        np.testing.assert_array_equal(touch & ~near, False, err_msg=f"a touch dropped, core of {len(core)} vertices")
        # far: beyond reach + margin of the outline and more than the margin beyond an edge line
        x, core = x.astype(float), core.astype(float)
        margin = 1e-5 * (reach + np.linalg.norm(x, axis=1) + radius)
        gap = _outline_distance(x, core)
        behind_all = np.ones(len(x), bool) if len(core) >= 3 else np.zeros(len(x), bool)
        if len(core) >= 3:
            for a, b in zip(core, np.roll(core, -1, axis=0), strict=True):
                e = b - a
                behind_all &= (x - a) @ np.array([e[1], -e[0]]) / np.linalg.norm(e) <= margin
        far = (gap > (reach + margin) * (1 + 1e-5)) & ~behind_all
        assert far.sum() > 10000
        np.testing.assert_array_equal(near[far], False, err_msg=f"a far point kept, core of {len(core)} vertices")
