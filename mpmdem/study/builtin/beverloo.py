"""The Beverloo studies of `silo-discharge` (MPM-SDEM §5.3, Fig. 16).

``BEVERLOO``: D0 = 2 ... 6 cm at the grids 2.5, 3.5 (Table 3) and 5 mm (≈ 38k, 19k and 9k points at
a 30 cm fill; the paper's runs had 8-10 thousand); the fits of the free power law and of the
paper's Beverloo form, and the charts (``beverloo_analysis``).

``METHODS``: the D0 = 4 cm silo on Table 3's grid under every model choice: Granular MPM against
stress-free and original MPM; `imp` against `grid` coupling (on original MPM, as `grid` is refused
with Granular MPM); the silo as SDEM bodies against the same plates as grid obstacles (rollers or
no-slip nodes, no DEM stage); each at the default DEM step and at 3 × it (``--dem-kappa``), where
the coupled step may fail. A failed run is a row with its status, marked in the chart.
"""

from pathlib import Path

from mpmdem.study.references.grain_calibration import DISK_REPOSE_DEG
from mpmdem.study.study import Study

from .beverloo_analysis import analyze, methods_report
from .run_summaries import load_runs


def analyze_rates(rows: list[dict], out: Path) -> dict:
    """Fits and charts from every run's summary.json (the rows keep scalars only; M(t) is there)."""
    return analyze(load_runs(out), out)


def analyze_methods(rows: list[dict], out: Path) -> dict:
    return methods_report(load_runs(out), out)


#: the orifice widths D0 [m] of every Beverloo study (MPM-SDEM Fig. 16's range)
ORIFICES = [0.02, 0.03, 0.04, 0.05, 0.06]

BEVERLOO = Study(
    name="beverloo",
    case="silo-discharge",
    description="silo discharge rate vs orifice at three grids, fitted to the 2D Beverloo law (MPM-SDEM Fig. 16)",
    grid={"--orifice": ORIFICES, "--cell-size": [0.0025, 0.0035, 0.005]},
    analyze=analyze_rates,
)

METHODS = Study(
    name="beverloo-methods",
    case="silo-discharge",
    description="the D0 = 4 cm silo under each model (Granular/stress-free/original MPM, imp/grid coupling, "
                "SDEM walls/grid obstacles) at the default and 3 x the DEM step",
    grid={"--method": ["granular", "stress-free", "original", "original-grid", "obstacle-slip", "obstacle-fixed"],
          "--dem-kappa": [0.1, 0.3]},
    fixed={"--orifice": 0.04, "--cell-size": 0.0035},
    analyze=analyze_methods,
)


#: grids of the refinement studies [m]: 5 mm (about the paper's point count) down to 1 mm; 2 → 1 mm
#: is the last halving
REFINED_GRIDS = [0.005, 0.0035, 0.0025, 0.002, 0.0014, 0.001]


def _refinement(name: str):
    def analyze_runs(rows: list[dict], out: Path) -> dict:
        from ..references.table3 import DENSITY, GRAVITY
        from .beverloo_refinement import analyze_study

        return analyze_study(out, name, DENSITY, GRAVITY)

    return analyze_runs


def analyze_grain_runs(rows: list[dict], out: Path) -> dict:
    from ..references.table3 import DENSITY, GRAVITY
    from .beverloo_refinement import analyze_grain, chart_intercepts, write

    result = analyze_grain(load_runs(out), DENSITY, GRAVITY)
    write(result, out, "beverloo-mu-i-grain")
    chart_intercepts({}, result, out / "beverloo-mu-i-grain_intercept.png")
    return result


REFINED = Study(
    name="beverloo-refined",
    case="silo-discharge",
    description="Drucker-Prager (Table 3) silo rate vs orifice on six grids, 5 to 1 mm: Richardson W_inf per D0 "
                "and the Beverloo intercept against h",
    grid={"--orifice": ORIFICES, "--cell-size": REFINED_GRIDS},
    analyze=_refinement("beverloo-refined"),
)

MU_I = Study(
    name="beverloo-mu-i",
    case="silo-discharge",
    description="mu(I) silo rate vs orifice on six grids, 5 to 1 mm (d = 2 mm): does W converge?",
    grid={"--orifice": ORIFICES, "--cell-size": REFINED_GRIDS},
    fixed={"--material": "mu-i"},
    analyze=_refinement("beverloo-mu-i"),
)

CALIBRATED = Study(
    name="beverloo-calibrated",
    case="silo-discharge",
    description="Drucker-Prager silo with the DEM disks' angle of repose as phi (psi = 0) on six grids, 5 to 1 mm: "
                "the continuum calibrated on the grains against the grains' own silo (beverloo-dem)",
    grid={"--orifice": ORIFICES, "--cell-size": REFINED_GRIDS},
    # φ: the heaps of the r_p = 1 mm disks (mpmdem.study.references.grain_calibration); ψ = 0: a flow at the
    # critical state changes no volume, and the grains' dilatancy is not measured
    fixed={"--friction-angle": DISK_REPOSE_DEG, "--dilatancy-angle": 0.0},
    analyze=_refinement("beverloo-calibrated"),
)

MU_I_DISKS = Study(
    name="beverloo-mu-i-disks",
    case="silo-discharge",
    description="mu(I) silo with the DEM disks' own incline fit (grain-incline: mu_s, mu_2, I0, d = 2 mm, their grain "
                "density) on six grids, 5 to 1 mm, against the DEM silo of those disks (beverloo-dem)",
    grid={"--orifice": ORIFICES, "--cell-size": REFINED_GRIDS},
    fixed={"--material": "mu-i", "--mu-i-set": "dem-disks"},
    analyze=_refinement("beverloo-mu-i-disks"),
)

MU_I_GRAIN = Study(
    name="beverloo-mu-i-grain",
    case="silo-discharge",
    description="mu(I) silo rate vs orifice at h = 2.5 mm for d = 0.5, 1, 2 and 4 mm: does the intercept follow d?",
    grid={"--orifice": [0.03, 0.04, 0.05, 0.06], "--grain-diameter": [0.0005, 0.001, 0.002, 0.004]},
    fixed={"--material": "mu-i", "--cell-size": 0.0025},
    analyze=analyze_grain_runs,
)


def analyze_dem_runs(rows: list[dict], out: Path) -> dict:
    from ..references.table3 import DENSITY, GRAVITY
    from .beverloo_refinement import analyze_dem, write

    result = analyze_dem(load_runs(out), DENSITY, GRAVITY)
    write(result, out, "beverloo-dem")
    return result


DEM = Study(
    name="beverloo-dem",
    case="silo-discharge",
    description="the silo with DEM grains (sphero-disks, r_p = 1 and 0.5 mm) at D0 = 2-6 cm: the grains' "
                "Beverloo C and k, the reference for the continuum",
    grid={"--orifice": ORIFICES, "--grain-radius": [0.001, 0.0005]},
    fixed={"--sand": "dem"},
    analyze=analyze_dem_runs,
)
