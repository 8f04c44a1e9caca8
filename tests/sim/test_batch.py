"""Batched runs (mpmdem.sim.batch_run): independent worlds tiled along x in one grid.

References: a world of a batch is the same simulation as its lone run, so the lone run is the
reference. World 0 sits at offset 0 on the same grid lines, and its points and contacts meet no
other world (the margin), so on the CPU, with a fixed dt, its outputs are bit for bit the lone
run's (the same operations in the same order). World w > 0 is bit for bit the lone run of its
scene translated by X_w on the batch's grid (the same translation, the grid from the same origin);
against its untranslated lone run, the grid's origin enters x − origin in another rounding, so it
matches to round-off (a relative 1e-9 in f64, far above the ulp-level differences and far below
any physical change).
"""

import dataclasses
import math

import numpy as np
import pytest
import warp as wp

import mpmdem as m
from mpmdem.errors import BlowUpError, InputError
from mpmdem.io.reader import RunFile
from mpmdem.model.config import SolverConfig
from mpmdem.model.spheropolygons import rounded_rectangle
from mpmdem.sim.batch_run import BatchedSimulation
from mpmdem.sim.batch_scene import batch_refusal, combine_scenes
from mpmdem.sim.simulation import Simulation

CONFIG = SolverConfig(precision="f64", dt=2.0e-5)
END, FRAMES = 0.004, 2
#: batch-wide sums (mpmdem.sim.world_diagnostics): not the lone run's
BATCH_WIDE = ("work_plastic", "work_boundary", "work_damping", "work_inflow", "wall_time")


def sand_on_plate(width=0.2, speed=0.0, dx=0.0, left=0.1, box=0.4):
    """A sand block on a fixed spheropolygon plate in a ``box`` × 0.3 m box (coupled: points and a
    body), all moved dx along x."""
    scene = m.Scene(domain=((dx, 0.0), (box + dx, 0.3)), cell_size=0.02, gravity=(0.0, -10.0),
                    contact=m.ContactLaw(1e5, restitution=0.5),
                    boundaries={"left": "slip", "right": "slip", "bottom": "slip", "top": "free"})
    scene.add_mpm_body(m.rectangle(left + dx, 0.08, left + width + dx, 0.16),
                       m.DruckerPrager(1e6, 0.3, 1500.0, friction_angle=30.0), velocity=(speed, 0.0))
    scene.add_rigid_body(rounded_rectangle(0.3, 0.02, 0.005), density=1000.0, position=(0.2 + dx, 0.05),
                         motion="fixed", name="floor")
    scene.add_mass_probe("low", hi=(math.inf, 0.1))
    return scene


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    out = tmp_path_factory.mktemp("batch")
    b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15)], CONFIG, device="cpu")
    results = b.run(END, outs=[out / "w0", out / "w1"], frames=FRAMES, names="sand")
    return b, results, out


def test_world_zero_is_its_lone_run_bit_for_bit(batch, tmp_path):
    b, results, _ = batch
    lone = Simulation(sand_on_plate(), CONFIG, device="cpu")
    ref = lone.run(END, frames=FRAMES, out=tmp_path, name="sand")
    assert results[0].status == "completed"
    for key, values in ref.diagnostics.items():
        if key not in BATCH_WIDE:
            assert np.array_equal(values, results[0].diagnostics[key]), key
    fields, ref_fields = b.view(0).fields(), lone.fields()
    for key, values in ref_fields.items():
        assert np.array_equal(values, fields[key]), key
    np.testing.assert_array_equal(b.view(0).body_fields()["x"], lone.body_fields()["x"])
    # the file: the lone run's datasets, shapes and frame times
    with RunFile(ref.path) as a, RunFile(results[0].path) as c:
        assert a.frame_count == c.frame_count == FRAMES + 1
        np.testing.assert_array_equal(a.times, c.times)
        assert a.fields == c.fields and a.body_fields == c.body_fields
        assert a.particle_count == c.particle_count and a.body_count == c.body_count
        for k in range(a.frame_count):
            for name in a.fields:
                np.testing.assert_array_equal(a.field(name, k), c.field(name, k), err_msg=name)
            for name in a.body_fields:
                np.testing.assert_array_equal(a.body_field(name, k), c.body_field(name, k), err_msg=name)
        assert a.body_geometry()["name"] == c.body_geometry()["name"]
        assert set(a.diagnostics) == set(c.diagnostics)


