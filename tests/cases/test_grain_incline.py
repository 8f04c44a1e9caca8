"""The μ(I) calibration of the DEM grains (issue 43 §2): the Jop fit of ``mpmdem.study.mu_i_fit`` on
synthetic points, the flow states of ``mpmdem.study.incline_flow``, and the ``grain-incline`` case
at a quick size on the CPU (f64, a strip 20 grains long)."""

from __future__ import annotations

import json
import math

import numpy as np

from mpmdem.study.incline_flow import flow_state
from mpmdem.study.mu_i_fit import fit_jop, jop_mu

#: known parameters: Jop et al. 2006's glass beads (``MuI.glass_beads``)
TRUE = (0.38, 0.64, 0.279)


def test_fit_recovers_known_parameters_within_their_noise():
    """Verify the fit recovers (μs, μ2, I0) from 12 points whose I carry a Gaussian scatter σ_I = 0.01
    (μ exact, as tan θ): each value within 3 of its own 1-σ of the truth (a 3-σ band holds 99.7 % of
    fits of this seed's kind), and the 1-σ are the size the noise makes them (not 0, not huge)."""
    rng = np.random.default_rng(7)
    true_i = np.geomspace(0.01, 1.5, 12)
    mu = jop_mu(true_i, *TRUE)
    sigma_i = np.full(12, 0.01)
    fit = fit_jop(true_i + rng.normal(0.0, sigma_i), mu, sigma_i)
    for name, value in zip(("mu_s", "mu_2", "i0"), TRUE, strict=True):
        assert abs(fit[name] - value) <= 3.0 * fit[f"{name}_std"], (name, fit)
        assert 0.0 < fit[f"{name}_std"] < 0.2 * value, (name, fit)
    assert fit["mu2_constrained"], fit


def test_fit_says_when_mu2_is_unconstrained():
    """Verify points all well below I0 (the plateau never reached) give mu2_constrained False, with a note."""
    i = np.geomspace(0.005, 0.05, 6)
    fit = fit_jop(i, jop_mu(i, *TRUE) + np.array([1, -1, 1, -1, 1, -1]) * 1e-3)
    assert not fit["mu2_constrained"] and "unconstrained" in fit["note"]
    assert fit_jop([0.1, 0.2], [0.4, 0.5])["mu_s"] is None  # (two points: no fit)


def test_flow_state_reads_stopped_steady_accelerating():
    """Verify the three states on made-up mean speeds against a drive g sin θ = 3 m/s²: at rest; flat with
    10 % noise; gaining 0.06 m/s² (2 % of the drive, over the 1 % limit)."""
    t = np.linspace(0.0, 1.0, 50)
    noise = 0.03 * np.sin(37.0 * t)
    assert flow_state(t, 1e-6 * np.ones(50), 0.6, 0.1, 3.0)["state"] == "stopped"
    assert flow_state(t, 0.3 + noise, 0.6, 0.1, 3.0)["state"] == "steady"
    assert flow_state(t, 0.3 + 0.06 * t + 0.1 * noise, 0.6, 0.1, 3.0)["state"] == "accelerating"


def incline(tmp_path, angle: float, flags: list[str]) -> dict:
    """The summary of a quick run at ``angle`` [deg] on a strip 12 grains long, a layer 8 deep."""
    from mpmdem.cli import main

    out = tmp_path / f"theta{angle:g}"
    rc = main(["run", "grain-incline", "--quick", "--device", "cpu", "--quiet", "--angle", str(angle),
               "--length", "12", "--height", "8", *flags, "--out", str(out)])
    assert rc == 0
    return json.loads((out / "summary.json").read_text())


def test_below_the_stopping_angle_the_layer_stops(tmp_path):
    """Verify a layer on a 14° slope, below the disks' angle of repose (17.9 ± 0.6°,
    bench/results/studies/grain-calibration), comes to rest: the summary says stopped."""
    s = incline(tmp_path, 14.0, ["--duration", "40"])
    assert s["state"] == "stopped" and not s["steady"], s["state"]


