"""Runnable scenes (imported as ``mpmdem.cases``); each also runs as ``python cases/<name>.py``.

A case module defines NAME, DESCRIPTION, DEFAULTS (SolverConfig fields), ``add_arguments(parser)``
(optional), ``build(args) -> CaseSetup`` and ``summarize(sim, result, args) -> dict``.

A case that compares runs (slope-flow, avalanche, normal-force --all-grids, silo-filling --compare)
declares them as data, ``VARIANTS`` (a list of ``mpmdem.study.variants.Variant``: flags and SolverConfig
fields overridden, optionally only under a flag), and defines ``compare(main, runs, args) -> dict``.
The runner runs each variant as a run of its own into OUT/<variant>/ and ``compare`` only reads
their results (``mpmdem.study.variants.VariantRun``); ``summarize`` starts no simulation.
"""

#: CLI name → module name, in the order ``mpmdem list`` shows them.
CASES = {
    "sulsky-disks": "sulsky_disks",
    "axial-bar": "axial_bar",
    "elastic-column": "elastic_column",
    "bouncing-disk": "bouncing_disk",
    "rotating-disk": "rotating_disk",
    "disk-collision": "disk_collision",
    "block-on-incline": "block_on_incline",
    "pentagon-pile": "pentagon_pile",
    "domino": "domino",
    "disconnection-1d": "disconnection_1d",
    "slope-flow": "slope_flow",
    "avalanche": "avalanche",
    "silo-filling": "silo_filling",
    "toyoura-flume": "toyoura_flume",
    "column-collapse": "column_collapse",
    "momentum-exchange": "momentum_exchange",
    "disk-drop": "disk_drop",
    "normal-force": "normal_force",
    "friction-force": "friction_force",
    "rod-collision": "rod_collision",
    "sand-blocks": "sand_blocks",
    "silo-discharge": "silo_discharge",
    "granular-matrix": "granular_matrix",
    "grain-incline": "grain_incline",
}

DEFAULT_CASE = "silo-discharge"
