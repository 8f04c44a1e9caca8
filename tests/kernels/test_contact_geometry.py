"""The pair geometry and pair law of ``kernels.contact_geometry`` (MPM-SDEM eq. 38–44), called from a
test kernel and checked against a brute-force reference: the DEM and the coupling use the same
functions, so this pins both."""

import numpy as np
import shapely
import warp as wp

from mpmdem.kernels.contact_geometry import make_contact_geometry

geometry = make_contact_geometry("f64")
edge_count, vertex_feature = geometry.edge_count, geometry.vertex_feature
contact_point, spring_dashpot = geometry.contact_point, geometry.spring_dashpot
vec2 = wp.types.vector(2, wp.float64)


@wp.kernel(module="unique")
def point_against_core(points: wp.array(dtype=vec2), world: wp.array(dtype=vec2), count: int, reach: wp.float64,
                       hits: wp.array(dtype=wp.int32), normal: wp.array(dtype=vec2), dist: wp.array(dtype=wp.float64),
                       point: wp.array(dtype=vec2)):
    # the feature search of the coupling's forces: a point (a core of one vertex) against a core
    p = wp.tid()
    X = points[p]
    n_edges = edge_count(count)
    inside = count >= 3
    best_d = wp.float64(-1.0e30)
    best_f = int(-1)  # noqa: UP018 (a Warp variable, not a constant)
    best_n = vec2()
    n = int(0)  # noqa: UP018
    for f in range(n_edges + count + 1):
        hit, N, d, feature, inside, best_d, best_f, best_n = vertex_feature(
            X, world, 0, count, f, n_edges, count, reach, 0, 1, 0, inside, best_d, best_f, best_n)
        if hit:
            n += 1
            normal[p] = N
            dist[p] = d
            delta, pc = contact_point(X, N, d, reach, wp.float64(0.05))
            point[p] = pc
    hits[p] = n


@wp.kernel(module="unique")
def pair_law(delta: wp.array(dtype=wp.float64), vel: wp.array(dtype=vec2), force: wp.array(dtype=vec2),
             slip: wp.array(dtype=wp.float64), energy: wp.array(dtype=wp.float64)):
    i = wp.tid()
    F, s, e, lost = spring_dashpot(wp.float64(1.0e6), wp.float64(5.0e5), wp.float64(0.0), wp.float64(0.5), delta[i],
                                   vel[i], vec2(wp.float64(0.0), wp.float64(1.0)), wp.float64(1.0),
                                   wp.float64(0.0), wp.float64(1.0e-3))
    force[i] = F
    slip[i] = s
    energy[i] = e


def test_point_against_a_square_matches_brute_force():
    """Verify a point within reach of a square core touches exactly one feature, at the distance
    and along the normal of the nearest outline point (a point inside: its nearest edge, d < 0)."""
    core = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    reach = 0.2
    x = np.random.default_rng(5).uniform(-0.3, 1.3, (4000, 2))
    n = len(x)
    hits = wp.zeros(n, dtype=wp.int32, device="cpu")
    normal = wp.zeros(n, dtype=vec2, device="cpu")
    dist = wp.zeros(n, dtype=wp.float64, device="cpu")
    point = wp.zeros(n, dtype=vec2, device="cpu")
    wp.launch(point_against_core, n, inputs=[wp.array(x, dtype=vec2, device="cpu"),
                                             wp.array(core, dtype=vec2, device="cpu"), 4, reach,
                                             hits, normal, dist, point], device="cpu")
    hits, normal, dist, point = hits.numpy(), normal.numpy(), dist.numpy(), point.numpy()
    square = shapely.Polygon(core)
    ring = square.exterior
    pts = shapely.points(x)
    inside = shapely.contains(square, pts)
    gap = shapely.distance(ring, pts)
    near = shapely.get_coordinates(shapely.shortest_line(ring, pts))[0::2]
    outside_near = ~inside & (gap < reach)
    assert outside_near.sum() > 500 and inside.sum() > 500
    assert (hits[outside_near] == 1).all() and (hits[inside] == 1).all()
    assert (hits[~inside & (gap >= reach)] == 0).all()
    np.testing.assert_allclose(np.abs(dist), gap * np.where(inside | outside_near, 1.0, 0.0), atol=1e-12)
    assert (dist[inside] < 0.0).all()
    towards = (x - near)[outside_near] / gap[outside_near, None]
    np.testing.assert_allclose(normal[outside_near], towards, atol=1e-9)
    # the contact point sits in the middle of the overlap (eq. 41): a_X − δ/2 behind the point
    delta = reach - dist[outside_near]
    expected = x[outside_near] - (0.05 - 0.5 * delta)[:, None] * normal[outside_near]
    np.testing.assert_allclose(point[outside_near], expected, atol=1e-12)


