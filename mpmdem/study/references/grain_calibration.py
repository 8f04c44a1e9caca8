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
           "MU_I_SOURCE", "POLYGON_REPOSE_DEG", "POLYGON_REPOSE_STD_DEG", "SOURCE"]

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