def test_world_one_matches_its_lone_run_to_round_off(batch):
    b, results, _ = batch
    X = b.worlds[1].offset
    assert X > 0.4 and math.isclose(X / 0.02, round(X / 0.02))  # past world 0's tile, on a grid line
    lone = Simulation(sand_on_plate(0.15, dx=X), CONFIG, device="cpu")
    ref = lone.run(END, frames=FRAMES)
    assert results[1].status == "completed"
    d = results[1].diagnostics
    # the lone run's angular momentum is about the origin X_w to its left
    ref.diagnostics["momentum_angular"] = ref.diagnostics["momentum_angular"] - X * ref.diagnostics["momentum_y"]
    for key in ("energy_kinetic", "energy_strain", "energy_gravity", "mass", "mass_low", "momentum_y",
                "momentum_angular", "energy_contact"):
        # scales: energies against the potential energy in play, momenta against mass × 1 m/s
        scale = np.abs(ref.diagnostics["energy_gravity"]).max() if key.startswith("energy") else (
            ref.diagnostics["mass"][0] * 1.0)
        np.testing.assert_allclose(d[key], ref.diagnostics[key], rtol=0, atol=1e-9 * scale, err_msg=key)
    f, rf = b.view(1).fields(), lone.fields()
    rf["x"][:, 0] -= X
    np.testing.assert_allclose(f["x"], rf["x"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(f["v"], rf["v"], rtol=0, atol=1e-9)  # [m/s], against speeds ~ g t ~ 0.04 m/s


def test_world_one_is_bit_for_bit_alone_in_the_batch_grid(batch):
    """World 1 alone on the batch's grid (translated by X_1 as the batch translates it, on a grid from
    x = 0 as the batch's): bit for bit the batch's world 1, so the other world changes nothing in it."""
    b, results, _ = batch
    X = b.worlds[1].offset
    alone, _ = combine_scenes([sand_on_plate(0.15)], [CONFIG], offsets=[X])
    assert alone.domain == b.combined.domain
    lone = Simulation(alone, CONFIG, device="cpu")
    ref = lone.run(END, frames=FRAMES)
    d = ref.diagnostics
    for prefix in ("points_", "bodies_"):  # about the world's own origin, as the world's output is taken
        d[f"{prefix}momentum_angular"] = d[f"{prefix}momentum_angular"] - X * d[f"{prefix}momentum_y"]
    d["momentum_angular"] = d["points_momentum_angular"] + d["bodies_momentum_angular"]
    for key, values in d.items():
        if key not in BATCH_WIDE:
            assert np.array_equal(values, results[1].diagnostics[key]), key
    f, rf = b.view(1).fields(), lone.fields()
    rf["x"][:, 0] -= X
    for key, values in rf.items():
        assert np.array_equal(values, f[key]), key


def test_a_blow_up_fails_its_world_only(tmp_path):
    """World 1 starts at 1e5 m/s (it leaves its domain in the first frame); world 0 completes as alone."""
    b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15, speed=1.0e5)], SolverConfig(precision="f64"),
                          device="cpu")
    results = b.run(END, outs=[tmp_path / "w0", tmp_path / "w1"], frames=FRAMES, names="sand")
    assert results[0].status == "completed"
    assert results[1].status == "blown-up" and results[1].message.startswith("world 1:")
    with RunFile(results[1].path) as f:
        assert f.status == "blown-up"
    lone = Simulation(sand_on_plate(), SolverConfig(precision="f64"), device="cpu").run(END, frames=FRAMES)
    np.testing.assert_array_equal(results[0].diagnostics["energy_kinetic"], lone.diagnostics["energy_kinetic"])


def test_a_world_reaching_its_side_wall_is_stopped_and_marked(tmp_path):
    """Worlds of different widths (0.4 and 0.38 m) have no walls between their tiles. World 1's sand
    slides right at 20 m/s: within 0.004 s it comes within 4 cells of its right wall, which the
    batch does not model, so the world is stopped (marked for a lone run); world 0 completes bit for
    bit as alone (fixed dt: the restart without world 1 changes nothing in it)."""
    b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15, speed=20.0, box=0.38)], CONFIG, device="cpu")
    assert not b.layout.walls
    results = b.run(END, frames=FRAMES)
    assert results[1].status == "blown-up" and results[1].extra["left_tile"]
    assert "within 4 cells of its left or right wall" in results[1].message
    lone = Simulation(sand_on_plate(), CONFIG, device="cpu").run(END, frames=FRAMES)
    assert results[0].status == "completed"
    np.testing.assert_array_equal(results[0].diagnostics["energy_kinetic"], lone.diagnostics["energy_kinetic"])


