"""MPM–DEM coupling by identified material points (MPM-SDEM §4): point–body lists, the IMP
force law, action = reaction, and the coupled step's inputs."""

import math

import numpy as np
import pytest
import shapely

import mpmdem as m
from mpmdem.model.spheropolygons import random_convex_polygon, rounded_rectangle

FREE = {s: "free" for s in ("left", "right", "bottom", "top")}


def _outline(world, start, count):
    pts = world[start:start + count]
    if count == 1:
        return shapely.Point(pts[0])
    if count == 2:
        return shapely.LineString(pts)
    return shapely.LinearRing(pts)


def test_imp_lists_equal_brute_force(monkeypatch):
    """The cell-binned, body-driven list build finds exactly the (point, body) pairs within
    a_i + r_p + skin of the core outline (eq. 44's gap plus the Verlet skin) of an all-pairs search."""
    # points are scattered through the bodies on purpose (points that have sunk into a body must be
    # listed too): skip the input check that refuses points starting inside a rigid body
    monkeypatch.setattr(m.Scene, "validate", lambda self, **_: [])
    rng = np.random.default_rng(3)
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e5), boundaries=FREE)
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_points(rng.uniform(0.05, 0.95, (3000, 2)), mat, size=0.5 * h, contact_radius=0.6 * h)
    for k in range(12):
        shape = random_convex_polygon(rng, 3 + k % 5, 0.03 + 0.05 * rng.random(), 0.004 + 0.01 * rng.random())
        scene.add_rigid_body(shape, density=1000.0, position=tuple(rng.uniform(0.1, 0.9, 2)),
                             angle=float(rng.uniform(0, 6)), motion="free" if k % 2 else "fixed")
    scene.add_rigid_body(m.sphero_disk(0.05), density=1000.0, position=(0.5, 0.5))
    scene.add_rigid_body(m.rod(0.3, 0.01), density=1000.0, position=(0.3, 0.7), angle=0.4)
    sim = m.Simulation(scene, m.SolverConfig(imp_skin=0.01), device="cpu")
    sim.stage.step()  # the clock has no stop time yet: dt = 0, the lists are built, nothing moves
    cp = sim.coupling
    n, S = sim.particle_count, cp.L.slots
    bodies = cp.L.body.numpy().reshape(n, S)
    count = cp.L.count.numpy()
    x = sim.mpm.P.x.numpy()
    world = sim.dem.world.numpy()
    vstart, vcount = sim.dem.B.vstart.numpy(), sim.dem.B.vcount.numpy()
    radius = sim.dem.B.radius.numpy()
    r_p = cp.L.radius.numpy()
    pts = shapely.points(x)
    expected = np.zeros((n, len(vstart)), bool)
    for b in range(len(vstart)):
        d = shapely.distance(pts, _outline(world, vstart[b], vcount[b]))
        expected[:, b] = d < radius[b] + r_p + cp.skin
    found = np.zeros_like(expected)
    for p in range(n):
        found[p, bodies[p, :count[p]]] = True
    # pairs within 1e-5 m of the cut-off may fall either way in f32: leave them out of the check
    assert expected.sum() > 200
    assert (found == expected).all()
    # each point's bodies are sorted (a fixed summation order, reproducible on GPUs)
    assert all((np.diff(bodies[p, :count[p]]) > 0).all() for p in range(n))


def _one_point_scene(y_point, x_point=0.5, kn=1.0e6):
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(kn, restitution=0.3),
                    boundaries=FREE)
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_points([[x_point, y_point]], mat, size=0.5 * h, contact_radius=0.012)
    # floor: 0.4 × 0.1 centred at (0.5, 0.3), sphero radius 0.005: core top edge y = 0.345, corner x = 0.695
    scene.add_rigid_body(rounded_rectangle(0.4, 0.1, 0.005), density=1000.0, position=(0.5, 0.3), motion="fixed")
    return scene


