"""The rod collision of "MPM-SDEM" §5.4 (Fig. 17-18): an elastic MPM rod hits an equal-mass rigid rod
end-on; the error of the system's Σ m v² measures each coupling scheme (cases/rod_collision.py).

All runs are in-process, f64, CPU, 400 points, k_n = 2 N/cm (the case's default, see its header):
~0.3-0.7 s each. The comparison is deterministic on the CPU; the margins below guard against small
changes of the library, not against noise.
"""

import functools

import pytest
from helpers import run_script

from mpmdem.cases import rod_collision as rc

COARSE = 1.0  # cm: dg = L, L/dg = 1, the paper's hardest case


@functools.cache
def _mean_error(scheme: str) -> float:
    """error_v2 at dg = L averaged over four positions of the contact point in its cell."""
    return rc.offset_mean_error(scheme, COARSE)


@functools.cache
def _run(scheme: str, grid_size_cm: float) -> dict:
    """The case's default set-up (contact point in the middle of its cell)."""
    return rc.run_pair(scheme, grid_size_cm)


@pytest.mark.parametrize("other", ["grid", "liu"])
def test_imp_scheme_beats_the_others_at_l_over_dg_1(other):
    """Fig. 18 at L/dg = 1: the paper's scheme (force at the material point, spread by its shape
    function) conserves Σ m v² better than the force put on the grid node nearest the contact
    point ("grid") and than Liu et al.'s momentum exchange ("liu"); MPM-SDEM §5.4 calls the other
    two schemes' errors "distinctively higher" at L/dg = 1-0.5 on Fig. 18's logarithmic axis.
    Reference: that ordering (MPM-SDEM §5.4, Fig. 18). Tolerance: "distinctively higher" on a log
    axis is read as at least one decade, so the rivals must be ≥ 10 × imp's error. Measured (mean
    of offsets 1/8 ... 7/8 of a cell): imp 2.47e-4, grid 5.7e-2 (230 ×), liu 0.50 (2000 ×)."""
    imp, rival = _mean_error("imp"), _mean_error(other)
    assert imp < 0.1 * rival, (imp, rival)


def test_imp_error_decreases_with_the_grid_size():
    """Fig. 18: the imp error falls as the grid is refined from dg = L. Measured: 2.5e-4 (1 cm),
    3.5e-5 (0.5 cm), 6.9e-6 (0.2 cm) — a factor 36 from 1.0 to 0.2 cm; asked: strictly falling and
    at least a factor 10 over that range. Each run also exchanges the velocities (rigid rod v1, MPM
    rod 0, to 1e-3 v1: measured 1.2e-4 v1 at dg = 1 cm, about half the v² error as S ∝ v²),
    conserves momentum to round-off (f64: measured ≤ 1e-14) and ends separated."""
    runs = [_run("imp", h) for h in (1.0, 0.5, 0.2)]
    errors = [r["error_v2"] for r in runs]
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[2] < 0.1 * errors[0], errors
    for r in runs:
        assert r["separated"] and r["contacts_max"] >= 1
        assert r["mass_ratio"] == pytest.approx(1.0, rel=1e-12)
        assert abs(r["momentum_balance"]) < 1e-9
        assert r["velocity_rigid_rod"] == pytest.approx(rc.V1, rel=1e-3)
        assert abs(r["velocity_mpm_rod"]) < 1e-3 * rc.V1


# The rod contact is elastic (restitution 1, no dashpot: cases/rod_collision.py), the rods have equal
# mass, and the rigid rod is at rest: an exact elastic exchange gives the rigid rod all the momentum
# (share 1). Tolerance 0.01: MPM-SDEM §5.1.1 shows its elastic coupling losing 0.8 % of the kinetic
# energy (the hard disk's 99.2 %); a two-body exchange that loses 2 ε of Σ m v² keeps a share
# (1 + sqrt(1 − 2 ε)) / 2 ≈ 1 − ε / 2, so twice the paper's loss (1.6 %) allows a share 0.992:
# rounded to 0.01.
ELASTIC_SHARE_TOL = 0.01


@pytest.mark.parametrize("grid_size_cm", [1.0, 0.5])
@pytest.mark.parametrize("scheme", ["imp", "grid"])
def test_elastic_schemes_hand_all_the_momentum_over(scheme, grid_size_cm):
    """The elastic coupling schemes (contact spring at the material point or at the nearest node)
    exchange the rods' momenta as an elastic collision of equal masses: share → 1 (measured imp
    0.99988 / 0.99998, grid 0.9989 / 0.9974 at 1 / 0.5 cm); the total is conserved to f64
    round-off (measured ≤ 1e-14)."""
    r = _run(scheme, grid_size_cm)
    assert r["momentum_share_rigid_rod"] == pytest.approx(1.0, abs=ELASTIC_SHARE_TOL), r
    assert abs(r["momentum_balance"]) < 1e-9, r


@pytest.mark.parametrize("grid_size_cm", [1.0, 0.5])
def test_liu_scheme_is_a_perfectly_inelastic_collision(grid_size_cm):
    """Liu et al.'s scheme as MPM-SDEM §5.4 (Fig. 17C) describes it: the rigid rod is three material
    points that meet the MPM rod at a shared node, a hard nodal contact with no spring, so the two
    rods move as one while in contact: a perfectly inelastic collision of equal masses, which keeps
    half of Σ m v² (error_v2 → 0.5) and leaves the rigid rod with at least half the momentum. The
    two-body balance ties the share to the loss: a collision that keeps 1 − ε of Σ m v² gives the
    rigid rod (1 + sqrt(1 − 2 ε)) / 2 of the momentum, whatever the contact law. Tolerances: 0.01 on
    the loss (the elastic tolerance above, the same accounting) and 0.01 on the share from the
    two-body balance (vibration energy left in the MPM rod is the only term the balance leaves out;
    the hard disk of §5.1.1 keeps 0.8 % of it). Measured: loss 0.4967 / 0.4985, share 0.540 / 0.527
    at 1 / 0.5 cm (two-body prediction 0.539 / 0.527)."""
    r = _run("liu", grid_size_cm)
    eps = r["error_v2"]
    assert eps == pytest.approx(0.5, abs=0.01), r
    assert r["momentum_share_rigid_rod"] >= 0.5 - 0.01, r
    two_body = 0.5 * (1.0 + (max(0.0, 1.0 - 2.0 * eps)) ** 0.5)
    assert r["momentum_share_rigid_rod"] == pytest.approx(two_body, abs=0.01), r
    assert abs(r["momentum_balance"]) < 1e-9, r


def test_script_writes_the_summary(tmp_path):
    """The script runs one (scheme, grid size) pair: --quick is L/dg = 1; summary.json holds the
    v² error, both rods' final velocities, the momentum and energy balances."""
    s = run_script("rod_collision", tmp_path, "--scheme", "grid")
    assert s["status"] == "completed"
    assert s["scheme"] == "grid" and s["grid_size_cm"] == COARSE and s["length_over_grid"] == pytest.approx(1.0)
    assert s["particles"] == rc.POINTS and s["bodies"] == 1
    assert s["separated"]
    for key in ("error_v2", "velocity_mpm_rod", "velocity_rigid_rod", "momentum_balance", "energy_total_change"):
        assert key in s
    # the pair run in-process on the same scene gives the same numbers (CPU runs are deterministic)
    assert s["error_v2"] == pytest.approx(_run("grid", COARSE)["error_v2"], rel=1e-9)
    assert s["error_v2"] < 0.3  # measured 0.059 at this offset (grid's nearest-node force)
