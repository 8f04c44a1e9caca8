"""Built-in studies (``mpmdem study NAME``), one module each defining ``STUDY = Study(...)``.

To add one: write ``mpmdem/studies/<module>.py`` with a ``STUDY`` (and, if wanted, the function its
``analyze`` names), then list it here.
"""

from __future__ import annotations

import importlib

#: study name → module name, in the order the usage text lists them
STUDIES = {
    "disk-restitution": "disk_restitution",
}


def study_by_name(name: str):
    """The ``Study`` of a built-in study."""
    return importlib.import_module(f"mpmdem.studies.{STUDIES[name]}").STUDY