def test_runs_that_cannot_share_a_grid_are_refused():
    other = sand_on_plate()
    other.gravity = (0.0, -9.81)
    reason = batch_refusal([sand_on_plate(), other], [CONFIG, CONFIG])
    assert reason.startswith("run 1 differs from run 0 in gravity")
    with pytest.raises(InputError, match="runs that can share one grid: run 1 differs from run 0 in config"):
        combine_scenes([sand_on_plate(), sand_on_plate()], [CONFIG, SolverConfig(precision="f32")])
    # sand against its left wall in a world of another width: no walls between the tiles to hold it
    reason = batch_refusal([sand_on_plate(), sand_on_plate(left=0.0, box=0.42)], [CONFIG, CONFIG])
    assert reason == ("run 1 cannot be a world of a batch: its points start within 4 cells of its left wall "
                      "(a batch of worlds of different widths has no walls between them)")
    # worlds of one width: each tile has its walls
    assert batch_refusal([sand_on_plate(), sand_on_plate(left=0.0)], [CONFIG, CONFIG]) is None


def test_study_batches_runs_of_one_key_and_says_how(tmp_path, capsys):
    """Three frictions of block-on-incline (DEM only, one domain: one batch key) in groups of 2: the
    first two run as one batch, the third alone; each keeps its own row and summary.json. The lone
    runs are the reference (world 0 bit for bit; world 1 to round-off: a relative 1e-9 of the
    acceleration fitted to the block's path)."""
    from mpmdem.study.study import Study, run_study

    study = Study("fr", "block-on-incline", grid={"--friction": [0.1, 0.3, 0.9]},
                  fixed={"--quick": True, "--angle": 30.0})
    alone = run_study(study, tmp_path / "alone", workers=0, device="cpu", progress=False, batch=1)
    batched = run_study(study, tmp_path / "batched", workers=0, device="cpu", progress=True, batch=2)
    assert "3 runs in 2 batch(es) of up to 2 (2, 1 runs; grouped by batch key" in capsys.readouterr().err
    assert [r["status"] for r in batched] == ["completed"] * 3
    assert [(r.get("batch"), r.get("batch_world")) for r in batched] == [
        ("friction=0.1", 0), ("friction=0.1", 1), (None, None)]
    assert batched[0]["acceleration"] == alone[0]["acceleration"]
    assert batched[1]["acceleration"] == pytest.approx(alone[1]["acceleration"], rel=1e-9)
    assert batched[2]["acceleration"] == alone[2]["acceleration"]
    assert (tmp_path / "batched" / "runs" / "friction=0.3" / "summary.json").is_file()


def test_groups_gather_runs_of_one_key():
    """Interleaved keys (a Beverloo grid: orifice × cell size, the cell size sets the key) come
    together, at most ``size`` a group; a run without a key runs alone."""
    from mpmdem.study.batch_worker import group_runs

    runs = list("abcdef")
    assert group_runs(runs, 2, keys=[1, 2, 1, 2, None, 1]) == [["a", "c"], ["f"], ["b", "d"], ["e"]]
    assert group_runs(runs, 4) == [["a", "b", "c", "d"], ["e", "f"]]
    assert group_runs(runs, 1) == [[r] for r in runs]


def test_study_runs_a_world_that_reached_its_wall_again_alone(tmp_path):
    """Sliding blocks in boxes of two widths batched (no walls between the tiles): the two at 20 m/s
    near their right walls in the batch, so the study runs them again alone (the wall then holds
    them); the two at rest keep their batched rows, and every row equals its lone run (the
    reference: world 0 bit for bit, world 1 to round-off, the reruns are lone runs)."""
    from mpmdem.study.study import Study, run_study

    study = Study("slide", "study_sliding_case", grid={"--speed": [0.0, 20.0], "--box": [0.4, 0.38]})
    alone = run_study(study, tmp_path / "alone", workers=0, device="cpu", progress=False, batch=1)
    batched = run_study(study, tmp_path / "batched", workers=0, device="cpu", progress=False, batch=4)
    assert [r["status"] for r in batched] == ["completed"] * 4
    assert [r.get("batch_note") for r in batched] == [None, None] + ["ran alone: it reached its side in the batch"] * 2
    assert [r.get("batch_world") for r in batched[:2]] == [0, 1]
    for a, b in zip(alone, batched, strict=True):
        assert b["right_edge"] == pytest.approx(a["right_edge"], rel=1e-9, abs=1e-12)
        assert b["low_mass"] == pytest.approx(a["low_mass"], rel=1e-9)
    assert [(a["right_edge"], a["low_mass"]) for a in alone[::2]] == [(b["right_edge"], b["low_mass"])
                                                                       for b in batched[::2]]


