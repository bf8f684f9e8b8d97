"""EN-04 (docs/studies.md, docs/model.md s.12): the config's rules, the actuation runs being
the sphere studies' own, the load energy against the run's bookkeeping, the still-cavity
frequencies against their closed forms, and the report contract.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import simpson

from creatio.dynamics import simulate
from creatio.errors import ConfigError
from creatio.model import actuation as act
from creatio.model.oscillation import regularised_rolling, still_cavity
from creatio.model.surface import Motion
from creatio.pipeline.config import resolve
from creatio.reports.en04 import ACTUATION_KEYS, CONTROL_CASE_KEYS, CONTROL_DEMAND_KEYS
from creatio.studies import en04


@pytest.fixture(scope="module")
def cfg() -> en04.En04Config:
    return resolve("en04").obj


@pytest.mark.parametrize(("override", "key", "rule"), [
    ("study.actuation.sigma=-1", "study.actuation.sigma", ">= 0"),
    ("study.actuation.sample_interval=0.003", "study.actuation.sample_interval",
     "multiple of bases.en02.solver.dt"),
    ("study.actuation.studies=[en02,en03]", "study.actuation.studies[1]", "key of bases"),
    ("study.actuation.damped_c_d=0", "study.actuation.damped_c_d", "> 0"),
    ("study.actuation.quadrature.growth=1", "study.actuation.quadrature.growth", "> 1"),
    ("study.oscillation.mus=[0.15,0.3]", "study.oscillation.mus", "mu = 0"),
    ("study.oscillation.amplitude_m=0.01", "study.oscillation.amplitude_m", "1 %"),
    ("study.oscillation.mus=[0,3]", "study.oscillation.mus[1]", "stability limit"),
    ("bases.en02.phases.gamma.phi0=0.1", "bases.en02.phases.gamma", "flat annulus"),
    ("bases.en02.sphere.mu=-1", "bases.en02.sphere.mu", ">= 0"),
])
def test_bad_values_are_refused_in_one_line(override: str, key: str, rule: str) -> None:
    with pytest.raises(ConfigError) as info:
        resolve("en04", [override])
    msg = str(info.value)
    assert "\n" not in msg
    assert info.value.key == key, msg
    assert rule in msg, msg


def test_actuation_runs_are_the_studies_own(cfg) -> None:
    """The actuation problem is the base study's problem but for the sampling, and its
    trajectory equals the base's run bit for bit at the base's output times."""
    base = cfg.bases["en02"]
    own = base.sphere_problem()
    prob = en04.actuation_problem(base, cfg.study.actuation.sample_interval)
    assert prob.replace(interval=own.output.interval) == own
    a, b = simulate(own), simulate(prob)
    every = round(own.output.interval / prob.output.interval)
    ha, hb = a.histories, b.histories
    assert np.array_equal(hb.t[::every], ha.t)
    assert np.array_equal(hb.X[::every], ha.X) and np.array_equal(hb.omega[::every], ha.omega)
    assert hb.surface_work[-1] == ha.surface_work[-1]


@pytest.mark.parametrize("study", ["en02", "en02r"])
def test_load_energy_equals_the_runs_surface_work_to_the_schemes_accuracy(cfg, study) -> None:
    """W_surface = int (N n + f) . c_t dt from the recorded contact (c_t computed at the
    recorded (R, alpha, t)) against the surface work the run integrates with its state
    (docs/model.md s.5): they differ by the scheme's truncation, which falls at 4th order
    when dt halves (measured 21x and 11x from 2 ms to 0.5 ms); the time quadrature of the
    samples is exact to far below it (Simpson on 10 ms and on every step agree to 1e-15 J)."""
    base = cfg.bases[study]
    surface, motion = base.geometry.surface(), Motion(*base.phases.laws())
    gaps = []
    for dt in (0.002, 0.001):
        h = simulate(en04.actuation_problem(base, 0.01, dt)).histories
        P = act.load_power(surface, motion, h.t, h.R, h.alpha, h.N, h.f)
        W = simpson(P, x=h.t)
        assert abs(W) > 1e-6  # the membrane does work: not two zeros agreeing
        gaps.append(abs(W - h.surface_work[-1]))
    assert gaps[0] <= 1e-5 * abs(h.surface_work[-1])
    assert gaps[1] <= gaps[0] / 8.0  # order >= 3: the scheme's truncation, not a bug


@pytest.fixture(scope="module")
def oscillation(cfg):
    return en04.run_oscillation(cfg)


def test_still_cavity_closed_forms(cfg) -> None:
    """The closed forms for EN-02's cavity: kappa_R = A k^2, kappa_alpha = A Ka^2 / rho_c^2,
    sliding omega^2 = g kappa / (1 - b kappa), rolling 5/7 of it; the regularised
    prediction tends to sliding as the friction vanishes and to rolling as it stiffens."""
    cf = en04.closed_forms(cfg.bases["en02"])
    k = 2.0 * math.pi / 1.72
    assert cf.kappa_R == pytest.approx(0.18 * k * k, rel=1e-15)
    assert cf.kappa_alpha == pytest.approx(0.18 * 36.0 / 1.11**2, rel=1e-15)
    assert cf.slide_alpha == pytest.approx(math.sqrt(9.81 * cf.kappa_alpha
                                                     / (1 - 0.12 * cf.kappa_alpha)), rel=1e-15)
    assert cf.roll_R == pytest.approx(cf.slide_R * math.sqrt(5.0 / 7.0), rel=1e-15)
    assert regularised_rolling(cf.slide_R, 1e-9)[0] == pytest.approx(cf.slide_R, rel=1e-9)
    assert regularised_rolling(cf.slide_R, 1e9)[0] == pytest.approx(cf.roll_R, rel=1e-12)
    with pytest.raises(ValueError, match="offset singular"):
        still_cavity(0.18, k, 6, 1.11, 0.2, 9.81)


def test_sliding_closed_form_is_the_offset_surfaces_hessian_over_its_metric(cfg) -> None:
    """omega_slide^2 = g (d2 X_z / dq^2) / |X_q|^2 at the bottom, from the centre's exact jets
    (creatio.model.offset), which the closed form does not use: the offset surface's
    curvature kappa / (1 - b kappa) in both directions; the Hessian is diagonal there."""
    from creatio.model.offset import offset_jets
    from creatio.model.sphere import centre_tangents

    cf = en04.closed_forms(cfg.bases["en02"])
    k = 2.0 * math.pi / 1.72
    _, _, _, _, _, P, Q, Z = offset_jets(0.43, math.pi / 6, 0.68, k, 0.18, 6.0, 0.12, 0.0, 0.0,
                                         0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    tangents = centre_tangents(P, Q, Z)
    XR, Xa = np.array(tangents[0:3]), np.array(tangents[3:6])
    assert abs(Z[5]) < 1e-15 and abs(Z[1]) < 1e-15 and abs(Z[2]) < 1e-15
    assert 9.81 * Z[4] / (XR @ XR) == pytest.approx(cf.slide_R**2, rel=1e-13)
    assert 9.81 * Z[7] / (Xa @ Xa) == pytest.approx(cf.slide_alpha**2, rel=1e-13)


def test_still_cavity_frequencies_equal_the_closed_forms(oscillation) -> None:
    """Measured (zero crossings of every step) against the closed forms, within the stated
    tolerance 2 (kappa a)^2 (the shift is second order in the amplitude a), plus for rolling
    at mu = 0.15 the regularised friction's own offset from rolling without slip (its linear
    prediction, 7e-5 along alpha, 1.6e-5 along R); then the second-order shift itself."""
    ds = oscillation
    assert set(ds.status.values) == {"ok"}
    a0 = float(ds.amplitude.values.min())
    for i in range(ds.sizes["run"]):
        direction = str(ds.direction.values[i])
        kappa = ds.attrs["kappa_alpha" if direction == "alpha" else "kappa_R"]
        amp = float(ds.amplitude.values[i])
        omega, closed = float(ds.omega.values[i]), float(ds.omega_closed_form.values[i])
        reg = float(ds.omega_regularised.values[i])
        tol = en04.oscillation_tolerance(kappa, amp) + abs(reg - closed) / closed
        assert abs(omega - closed) <= tol * closed, (direction, float(ds.mu.values[i]), amp)
        assert int(ds.crossings.values[i]) >= 30
        # against the regularised-friction prediction (= the closed form at mu = 0)
        assert abs(omega - reg) <= en04.oscillation_tolerance(kappa, amp) * reg
        if amp == a0 and float(ds.mu.values[i]) > 0.0:  # the decay, too
            assert float(ds.decay.values[i]) == pytest.approx(
                float(ds.decay_regularised.values[i]), rel=1e-4)
    # the shift is second order: doubling the amplitude quadruples it, and removing it
    # leaves the closed form (or the regularised prediction) to 1e-8
    for m in range(ds.sizes["mode"]):
        d, mu = str(ds.mode_direction.values[m]), float(ds.mode_mu.values[m])
        sel = np.flatnonzero((ds.direction.values == d) & (ds.mu.values == mu))
        w1, w2 = ds.omega.values[sel]
        target = float(ds.omega_regularised.values[sel[0]])
        assert (w2 - target) / (w1 - target) == pytest.approx(4.0, rel=0.05)
        assert float(ds.omega_zero_amplitude.values[m]) == pytest.approx(target, rel=1e-8)


def test_rolling_limit_at_the_study_friction_is_reached_to_the_regularisation(cfg) -> None:
    """At mu = 0.15, eps = 0.01 m/s the regularised rolling frequency sits 6.8e-5 (alpha) and
    1.6e-5 (R) above rolling without slip; ten times the friction brings it 100x closer
    (the offset falls as (mu g / eps)^-2)."""
    cf = en04.closed_forms(cfg.bases["en02"])
    sp = cfg.bases["en02"].sphere
    off = [abs(regularised_rolling(cf.slide_alpha, mu * sp.g / sp.eps)[0] / cf.roll_alpha - 1)
           for mu in (0.15, 1.5)]
    assert 5e-5 < off[0] < 1e-4
    assert off[0] / off[1] == pytest.approx(100.0, rel=0.05)


def test_report_contract_on_short_cycles(tmp_path) -> None:
    """The whole study on 10-s cycles: the JSON has actuation.<study> with exactly the contract
    keys, oscillation.alpha / .R with theirs, control with its contract on a small grid, and
    the closed forms it prints agree with the measured figures."""
    from creatio.pipeline.run import run_resolved

    ovs = ["bases.en02.phases.T=10", "bases.en02r.phases.T=10", "study.oscillation.duration=8",
           "study.control.omega_max=[2.0]", "study.control.delta_max_deg=[5.0,20.0]",
           "study.control.omega_c=[4.0]", "study.control.omega_n=[20.0]",
           "study.control.trapezoid.omega_max=[1.5]", "study.control.trapezoid.a_max=[1.5]",
           "study.control.robustness.mus=[0.15]", "study.control.robustness.mass_factors=[1.0]",
           "study.control.quintic.tol=0.5"]
    root = run_resolved(resolve("en04", ovs), tmp_path)
    report = json.loads((root / "reports" / "en04.json").read_text())
    assert set(report["actuation"]) == {"en02", "en02r"}
    for fig in report["actuation"].values():
        assert list(fig) == [k for k, _ in ACTUATION_KEYS]
        assert fig["K_m_max_J"] == pytest.approx(fig["K_m_max_closed_form_J"], rel=1e-10)
        assert fig["quadrature_rel_change"] <= 1e-10
        # 12 pi over 10 s: the bandwidth scales with the pattern's speed (0.09375 Hz x 12)
    assert report["actuation"]["en02"]["bandwidth_hz"] == pytest.approx(1.125, rel=1e-12)
    for d in ("alpha", "R"):
        assert list(report["oscillation"][d]) == ["slide_rad_s", "slide_closed_form_rad_s",
                                                  "roll_rad_s", "roll_closed_form_rad_s"]
        assert report["oscillation_checks"][d]["within_tolerance"] is True
    c = report["control"]
    assert list(c) == ["cases", "fastest_arrival_s", "fastest_case", "open_loop_boundary_T_s",
                       "trapezoid_best", "robustness"]
    assert len(c["cases"]) == 2
    for case in c["cases"]:
        assert list(case) == [k for k, _ in CONTROL_CASE_KEYS + CONTROL_DEMAND_KEYS]
        # what the actuator delivered along the closed loop (each controlled run's own)
        assert case["E_actuator_J"] > 0.0 and case["K_m_max_J"] > 0.0
        # 2 A: the sweep is 12 pi (W's extremes met at the path samples to about 1e-7)
        assert case["stroke_m"] == pytest.approx(0.36, rel=1e-6)
    assert set(c["fastest_case"]) >= {k for k, _ in CONTROL_DEMAND_KEYS}
    assert all(r["closed_loop_P_actuator_peak_W"] > 0.0 for r in c["robustness"])
    demand = report["control_checks"]["demand"]
    assert demand["quadrature_converged"] and demand["max_K_m_closed_form_rel_error"] < 1e-12
    carried = [case["arrival_s"] for case in c["cases"] if case["carried"]]
    assert carried and c["fastest_arrival_s"] == min(carried)
    assert set(c["trapezoid_best"]) >= {"Omega_max_rad_s", "a_max_rad_s2", "arrival_s"}
    assert 4.0 < c["open_loop_boundary_T_s"] < 14.0
    assert [set(r) >= {"mu", "mass_factor", "closed_loop_carried", "open_loop_carried"}
            for r in c["robustness"]] == [True]
    # the accuracy budgets: the bisection's (1e-2 of its 0.5 s resolution) on its final
    # bracket, the arrivals' (1e-2 of the 2-ms step) on every case of a grid this small
    checks = report["control_checks"]
    boundary, arrival = checks["quintic_boundary_accuracy"], checks["arrival_accuracy"]
    assert boundary["budget_s"] == pytest.approx(5e-3) and boundary["points"] == 2
    assert boundary["ok"] and boundary["observed_s"] == 0.0
    assert arrival["budget_s"] == pytest.approx(2e-5) and arrival["points"] == 2
    assert arrival["reference_dt_s"] == pytest.approx(5e-4)
    assert arrival["ok"] == (arrival["observed_s"] <= arrival["budget_s"])
    md = (root / "reports" / "en04.md").read_text()
    assert boundary["line"] in md and arrival["line"] in md
    for suffix in (".md", ".png", "_history.csv", "_trajectory.png", "_convergence.png",
                   "_control.png", "_control_paths.png", "_control_powers.png"):
        assert (root / "reports" / f"en04{suffix}").stat().st_size > 0
