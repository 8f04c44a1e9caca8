"""The block-impact studies of `sand-blocks` (MPM-SDEM §6 on the experiment's geometry).

``GRIDS``: three grids (2048, 8192 and 12800 points) × both friction sets (Table 3's 0.2, the
reproduction's values). ``COUPLING``: the three coupling schemes on plain MPM (`grid` and `liu` are
refused with Granular MPM, whose `imp` run is in ``GRIDS``). ``ROUNDING``: the blocks' corner
rounding 1, 2 and 3 mm: the events must not depend on it. ``ENSEMBLE``: 16 starts per grid
(``--ensemble-seed`` 1-16: the free blocks moved by up to ±0.5 mm along x, the sand points by up to a
tenth of their spacing), because block 1 tumbles and one run per grid says little; ``--set
ensemble-seed=1,2,...`` changes N. Each writes the event times against the paper under both
readings (first touch, at rest on a face), the final poses, block 2's orientation history and a
speed × accuracy chart, and for several starts per grid the median, spread and pose distribution
(``block_impact_analysis``).
"""

from functools import partial
from pathlib import Path

from mpmdem.study.references.block_impact import ENSEMBLE_STARTS as ENSEMBLE_STARTS_CASE
from mpmdem.study.study import Study

from .block_impact_analysis import analyze
from .run_summaries import load_runs


def analyze_runs(rows: list[dict], out: Path, title: str) -> dict:
    return analyze(load_runs(out), out, title)


GRIDS = Study(
    name="block-impact",
    case="sand-blocks",
    description="block impact at three grids with both friction sets: event times and block 2's orientation",
    grid={"--cell-size": [0.00625, 0.003125, 0.0025], "--friction": ["paper", "reproduction"]},
    analyze=partial(analyze_runs, title="block impact: grids × friction sets"),
)

COUPLING = Study(
    name="block-impact-coupling",
    case="sand-blocks",
    description="block impact with the imp, grid and liu coupling schemes (plain MPM: the latter two are refused "
                "with Granular MPM)",
    grid={"--coupling": ["imp", "grid", "liu"]},
    fixed={"--granular": False},
    analyze=partial(analyze_runs, title="block impact: coupling schemes (plain MPM)"),
)

ROUNDING = Study(
    name="block-impact-rounding",
    case="sand-blocks",
    description="block impact with the blocks' corners rounded by 1, 2 and 3 mm",
    grid={"--sphero-radius": [0.001, 0.002, 0.003]},
    analyze=partial(analyze_runs, title="block impact: corner rounding"),
)

#: the starts of the ensemble (``--ensemble-seed``), as the validation row of block 1 runs them
ENSEMBLE_STARTS = tuple(range(1, ENSEMBLE_STARTS_CASE + 1))

ENSEMBLE = Study(
    name="block-impact-ensemble",
    case="sand-blocks",
    description="block impact at three grids × 16 perturbed starts (blocks ±0.5 mm in x, the sand lattice "
                "jittered): each event's median and spread, the final poses",
    grid={"--cell-size": [0.00625, 0.003125, 0.0025], "--ensemble-seed": list(ENSEMBLE_STARTS)},
    analyze=partial(analyze_runs, title="block impact: 16 perturbed starts per grid"),
)