def test_study_batch_with_walls_holds_a_world_at_its_wall(tmp_path):
    """The same two blocks in boxes of one width: each tile has its world's walls, so the block at
    20 m/s stays in the batch and both rows equal their lone runs (world 0 bit for bit, world 1 to
    round-off), with no lone rerun."""
    from mpmdem.study.study import Study, run_study

    study = Study("slide", "study_sliding_case", grid={"--speed": [0.0, 20.0]})
    alone = run_study(study, tmp_path / "alone", workers=0, device="cpu", progress=False, batch=1)
    batched = run_study(study, tmp_path / "batched", workers=0, device="cpu", progress=False, batch=2)
    assert [r["status"] for r in batched] == ["completed", "completed"]
    assert [(r.get("batch_world"), r.get("batch_note")) for r in batched] == [(0, None), (1, None)]
    assert (alone[0]["right_edge"], alone[0]["low_mass"]) == (batched[0]["right_edge"], batched[0]["low_mass"])
    assert batched[1]["right_edge"] == pytest.approx(alone[1]["right_edge"], rel=1e-9)
    assert batched[1]["low_mass"] == pytest.approx(alone[1]["low_mass"], rel=1e-9)


#: granular mode with quadratic B-splines (the block-impact case's scheme): wall images on every wall
GRANULAR = SolverConfig(precision="f64", dt=2.0e-5, granular=True, shape="bspline2")


@pytest.fixture(scope="module")
def walled(tmp_path_factory):
    """Two worlds of one width, sand against their walls: world 0 against its left wall, world 1
    pressed into its right wall at 5 m/s."""
    scenes = [sand_on_plate(left=0.0), sand_on_plate(0.2, speed=5.0, left=0.2)]
    b = BatchedSimulation(scenes, GRANULAR, device="cpu")
    return b, b.run(END, frames=FRAMES)


def test_walled_tiles_are_the_worlds_lone_grids(walled):
    """Each tile is its world's lone grid and empty rows: tile width at least the lone grid's nodes,
    walls of tile 0 where the lone run has them, world 1 a whole number of tiles along."""
    b, _ = walled
    tiles = b.combined.wall_tiles
    assert b.layout.walls and tiles.count == 2 and tiles.cells == 20
    assert tiles.rows >= 20 + 1 + 2 * 3
    assert b.worlds[1].offset == pytest.approx(tiles.rows * 0.02, rel=1e-12)
    assert b.combined.domain[1][0] == pytest.approx((tiles.rows + 20) * 0.02, rel=1e-12)


def test_walled_world_zero_is_its_lone_run_bit_for_bit(walled):
    """World 0's sand lies against its left wall (wall images, clamp): bit for bit its lone run."""
    b, results = walled
    lone = Simulation(sand_on_plate(left=0.0), GRANULAR, device="cpu")
    ref = lone.run(END, frames=FRAMES)
    assert results[0].status == "completed"
    for key, values in ref.diagnostics.items():
        # (the world's own sums; counters such as list rebuilds and components are the batch's)
        if key.startswith(("energy", "momentum", "mass", "points_", "bodies_", "work_imp")):
            assert np.array_equal(values, results[0].diagnostics[key]), key
    for key, values in lone.fields().items():
        assert np.array_equal(values, b.view(0).fields()[key]), key


