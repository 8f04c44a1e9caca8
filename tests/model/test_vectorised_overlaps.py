"""The vectorised initial-overlap search (``rigid_arrays``, ``overlaps.overlap_pairs``) against a
pair-by-pair computation written here: a random pack of disks, rods, triangles, rectangles and
pentagons, free, fixed and kinematic, dense enough that many cores cross."""

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon

from mpmdem import (
    ContactLaw,
    Scene,
    Simulation,
    random_convex_polygon,
    regular_polygon,
    rod,
    rounded_rectangle,
    sphero_disk,
)
from mpmdem.model.overlaps import OVERLAP_FRACTION, body_overlaps, pairs_within
from mpmdem.model.rigid_arrays import rigid_arrays

KN = 1.0e7  # [N/m per m]
GRAVITY = (0.0, -9.81)  # [m/s²]
SIZE = 2.0  # [m] square domain


def random_pack(seed: int = 3, n: int = 160) -> Scene:
    rng = np.random.default_rng(seed)
    scene = Scene(domain=((0.0, 0.0), (SIZE, SIZE)), gravity=GRAVITY, contact=ContactLaw(KN),
                  allow_initial_overlap=True)
    shapes = [sphero_disk(0.06), rod(0.2, 0.02), regular_polygon(3, 0.08, 0.01), rounded_rectangle(0.2, 0.1, 0.01),
              random_convex_polygon(rng, 5, 0.08, 0.01), rounded_rectangle(0.3, 0.05)]
    for _ in range(n):
        shape = shapes[rng.integers(len(shapes))]
        motion = "fixed" if shape.radius == 0.0 else ("free", "free", "fixed", "kinematic")[rng.integers(4)]
        scene.add_rigid_body(shape, density=float(rng.uniform(500.0, 3000.0)), motion=motion,
                             position=tuple(rng.uniform(0.1, SIZE - 0.1, 2)), angle=float(rng.uniform(0.0, 7.0)))
    return scene


def core(body):
    v = body.world_vertices()
    return Point(v[0]) if len(v) == 1 else LineString(v) if len(v) == 2 else Polygon(v)


def vertex_depth(vertex, other, a: float) -> float:
    """a − the vertex's distance to the other core, or a + its distance to the outline when inside."""
    d = other.distance(vertex)
    if d == 0.0 and other.geom_type == "Polygon":
        return a + other.boundary.distance(vertex)
    return a - d


def expected_overlaps(bodies) -> dict[tuple[int, int], float]:
    """{(i, j): depth [m]} pair by pair: a_i + a_j − core distance, or when the cores cross, the
    deepest vertex of either core inside the other."""
    cores = [core(b) for b in bodies]
    out = {}
    for i in range(len(bodies)):
        for j in range(i + 1, len(bodies)):
            if "free" not in (bodies[i].motion, bodies[j].motion):
                continue
            a = bodies[i].shape.radius + bodies[j].shape.radius
            depth = a - cores[i].distance(cores[j])
            if depth >= a:
                for p, q in ((i, j), (j, i)):
                    for v in bodies[p].world_vertices():
                        depth = max(depth, vertex_depth(Point(v), cores[q], a))
            if depth > 0.0:
                out[(i, j)] = depth
    return out


def test_overlaps_match_a_pair_by_pair_computation():
    """Verify every touching pair that can meet (one free body) is found with the depth of the
    pair-by-pair computation, deepest first, none more; that the pack has the cases (1 to 5
    vertices, fixed and kinematic bodies, crossing cores)."""
    bodies = random_pack().rigid_bodies
    expected = expected_overlaps(bodies)
    found = body_overlaps(bodies)
    assert {(o.i, o.j) for o in found} == set(expected)
    for o in found:
        assert o.depth == pytest.approx(expected[(o.i, o.j)], rel=1e-12, abs=1e-15)
    depths = [o.depth for o in found]
    assert depths == sorted(depths, reverse=True)
    a = {(o.i, o.j): bodies[o.i].shape.radius + bodies[o.j].shape.radius for o in found}
    assert sum(o.depth > a[(o.i, o.j)] for o in found) >= 5  # crossing cores with a vertex inside
    assert {len(b.shape.vertices) for b in bodies} == {1, 2, 3, 4, 5}
    assert {b.motion for b in bodies} == {"free", "fixed", "kinematic"}


def test_world_vertices_and_cores_are_those_of_each_body():
    """Verify the columns' world vertices are each body's ``world_vertices`` (the same floats) and
    the cores the shapely points, segments and polygons built from them."""
    bodies = random_pack().rigid_bodies
    arrays = rigid_arrays(bodies)
    for k, b in enumerate(bodies):
        rows = slice(arrays.starts[k], arrays.starts[k] + arrays.counts[k])
        assert np.array_equal(arrays.world[rows], b.world_vertices())
        assert np.array_equal(arrays.local[rows], b.shape.vertices)
        assert shapely.equals_exact(arrays.cores[k], core(b), tolerance=0.0)
    assert np.array_equal(arrays.core_radius, [b.shape.core_radius for b in bodies])
    assert np.array_equal(arrays.mass, [b.mass for b in bodies])


def test_pairs_within_are_those_of_the_dwithin_query():
    """Verify the pairs measured are those, in the order, of an STRtree "dwithin" query of the cores
    (a_i + max a apart; one body free), so the deepest-first order is that query's also among
    equal depths."""
    arrays = rigid_arrays(random_pack().rigid_bodies)
    cores, radius, free = arrays.cores, arrays.radius, arrays.free
    reach = radius + radius.max()
    i, j = shapely.STRtree(cores).query(cores, predicate="dwithin", distance=reach)
    keep = (i < j) & (free[i] | free[j])
    mine_i, mine_j, dist = pairs_within(arrays, reach)
    assert np.array_equal(mine_i, i[keep]) and np.array_equal(mine_j, j[keep])
    assert np.array_equal(dist, shapely.distance(cores[i[keep]], cores[j[keep]]))
    assert len(mine_i) > 200


def test_initial_overlaps_use_the_documented_tolerance_and_reach_the_dem():
    """Verify ``initial_overlaps`` keeps the pairs deeper than round-off + max(1 % of the smaller
    bounding radius, 3 ρ g H 2 r / k_n), that ``validate`` returns them and that the DEM stage of a
    Simulation holds them; a body added afterwards is seen by the next Simulation."""
    scene = random_pack(n=60)
    bodies = scene.rigid_bodies
    g, height, roundoff = math.hypot(*GRAVITY), SIZE, 1e-9 * SIZE
    deep = []
    for (i, j), depth in sorted(expected_overlaps(bodies).items(), key=lambda kv: -kv[1]):
        size = min(bodies[i].shape.bounding_radius, bodies[j].shape.bounding_radius)
        rho = max(b.density for b in (bodies[i], bodies[j]) if b.motion == "free")
        tol = roundoff + max(OVERLAP_FRACTION * size, 3.0 * rho * g * height * 2.0 * size / KN)
        if depth > tol:
            deep.append((bodies[i].name, bodies[j].name))
    overlaps = scene.initial_overlaps()
    assert deep and [(a, b) for a, b, _ in overlaps] == deep
    assert scene.validate() == overlaps
    assert Simulation(scene, device="cpu").dem.initial_overlaps == overlaps
    scene.add_rigid_body(sphero_disk(0.06), density=1000.0, position=bodies[0].position, name="late")
    assert Simulation(scene, device="cpu").dem.initial_overlaps == scene.initial_overlaps() != overlaps
