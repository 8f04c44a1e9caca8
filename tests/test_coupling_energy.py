"""Energy checks of the MPM–DEM coupling ("MPM-SDEM" §5.1): the momentum-exchange and disk-drop
cases run as scripts (``--quick``: Table 1's 3 mm grid with 3×3 points per cell, Table 1's
contact springs, FLIP) and their summary.json is checked.

Each case runs once per material (module-scoped cache); the four runs take ~5-20 s each on two
cores.
"""

import pytest
from helpers import run_script

SPEED = 2.0  # m/s, the MPM disk's impact speed in cases/momentum_exchange.py
PAPER_SOFT_SPEED = 1.92  # m/s, MPM-SDEM §5.1.1

RUNS = [("momentum_exchange", "hard"), ("momentum_exchange", "soft"), ("disk_drop", "hard"), ("disk_drop", "soft")]


@pytest.fixture(scope="module")
def summary(tmp_path_factory):
    """summary(case, material): the case's summary.json, each run made once."""
    cache = {}

    def get(case, material):
        if (case, material) not in cache:
            out = tmp_path_factory.mktemp(f"{case}_{material}")
            cache[case, material] = run_script(case, out, "--material", material)
        return cache[case, material]

    return get


def test_momentum_exchange_hard(summary):
    s = summary("momentum_exchange", "hard")
    assert s["status"] == "completed" and s["bodies"] == 1
    assert not s["contact_at_end"]  # the exchange is over: the DEM disk coasts at its final speed
    v = s["dem_speed_final"]
    # The paper's hard disk leaves at 1.992 m/s. With Table 1's contact springs (k_n = 6e8 N/m per
    # m, far stiffer than the disk, E = 8.9 MPa) the DEM disk's speed is set by the grid, not by
    # dt, r_p, precision or the stress update (see the case header): measured 1.858 m/s here,
    # 1.868 at Table 1's full resolution and 1.90-1.94 on grids down to 0.5 mm, so the 1.95 m/s
    # one would ask from the paper is out of reach of this model. 1.80 m/s leaves ~3 % for other
    # changes; PIC, which damps the impact, fails it (1.26 m/s measured on this case; APIC 1.815).
    assert v >= 1.80
    # Never faster than a perfectly elastic exchange allows (momentum and energy of two bodies with
    # the seeded mass ratio m_mpm / m_dem, 1.006 here): more would be energy made.
    ratio = s["mass_ratio_mpm_over_dem"]
    assert v <= 2.0 * ratio / (1.0 + ratio) * SPEED * (1.0 + 1e-9)
    # the DEM disk's share of the kinetic energy (the paper's 99.2 % measure), ≈ (v / v0)² here
    assert 0.80 < s["kinetic_energy_ratio"] <= 1.0
    # the point–body forces are equal and opposite: total momentum is kept to f64 round-off
    # (measured 0 to 1e-13 relative)
    assert s["momentum_drift_relative"] < 1e-9


def test_momentum_exchange_soft_near_paper(summary):
    soft = summary("momentum_exchange", "soft")
    hard = summary("momentum_exchange", "hard")
    assert soft["status"] == "completed" and not soft["contact_at_end"]
    # The paper's soft disk leaves at 1.92 m/s. Measured here 1.817 m/s, 1.824 at Table 1's full
    # resolution and 1.81-1.89 on grids from 3 to 0.75 mm: the grid alone moves the result by up
    # to 0.11 m/s below the paper, so ±0.15 m/s (8 %) is the tolerance; PIC's damping falls far
    # outside it (1.26 m/s already for the hard disk).
    assert soft["dem_speed_final"] == pytest.approx(PAPER_SOFT_SPEED, abs=0.15)
    # the paper's finding that the soft disk hands over less than the hard one (its slower waves
    # keep more of the impact as vibrations); measured 1.817 against 1.858 m/s
    assert soft["dem_speed_final"] < hard["dem_speed_final"]
    assert soft["momentum_drift_relative"] < 1e-9


@pytest.mark.parametrize("case, material", RUNS)
def test_coupled_run_never_gains_energy(summary, case, material):
    s = summary(case, material)
    assert s["status"] == "completed"
    # energy_total (kinetic + gravity + strain + contact springs of points and body) at every
    # frame against its start, relative to the initial kinetic energy (momentum exchange) or to
    # the potential energy the fall releases down to the impact (disk drop). With e = 1 the
    # coupling has nothing to dissipate with but friction, and FLIP only loses energy; a coupling
    # that made energy (a force on one side only, an unstable contact step) shows up here.
    # Measured: 0 to f64 round-off (≤ 3e-15) in all four runs; 0.5 % as asked.
    assert s["energy_max_gain_relative"] < 0.005


@pytest.mark.parametrize("material", ["hard", "soft"])
def test_disk_drop_bounces_without_making_energy(summary, material):
    s = summary("disk_drop", material)
    assert s["status"] == "completed" and s["bounced"]
    # the free fall is exact: the frame before the impact is at most one frame interval
    # (0.15 ms of a 20 ms fall) early, so the speed there is within 1 % of sqrt(2 g d)
    assert s["impact_speed"] == pytest.approx(s["impact_speed_exact"], rel=0.01)
    # Rebound: the centroid's kinetic energy on the way up over the energy released down to the
    # same height. The paper: 0.99 (hard), 0.93 (soft). Measured here 0.847 (hard) and 0.854
    # (soft), 0.903 / 0.895 at Table 1's full resolution; the rest stays in the disk as
    # vibrations or is damped by FLIP. 0.7 asks for a real bounce, 18 % below the measured
    # value; 2×2 points per cell would sit at the limit (0.70) and PIC fails it (0.11).
    assert s["rebound_fraction"] > 0.7
    # Never more kinetic energy than the fall released, at any frame: during the free fall the
    # ratio is 1 − O(dt / t) (measured 0.99994); from the impact on it stays below 1 (measured
    # 0.93 hard, 0.95 soft, largest in the first frames of the contact; 0.99 at full resolution).
    assert s["kinetic_over_released_max"] <= 1.0 + 1e-9
    assert s["kinetic_over_released_max_after_impact"] < 1.0
