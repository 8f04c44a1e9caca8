"""Jop et al. 2006's friction law μ(I) = μs + (μ2 − μs) / (I0 / I + 1) fitted to measured (I, μ)
points, with the parameters' 1-σ uncertainties (least squares, ``scipy.optimize.curve_fit``).

The points of steady incline flows (``cases/grain_incline.py``) have μ = tan θ exact and I measured
with a scatter σ_I; the fit weighs each point by the scatter its σ_I makes in μ through the law's
slope (σ_μ = |dμ/dI| σ_I, the effective-variance method, one pass after an unweighted fit), and a
floor ``mu_floor`` for points whose σ_I is zero or unknown. μ2 is the plateau the law reaches at
large I: points with I well below I0 cannot pin it, and the fit says so (``mu2_constrained``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["fit_jop", "jop_mu"]


def jop_mu(inertial, mu_s: float, mu_2: float, i0: float):
    """μ(I) of Jop et al. 2006 (their eq. 2 in the form of ``kernels/mu_i.py``)."""
    inertial = np.asarray(inertial, float)
    return mu_s + (mu_2 - mu_s) / (i0 / inertial + 1.0)


def _slope(inertial, mu_s, mu_2, i0):
    """dμ/dI of ``jop_mu``."""
    return (mu_2 - mu_s) * i0 / (i0 + inertial) ** 2


def fit_jop(inertial, mu, inertial_std=None, *, mu_floor: float = 0.0) -> dict:
    """Fit μs, μ2, I0 to points (I, μ) (I > 0). ``inertial_std``: each point's σ_I (None: unweighted,
    the uncertainties from the residuals' scatter); ``mu_floor``: the least σ_μ a point is given.

    Returns the values, their 1-σ (square roots of the covariance's diagonal), the covariance, the
    residuals' RMS, the points used and ``mu2_constrained``: False when σ(μ2) exceeds half of μ2 − μs
    or the largest I is below I0 (the plateau not reached), with a note. Fewer than 3 points, or a
    fit that does not converge: the values are None and the note says why."""
    from scipy.optimize import curve_fit

    inertial = np.asarray(inertial, float)
    mu = np.asarray(mu, float)
    ok = np.isfinite(inertial) & np.isfinite(mu) & (inertial > 0.0)
    inertial, mu = inertial[ok], mu[ok]
    std = None if inertial_std is None else np.asarray(inertial_std, float)[ok]
    out = {"law": "mu(I) = mu_s + (mu_2 - mu_s) / (I0 / I + 1) (Jop et al. 2006)", "points": int(len(mu)),
           "mu_s": None, "mu_2": None, "i0": None, "mu_s_std": None, "mu_2_std": None, "i0_std": None,
           "covariance": None, "rms_residual": None, "mu2_constrained": False, "note": ""}
    if len(mu) < 3:
        out["note"] = f"{len(mu)} points: three parameters need at least 3"
        return out
    order = np.argsort(inertial)
    p0 = (float(mu[order[0]]) - 0.02, float(mu[order[-1]]) + 0.1, float(np.median(inertial)))
    bounds = ([0.0, 0.0, 1e-5], [5.0, 10.0, 100.0])
    try:
        params, cov = curve_fit(jop_mu, inertial, mu, p0=p0, bounds=bounds, maxfev=20000)
        absolute = False
        sigma = None
        if std is not None:
            sigma = np.maximum(np.abs(_slope(inertial, *params)) * np.nan_to_num(std), mu_floor)
            if np.all(sigma > 0.0):
                params, cov = curve_fit(jop_mu, inertial, mu, p0=params, sigma=sigma, absolute_sigma=True,
                                        bounds=bounds, maxfev=20000)
                absolute = True
    except (RuntimeError, ValueError) as e:
        out["note"] = f"the fit did not converge ({e})"
        return out
    err = np.sqrt(np.abs(np.diag(cov)))
    mu_s, mu_2, i0 = (float(v) for v in params)
    out.update(mu_s=mu_s, mu_2=mu_2, i0=i0, mu_s_std=float(err[0]), mu_2_std=float(err[1]), i0_std=float(err[2]),
               covariance=[[float(v) for v in row] for row in cov],
               rms_residual=float(np.sqrt(np.mean((jop_mu(inertial, *params) - mu) ** 2))),
               weights="sigma_mu = |dmu/dI| sigma_I (absolute)" if absolute else "unweighted (scatter of residuals)")
    notes = []
    if not math.isfinite(err[1]) or err[1] > 0.5 * abs(mu_2 - mu_s):
        notes.append(f"sigma(mu_2) = {err[1]:.3g} exceeds half of mu_2 - mu_s = {mu_2 - mu_s:.3g}")
    if float(inertial.max()) < i0:
        notes.append(f"the largest I, {inertial.max():.3g}, is below I0 = {i0:.3g}: the plateau mu_2 is not reached")
    out["mu2_constrained"] = not notes
    out["note"] = "; ".join(notes) + ("; mu_2 is unconstrained: read mu_s and the slope at small I" if notes else "")
    return out