def test_walled_world_one_is_held_by_its_own_wall(walled):
    """World 1's sand is pushed into its right wall: its tile's wall holds it as its lone run's does
    (no point past x = 0.4 m in its own coordinates), and it matches that lone run to round-off (the
    scales of test_world_one_matches_its_lone_run_to_round_off)."""
    b, results = walled
    lone = Simulation(sand_on_plate(0.2, speed=5.0, left=0.2), GRANULAR, device="cpu")
    ref = lone.run(END, frames=FRAMES)
    assert results[1].status == "completed"
    f, rf = b.view(1).fields(), lone.fields()
    # (free flight would carry the outer points 2 cm past the wall, to x = 0.415 m)
    assert f["x"][:, 0].max() < 0.4 and rf["x"][:, 0].max() < 0.4
    np.testing.assert_allclose(f["x"], rf["x"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(f["v"], rf["v"], rtol=0, atol=1e-9)
    scale = np.abs(ref.diagnostics["energy_gravity"]).max()
    for key in ("energy_kinetic", "energy_strain", "energy_contact"):
        np.testing.assert_allclose(results[1].diagnostics[key], ref.diagnostics[key], rtol=0, atol=1e-9 * scale,
                                   err_msg=key)


@pytest.mark.parametrize("k", [0, 1])
def test_walled_worlds_works_are_their_own(walled, k):
    """With walls between the tiles each world's works (the grid's: walls, plasticity, damping,
    inflow; the contacts'; the DEM's) and its energy balance are its lone run's, to round-off: each
    tile sums into its own share of the works' slots, in another order than the lone run's (1e-9 of
    world 1's initial kinetic energy, 300 J/m). World 1's sand dissipates a quarter of it in
    plastic work, world 0's (at rest) none: a batch-wide sum fails for both."""
    b, results = walled
    lone = [sand_on_plate(left=0.0), sand_on_plate(0.2, speed=5.0, left=0.2)][k]
    ref = Simulation(lone, GRANULAR, device="cpu").run(END, frames=FRAMES).diagnostics
    d = results[k].diagnostics
    scale = 300.0
    if k == 1:
        assert -ref["work_plastic"][-1] > 0.1 * scale  # (the test can fail: there is plastic work)
    for key in [name for name in ref if name.startswith("work_")]:
        np.testing.assert_allclose(d[key], ref[key], rtol=0, atol=1e-9 * scale, err_msg=key)


def test_walled_world_one_alone_in_the_batch_grid_is_bit_for_bit(walled):
    """World 1 alone on the batch's grid (its tile, tile 0 left empty): bit for bit the batch's
    world 1, so nothing of world 0 reaches it across the walls."""
    b, results = walled
    alone, layout = combine_scenes([sand_on_plate(0.2, speed=5.0, left=0.2)], [GRANULAR],
                                   offsets=[b.worlds[1].offset])
    assert alone.wall_tiles == b.combined.wall_tiles and alone.domain == b.combined.domain
    sim = Simulation(alone, GRANULAR, device="cpu")
    sim.run(END, frames=FRAMES)
    rf = sim.fields()
    f = b.view(1).fields()
    rf["x"][:, 0] -= b.worlds[1].offset
    for key, values in rf.items():
        assert np.array_equal(values, f[key]), key


def test_walled_offsets_must_sit_on_tiles():
    """A world given an offset off its tile's left wall is refused, naming the tile width."""
    scenes = [sand_on_plate(), sand_on_plate()]
    _, layout = combine_scenes(scenes, [CONFIG, CONFIG])
    with pytest.raises(InputError, match="a whole number of tiles"):
        combine_scenes(scenes, [CONFIG, CONFIG], offsets=[0.0, layout.worlds[1].offset + 0.02])


def test_every_part_of_a_world_moves_with_it():
    """Points, rigid bodies, obstacles (a disk's centre too) and the layout: world 1 is world 0's
    scene moved X_1 along x, on a grid line, its points and bodies after world 0's."""
    scenes = []
    for _ in range(2):
        scene = sand_on_plate()
        scene.add_obstacle(m.disk((0.35, 0.2), 0.02), kind="slip")
        scenes.append(scene)
    combined, layout = combine_scenes(scenes, [CONFIG, CONFIG])
    X = layout.worlds[1].offset
    assert math.isclose(X / 0.02, round(X / 0.02)) and X >= 0.4 + layout.margin * 0.02 - 1e-12
    assert combined.obstacles[1].shape._circle() == ((0.35 + X, 0.2), 0.02)
    assert combined.rigid_bodies[1].position == (0.2 + X, 0.05)
    n = layout.worlds[0].points.stop
    x = combined.particles()["x"]
    np.testing.assert_allclose(x[n:, 0] - X, x[:n, 0], rtol=0, atol=1e-12)
    assert layout.world_of_point(n) == 1 and layout.world_of_body(1) == 1


def test_keys_come_from_builds_unless_the_build_simulates(tmp_path):
    """The planner builds each run for its batch key (two speeds of one scene: one key), but not the
    runs whose build settles grains (``costly_build``): those are grouped in grid order."""
    from mpmdem.study.batch_worker import run_keys
    from mpmdem.study.study import Study, plan_runs

    runs = plan_runs(Study("slide", "study_sliding_case", grid={"--speed": [0.0, 1.0]}), "cpu")
    keys = run_keys("study_sliding_case", runs, str(tmp_path))
    assert keys[0] == keys[1] is not None
    dem = plan_runs(Study("dem", "silo-discharge", grid={"--orifice": [0.04, 0.05]}, fixed={"--sand": "dem"}), "cpu")
    assert run_keys("silo-discharge", dem, str(tmp_path)) is None


@pytest.mark.cuda
@pytest.mark.skipif(not wp.get_cuda_device_count(), reason="no CUDA device here: the CUDA items run on the GPU "
                    "machine (pytest -m cuda)")
def test_batch_on_cuda_matches_lone_runs():
    """On a GPU (f32, CUDA graphs): each world of a batch against its lone run. GPU atomics sum in no
    fixed order, so two lone runs differ too: f32 round-off (1e-7) grown over 200 steps of a
    dissipative flow; 1e-4 of the potential energy in play and of the mass bounds that."""
    kinds = {"plain": (SolverConfig(precision="f32", dt=2.0e-5), [{}, {"width": 0.15}]),
             # granular, B-splines, sand against the walls of both tiles (test_walled_*)
             "walled": (SolverConfig(precision="f32", dt=2.0e-5, granular=True, shape="bspline2"),
                        [{"left": 0.0}, {"width": 0.2, "speed": 5.0, "left": 0.2}])}
    for name, (config, worlds) in kinds.items():
        b = BatchedSimulation([sand_on_plate(**w) for w in worlds], config, device="cuda")
        assert b.layout.walls
        results = b.run(END, frames=FRAMES)
        for k, world in enumerate(worlds):
            ref = Simulation(sand_on_plate(**world), config, device="cuda").run(END, frames=FRAMES).diagnostics
            d = results[k].diagnostics
            assert results[k].status == "completed", (name, results[k].message)
            scale = np.abs(ref["energy_gravity"]).max()
            for key in ("energy_kinetic", "energy_strain", "energy_gravity", "energy_contact"):
                np.testing.assert_allclose(d[key], ref[key], rtol=0, atol=1e-4 * scale, err_msg=f"{name} {key}")
            np.testing.assert_allclose(d["mass_low"], ref["mass_low"], rtol=0, atol=1e-4 * ref["mass"][0])


def test_a_failure_of_the_whole_batch_marks_every_world_for_a_lone_run(tmp_path):
    """A check no point can be traced to a world (here the point–body search's cells overflow: at
    most 1 point a cell) fails every world, each marked ``batch_wide`` so that a study runs it again
    alone to find which world it was; the lone run of the same scene fails the same check."""
    config = SolverConfig(precision="f64", dt=2.0e-5, imp_cell_capacity=1)
    b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15)], config, device="cpu")
    results = b.run(END, outs=[tmp_path / "w0", tmp_path / "w1"], frames=FRAMES, names="sand")
    assert [r.status for r in results] == ["blown-up", "blown-up"]
    assert all(r.extra["batch_wide"] and not r.extra["left_tile"] for r in results)
    assert results[1].message.startswith("the batch of 2 worlds (world 1 is one): ")
    assert "point–body search" in results[0].message
    with RunFile(results[1].path) as f:
        assert f.status == "blown-up"
    with pytest.raises(BlowUpError, match="point–body search"):
        Simulation(sand_on_plate(), config, device="cpu").run(END, frames=FRAMES)


