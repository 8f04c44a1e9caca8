"""mpmdem: granular MPM meeting spheropolygon DEM in 2D plane strain, on NVIDIA Warp.

Everything a case script needs: ``Scene`` → ``Simulation(scene, SolverConfig(...))`` → ``run()``.
"""

__version__ = "0.1.0"

import warp as _wp

# module-load timings and the init banner are noise for users; warnings and errors still show
if hasattr(_wp, "LOG_WARNING"):
    _wp.config.log_level = _wp.LOG_WARNING
else:  # older Warp
    _wp.config.quiet = True

from .config import SHAPE_FUNCTIONS, STRESS_UPDATES, TRANSFER_SCHEMES, SolverConfig, TransferScheme
from .errors import BlowUpError, InputError
from .materials import LinearElastic, Material, NeoHookean
from .scene import Boundary, MPMBody, Scene
from .shapes import Shape, disk, polygon, rectangle, seed_points
from .simulation import RunResult, Simulation, default_device

__all__ = [
    "SHAPE_FUNCTIONS",
    "STRESS_UPDATES",
    "TRANSFER_SCHEMES",
    "BlowUpError",
    "Boundary",
    "InputError",
    "LinearElastic",
    "MPMBody",
    "Material",
    "NeoHookean",
    "RunResult",
    "Scene",
    "Shape",
    "Simulation",
    "SolverConfig",
    "TransferScheme",
    "default_device",
    "disk",
    "polygon",
    "rectangle",
    "seed_points",
]
