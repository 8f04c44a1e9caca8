"""The ``mpmdem`` command line (``main``): a thin layer over the study layer and ``mpmdem.io``."""

from .commands import main

__all__ = ["main"]
