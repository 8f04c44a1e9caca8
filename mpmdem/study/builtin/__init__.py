"""Built-in studies (``mpmdem study NAME``), each a ``Study`` in a module of this package.

To add one: write ``mpmdem/study/builtin/<module>.py`` with a ``STUDY = Study(...)`` (and, if wanted, the
function its ``analyze`` names), then list it here; a module holding several studies names each as
``"module:ATTRIBUTE"``.
"""

from __future__ import annotations

import importlib

#: study name → "module" (its ``STUDY``) or "module:ATTRIBUTE", in the order the usage text lists them
STUDIES = {
    "beverloo": "beverloo:BEVERLOO",
    "beverloo-methods": "beverloo:METHODS",
    "beverloo-refined": "beverloo:REFINED",
    "beverloo-calibrated": "beverloo:CALIBRATED",
    "beverloo-mu-i": "beverloo:MU_I",
    "beverloo-mu-i-grain": "beverloo:MU_I_GRAIN",
    "beverloo-mu-i-disks": "beverloo:MU_I_DISKS",
    "beverloo-dem": "beverloo:DEM",
    "block-impact": "block_impact:GRIDS",
    "block-impact-coupling": "block_impact:COUPLING",
    "block-impact-rounding": "block_impact:ROUNDING",
    "block-impact-ensemble": "block_impact:ENSEMBLE",
    "block-impact-dem": "block_impact_dem",
    "column-collapse": "column_collapse",
    "column-collapse-mu-i": "column_collapse:MU_I",
    "column-collapse-mu-i-disks": "column_collapse:MU_I_DISKS",
    "column-collapse-dem": "column_collapse_dem",
    "column-collapse-dem-seeds": "column_collapse_dem:SEEDS",
    "column-collapse-dem-heap": "column_collapse_dem:HEAP",
    "column-collapse-dem-polygon": "column_collapse_dem:POLYGON",
    "disk-restitution": "disk_restitution",
    "grain-incline": "grain_incline",
    "grain-incline-polygon": "grain_incline:POLYGON",
}


def study_by_name(name: str):
    """The ``Study`` of a built-in study."""
    module, _, attribute = STUDIES[name].partition(":")
    return getattr(importlib.import_module(f"mpmdem.study.builtin.{module}"), attribute or "STUDY")
