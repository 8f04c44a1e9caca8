"""Small scene builders and a case runner shared by the tests."""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from mpmdem import LinearElastic, NeoHookean, Scene, disk


def free_disk_scene(*, cell_size=0.1, velocity=(0.0, 0.0), angular_velocity=0.0, material=None,
                    gravity=(0.0, 0.0), boundaries=None, radius=0.3, center=(1.0, 1.0)):
    """One disk in the middle of a 2 m × 2 m box, far from the walls."""
    scene = Scene(domain=((0.0, 0.0), (2.0, 2.0)), cell_size=cell_size, gravity=gravity,
                  boundaries=boundaries or {})
    scene.add_mpm_body(disk(center=center, radius=radius), material or NeoHookean(1.0e4, 0.3, 1000.0),
                   velocity=velocity, angular_velocity=angular_velocity)
    return scene


def random_velocity(seed=0, scale=0.1):
    """A velocity field function with random point velocities."""
    def field(x):
        return np.random.default_rng(seed).normal(0.0, scale, size=x.shape)
    return field


ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def run_script(name, out, *flags, timeout=600):
    """Run ``cases/<name>.py --quick`` on the CPU as a user would; return its summary.json."""
    cmd = [sys.executable, str(ROOT / "cases" / f"{name}.py"), "--quick", "--quiet", "--device", "cpu",
           "--out", str(out), *flags]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=ENV)
    assert proc.returncode == 0, proc.stderr
    return json.loads((out / "summary.json").read_text())


_QUICK_RUNS: dict[tuple, tuple[dict, Path]] = {}


def quick_run(name, *flags):
    """``run_script(name, folder, *flags)`` once per (name, flags) in a test session: (summary.json,
    folder). The test modules of a case and the in-suite ``mpmdem validate --quick`` share the run."""
    key = (name, tuple(flags))
    if key not in _QUICK_RUNS:
        out = Path(tempfile.mkdtemp(prefix=f"mpmdem-{name}-"))
        _QUICK_RUNS[key] = (run_script(name, out, *flags), out)
    return _QUICK_RUNS[key]


def run_refused(name, out, *flags, timeout=120):
    """Run ``cases/<name>.py --quick`` on the CPU with flags it should refuse; return (exit code, the
    lines of stderr other than Warp's note that there is no CUDA driver)."""
    cmd = [sys.executable, str(ROOT / "cases" / f"{name}.py"), "--quick", "--device", "cpu", "--out", str(out), *flags]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=ENV)
    return proc.returncode, [ln for ln in proc.stderr.strip().splitlines() if "CUDA driver" not in ln]


__all__ = ["ENV", "ROOT", "LinearElastic", "free_disk_scene", "quick_run", "random_velocity", "run_refused",
           "run_script"]