@pytest.mark.parametrize("where", ["edge", "corner"])
def test_point_resting_on_a_body_gets_kn_overlap(where):
    """A point at rest overlapping the body by δ gets k_n δ along the outward normal of the nearest
    feature (eq. 44, 46): the edge normal on a face, the direction from the corner beyond it; the
    fixed body carries the opposite force."""
    kn, delta = 1.0e6, 0.002  # overlap 2 mm of the reach a + r_p = 17 mm
    reach = 0.005 + 0.012
    if where == "edge":
        x, y = 0.55, 0.345 + reach - delta
        normal = np.array([0.0, 1.0])
    else:
        normal = np.array([1.0, 1.0]) / math.sqrt(2.0)
        x, y = np.array([0.695, 0.345]) + (reach - delta) * normal
    sim = m.Simulation(_one_point_scene(y, x, kn), m.SolverConfig(precision="f64"), device="cpu")
    sim.advance_to(1.0e-7)  # one step: the force of the initial state (v = 0: no damping, no slip)
    f = sim.fields()["contact_force"][0]
    # f64: the force is k_n δ to round-off of the geometry (1e-9 relative)
    np.testing.assert_allclose(f, kn * delta * normal, rtol=1e-9, atol=1e-9 * kn * delta)
    np.testing.assert_allclose(sim.body_fields()["force"][0], -f, rtol=1e-12)


@pytest.mark.parametrize("scheme", ["imp", "grid", "liu"])
def test_frictional_oblique_collision_conserves_momenta(scheme, device):
    """Action = reaction, in each coupling scheme (forces at the point; at the grid node nearest
    the contact point with the body's lever taken at the contact point; Liu et al.'s nodal momentum exchange): an
    elastic MPM disk hits a free, tilted rigid square off-centre with
    friction (no gravity, no walls). Linear momentum of points + body and the total angular
    momentum (points' x × m v plus APIC's spin m (h²/4)(C_yx − C_xy) for quadratic B-splines, plus
    the body's m x × v + I ω) are conserved to round-off (f64)."""
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    boundaries=FREE)
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.3, 0.45), radius=0.08), mat, points_per_cell=2, velocity=(2.0, 0.3))
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.01), density=1000.0, position=(0.55, 0.55), angle=0.3,
                         friction=0.5)
    config = m.SolverConfig(transfer="APIC", shape="bspline2", precision="f64", coupling=scheme)
    sim = m.Simulation(scene, config, device=device)
    P, B = sim.mpm.P, sim.dem.B

    def momenta():
        x, v, mass, C = P.x.numpy(), P.v.numpy(), P.mass.numpy(), P.C.numpy()
        bf = sim.body_fields()
        mb, ib = B.mass.numpy(), B.inertia.numpy()
        p = (mass[:, None] * v).sum(axis=0) + (mb[:, None] * bf["v"]).sum(axis=0)
        ang = (mass * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0])).sum()
        ang += (mass * 0.25 * h * h * (C[:, 1, 0] - C[:, 0, 1])).sum()
        ang += (mb * (bf["x"][:, 0] * bf["v"][:, 1] - bf["x"][:, 1] * bf["v"][:, 0]) + ib * bf["omega"]).sum()
        return p, ang

    p0, l0 = momenta()
    sim.advance_to(0.1)  # contact from ~0.05 s to ~0.08 s
    d = sim.diagnostics()
    if scheme != "liu":  # Liu et al.'s exchange is frictionless
        assert d["work_imp_friction"] < -0.01  # the contact slid: friction did work
    p1, l1 = momenta()
    assert np.abs(sim.body_fields()["omega"]).max() > 1.0  # the square was set spinning
    # round-off of ~1e4 f64 steps over ~500 points: measured 1e-12 (linear), 1e-15 (angular)
    np.testing.assert_allclose(p1, p0, rtol=1e-9)
    # the grid scheme's force acts at a node up to a cell from the contact point q, where the body's
    # lever is taken: angular momentum drifts by that moment arm (well under 2e-3 here)
    assert l1 == pytest.approx(l0, rel=2e-3 if scheme == "grid" else 1e-9)


