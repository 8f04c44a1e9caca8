"""Energy checks of the MPM–DEM coupling ("MPM-SDEM" §5.1): the momentum-exchange and disk-drop
cases run as scripts (``--quick``: Table 1's 3 mm grid with 3×3 points per cell, Table 1's
contact springs, FLIP) and their summary.json is checked.

Each case runs once per material (module-scoped cache); the four runs take ~5-20 s each on two
cores.
"""

import pytest
from helpers import run_script

SPEED = 2.0  # m/s, the MPM disk's impact speed in cases/momentum_exchange.py

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


# MPM-SDEM §5.1.1-5.1.2 (text under Fig. 7 and Fig. 9): the paper's numbers.
PAPER_EXCHANGE = {"hard": (1.992, 0.99202), "soft": (1.92, 1.0 - 0.0784)}  # DEM speed [m/s], E_k share
PAPER_REBOUND = {"hard": 0.9895, "soft": 1.0 - 0.06947}  # E_k on the way up / released, Fig. 9
# Tolerance on the paper's speeds: 0.02 m/s, 1 % of the impact speed. The paper gives its numbers
# to 3-4 digits and no scatter, so the tolerance is our own discretisation error at this size,
# estimated by one refinement (case header: 1.858 m/s --quick against 1.868 at Table 1's full
# resolution, 0.01 m/s), doubled. Energy shares go as v², so 2 % of them (0.02 absolute).
SPEED_TOL = 0.02  # m/s
SHARE_TOL = 0.02


def _elastic_limit(s):
    """The DEM disk's speed after a perfectly elastic head-on exchange of the two disks (momentum
    and energy of two bodies with the seeded mass ratio m_mpm / m_dem)."""
    ratio = s["mass_ratio_mpm_over_dem"]
    return 2.0 * ratio / (1.0 + ratio) * SPEED


def test_momentum_exchange_hard(summary):
    s = summary("momentum_exchange", "hard")
    assert s["status"] == "completed" and s["bodies"] == 1
    assert not s["contact_at_end"]  # the exchange is over: the DEM disk coasts at its final speed
    # Never faster than a perfectly elastic exchange allows: more would be energy made. The limit is
    # exact (two-body momentum and energy balance); 1e-9 is round-off.
    assert s["dem_speed_final"] <= _elastic_limit(s) * (1.0 + 1e-9)
    # the point–body forces are equal and opposite: total momentum is kept to f64 round-off
    # (measured 0 to 1e-13 relative)
    assert s["momentum_drift_relative"] < 1e-9


@pytest.mark.xfail(strict=True, reason=(
    "we get 1.852 m/s --quick, 1.868 at Table 1's resolution (paper 1.992, MPM-SDEM §5.1.1): with "
    "Table 1's k_n the DEM disk's speed is set by the grid (1.90-1.94 m/s down to 0.5 mm); the rest "
    "stays in the MPM disk as vibrations or is damped by FLIP (cases/momentum_exchange.py header)"))
def test_momentum_exchange_hard_speed_matches_paper(summary):
    # Reference: the hard DEM disk leaves at 1.992 m/s (MPM-SDEM §5.1.1, text under Fig. 7);
    # tolerance SPEED_TOL (see above).
    s = summary("momentum_exchange", "hard")
    assert s["dem_speed_final"] == pytest.approx(PAPER_EXCHANGE["hard"][0], abs=SPEED_TOL)


@pytest.mark.xfail(strict=True, reason=(
    "we get 0.857 of the kinetic energy in the DEM disk (paper 0.992, MPM-SDEM §5.1.1): the same "
    "grid-limited exchange as the speed, E_k share ≈ (v / v0)²"))
def test_momentum_exchange_hard_energy_share_matches_paper(summary):
    # Reference: 99.202 % of the elastic collision's kinetic energy (MPM-SDEM §5.1.1); tolerance
    # SHARE_TOL (twice the relative speed tolerance, E_k ∝ v²).
    s = summary("momentum_exchange", "hard")
    assert s["kinetic_energy_ratio"] == pytest.approx(PAPER_EXCHANGE["hard"][1], abs=SHARE_TOL)


