"""μ(I) rheology (``MuI``, ``kernels/mu_i.py``): the return mapping against the analytic law, single points.

Reference: a homogeneous simple shear at rate γ̇ under pressure p reaches the steady state
τ/p = μ(I), I = γ̇ d / sqrt(p/ρs), μ(I) = μs + (μ2 − μs)/(I0/I + 1) (Jop, Forterre & Pouliquen 2006
eq. 1–2). Once the elastic transient has died out, the whole shear increment is plastic, and the
closed-form return (Dunatunga & Kamrin 2015 §3) solves this relation exactly each step; what is
left is the first-order Jaumann rotation σ + Δw σ − σ Δw, whose error per step is of the order
of the strain increment γ̇ dt (≤ 3.4e-6 here). So the tolerance is 1e-6 relative, not a fit to
our result (the issue asks for 1 %).
Everything runs through ``make_point_driver`` on the CPU in f64 and f32 (f32: 1e-4, a few
hundred ulp of single-precision stress).
"""

import math

import numpy as np
import pytest
from test_plasticity import drive, mean_tau

from mpmdem import MuI
from mpmdem.errors import InputError
from mpmdem.kernels.point_driver import make_point_driver

P0 = 2.0e3  # confining pressure [Pa]: ~14 cm of sand
N_STEPS = 4000


@pytest.fixture(scope="module")
def driver():
    return make_point_driver("f64", "mu_i")


def beads(**kw) -> MuI:
    return MuI.glass_beads(youngs_modulus=1.0e7, **kw)


def shear_path(rate: float, dt: float, n: int = N_STEPS, points: int = 1):
    """Simple shear increments (ε_xy = γ̇ dt / 2 and the matching spin) [-], shape [points, n, 2, 2]."""
    g = 0.5 * rate * dt
    deps = np.zeros((points, n, 2, 2))
    dw = np.zeros((points, n, 2, 2))
    deps[..., 0, 1] = deps[..., 1, 0] = g
    dw[..., 0, 1], dw[..., 1, 0] = g, -g
    return deps, dw


def steady_ratio(out):
    """τ/p of the last step of each point, with p = −σ_m."""
    sm, tau = mean_tau(out["sig"][:, -1], out["szz"][:, -1])
    return tau / -sm, -sm


@pytest.mark.parametrize("inertial", [1e-3, 0.05, 0.279, 1.0])
def test_simple_shear_reaches_mu_of_i(driver, inertial):
    """Steady simple shear: τ/p = μ(I) at the imposed γ̇, from slow (I = 1e-3) to fast (I = 1) flow."""
    mat = beads()
    rate = inertial * math.sqrt(P0 / mat.grain_density) / mat.grain_diameter
    # enough strain for the elastic transient (τ_y / G ~ 1e-4) to die: 40 × μ2 p / G
    dt = 40.0 * mat.mu_2 * P0 / mat.shear_modulus / rate / N_STEPS
    deps, dw = shear_path(rate, dt)
    out = drive(driver, mat, -P0 * np.eye(2)[None], np.array([-P0]), deps, dw, dt=dt)
    ratio, p = steady_ratio(out)
    assert p[0] == pytest.approx(P0, rel=1e-9)  # isochoric flow: the pressure stays
    assert ratio[0] == pytest.approx(float(mat.friction(inertial)), rel=1e-6)
    assert np.all(out["work"] >= 0.0)


def test_friction_lies_between_the_limits(driver):
    """μs ≤ τ/p ≤ μ2 at every step of shears from I = 1e-6 to 1e3, and τ/p grows with the rate."""
    mat = beads()
    rates = np.logspace(-6, 3, 10) * math.sqrt(P0 / mat.grain_density) / mat.grain_diameter
    ratios = []
    for rate in rates:
        dt = 20.0 * mat.mu_2 * P0 / mat.shear_modulus / rate / 1000
        deps, dw = shear_path(rate, dt, n=1000)
        out = drive(driver, mat, -P0 * np.eye(2)[None], np.array([-P0]), deps, dw, dt=dt)
        sm, tau = mean_tau(out["sig"][0], out["szz"][0])
        assert np.all(tau / -sm <= mat.mu_2 * (1 + 1e-12))
        ratios.append(steady_ratio(out)[0][0])
    assert np.all(np.diff(ratios) > 0.0)
    assert ratios[0] == pytest.approx(mat.mu_s, rel=1e-4)
    assert ratios[-1] == pytest.approx(mat.mu_2, rel=1e-3)


def test_below_mu_s_stays_elastic(driver):
    """A shear that never reaches τ = μs p is elastic: no plastic work, the stress is Hooke's."""
    mat = beads()
    strain = 0.5 * mat.mu_s * P0 / mat.shear_modulus  # peak τ = G γ = μs p / 2
    n = 50
    deps, dw = shear_path(1.0, strain / n, n=n)
    dw[:] = 0.0
    out = drive(driver, mat, -P0 * np.eye(2)[None], np.array([-P0]), deps, dw, dt=strain / n)
    assert np.all(out["work"] == 0.0)
    assert out["sig"][0, -1, 0, 1] == pytest.approx(mat.shear_modulus * strain, rel=1e-12)


def test_tension_is_stress_free(driver):
    """A stretched point (p_trial ≤ 0) separates: σ = 0 (Dunatunga & Kamrin 2015 §3)."""
    mat = beads()
    deps = np.zeros((1, 3, 2, 2))
    deps[0, :, 0, 0] = deps[0, :, 1, 1] = 1e-3
    out = drive(driver, mat, -P0 * np.eye(2)[None], np.array([-P0]), deps, dt=1e-4)
    assert np.all(out["sig"][0, -1] == 0.0) and out["szz"][0, -1] == 0.0


