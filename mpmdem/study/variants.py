"""Variants of a case: further runs its summary compares, declared as data and run by the runner.

A case module may declare ``VARIANTS``, a list of ``Variant``: each is the case's run again with some
of its flags (``args``, seen by the case's ``build``) and some SolverConfig fields (``config``)
overridden, optionally only when a flag of the case is on (``flag``). After the case's own run
(the "main" run, written to OUT as always), the runner runs every enabled variant as a separate run
into OUT/<variant name>/ (its run file, energy.csv and summary.json, as a run of its own); a variant
that builds the main run's scene with the main run's config, end time and frames is not run again:
it is the main run. The runner then calls the case's ``compare(main, runs, args) -> dict``, which
only reads those results (``VariantRun``: the summary and the run file of each) and whose dict goes
into the main run's summary.json after the case's ``summarize``.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

import numpy as np

from ..errors import BlowUpError
from ..model.config import SolverConfig
from .flag_types import given

__all__ = ["Variant", "VariantRun", "compare_variants", "run_variants"]

#: (setup, case module, flags) → the SolverConfig of a run
Configure = Callable[..., "SolverConfig"]


@dataclass(frozen=True)
class Variant:
    """One further run of a case.

    Attributes:
        name: Its key in the summary and the name of its folder under OUT.
        config: SolverConfig fields set on top of the main run's choices (case defaults, the
            case's build, the user's flags).
        args: Flags of the case set before its ``build`` (attributes of the parsed arguments; a
            name the parser does not know is seen by ``build`` through ``getattr``).
        flag: The case flag that switches the variant on (e.g. "compare"); None: always run.
    """

    name: str
    config: Mapping = field(default_factory=dict)
    args: Mapping = field(default_factory=dict)
    flag: str | None = None

    def enabled(self, args: argparse.Namespace) -> bool:
        """Whether this variant runs with these flags."""
        return self.flag is None or bool(getattr(args, self.flag, False))


@dataclass
class VariantRun:
    """The results of one run that ``compare`` reads.

    Attributes:
        name: The variant's name ("main" for the case's own run when no variant is it).
        path: Its run file (None when it wrote none).
        summary: What its summary.json holds (status, steps, the case's ``summarize``, ...).
        measures: What the case's ``summarize`` returned for it ({} when it blew up).
        args: The flags it ran with.
        is_main: Whether it is the case's own run (written to OUT itself).
    """

    name: str
    path: Path | None
    summary: dict
    measures: dict
    args: argparse.Namespace
    is_main: bool = False


def _scene_key(scene) -> str:
    """What identifies the run of a scene: its description and its material points."""
    digest = hashlib.sha256(json.dumps(scene.to_dict(), sort_keys=True, default=str).encode())
    if scene.has_mpm:
        for k, a in sorted(scene.particles().items()):
            digest.update(k.encode() + np.ascontiguousarray(a).tobytes())
    return digest.hexdigest()


def _variant_args(args: argparse.Namespace, variant: Variant) -> argparse.Namespace:
    vargs = argparse.Namespace(**vars(args))
    for k, v in variant.args.items():
        setattr(vargs, k, v)
    return vargs


def compare_variants(module: ModuleType, args: argparse.Namespace, sim, main: VariantRun, out: Path,
                     end_time: float, frames: int, configure: Configure) -> dict:
    """Run the enabled variants of ``module`` (``run_variants``), then its ``compare``: the entries
    the main run's summary gets."""
    return module.compare(main, run_variants(module, args, sim, main, out, end_time, frames, configure), args)


def run_variants(module: ModuleType, args: argparse.Namespace, sim, main: VariantRun, out: Path, end_time: float,
                 frames: int, configure: Configure) -> dict[str, VariantRun]:
    """Run the enabled variants of ``module`` after its main run ``sim`` (``main``, in the folder
    ``out``, run to ``end_time`` [s] in ``frames`` frames); ``configure(setup, module, args)`` is how
    the runner makes a run's SolverConfig (``mpmdem.study.runner.config_from_args``). Returns name →
    VariantRun, in the order of ``VARIANTS``."""
    from ..sim.simulation import Simulation

    name = module.NAME.replace("-", "_")
    main_key = (_scene_key(sim.scene), sim.config, end_time, frames)
    runs: dict[str, VariantRun] = {}
    for variant in module.VARIANTS:
        if not variant.enabled(args):
            continue
        vargs = _variant_args(args, variant)
        setup = module.build(vargs)
        config = dataclasses.replace(configure(setup, module, vargs), **variant.config)
        v_end = given(vargs.end_time, setup.end_time)
        v_frames = given(vargs.frames, setup.frames)
        key = (_scene_key(setup.scene), config, v_end, v_frames)
        if key == main_key:
            runs[variant.name] = dataclasses.replace(main, name=variant.name, args=vargs)
            continue
        folder = out / variant.name
        folder.mkdir(parents=True, exist_ok=True)
        vsim = Simulation(setup.scene, config, device=sim.device, tuning=sim.tuning)
        summary = {"case": module.NAME, "variant": variant.name, "status": "error", "device": vsim.device,
                   "particles": vsim.particle_count, "bodies": vsim.body_count, "config": config.to_dict(),
                   "end_time": v_end, "frames": v_frames}
        t0 = time.perf_counter()
        try:
            result = vsim.run(v_end, out=folder, frames=v_frames, name=name)
            summary.update(status=result.status, steps=result.steps, wall_seconds=time.perf_counter() - t0,
                           output=str(result.path))
            measures = module.summarize(vsim, result, vargs)
            summary.update(measures)
        except BlowUpError as e:
            measures = {}
            summary.update(status="blown-up", reason=e.reason, message=str(e), time=e.time,
                           output=str(folder / f"{name}.h5"))
        (folder / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
        runs[variant.name] = VariantRun(variant.name, Path(summary["output"]), summary, measures, vargs)
    return runs