def test_spring_dashpot_normal_force_and_coulomb_cap():
    """Verify the undamped pair law gives k_n δ along N, the tangential spring k_t v_t dt below
    the Coulomb cap μ k_n δ and the cap above it (eq. 43), and the stored energy ½(k_n δ² + k_t δ_t²)."""
    delta = np.array([1e-4, 1e-4, 2e-4])
    vel = np.array([[0.0, 0.0], [-0.01, 0.0], [-10.0, 0.0]])
    n = len(delta)
    force = wp.zeros(n, dtype=vec2, device="cpu")
    slip = wp.zeros(n, dtype=wp.float64, device="cpu")
    energy = wp.zeros(n, dtype=wp.float64, device="cpu")
    wp.launch(pair_law, n, inputs=[wp.array(delta, dtype=wp.float64, device="cpu"),
                                   wp.array(vel, dtype=vec2, device="cpu"), force, slip, energy], device="cpu")
    force, slip, energy = force.numpy(), slip.numpy(), energy.numpy()
    kn, kt, mu, dt = 1e6, 5e5, 0.5, 1e-3
    np.testing.assert_allclose(force[:, 1], kn * delta, rtol=1e-12)
    # tangent T = (−N_y, N_x) = (−1, 0): v_t = −v_x
    assert force[0, 0] == 0.0
    np.testing.assert_allclose(slip[1], 0.01 * dt, rtol=1e-12)
    np.testing.assert_allclose(force[1, 0], kt * slip[1], rtol=1e-12)  # −k_t δ_t along T = (−1, 0)
    np.testing.assert_allclose(abs(force[2, 0]), mu * kn * delta[2], rtol=1e-12)
    np.testing.assert_allclose(slip[2], mu * kn * delta[2] / kt, rtol=1e-12)
    np.testing.assert_allclose(energy, 0.5 * (kn * delta**2 + kt * slip**2), rtol=1e-12)


@wp.kernel(module="unique")
def outline_distances(points: wp.array(dtype=vec2), world: wp.array(dtype=vec2), count: int,
                      box: wp.array(dtype=wp.float64), outline: wp.array(dtype=wp.float64)):
    p = wp.tid()
    box[p] = geometry.box_distance(points[p], world, 0, count)
    outline[p] = geometry.polygon_distance(points[p], world, 0, count)


def test_box_distance_is_the_bounding_box_distance_and_a_lower_bound():
    """Verify ``box_distance`` (the DEM's cheap test before a large core's outline) is shapely's
    distance to the vertices' bounding box, and never more than the outline distance, which is
    shapely's distance to the boundary: so the test it guards lists the same pairs."""
    rng = np.random.default_rng(11)
    angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, 6))
    core = np.c_[2.0 + 1.5 * np.cos(angles), -1.0 + 0.7 * np.sin(angles)]
    x = rng.uniform(-1.0, 5.0, (3000, 2)) + np.array([0.0, -2.5])
    box = wp.zeros(len(x), dtype=wp.float64)
    outline = wp.zeros(len(x), dtype=wp.float64)
    wp.launch(outline_distances, len(x), inputs=[wp.array(x, dtype=vec2), wp.array(core, dtype=vec2), len(core),
                                                 box, outline])
    points = shapely.points(x)
    ref_box = shapely.distance(shapely.box(*core.min(0), *core.max(0)), points)
    ref_outline = shapely.distance(shapely.Polygon(core).exterior, points)
    np.testing.assert_allclose(box.numpy(), ref_box, rtol=0, atol=1e-12)
    np.testing.assert_allclose(outline.numpy(), ref_outline, rtol=0, atol=1e-12)
    assert np.all(box.numpy() <= outline.numpy())
    assert (ref_box > 0).sum() > 1000 and (ref_box == 0).sum() > 100  # points outside and inside the box
