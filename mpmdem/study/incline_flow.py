"""A granular layer flowing down a rough incline, read from its grains (SI units): whether it is
steady, and its depth profiles averaged over a time window.

The layer lies on a rough base along x (periodic), y normal to the base, gravity tilted by θ. In a
steady uniform flow the momentum balance across the layer gives τ_xy / p = tan θ at every depth,
with p(y) = ρs g cos θ ∫_y^top φ dy' (the weight of the grains above, per unit area), so each
steady run is one point (I, μ = tan θ) of the friction law μ(I), I = γ̇ d / sqrt(p / ρs) (GDR MiDi
2004; Jop et al. 2006). A run below the stopping angle comes to rest; above the largest angle of
steady flow it keeps accelerating: ``flow_state`` says which (a steady flow's net acceleration a
is a small fraction of g sin θ, and μ = tan θ − a / (g cos θ)).

Profiles (``layer_profiles``): the grains binned by centroid height in bins of one width: solid
fraction φ (grain area in the bin over its area), mean velocity u (mass-weighted), p from the top
down, γ̇ = du/dy by central differences, and I. The core (``core_values``) leaves ``margin`` grain
diameters out at the base and at the surface, where the profiles feel the boundary.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["STATES", "core_values", "flow_height", "flow_state", "layer_profiles"]

#: what ``flow_state`` reports
STATES = ("stopped", "steady", "accelerating")
#: at rest: the mean speed at the end below this fraction of sqrt(g d)
REST_SPEED = 1e-3
#: accelerating: the window's mean acceleration (a linear fit of the mean speed) above this fraction of
#: the drive g sin θ. The balance of the layer, m a = m g sin θ − μ m g cos θ, then reads μ = tan θ to
#: this fraction of tan θ: a steady flow's μ (a small strip's mean speed fluctuates by ~10 % from frame
#: to frame, which a test on the relative change would take for acceleration)
DRIVE_FRACTION = 0.01
#: ... and above this many standard errors of the fit's slope (a short window's fluctuations of a
#: steady flow are not taken for acceleration)
SIGNIFICANCE = 3.0


def flow_state(times: np.ndarray, mean_speed: np.ndarray, start: float, speed_scale: float, drive: float) -> dict:
    """Whether the layer stopped, flows steadily or accelerates over the window t ≥ ``start`` [s]:
    ``mean_speed`` [m/s] per frame (the grains' mean down-slope velocity), ``speed_scale`` sqrt(g d)
    [m/s], ``drive`` g sin θ [m/s²]. Stopped: the last frame's speed below REST_SPEED × the scale;
    accelerating: the window's mean acceleration a (a linear fit) above DRIVE_FRACTION × the drive
    and above SIGNIFICANCE standard errors of the fit; else steady. Returns the state, the window's
    mean speed, a / drive with its standard error, and the final speed over the scale."""
    t = np.asarray(times, float)
    u = np.asarray(mean_speed, float)
    window = t >= start
    tw, uw = t[window], u[window]
    mean = float(np.mean(uw))
    accel, accel_err = 0.0, 0.0
    if len(tw) >= 4:
        coef, cov = np.polyfit(tw, uw, 1, cov=True)
        accel, accel_err = float(coef[0]), float(np.sqrt(max(cov[0, 0], 0.0)))
    final = float(u[-1]) / speed_scale
    if abs(final) < REST_SPEED:
        state = "stopped"
    elif accel > DRIVE_FRACTION * drive and accel > SIGNIFICANCE * accel_err:
        state = "accelerating"
    else:
        state = "steady"
    return {"state": state, "window_mean_speed": mean, "acceleration_over_drive": accel / drive,
            "acceleration_over_drive_std": accel_err / drive, "final_speed_scaled": final}


def layer_profiles(y: list[np.ndarray], u: list[np.ndarray], area: np.ndarray, mass: np.ndarray, *, base: float,
                   bin_width: float, length: float, grain_density: float, g_normal: float, diameter: float) -> dict:
    """Depth profiles averaged over frames: ``y`` and ``u`` per frame, the grains' centroid heights [m]
    and down-slope velocities [m/s]; ``area`` [m²] and ``mass`` [kg/m] per grain; ``base`` [m] the
    base's top; ``length`` [m] the period; ``g_normal`` = g cos θ [m/s²]; ``diameter`` d [m].
    Returns arrays over the bins: ``z`` (bin centres above the base [m]), ``phi``, ``u`` [m/s],
    ``p`` [Pa = N/m²], ``shear_rate`` [1/s] and ``inertial_number``."""
    top = max(float(np.max(f)) for f in y) - base + bin_width
    edges = np.arange(0.0, top + bin_width, bin_width)
    n = len(edges) - 1
    area_sum = np.zeros(n)
    momentum = np.zeros(n)
    mass_sum = np.zeros(n)
    for yf, uf in zip(y, u, strict=True):
        k = np.clip(np.floor((yf - base) / bin_width).astype(int), 0, n - 1)
        area_sum += np.bincount(k, weights=area, minlength=n)
        momentum += np.bincount(k, weights=mass * uf, minlength=n)
        mass_sum += np.bincount(k, weights=mass, minlength=n)
    phi = area_sum / (len(y) * length * bin_width)
    vel = np.divide(momentum, mass_sum, out=np.full(n, np.nan), where=mass_sum > 0.0)
    # p at a bin centre: the weight of the grains above it, half its own bin's included
    above = np.cumsum(phi[::-1])[::-1] - 0.5 * phi
    p = grain_density * g_normal * above * bin_width
    rate = np.gradient(vel, bin_width) if n >= 2 else np.zeros(n)
    with np.errstate(invalid="ignore", divide="ignore"):
        inertial = rate * diameter / np.sqrt(p / grain_density)
    return {"z": 0.5 * (edges[:-1] + edges[1:]), "phi": phi, "u": vel, "p": p, "shear_rate": rate,
            "inertial_number": inertial}


def flow_height(profiles: dict) -> float:
    """The layer's height above the base [m]: the grains' area per unit length over the bulk solid
    fraction (the median φ of the bins denser than half the densest)."""
    phi, z = profiles["phi"], profiles["z"]
    width = float(z[1] - z[0]) if len(z) > 1 else 2.0 * float(z[0])
    dense = phi[phi > 0.5 * phi.max()]
    return float(phi.sum() * width / np.median(dense))


def core_values(profiles: dict, height: float, margin: float) -> dict:
    """Means and standard deviations of I, φ and γ̇ over the core: bins at least ``margin`` [m] above
    the base and below the surface at ``height`` [m] (no core: NaNs and 0 bins)."""
    z = profiles["z"]
    core = (z >= margin) & (z <= height - margin) & np.isfinite(profiles["inertial_number"])
    out = {"core_bins": int(np.count_nonzero(core)), "core_range_m": [margin, height - margin]}
    for key, name in (("inertial_number", "I"), ("phi", "phi"), ("shear_rate", "shear_rate")):
        v = profiles[key][core]
        out[f"{name}_core"] = float(np.mean(v)) if len(v) else math.nan
        out[f"{name}_core_std"] = float(np.std(v)) if len(v) else math.nan
    return out
