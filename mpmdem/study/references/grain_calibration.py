"""Our DEM grains as a continuum: the friction angles measured by the grain calibration (issue 43 §2,
``bench/results/studies/grain-calibration/calibration.json``, written by
``mpmdem.study.builtin.grain_calibration``). A continuum run that stands for these grains takes its
friction angle from here; ``tests/results/test_grain_calibration.py`` checks that these constants are the
committed calibration's, so a new calibration cannot leave a stale copy behind.

The silo's grains (``silo-discharge --sand dem``) are sphero-disks of r_p = 1 mm ± 15 %, grain–grain
μ = 0.5: their angle of repose by the discharge method (a heap on a ledge, five seeds) is the
continuum's φ. Disks roll freely (no rolling resistance), hence the low angle against a sand's ~30°.
"""

__all__ = ["DISK_DIAMETER", "DISK_MU_I", "DISK_MU_I_STD", "DISK_REPOSE_DEG", "DISK_REPOSE_STD_DEG",
           "MU_I_SETS", "MU_I_SOURCE", "mu_i_law", "POLYGON_REPOSE_DEG", "POLYGON_REPOSE_STD_DEG", "SOURCE"]

SOURCE = "bench/results/studies/grain-calibration/calibration.json"
#: angle of repose [deg] of the r_p = 1 mm disks (mean of five heaps) and the heaps' standard deviation
DISK_REPOSE_DEG = 17.9
DISK_REPOSE_STD_DEG = 0.6
#: the same for random convex sphero-polygons of r_p = 1 mm
POLYGON_REPOSE_DEG = 30.2
POLYGON_REPOSE_STD_DEG = 2.1

#: μ(I) of the r_p = 1 mm disks (Jop et al. 2006's form, μs + (μ2 − μs)/(I0/I + 1)), fitted to six steady
#: flows down a rough periodic incline at 18-30° (``mpmdem study grain-incline``,
#: ``bench/results/studies/grain-incline/mu_i_fit.json``), each with its 1-σ from the fit's covariance
DISK_MU_I = {"mu_s": 0.228, "mu_2": 0.806, "i0": 0.376}
DISK_MU_I_STD = {"mu_s": 0.026, "mu_2": 0.083, "i0": 0.138}
#: d [m] of those disks (2 r_p)
DISK_DIAMETER = 0.002
MU_I_SOURCE = "bench/results/studies/grain-incline/mu_i_fit.json"
#: the named μ(I) laws a case's --mu-i-set picks: Jop et al. 2006's glass beads, or our disks' incline fit
MU_I_SETS = {"glass-beads": "Jop et al. 2006 (glass beads)", "dem-disks": MU_I_SOURCE}
#: ρ / ρs of the glass-bead set: a dense flowing pack of beads
GLASS_BEAD_SOLID_FRACTION = 0.6


def mu_i_law(name: str, bulk_density: float) -> tuple[dict, float]:
    """({mu_s, mu_2, i0}, ρs [kg/m³]) of the μ(I) set ``name`` for a continuum of bulk density ρ
    [kg/m³]: the glass beads with ρs = ρ / GLASS_BEAD_SOLID_FRACTION, or our disks with their grain
    density ρ / PACKING_FRACTION (the DEM grains' own, ``mpmdem.sim.gated_grains``)."""
    from ...errors import InputError
    from ...model.granular_materials import MuI
    from ...sim.gated_grains import PACKING_FRACTION

    if name == "dem-disks":
        return dict(DISK_MU_I), bulk_density / PACKING_FRACTION
    if name == "glass-beads":
        beads = MuI.glass_beads()
        return {"mu_s": beads.mu_s, "mu_2": beads.mu_2, "i0": beads.i0}, bulk_density / GLASS_BEAD_SOLID_FRACTION
    raise InputError("--mu-i-set", name, "one of " + ", ".join(MU_I_SETS))
