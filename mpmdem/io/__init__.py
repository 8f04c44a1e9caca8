"""Run files: the format (``format``), the HDF5 frame writer (``writer``; ``background`` runs its
frames in a worker thread), its XDMF sidecars (``xdmf``) and CSV energy log (``csv``), and the
reader (``reader``).

The layout of a run file is described in ``mpmdem.io.format``.
"""

from .background import BackgroundFrameWriter
from .format import (
    BODY_GEOMETRY_KEYS,
    FORMAT,
    MOTION_FIXED,
    MOTION_FREE,
    MOTION_KINEMATIC,
    default_body_field_specs,
    default_field_specs,
)
from .reader import RunFile
from .writer import FrameWriter

__all__ = ["BODY_GEOMETRY_KEYS", "FORMAT", "MOTION_FIXED", "MOTION_FREE", "MOTION_KINEMATIC", "BackgroundFrameWriter",
           "FrameWriter",
           "RunFile", "default_body_field_specs", "default_field_specs"]