def test_study_runs_the_worlds_of_a_failed_batch_again_alone(tmp_path):
    """A batch that fails a check of the whole batch (no world named) does not end its runs: each is
    run again alone, and its row is then the lone run's (here the same check fails alone too, and
    says so)."""
    from mpmdem.study.study import Study, run_study

    study = Study("overflow", "study_sliding_case", grid={"--speed": [0.0, 0.5]}, fixed={"--cell-capacity": 1})
    rows = run_study(study, tmp_path / "batched", workers=0, device="cpu", progress=False, batch=2)
    assert [r["status"] for r in rows] == ["blown-up", "blown-up"]
    for row in rows:
        assert row["batch_note"] == "ran alone: the batch failed in a check no world could be named for"
        assert "point–body search" in row["message"] and not row["message"].startswith("the batch")


def test_dem_worlds_works_are_their_own():
    """Two blocks sliding down a 30° incline (DEM only) at μ = 0.1 and 0.3, batched: each world's
    contact works (friction, damping) are its lone run's to round-off (host sums over its bodies'
    slots; 1e-9 of the friction work, 11 and 19 J/m: the batch's sum, 30 J/m, fails both)."""
    from mpmdem.study.case import load_case
    from mpmdem.study.runner import config_from_args, make_case_parser

    module = load_case("block-on-incline")
    setups = []
    for mu in (0.1, 0.3):
        args = make_case_parser(module).parse_args(["--quick", "--friction", str(mu), "--angle", "30", "--quiet"])
        setup = module.build(args)
        setups.append((setup.scene, config_from_args(setup, module, args)))
    end = 0.4
    results = BatchedSimulation([s for s, _ in setups], setups[0][1], device="cpu").run(end, frames=4)
    for k, (scene, config) in enumerate(setups):
        ref = Simulation(scene, config, device="cpu").run(end, frames=4).diagnostics
        assert -ref["work_contact_friction"][-1] > 5.0
        for key in ("work_contact_friction", "work_contact_damping", "work_driven", "work_numerical"):
            np.testing.assert_allclose(results[k].diagnostics[key], ref[key], rtol=0,
                                       atol=1e-9 * abs(ref["work_contact_friction"][-1]), err_msg=key)


