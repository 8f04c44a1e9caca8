"""mpmdem: granular MPM meeting spheropolygon DEM in 2D plane strain, on NVIDIA Warp.

Everything a case script needs: ``Scene`` → ``Simulation(scene, SolverConfig(...))`` → ``run()``.
"""

__version__ = "0.1.0"

import os as _os

# In a source checkout run without installing (PYTHONPATH=., python -m pytest), the device code in
# ../kernels and the cases in ../cases are not inside this folder; an install maps them to
# mpmdem.kernels and mpmdem.cases (pyproject [tool.setuptools.package-dir]). Let the import
# system find them in the checkout too.
_checkout = _os.path.dirname(_os.path.dirname(_os.path.abspath(__file__)))
if not _os.path.isdir(_os.path.join(__path__[0], "kernels")) and _os.path.isfile(
    _os.path.join(_checkout, "kernels", "transfer.py")
):
    __path__.append(_checkout)

import warp as _wp

# module-load timings and the init banner are noise for users; warnings and errors still show
if hasattr(_wp, "LOG_WARNING"):
    _wp.config.log_level = _wp.LOG_WARNING
else:  # older Warp
    _wp.config.quiet = True

from .errors import BlowUpError, InputError
from .model.bodies import ContactLaw, RigidBody
from .model.config import SHAPE_FUNCTIONS, STRESS_UPDATES, TRANSFER_SCHEMES, SolverConfig, TransferScheme
from .model.finished import Model
from .model.granular_materials import DruckerPrager, MohrCoulomb, MuI
from .model.materials import LinearElastic, Material, NeoHookean
from .model.scene import Boundary, MassProbe, MPMBody, Scene
from .model.shapes import Shape, disk, polygon, rectangle, seed_points
from .model.spheropolygons import (
    Spheropolygon,
    random_convex_polygon,
    regular_polygon,
    rod,
    rounded_rectangle,
    sphero_disk,
    spheropolygon,
    spheropolygon_from_file,
)
from .sim.simulation import RunResult, Simulation, default_device
from .sim.tuning import Tuning

__all__ = [
    "SHAPE_FUNCTIONS",
    "STRESS_UPDATES",
    "TRANSFER_SCHEMES",
    "BlowUpError",
    "Boundary",
    "ContactLaw",
    "DruckerPrager",
    "InputError",
    "LinearElastic",
    "MPMBody",
    "MassProbe",
    "Material",
    "Model",
    "MohrCoulomb",
    "MuI",
    "NeoHookean",
    "RigidBody",
    "RunResult",
    "Scene",
    "Shape",
    "Simulation",
    "SolverConfig",
    "Spheropolygon",
    "TransferScheme",
    "Tuning",
    "default_device",
    "disk",
    "polygon",
    "random_convex_polygon",
    "rectangle",
    "regular_polygon",
    "rod",
    "rounded_rectangle",
    "seed_points",
    "sphero_disk",
    "spheropolygon",
    "spheropolygon_from_file",
]
