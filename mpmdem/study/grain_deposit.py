"""Reading a deposit of grains (SI units): its connected front, its surface profile and the angle of
its flank.

A deposit of grains on a floor (x along the floor, y up) is read from the grain centres x (n, 2) [m]
and bounding radii r (n,) [m]:

* ``connected_front``: the right edge of the grains reached from the wall through gaps (along x)
  narrower than ``gap``: the farthest grain that is still part of the deposit, leaving out grains
  thrown beyond it;
* ``surface_profile``: the top of the grains (max y + r) in bins of a given width along x;
* ``flank_angle``: the slope of a straight line fitted by least squares to the profile's flank,
  between where it falls below ``upper`` × its height at the wall and where it falls below
  ``lower`` × that height, as an angle [deg] with its standard error. The surface of a deposit
  left at rest is at most as steep as the grains' angle of repose; its flank is where the angle is
  read (``bench/grain_calibration.py``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["connected_front", "flank_angle", "surface_profile"]


def connected_front(x: np.ndarray, radius: np.ndarray, x_wall: float, gap: float) -> float:
    """Position [m] of the deposit's far edge: the grains sorted by their left edge x − r, walking
    from the wall at ``x_wall``, the deposit ends at the first gap wider than ``gap`` [m] between
    a grain's left edge and the farthest right edge x + r before it."""
    left = x[:, 0] - radius
    order = np.argsort(left, kind="stable")
    left, right = left[order], (x[:, 0] + radius)[order]
    reach = np.maximum.accumulate(np.concatenate([[x_wall], right]))
    breaks = np.flatnonzero(left - reach[:-1] > gap)
    return float(reach[breaks[0]] if len(breaks) else reach[-1])


def surface_profile(x: np.ndarray, radius: np.ndarray, x_wall: float, width: float,
                    end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(bin centres [m], top of the grains in each bin [m]) over bins of ``width`` [m] from
    ``x_wall`` to ``end`` [m] (default the farthest grain); an empty bin's top is NaN."""
    end = float((x[:, 0] + radius).max()) if end is None else end
    nb = max(1, int(math.ceil((end - x_wall) / width)))
    k = np.floor((x[:, 0] - x_wall) / width).astype(int)
    sel = (k >= 0) & (k < nb)
    top = np.full(nb, -np.inf)
    np.maximum.at(top, k[sel], x[sel, 1] + radius[sel])
    top[~np.isfinite(top)] = np.nan
    return x_wall + (np.arange(nb) + 0.5) * width, top


def flank_angle(centres: np.ndarray, top: np.ndarray, *, upper: float = 0.8, lower: float = 0.2,
                floor: float = 0.0) -> dict:
    """The angle [deg] of the profile's flank (``surface_profile``) above ``floor`` [m]: a least-squares
    line through the bins from the last one (from the wall) above ``upper`` × the height at the wall
    to the first one after it below ``lower`` × that height, both excluded. Returns angle_deg,
    angle_stderr_deg (from the slope's standard error), bins (how many were fitted) and the
    flank's x range [m]; the angle is None with fewer than 5 bins (the error needs 3 degrees of freedom)."""
    h = top - floor
    ok = np.isfinite(h)
    out = {"angle_deg": None, "angle_stderr_deg": None, "bins": 0, "x_range_m": None}
    if not ok.any():
        return out
    h_wall = float(h[np.flatnonzero(ok)[0]])
    high = np.flatnonzero(ok & (h >= upper * h_wall))
    start = int(high[-1]) + 1 if len(high) else 0
    low = np.flatnonzero(~ok[start:] | (h[start:] <= lower * h_wall))
    stop = start + (int(low[0]) if len(low) else len(h) - start)
    xs, ys = centres[start:stop], h[start:stop]
    out["bins"] = len(xs)
    if len(xs) < 5:
        return out
    (slope, _), cov = np.polyfit(xs, ys, 1, cov=True)
    se = math.sqrt(max(float(cov[0, 0]), 0.0))
    out.update(angle_deg=math.degrees(math.atan(-slope)), angle_stderr_deg=math.degrees(se / (1.0 + slope * slope)),
               x_range_m=[float(xs[0]), float(xs[-1])])
    return out