def test_walled_worlds_obstacle_forces_and_damping_are_their_own():
    """Two blocks (0.2 and 0.1 m wide) settling on a ledge obstacle under Cundall damping, batched
    with walls: each world's force on its obstacle and its damping work are its lone run's to
    round-off (each tile sums into its own share of the slots; 1e-9 of the weight and of the
    potential energy in play), where the batch's sums would be the two worlds' together."""
    config = SolverConfig(precision="f64", transfer="PIC", damping=0.1, shape="linear", dt=2.0e-4)

    def block(width):
        scene = m.Scene(domain=((0.0, 0.0), (0.4, 0.4)), cell_size=0.02, gravity=(0.0, -9.81))
        scene.add_obstacle(m.rectangle(-0.1, -0.1, 0.5, 0.1))
        scene.add_mpm_body(m.rectangle(0.1, 0.1, 0.1 + width, 0.2),
                           m.MohrCoulomb(1.0e6, 0.3, 1000.0, 30.0, cohesion=5.0e3, critical_density=990.0),
                           points_per_cell=2)
        return scene

    end = 0.04
    results = BatchedSimulation([block(0.2), block(0.1)], config, device="cpu").run(end, frames=4)
    for k, width in enumerate((0.2, 0.1)):
        ref = Simulation(block(width), config, device="cpu").run(end, frames=4).diagnostics
        d = results[k].diagnostics
        weight = 1000.0 * width * 0.1 * 9.81
        assert -ref["force_obstacles_y"][-1] > 0.5 * weight  # (the ledge carries the block)
        np.testing.assert_allclose(d["force_obstacles_y"], ref["force_obstacles_y"], rtol=0, atol=1e-9 * weight)
        np.testing.assert_allclose(d["force_obstacles_x"], ref["force_obstacles_x"], rtol=0, atol=1e-9 * weight)
        assert -ref["work_damping"][-1] > 0.0
        scale = np.abs(ref["energy_gravity"]).max()
        np.testing.assert_allclose(d["work_damping"], ref["work_damping"], rtol=0, atol=1e-9 * scale)


def test_runs_taking_turns_on_a_device_are_their_runs_alone(tmp_path, device):
    """Two runs in two threads, each on its own CUDA stream, taking turns to launch
    (``mpmdem.sim.device_turns``), against the same runs one after the other on the device's stream:
    deterministic mode (ordered atomics) makes a GPU run bit-identical from run to run, so every
    frame of each file is the same bit for bit (the streams change no launch of a run, only what
    runs beside it). On the CPU the turns are the lock alone and the runs interleave the same way."""
    import threading

    from mpmdem.sim.device_turns import DeviceTurns

    config = SolverConfig(precision="f64", dt=2.0e-5, deterministic=True)
    scenes = [sand_on_plate(), sand_on_plate(0.15, speed=0.5)]
    alone = [Simulation(s, config, device=device).run(END, frames=FRAMES, out=tmp_path / f"a{k}", name="sand")
             for k, s in enumerate(scenes)]
    turns = DeviceTurns(device)
    side = [None, None]

    def run(k):
        with turns.turn():
            side[k] = Simulation(scenes[k], config, device=device).run(END, frames=FRAMES, out=tmp_path / f"s{k}",
                                                                       name="sand")

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(turns.seconds) == sorted(t.name for t in threads)
    assert all(parts["held"] > 0.0 for parts in turns.seconds.values())
    for a, s in zip(alone, side, strict=True):
        assert s is not None and s.status == a.status == "completed"
        with RunFile(a.path) as ra, RunFile(s.path) as rs:
            assert ra.frame_count == rs.frame_count == FRAMES + 1
            for frame in range(ra.frame_count):
                for name in ra.fields:
                    assert np.array_equal(ra.field(name, frame), rs.field(name, frame)), (frame, name)
                for name in ra.body_fields:
                    assert np.array_equal(ra.body_field(name, frame), rs.body_field(name, frame)), (frame, name)


