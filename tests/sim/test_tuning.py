"""The performance knobs in one frozen object (``mpmdem.Tuning``, issue 47): validated on
construction, passed through ``Simulation`` to every stage, documented field by field.

Whether a knob changes results is tested where its paths are compared (tests/kernels/test_disk_contacts.py,
test_dem_split.py, test_wall_images.py, test_musl_remap.py, test_p2g_rows.py, test_link_lanes.py,
test_node_range_moves.py, test_imp_static_lists.py, test_imp_sift.py, test_block_layout.py,
test_auto_sort.py); here, the object itself.
"""

import ast
import dataclasses
import math

import pytest
from helpers import ROOT, free_disk_scene

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle


@pytest.mark.parametrize("field, value", [
    ("disk_pairs", 1),  # a bool, not a number
    ("mirror_in_g2p", "yes"),
    ("link_lanes", 0),  # at least one thread a point
    ("relink_lanes", 33),  # at most a warp
    ("tiled_p2g_block", 64.0),  # an integer
    ("steps_per_graph", True),  # a bool is not an integer here
    ("split_assemble_registers", 8),  # below any kernel's need
    ("static_imp_devices", "cuda"),  # a tuple of kinds, not a string
    ("row_p2g_devices", ("gpu",)),
    ("auto_sort_drift", math.nan),
    ("auto_sort_drift", 1.5),  # a fraction
    ("large_factor", 0.5),  # a large body is larger than the median
    ("critical_band", 0.0),  # below one quantum (2^-20 cells)
    ("critical_band", 0.3),  # wider than the widest band
    ("conditional_below", 0.6),  # not below inline_above: would switch at every window
    ("writer_switch_interval", -1e-3),  # an interval [s] >= 0
])
def test_bad_values_name_their_field(field, value):
    """Verify a bad value raises InputError naming the field and the value, before anything runs."""
    with pytest.raises(m.InputError) as err:
        m.Tuning(**{field: value})
    assert err.value.name == field and str(err.value).startswith(f"{field}={value!r} is invalid")


def test_defaults_are_valid_frozen_and_normalised():
    """Verify the defaults construct, cannot be assigned, a list of device kinds becomes a tuple,
    and None lets the compiler choose the split search's registers."""
    t = m.Tuning()
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.disk_pairs = False
    assert m.Tuning(row_p2g_devices=["cpu"]).row_p2g_devices == ("cpu",)
    assert m.Tuning(split_assemble_registers=None).split_assemble_registers is None
    assert m.Tuning(disk_pairs=False) != t and m.Tuning(disk_pairs=True) == t


def test_every_field_has_a_docstring_and_a_row_in_the_benchmark_docs():
    """Verify each field of Tuning has its docstring line (what it chooses) and is named in
    docs/benchmarks.md's tuning section (where the measured reasons are)."""
    tree = ast.parse((ROOT / "mpmdem" / "sim" / "tuning.py").read_text())
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Tuning")
    documented = {a.target.id for a, b in zip(cls.body, cls.body[1:], strict=False)
                  if isinstance(a, ast.AnnAssign) and isinstance(b, ast.Expr) and isinstance(b.value, ast.Constant)}
    names = {f.name for f in dataclasses.fields(m.Tuning)}
    assert names - documented == set()
    docs = (ROOT / "docs" / "benchmarks.md").read_text().split("## Tuning constants")[1]
    assert {n for n in names if f"`{n}`" not in docs} == set()


def test_simulation_passes_its_tuning_to_every_stage():
    """Verify the object given to Simulation is the one the MPM, DEM and coupled stages read, the
    default is Tuning(), and anything else is refused."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.05, contact=m.ContactLaw(1.0e6))
    scene.add_mpm_body(m.disk(center=(0.5, 0.5), radius=0.1), m.NeoHookean(1.0e5, 0.3, 1000.0))
    scene.add_rigid_body(rounded_rectangle(0.8, 0.1, 0.01), density=1000.0, position=(0.5, 0.2), motion="fixed")
    tuning = m.Tuning(static_imp_devices=("cpu", "cuda"), steps_per_graph=4)
    sim = m.Simulation(scene, device="cpu", tuning=tuning)
    assert sim.tuning is tuning and sim.mpm.tuning is tuning and sim.dem.tuning is tuning
    assert sim.coupling.tuning is tuning and sim.coupling.static_lists  # (off on a CPU by default)
    assert m.Simulation(free_disk_scene(cell_size=0.05), device="cpu").tuning == m.Tuning()
    with pytest.raises(m.InputError, match="tuning"):
        m.Simulation(free_disk_scene(cell_size=0.05), device="cpu", tuning={"disk_pairs": False})


@pytest.mark.parametrize("batched", [False, True])
def test_frames_are_written_under_the_tunings_switch_interval(tmp_path, batched):
    """Verify a run (lone or batched) that writes its frames steps under the Tuning's
    writer_switch_interval (seen from its progress callback) and restores Python's after; a run
    without files leaves it alone."""
    import sys

    from mpmdem.sim.batch_run import BatchedSimulation

    before = sys.getswitchinterval()
    tuning = m.Tuning(writer_switch_interval=before / 4)
    seen = []

    def progress(t, dt):
        seen.append(sys.getswitchinterval())

    def run(out):
        scene = free_disk_scene(cell_size=0.2)
        if batched:
            b = BatchedSimulation([scene, free_disk_scene(cell_size=0.2)], device="cpu", tuning=tuning)
            b.run(0.002, outs=None if out is None else [out / "a", out / "b"], frames=1, progress=progress)
        else:
            m.Simulation(scene, device="cpu", tuning=tuning).run(0.002, out=out, frames=1, progress=progress)

    run(tmp_path)
    assert seen and seen == pytest.approx([before / 4] * len(seen)) and sys.getswitchinterval() == before
    seen.clear()
    run(None)
    assert seen and set(seen) == {before}