def test_coupling_inputs_are_checked():
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e6))
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)
    # eq. 45 with 2 x 2 points per cell: h/2 < r_p < h
    with pytest.raises(m.InputError, match=r"contact_radius.*\(0\.01, 0\.02\)"):
        scene.add_mpm_body(m.disk(center=(0.5, 0.5), radius=0.1), mat, contact_radius=0.005)
    with pytest.raises(m.InputError, match="contact_radius"):
        scene.add_mpm_body(m.disk(center=(0.5, 0.5), radius=0.1), mat, contact_radius=0.02)
    body = scene.add_mpm_body(m.disk(center=(0.5, 0.7), radius=0.1), mat)
    assert body.contact_radius == pytest.approx(math.sqrt(0.01 * 0.02))
    floor = scene.add_rigid_body(rounded_rectangle(0.8, 0.1, 0.01), density=1000.0, position=(0.5, 0.2),
                                 motion="fixed")
    with pytest.raises(m.InputError, match="friction"):
        scene.set_coupling_friction(mat, floor, -0.1)
    with pytest.raises(m.InputError, match="rigid_body"):
        scene.set_coupling_friction(mat, "nowhere", 0.3)
    # a fixed dt above the contact bound (a point of 1000 kg/m³ × (h/2)² on k_n) is refused
    bound = 2.0 * math.sqrt(1000.0 * 0.01**2 / 1.0e6) * (math.sqrt(1 + 0.215**2) - 0.215)
    with pytest.raises(m.InputError, match="dt"):
        m.Simulation(scene, m.SolverConfig(dt=2.0 * bound), device="cpu")
    with pytest.raises(m.InputError, match="coupling"):
        m.SolverConfig(coupling="rigid")
    with pytest.raises(m.InputError, match="coupling"):
        m.SolverConfig(coupling="grid", granular=True, transfer="PIC")
    with pytest.raises(m.InputError, match="sort_interval"):
        m.Simulation(scene, m.SolverConfig(sort_interval=10), device="cpu")


def test_granular_pile_rests_on_a_rigid_floor():
    """Granular mode: the contact force of each point enters its component's grid layer (eq. 47
    per layer). A Mohr–Coulomb block (with a critical density) dropped on a fixed spheropolygon
    floor comes to rest on it: no point passes through, and the floor carries the weight."""
    h = 0.01
    scene = m.Scene(domain=((0.0, 0.0), (0.4, 0.3)), cell_size=h, gravity=(0.0, -9.81),
                    contact=m.ContactLaw(1.0e6, restitution=0.2), boundaries=FREE)
    mat = m.MohrCoulomb(2.0e6, 0.3, 2000.0, 35.0, critical_density=1950.0)
    scene.add_mpm_body(m.rectangle(0.15, 0.08, 0.25, 0.14), mat, points_per_cell=2)
    scene.add_rigid_body(rounded_rectangle(0.36, 0.04, 0.005), density=2000.0, position=(0.2, 0.05), motion="fixed")
    config = m.SolverConfig(granular=True, transfer="PIC", shape="bspline2", damping=0.1)
    sim = m.Simulation(scene, config, device="cpu")
    res = sim.run(0.25, frames=5)
    d = res.diagnostics
    weight = 9.81 * d["points_mass"][-1]
    y = sim.fields()["x"][:, 1]
    assert y.min() > 0.07  # floor top 0.07 m; the lowest points hover r_p + a above the core
    assert d["imp_contacts"][-1] >= 8  # the bottom row (10 points wide) touches
    assert d["components"][-1] >= 1
    # the floor's reaction after settling: weight within 5 % (PIC + damping leave a little
    # vibration; the instantaneous force of the last step is read)
    assert -sim.body_fields()["force"][0, 1] == pytest.approx(weight, rel=0.05)


def test_kinematic_paddle_pushes_points_and_keeps_its_motion():
    """A kinematic body takes contact without being integrated: a paddle moving at a prescribed
    0.5 m/s pushes an elastic block (no gravity, no walls). The paddle keeps its velocity, the block
    is carried along, and the energy it gains is the work the paddle did (``work_driven``)."""
    h = 0.02
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    boundaries=FREE)
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.rectangle(0.3, 0.4, 0.4, 0.5), mat)
    scene.add_rigid_body(rounded_rectangle(0.04, 0.16, 0.005), density=1000.0, position=(0.25, 0.45),
                         velocity=(0.5, 0.0), motion="kinematic", friction=0.0)
    sim = m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device="cpu")
    res = sim.run(0.4, frames=4)
    d = res.diagnostics
    bf = sim.body_fields()
    np.testing.assert_allclose(bf["v"][0], [0.5, 0.0], atol=1e-12)  # prescribed, not integrated
    assert bf["x"][0, 0] == pytest.approx(0.25 + 0.5 * sim.time, rel=1e-9)
    assert sim.fields()["v"][:, 0].mean() > 0.3  # carried along
    assert d["work_driven"][-1] > 0.0
    # the paddle's work went into the block's kinetic and strain energy, the contact dashpots, or
    # was lost by the transfers in the repeated impacts (work_numerical = -0.16 x the driven work,
    # measured); no energy appeared from nowhere (0.5 %: the no-gain bound)
    assert d["work_imp_damping"][-1] < 0.0
    assert d["work_numerical"][-1] < 0.005 * d["work_driven"][-1]