@pytest.mark.parametrize("processes", [1, 2])
def test_a_batch_writing_its_frames_in_child_processes_writes_the_same_files(tmp_path, processes):
    """``Tuning(batch_writer_processes=N)``: the two worlds' files, written by one child process or
    one each, hold every dataset of the files the shared writer thread writes, bit for bit (the
    wall times aside), and the same status."""
    import h5py

    from mpmdem.sim.tuning import Tuning

    def files(out, tuning):
        b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15)], CONFIG, device="cpu", tuning=tuning)
        results = b.run(END, outs=[out / "w0", out / "w1"], frames=FRAMES, names="sand")
        assert [r.status for r in results] == ["completed"] * 2
        found = []
        for r in results:
            with h5py.File(r.path, "r") as f:
                names = []
                f.visit(names.append)
                data = {n: f[n][()] for n in names if isinstance(f[n], h5py.Dataset)}
                data["status"] = f.attrs["status"]
            found.append(data)
        return found

    children = Tuning(batch_writer_processes=processes)
    for a, b in zip(files(tmp_path / "thread", None), files(tmp_path / "child", children), strict=True):
        assert a.keys() == b.keys()
        for name in a:
            if not name.endswith(("wall_time", "diagnostic_values")):  # (the table: its columns are the views)
                assert np.array_equal(a[name], b[name]), name


@pytest.mark.parametrize("shape", ["bspline2", "linear"])
def test_a_nan_point_of_one_world_leaves_the_other_worlds_points_alone(shape):
    """A point of world 1 made NaN mid-run (a blow-up beginning there) changes nothing of world 0,
    whose sand lies against its left wall, over the next 600 steps: bit for bit against the same
    batch without it. (The granular search clamps a point's cell into the grid, so a NaN point's
    cell is the grid's first, which is world 0's: what it links there must not reach world 0.)"""

    def world_zero_after(poison: bool) -> dict[str, np.ndarray]:
        config = dataclasses.replace(GRANULAR, shape=shape)
        b = BatchedSimulation([sand_on_plate(left=0.0), sand_on_plate(0.2, left=0.1)], config, device="cpu")
        b.sim.advance(10)
        searched = b.sim.stage.diagnostics()["granular_rebuilds"]
        if poison:
            w1 = b.worlds[1].points
            x = b.sim.mpm.points.x.numpy().copy()
            x[w1.start:w1.start + 3] = np.nan
            b.sim.mpm.points.x.assign(x)
        b.sim.advance(600)
        if poison:  # (the search ran again with the NaN points)
            assert b.sim.stage.diagnostics()["granular_rebuilds"] > searched
        b._fresh_frame()
        return b.point_fields(b.worlds[0])

    clean, poisoned = world_zero_after(False), world_zero_after(True)
    assert clean.keys() == poisoned.keys()
    for name in clean:
        np.testing.assert_array_equal(poisoned[name], clean[name], err_msg=name)


def test_a_frames_host_copies_refuse_a_read_after_the_launch():
    """A batch launches the next frame's first steps before it sums each world's diagnostics from the
    frame's host copies (``HostArrays.seal``): the copies keep the frame's values, and a sum that reads
    an array not copied before the launch would read the device as those steps leave it, so it is
    refused, naming the array."""
    from mpmdem.sim.world_diagnostics import HostArrays

    a = wp.array(np.arange(4.0), dtype=wp.float64, device="cpu")
    host = HostArrays()
    host.prefetch({"a": a})
    host.seal()
    a.fill_(7.0)  # (the launched steps change the device array; on the CPU the read-back was a view of it)
    np.testing.assert_array_equal(host("a", a), np.arange(4.0))  # the frame's values
    with pytest.raises(RuntimeError, match="'b' was not read back before the next steps"):
        host("b", a)


@pytest.mark.parametrize("interval, rewrites", [(0.0, FRAMES + 1), (1e6, 2)])
def test_a_batch_rewrites_its_worlds_sidecars_at_the_tunings_interval(tmp_path, monkeypatch, interval, rewrites):
    """A batch's worlds share one writer, so each world's XDMF sidecars are rewritten at most every
    ``Tuning.batch_sidecar_interval`` seconds (0: after every frame), and once more at the end."""
    from mpmdem.io.writer import FrameWriter

    counts: dict = {}
    real = FrameWriter._write_xdmf

    def counted(self):
        counts[self.path] = counts.get(self.path, 0) + 1
        return real(self)

    monkeypatch.setattr(FrameWriter, "_write_xdmf", counted)
    b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15)], CONFIG, device="cpu",
                          tuning=m.Tuning(batch_sidecar_interval=interval))
    results = b.run(END, outs=[tmp_path / "w0", tmp_path / "w1"], frames=FRAMES, names="sand")
    # (0 s: after each of the FRAMES + 1 frames, and the end has nothing to add; a long interval: after
    # the first frame and at the end)
    assert {r.path: counts[r.path] for r in results} == {r.path: rewrites for r in results}
