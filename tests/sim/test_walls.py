"""Walls hold material: a fixed, slip or friction side lies exactly where the scene puts it, and no
point ever ends a step beyond it (issue: a silo pile 2.5 mm past a slip wall)."""

import numpy as np
import pytest

from mpmdem import InputError, LinearElastic, MohrCoulomb, Scene, Simulation, SolverConfig, rectangle
from mpmdem.model.boundaries import Boundary

MAT = LinearElastic(1.0e6, 0.3, 1000.0)


@pytest.mark.parametrize("side, domain", [("right", ((0, 0), (0.4, 0.35))), ("top", ((0, 0), (0.35, 0.4)))])
def test_wall_off_the_grid_lines_is_an_error(side, domain):
    """0.4 m is 114.3 cells of 3.5 mm: the grid would put that wall at 0.4025 m, 2.5 mm beyond the
    side the user gave, so the scene refuses it and names both whole-cell alternatives."""
    with pytest.raises(InputError, match=rf"{side} wall on a grid line.*0\.399 or 0\.4025"):
        Scene(domain=domain, cell_size=0.0035)


def test_free_side_may_end_anywhere():
    """A free side has no wall to misplace: the grid simply covers it."""
    s = Scene(domain=((0, 0), (0.4, 0.4)), cell_size=0.0035, boundaries={"right": "free", "top": "free"})
    assert s.cell_counts == (115, 115)


@pytest.mark.parametrize("granular", [False, True])
@pytest.mark.parametrize("wall", ["fixed", "slip", "friction"])
def test_points_never_pass_a_wall(wall, granular, device):
    """Points thrown at the right wall at 60 m/s with a fixed step of three times the Courant bound
    (without the projection onto the wall such a step carries points up to a cell past it) still
    end every step on or inside the wall."""
    from mpmdem import Boundary

    h = 0.01
    mat = MohrCoulomb(1.0e6, 0.3, 1500.0, friction_angle=30.0, critical_density=1485.0) if granular else MAT
    b = Boundary("friction", friction=0.3) if wall == "friction" else wall
    scene = Scene(domain=((0, 0), (0.2, 0.2)), cell_size=h, boundaries={"right": b, "top": "free"})
    scene.add_mpm_body(rectangle(0.15, 0.05, 0.19, 0.09), mat, velocity=(60.0, 0.0), points_per_cell=2)
    c = np.sqrt(1.0e6 * 0.7 / (1.3 * 0.4) / 1500.0) if granular else np.sqrt(1.0e6 * 0.7 / (1.3 * 0.4) / 1000.0)
    dt = 3.0 * h / (c + 60.0)
    sim = Simulation(scene, SolverConfig(granular=granular, transfer="PIC", dt=dt, allow_unstable=True,
                                         blowup_energy_factor=1e9), device=device)
    sim.stage.set_stop_time(1.0)
    for _ in range(12):
        sim.advance(1)
        x = sim.fields()["x"]
        assert np.isfinite(x).all()
        assert x[:, 0].max() <= 0.2, f"a point at x = {x[:, 0].max()!r} beyond the {wall} wall at 0.2 m"



@pytest.mark.parametrize("sides, parameter", [
    ({"bottom": ("slip", 1.0)}, "velocity"),
    ({"bottom": ("fixed", float("nan"))}, "velocity"),
    ({"bottom": ("fixed", 1.0), "left": "slip", "right": "free"}, "boundaries['left']"),
    ({"top": ("fixed", 1.0), "left": "free", "right": "fixed"}, "boundaries['right']"),
])
def test_moving_wall_bad_input(sides, parameter):
    """Verify a wall speed on a non-fixed wall, or a moving wall with a wall beside it, is an InputError."""
    with pytest.raises(InputError, match=parameter.replace("[", r"\[")):
        boundaries = {k: Boundary(v[0], velocity=v[1]) if isinstance(v, tuple) else v for k, v in sides.items()}
        Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.1, boundaries=boundaries)


@pytest.mark.parametrize("side, update, transfer", [("bottom", "USL", "APIC"), ("left", "USL", "APIC"),
                                                    ("right", "MUSL", "FLIP")])
def test_block_on_a_moving_wall_rides_along(side, update, transfer, device):
    """Verify a block moving with a moving no-slip wall (touching it) keeps the wall's velocity exactly."""
    speed = 0.3 if side != "right" else -0.3
    along = np.array([1.0, 0.0]) if side == "bottom" else np.array([0.0, 1.0])
    block = {"bottom": (0.08, 0.0, 0.14, 0.02), "left": (0.0, 0.08, 0.02, 0.14), "right": (0.18, 0.08, 0.2, 0.14)}[side]
    boundaries = {s: "free" for s in ("left", "right", "bottom", "top")}
    boundaries[side] = Boundary("fixed", velocity=speed)
    scene = Scene(domain=((0.0, 0.0), (0.2, 0.2)), cell_size=0.01, boundaries=boundaries)
    scene.add_mpm_body(rectangle(*block), LinearElastic(1.0e5, 0.3, 1000.0), velocity=tuple(speed * along))
    sim = Simulation(scene, SolverConfig(precision="f64", update=update, transfer=transfer), device=device)
    x0 = sim.fields()["x"]
    sim.advance_to(0.1)
    f = sim.fields()
    # a rigid translation at the wall's velocity meets the no-slip condition: the images reflect a
    # uniform U about U to U, so no shear reaches the block (a wall at rest would brake it)
    np.testing.assert_allclose(f["v"], np.tile(speed * along, (len(x0), 1)), atol=1e-9)
    np.testing.assert_allclose(f["x"] - x0, np.tile(0.1 * speed * along, (len(x0), 1)), atol=1e-9)


def test_energy_a_moving_wall_puts_in_is_not_a_blow_up():
    """Verify the blow-up detector books a moving wall's work as driven, not as growth."""
    scene = Scene(domain=((0.0, 0.0), (0.2, 0.1)), cell_size=0.01,
                  boundaries={"bottom": Boundary("fixed", velocity=0.3), "left": "free", "right": "free",
                              "top": "free"})
    scene.add_mpm_body(rectangle(0.05, 0.0, 0.15, 0.03), LinearElastic(1.0e5, 0.3, 1000.0))
    sim = Simulation(scene, SolverConfig(precision="f64"), device="cpu")
    result = sim.run(0.05, frames=5)  # (a scene at rest without gravity: the scale is the wall's work)
    assert result.diagnostics["work_boundary"][-1] > 0.0