def test_momentum_exchange_soft(summary):
    soft = summary("momentum_exchange", "soft")
    hard = summary("momentum_exchange", "hard")
    assert soft["status"] == "completed" and not soft["contact_at_end"]
    assert soft["dem_speed_final"] <= _elastic_limit(soft) * (1.0 + 1e-9)
    # MPM-SDEM §5.1.1: the soft disk hands over less than the hard one (1.92 against 1.992 m/s: its
    # slower waves keep more of the impact as vibrations). The paper's gap is 0.072 m/s, 3.6 × the
    # tolerance SPEED_TOL on each value, so the ordering is a resolved prediction of the reference.
    assert soft["dem_speed_final"] < hard["dem_speed_final"]
    assert soft["momentum_drift_relative"] < 1e-9


@pytest.mark.xfail(strict=True, reason=(
    "we get 1.812 m/s --quick, 1.824 at Table 1's resolution, 1.81-1.89 on grids from 3 to 0.75 mm "
    "(paper 1.92, MPM-SDEM §5.1.1): grid-limited as the hard disk"))
def test_momentum_exchange_soft_speed_matches_paper(summary):
    # Reference: 1.92 m/s, a 7.84 % loss of kinetic energy (MPM-SDEM §5.1.1); tolerance SPEED_TOL.
    s = summary("momentum_exchange", "soft")
    assert s["dem_speed_final"] == pytest.approx(PAPER_EXCHANGE["soft"][0], abs=SPEED_TOL)


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
    # same height, compared with the paper's in test_disk_drop_rebound_matches_paper.
    # Never more kinetic energy than the fall released, at any frame: during the free fall the
    # ratio is 1 − O(dt / t) (measured 0.99994); from the impact on it stays below 1 (measured
    # 0.93 hard, 0.95 soft, largest in the first frames of the contact; 0.99 at full resolution).
    assert s["kinetic_over_released_max"] <= 1.0 + 1e-9
    assert s["kinetic_over_released_max_after_impact"] < 1.0


@pytest.mark.xfail(strict=True, reason=(
    "we get 0.850 (hard) and 0.855 (soft) --quick, 0.903 / 0.895 at Table 1's full resolution (paper "
    "0.9895 / 0.9305, MPM-SDEM §5.1.2): the part of the impact energy that the grid-limited contact "
    "leaves in the disk as vibrations is damped by FLIP, as in the momentum exchange"))
@pytest.mark.parametrize("material", ["hard", "soft"])
def test_disk_drop_rebound_matches_paper(summary, material):
    # Reference: MPM-SDEM §5.1.2 (Fig. 9): the hard disk's kinetic energy reaches 98.95 % of the
    # potential energy released, the soft disk loses 6.947 %. Tolerance SHARE_TOL (2 % of the
    # energy: the free fall alone is checked to 1 % in speed above, 2 % in energy).
    s = summary("disk_drop", material)
    assert s["rebound_fraction"] == pytest.approx(PAPER_REBOUND[material], abs=SHARE_TOL)


@pytest.mark.xfail(strict=True, reason=(
    "we get the soft disk rebounding with 0.855 against the hard disk's 0.850 --quick (paper: 0.9305 "
    "against 0.9895, MPM-SDEM §5.1.2): our loss is set by the grid, not by the disk's stiffness"))
def test_disk_drop_hard_rebounds_higher_than_soft(summary):
    # Reference: MPM-SDEM §5.1.2: the hard disk conserves energy better (98.95 % against 93.05 %);
    # the gap (0.059) is 3 × SHARE_TOL, so the ordering is a resolved prediction.
    assert summary("disk_drop", "hard")["rebound_fraction"] > summary("disk_drop", "soft")["rebound_fraction"]