def test_points_inside_bodies_and_oversized_bodies_are_refused():
    """Bad scenes are refused before any kernel runs: material points starting inside a rigid body
    (the error names the body and counts the points; added in either order, walls included in the
    check), and a free rigid body larger than the domain. Points touching a body, fixed bodies and
    walls longer than the domain are accepted."""
    h = 0.02
    mat = m.LinearElastic(youngs_modulus=1.0e5, poisson_ratio=0.3, density=1000.0)

    def scene():
        s = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h, contact=m.ContactLaw(1.0e6))
        s.add_walls(("left", "right", "bottom", "top"))
        return s

    # 2 x 2 points per cell: rows at y = 0.305, 0.315, ...; the floor's rounded top is y = 0.35, its
    # sides x = 0.4, 0.6: 5 rows x 20 columns of the block's points are inside it (corners included)
    s = scene()
    s.add_rigid_body(rounded_rectangle(0.2, 0.1, 0.01), density=1000.0, position=(0.5, 0.3), motion="fixed",
                     name="floor")
    s.add_rigid_body(m.sphero_disk(0.03), density=1000.0, position=(0.5, 0.8), name="ball")
    s.add_mpm_body(m.rectangle(0.3, 0.3, 0.7, 0.5), mat, name="block")
    with pytest.raises(m.InputError, match=r"rigid body 'floor'.*100 points of MPM body 'block' start inside it "
                                           r"\(100 points start inside 1 rigid body in all\)"):
        m.Simulation(s, device="cpu")
    # the other order, a free body: the first body with points inside is named, the total counts all
    s = scene()
    s.add_points([[0.1, 0.1], [0.5, 0.8], [0.51, 0.8], [0.5, 0.5]], mat, size=0.5 * h, name="grains")
    s.add_rigid_body(m.sphero_disk(0.03), density=1000.0, position=(0.5, 0.8), name="ball")
    s.add_rigid_body(m.rod(0.2, 0.01), density=1000.0, position=(0.5, 0.5), motion="kinematic", name="paddle")
    with pytest.raises(m.InputError, match=r"rigid body 'ball'.*2 points of MPM body 'grains' start inside it "
                                           r"\(3 points start inside 2 rigid bodies in all\)"):
        s.validate()
    # points touching a body (centre at a + r_p (1 - 1e-3) from the core) or on the walls' faces are fine
    s = scene()
    s.add_rigid_body(m.sphero_disk(0.03), density=1000.0, position=(0.5, 0.5), name="ball")
    touch = (0.03 + 0.012) * (1.0 - 1.0e-3)
    s.add_points([[0.5, 0.5 + touch], [0.5 + touch, 0.5], [0.0, 0.2], [1.0, 1.0]], mat, size=0.5 * h,
                 contact_radius=0.012)
    m.Simulation(s, device="cpu")
    # a free body larger than the domain (bounding box of the rounded body) is refused; fixed ones may be
    s = scene()
    with pytest.raises(m.InputError, match=r"rigid body 'beam' size=\(1\.22, 0\.02\).*no larger than the domain, "
                                           r"1 x 1 m"):
        s.add_rigid_body(m.rod(1.2, 0.01), density=1000.0, position=(0.5, 0.9), name="beam")
    with pytest.raises(m.InputError, match=r"rigid body 'slab' size"):
        s.add_rigid_body(rounded_rectangle(0.5, 1.1, 0.01), density=1000.0, position=(0.5, 0.5), name="slab")
    s.add_rigid_body(m.rod(1.2, 0.01), density=1000.0, position=(0.5, 0.5), angle=math.pi / 4, name="beam")
    s.add_rigid_body(m.rod(1.5, 0.01), density=1000.0, position=(0.5, 0.95), motion="fixed", name="bar")
    assert [b.name for b in s.rigid_bodies] == ["wall_left", "wall_right", "wall_bottom", "wall_top", "beam", "bar"]
