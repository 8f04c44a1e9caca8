"""The variant protocol of the cases (mpmdem.study.variants): declared runs, each run by the runner into a
folder of its own, compared by reading their results; the one equal to the case's own run is that run."""

import json
import types

from mpmdem import ContactLaw, Scene, sphero_disk
from mpmdem.study.runner import CaseSetup, run_case
from mpmdem.study.variants import Variant


def _case() -> types.ModuleType:
    """A DEM disk falling for 10 ms, with three variants: the case's own run, a denser disk, and one
    that runs only under --extra."""
    case = types.ModuleType("variant_case")
    case.NAME, case.DESCRIPTION, case.DEFAULTS = "variant-case", "a falling DEM disk", {}
    case.VARIANTS = [Variant("same", args={"density": 1000.0}), Variant("dense", args={"density": 3000.0}),
                     Variant("extra", config={"dem_kappa": 0.05}, flag="extra")]
    compared = {}

    def add_arguments(parser):
        parser.add_argument("--extra", action="store_true")

    def build(args):
        scene = Scene(domain=((-1.0, -1.0), (1.0, 1.0)), gravity=(0.0, -9.81), contact=ContactLaw(1e6))
        scene.add_rigid_body(sphero_disk(0.1), density=getattr(args, "density", 1000.0), position=(0.0, 0.0))
        return CaseSetup(scene, end_time=0.01, frames=2)

    def summarize(sim, result, args):
        return {"mass": float(sim.scene.rigid_bodies[0].mass), "y_end": float(sim.body_fields()["x"][0, 1])}

    def compare(main, runs, args):
        compared.update(runs)
        return {name: {"mass": run.measures["mass"], "is_main": run.is_main} for name, run in runs.items()}

    case.add_arguments, case.build, case.summarize, case.compare = add_arguments, build, summarize, compare
    case.compared = compared
    return case


def test_variants_run_each_into_its_folder_and_are_compared(tmp_path):
    """Verify the enabled variants run as runs of their own (OUT/<name>/ with a run file and a
    summary.json), the one equal to the main run is not run again, a flag gates a variant, and
    compare's dict goes into the main summary."""
    case = _case()
    assert run_case(case, ["--device", "cpu", "--out", str(tmp_path), "--quiet"]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["same"] == {"mass": s["mass"], "is_main": True}
    assert s["dense"]["mass"] == 3.0 * s["mass"] and not s["dense"]["is_main"]
    assert "extra" not in s and not (tmp_path / "extra").exists() and not (tmp_path / "same").exists()
    dense = json.loads((tmp_path / "dense" / "summary.json").read_text())
    assert dense["variant"] == "dense" and dense["status"] == "completed"
    assert (tmp_path / "dense" / "variant_case.h5").is_file() and dense["mass"] == s["dense"]["mass"]
    assert dense["y_end"] < 0.0 and s["y_end"] < 0.0  # both fell
    assert case.compared["same"].path == tmp_path / "variant_case.h5"

    case = _case()
    assert run_case(case, ["--device", "cpu", "--out", str(tmp_path / "x"), "--quiet", "--extra"]) == 0
    s = json.loads((tmp_path / "x" / "summary.json").read_text())
    assert not s["extra"]["is_main"] and (tmp_path / "x" / "extra" / "summary.json").is_file()
    extra = json.loads((tmp_path / "x" / "extra" / "summary.json").read_text())
    assert extra["config"]["dem_kappa"] == 0.05