def test_above_it_the_layer_flows_steadily(tmp_path):
    """Verify a layer on a 22° slope (above the angle of repose, below the largest angle of steady flow
    of disks: a quick run of 500 sqrt(d/g) settles at a constant mean speed there) flows steadily over
    the last 150 sqrt(d/g) of 300, with a positive inertial number in its core, and φ below the
    settled pack's 0.82 (a flowing layer dilates). Twice the default step (dem_kappa 0.2, π κ2 = 0.63
    of the stable bound) halves the test's time; the states do not hinge on the step's size."""
    s = incline(tmp_path, 22.0, ["--duration", "300", "--average", "0.5", "--dem-kappa", "0.2"])
    assert s["state"] == "steady", (s["state"], s["acceleration_over_drive"], s["acceleration_over_drive_std"])
    assert s["I"] > 0.0 and s["I"] > 3.0 * s["I_std"] / math.sqrt(s["core_bins"]), (s["I"], s["I_std"])
    assert 0.6 < s["phi"] < 0.82


def test_study_analysis_fits_the_steady_runs(tmp_path):
    """Verify the grain-incline analysis reads run summaries, fits the steady ones only (the stopped and
    the accelerating ones listed as bounds) and writes mu_i_fit.json and the chart: made-up runs on
    Jop's glass-bead law, I exact, so the fit returns the law to 1e-6 (curve_fit's tolerance)."""
    from mpmdem.study.builtin.grain_incline import analyze

    angles = [22.0, 24.0, 26.0, 28.0, 30.0]  # (tan θ between μs and μ2)
    inverse = {a: TRUE[2] * (math.tan(math.radians(a)) - TRUE[0]) / (TRUE[1] - math.tan(math.radians(a)))
               for a in angles}  # (I of μ = tan θ on the law)
    runs = [(a, "steady", inverse[a]) for a in angles] + [(19.0, "stopped", 0.0), (40.0, "accelerating", 2.0)]
    for angle, state, inertial in runs:
        folder = tmp_path / "runs" / f"angle={angle:g}"
        folder.mkdir(parents=True)
        summary = {"status": "completed", "grain_shape": "disk", "grain_radius_m": 0.001, "angle_deg": angle,
                   "mu": math.tan(math.radians(angle)), "state": state, "I": inertial, "I_std": 0.0, "phi": 0.78,
                   "phi_std": 0.01, "flow_height_in_d": 20.0, "acceleration_over_drive": 0.0, "grains": 600,
                   "base_grains": 30, "steps": 1000, "wall_seconds": 2.0, "device": "cpu"}
        (folder / "summary.json").write_text(json.dumps(summary))
    analyze([], tmp_path)
    per = json.loads((tmp_path / "mu_i_fit.json").read_text())["per_grain"]["disk:0.001"]
    assert per["stopped_angles_deg"] == [19.0] and per["accelerating_angles_deg"] == [40.0]
    fit = per["fit"]
    assert fit["points"] == 5
    np.testing.assert_allclose([fit["mu_s"], fit["mu_2"], fit["i0"]], TRUE, rtol=1e-4)
    assert (tmp_path / "mu_i.png").stat().st_size > 0


def test_studies_plan_six_angles_each():
    """Verify the grain-incline studies are registered and their runs parse with the case's flags."""
    from mpmdem.study.study import load_study, plan_runs

    for name, shape in (("grain-incline", "disk"), ("grain-incline-polygon", "polygon")):
        runs = plan_runs(load_study(name), "cuda")
        assert len(runs) == 6 and all(("--grain-shape", shape) == r.argv[2:4] for r in runs), runs[0].argv
        assert all(("--grain-radius", "0.001") == r.argv[4:6] for r in runs), runs[0].argv