def test_dilatancy_raises_pressure_by_k_q_psi_dgamma(driver):
    """With ψ > 0 a constrained simple shear builds pressure at dp/dγᵖ = K q_ψ and still flows on
    τ = μ(I) p: both checked step by step from the stresses alone (γᵖ from the slip τ_trial − τ)."""
    mat = beads(dilatancy_angle=5.0)
    rate, dt, n = 50.0, 2e-6, 400
    deps, dw = shear_path(rate, dt, n=n)
    out = drive(driver, mat, -P0 * np.eye(2)[None], np.array([-P0]), deps, dw, dt=dt)
    sm, tau = mean_tau(out["sig"][0], out["szz"][0])
    p = -sm
    g = mat.shear_modulus
    bulk = mat.lame_lambda + 2.0 / 3.0 * g
    # elastic trial of step k from step k−1's state: τ_tr = |s + 2G Δe| (Jaumann spin of a
    # deviator with s_xx = −s_yy, s_zz = 0 rotates it; compute it exactly from the tensors)
    sig, szz = out["sig"][0], out["szz"][0]
    flowing = 0
    for k in range(1, n):
        s_old = sig[k - 1]
        w = dw[0, k]
        rot = s_old + w @ s_old - s_old @ w
        tr = rot + 2.0 * g * deps[0, k]
        sm_tr = (np.trace(tr) + szz[k - 1]) / 3.0
        if -sm_tr * mat.mu_s >= mean_tau(tr[None], np.array([szz[k - 1]]))[1][0]:
            continue
        _, tau_tr = mean_tau(tr[None], np.array([szz[k - 1]]))
        slip = tau_tr[0] - tau[k]  # G Δγᵖ
        assert p[k] - (-sm_tr) == pytest.approx(bulk * mat.q_psi * slip / g, rel=1e-8, abs=1e-9 * P0)
        inertial = slip / g / dt * mat.grain_diameter / math.sqrt(p[k] / mat.grain_density)
        assert tau[k] / p[k] == pytest.approx(float(mat.friction(inertial)), rel=1e-8)
        flowing += 1
    assert flowing > n // 2
    assert p[-1] > 1.05 * P0


def test_f32_matches_the_law():
    """The single-precision build returns on the same law (tolerance: a few hundred f32 ulp)."""
    import warp as wp

    from mpmdem.kernels.plasticity import param_vector

    drv = make_point_driver("f32", "mu_i")
    mat = beads()
    inertial = 0.1
    rate = inertial * math.sqrt(P0 / mat.grain_density) / mat.grain_diameter
    n = 2000
    dt = 40.0 * mat.mu_2 * P0 / mat.shear_modulus / rate / n
    deps, dw = shear_path(rate, dt, n=n)
    m22 = wp.types.matrix((2, 2), wp.float32)
    outs = [wp.zeros((1, n), dtype=d, device="cpu") for d in (m22, wp.float32, wp.float32, wp.float32, m22)]
    arr = lambda a, d: wp.array(np.ascontiguousarray(a, dtype=np.float32), dtype=d, device="cpu")  # noqa: E731
    wp.launch(drv, dim=1, inputs=[
        arr(-P0 * np.eye(2)[None], m22), arr([-P0], wp.float32), arr([mat.packed()], param_vector("f32")),
        arr(deps, m22), arr(dw, m22), float(dt), wp.zeros(1, dtype=wp.int32, device="cpu"),
        wp.zeros(1, dtype=wp.float32, device="cpu")], outputs=outs, device="cpu")
    sm, tau = mean_tau(outs[0].numpy()[:, -1].astype(float), outs[1].numpy()[:, -1].astype(float))
    assert tau[0] / -sm[0] == pytest.approx(float(mat.friction(inertial)), rel=1e-4)


@pytest.mark.parametrize(("field", "value", "allowed"), [
    ("mu_2", 0.2, "mu_2 > mu_s"),
    ("mu_2", 0.38, "mu_2 > mu_s"),
    ("i0", 0.0, "I0 > 0"),
    ("i0", -1.0, "I0 > 0"),
    ("grain_diameter", 0.0, "d > 0"),
    ("grain_diameter", -1e-3, "d > 0"),
    ("grain_density", 100.0, "rho_s >="),
    ("mu_s", 0.0, "mu_s > 0"),
    ("dilatancy_angle", -1.0, "0 <= psi < 90"),
    ("i0", math.nan, "finite"),
])
def test_bad_parameters_name_themselves(field, value, allowed):
    kw = {"mu_s": 0.38, "mu_2": 0.64, "i0": 0.28, "grain_diameter": 5e-4, "grain_density": 2450.0}
    kw[field] = value
    with pytest.raises(InputError) as err:
        MuI(1e7, 0.3, 1470.0, **kw)
    assert field in str(err.value)
    assert allowed in str(err.value) or "finite" in allowed


def test_glass_beads_are_jops_values():
    """The preset carries Jop et al. 2006's fit: μs = tan 20.9°, μ2 = tan 32.76°, I0 = 0.279."""
    m = MuI.glass_beads()
    assert m.mu_s == pytest.approx(0.3819, abs=1e-4)
    assert m.mu_2 == pytest.approx(0.6435, abs=1e-4)
    assert m.i0 == 0.279
    assert float(m.friction(m.i0)) == pytest.approx(0.5 * (m.mu_s + m.mu_2))
