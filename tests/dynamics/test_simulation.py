"""Sphere dynamics: EN-02 figures, physics identities, stability limit and stop conditions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, UnstableStepError, simulate, stability_limit
from creatio.dynamics import sphere as core
from creatio.dynamics.kinematics import centre_kinematics
from creatio.dynamics.solvers.tableaus import RK4_REAL_STABILITY
from creatio.model.laws import Law


@pytest.fixture(scope="module")
def lively(en02_problem: SphereProblem) -> SphereProblem:
    """A lively case: every law active, time-varying inclination, initial slip and spin."""
    return en02_problem.replace(
        phi_r=Law(0.1, 0.02, 0.1, 2.0, 0.02, 1.3), phi_a=Law(0.0, 0.05, 0.1, 1.5, 0.02, 0.9),
        gamma=Law(0.2, 0.0, 0.05, 2.0, 0.02, 1.7), mu=0.3, R=0.45, alpha=0.5, Rdot=0.02,
        alphadot=0.03, omega=(0.5, -1.0, 0.5), t_end=2.0, dt=1e-3, interval=1e-3)


GRAVITY = np.array([0.0, 0.0, -9.81])


def _kin(p: SphereProblem, R: float, alpha: float, t: float) -> dict[str, np.ndarray]:
    return centre_kinematics(p.model.surface, p.model.motion, p.model.sphere.b, R, alpha, t
    )


@pytest.fixture(scope="module")
def en02_pair(en02_problem: SphereProblem):
    return simulate(en02_problem), simulate(en02_problem.replace(dt=0.001))


@pytest.fixture(scope="module")
def en02r_pair(en02r_problem: SphereProblem):
    return simulate(en02r_problem), simulate(en02r_problem.replace(dt=0.001))


def test_en02_published_figures(en02_pair) -> None:
    res, half = en02_pair
    assert res.status == "ok" and res.stop_time == 120.0 and res.steps == 60_000
    assert res.rhs_evals == 4 * 60_000 + 1
    assert len(res.t) == 1201 and res.t[-1] == pytest.approx(120.0, abs=1e-12)
    displacement = math.degrees(res.azimuth[-1] - res.azimuth[0])
    assert displacement == pytest.approx(-360.0, abs=1e-3)
    assert round(float(np.hypot(*res.X[-1, :2])), 3) == 1.110
    assert round(res.min_N, 3) == 9.810
    timestep_difference = np.abs(res.X - half.X).max()
    assert timestep_difference <= 6.04e-11  # published upper bound
    assert timestep_difference < 1e-12  # exact derivatives: ~1e-13
    assert res.max_energy_residual <= 1.48e-7
    assert res.max_energy_residual < 1e-12
    assert res.min_edge_clearance > 0.3 and res.max_b_kappa < 1.0
    np.testing.assert_allclose(res.cavity_R, 0.43, atol=1e-12)


def test_en02r_transport(en02r_pair) -> None:
    res, half = en02r_pair
    assert res.status == "ok"
    assert math.degrees(res.azimuth[-1] - res.azimuth[0]) == pytest.approx(360.0, abs=1e-3)
    assert np.hypot(*res.X[0, :2]) == pytest.approx(1.11, abs=1e-12)
    assert np.hypot(*res.X[-1, :2]) == pytest.approx(1.97, abs=1e-4)
    s = res.t / 120.0
    np.testing.assert_allclose(res.cavity_R, 0.43 + 0.86 * s**3 * (10 - 15 * s + 6 * s**2))
    assert res.max_cavity_tracking_error < 2e-3
    assert np.abs(res.R - res.cavity_R).max() <= res.max_cavity_tracking_error
    assert 0.0 < res.min_edge_clearance <= 0.31
    assert np.abs(res.X - half.X).max() < 1e-12
    assert res.max_energy_residual < 1e-12


def test_extrema_cover_every_step(en02_pair) -> None:
    res, _ = en02_pair
    assert res.min_N <= res.N.min() and res.max_N >= res.N.max()
    assert res.max_slip_speed >= res.slip_speed.max()
    assert res.max_energy_residual >= np.abs(res.energy_residual).max()


def test_newton_identity_on_running_state(lively: SphereProblem) -> None:
    """m (X'' - g) = N n + f, I omega' = (-b n) x f, m' = omega x m, from differences."""
    h = 2.5e-4
    res = simulate(lively.replace(dt=h, interval=h))
    assert res.status == "ok" and res.max_slip_speed > 0.1 and not res.warnings
    assert res.slip_speed[20] > 0.05 and res.slip_speed[2800] < 0.01
    sphere = lively.model.sphere
    inertia = 0.4 * sphere.m * sphere.b**2
    for i in (20, 2800, 6000):  # sliding (|v_s| >> eps) at 5 ms, then near rolling
        acc = (-res.X[i - 2] + 16 * res.X[i - 1] - 30 * res.X[i] + 16 * res.X[i + 1]
               - res.X[i + 2]) / (12 * h * h)  # fmt: skip
        n = _kin(lively, res.R[i], res.alpha[i], res.t[i])["n"]
        np.testing.assert_allclose(sphere.m * (acc - GRAVITY), res.N[i] * n + res.f[i], atol=1e-6)
        dw = (res.omega[i - 2] - 8 * res.omega[i - 1] + 8 * res.omega[i + 1]
              - res.omega[i + 2]) / (12 * h)  # fmt: skip
        np.testing.assert_allclose(inertia * dw, np.cross(-sphere.b * n, res.f[i]), atol=1e-7)
        # the body marker turns with the world-frame omega: dm/dt = omega x m
        dm = (res.marker[i - 2] - 8 * res.marker[i - 1] + 8 * res.marker[i + 1]
              - res.marker[i + 2]) / (12 * h)  # fmt: skip
        np.testing.assert_allclose(dm, np.cross(res.omega[i], res.marker[i]), atol=1e-8)
        # friction is tangential, bounded by mu N, and opposes the slip
        assert abs(res.f[i] @ n) < 1e-12
        assert np.linalg.norm(res.f[i]) <= sphere.mu * res.N[i]
        vel = (res.X[i - 2] - 8 * res.X[i - 1] + 8 * res.X[i + 1] - res.X[i + 2]) / (12 * h)
        np.testing.assert_allclose(res.V[i], vel, atol=1e-9)


def test_energy_balance_converges_at_fourth_order(lively: SphereProblem) -> None:
    coarse = simulate(lively.replace(dt=2e-3, interval=2e-3))
    fine = simulate(lively)
    assert coarse.friction_dissipation[-1] > 1e-3 and abs(coarse.surface_work[-1]) > 1e-2
    np.testing.assert_allclose(
        coarse.energy_residual,
        coarse.energy - coarse.energy[0] - coarse.surface_work + coarse.friction_dissipation,
        atol=1e-15,
    )
    np.testing.assert_allclose(coarse.energy, coarse.kinetic + coarse.potential)
    assert fine.max_energy_residual < 1e-6
    assert coarse.max_energy_residual / fine.max_energy_residual > 10.0  # ~2^4


def test_frictionless_no_spin_and_auto_rotation_off(en02_problem: SphereProblem) -> None:
    p = en02_problem.replace(mu=0.0, t_end=20.0)
    auto = simulate(p)
    assert not auto.rotation_integrated and auto.energy_integrated
    assert np.all(auto.omega == 0.0) and np.all(auto.cumulative_spin == 0.0)
    np.testing.assert_array_equal(auto.Q, np.tile([1.0, 0.0, 0.0, 0.0], (len(auto.t), 1)))
    np.testing.assert_array_equal(auto.marker, np.tile([0.0, 0.0, 1.0], (len(auto.t), 1)))
    forced = simulate(p.replace(rotation=True))
    assert forced.rotation_integrated
    assert np.all(forced.omega == 0.0) and np.all(forced.cumulative_spin == 0.0)
    np.testing.assert_array_equal(forced.marker[-1], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(forced.X, auto.X, rtol=0, atol=1e-15)
    assert np.all(forced.slip_speed[1:] > 0.0)  # it slides: the pattern moves under it
    assert forced.max_energy_residual < 1e-12


def test_trajectory_only_matches_full_run_when_frictionless(en02_problem: SphereProblem) -> None:
    p = en02_problem.replace(mu=0.0, t_end=30.0)
    full = simulate(p.replace(rotation=True, energy=True))
    bare = simulate(p.replace(rotation=False, energy=False))
    assert not bare.rotation_integrated and not bare.energy_integrated
    np.testing.assert_allclose(bare.X, full.X, rtol=0, atol=1e-15)
    np.testing.assert_allclose(bare.N, full.N, rtol=0, atol=1e-13)
    assert np.isnan(bare.max_energy_residual)
    for name in ("kinetic", "potential", "energy", "surface_work", "friction_dissipation",
                 "energy_residual"):  # fmt: skip
        assert np.all(np.isnan(getattr(bare, name)))


def test_rotation_false_refused_with_friction(en02_problem: SphereProblem) -> None:
    with pytest.raises(ValueError, match="rotation=False"):
        en02_problem.replace(rotation=False)


def test_quaternion_and_marker_follow_a_free_spin(en02_problem: SphereProblem) -> None:
    """Frictionless, spin w about x: Q = (cos wt/2, sin wt/2, 0, 0), marker (0, -sin wt, cos wt)."""
    w = 3.0
    p = en02_problem.replace(mu=0.0, omega=(w, 0.0, 0.0), t_end=10.0)
    res = simulate(p)
    assert res.rotation_integrated
    half = 0.5 * w * res.t
    zero = np.zeros_like(half)
    np.testing.assert_allclose(res.Q, np.stack([np.cos(half), np.sin(half), zero, zero], 1),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(res.marker, np.stack([zero, -np.sin(2 * half), np.cos(2 * half)], 1),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(res.cumulative_spin, w * res.t, rtol=1e-12)


def test_quaternion_stays_unit(en02_pair) -> None:
    res, _ = en02_pair
    np.testing.assert_allclose(np.linalg.norm(res.Q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(res.marker, axis=1), 1.0, atol=1e-14)
    assert res.cumulative_spin[-1] > 10.0 and np.all(np.diff(res.cumulative_spin) >= 0.0)


def test_output_sampling_and_interval_validation(en02_problem: SphereProblem) -> None:
    res = simulate(en02_problem.replace(t_end=1.05, interval=0.1))
    np.testing.assert_allclose(res.t, np.r_[np.arange(11) * 0.1, 1.05], atol=1e-12)
    with pytest.raises(ValueError, match=r"interval = 0\.101 s is not .* dt = 0\.002"):
        en02_problem.replace(interval=0.101)
    with pytest.raises(ValueError, match="t_end"):
        en02_problem.replace(t_end=1.0001)


# ---------------------------------------------------------------- stability limit


def test_stability_limit_formula_and_slip_eigenvalue(en02_problem: SphereProblem) -> None:
    # 3.5 mu N / (m eps) with N = 1.25 m g at the EN-02 start (N0 = m g at a cavity bottom)
    expected = RK4_REAL_STABILITY / (3.5 * 0.15 * 1.25 * 9.81 / 0.01)
    assert stability_limit(en02_problem) == pytest.approx(expected, rel=1e-12)
    assert stability_limit(en02_problem.replace(mu=0.0)) == math.inf
    # RK4 amplification factor at the stated real-axis limit has modulus 1
    z = -RK4_REAL_STABILITY
    assert abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) == pytest.approx(1.0, abs=1e-12)
    # the stiffest eigenvalue of the linearised dynamics at rest (zero slip) is -3.5 mu N/(m eps)
    y = en02_problem.initial_state(True, True)
    p, laws = en02_problem.parameter_vector(), en02_problem.law_matrix()
    jac = np.empty((y.size, y.size))
    for j in range(y.size):
        e = np.zeros(y.size)
        e[j] = 1e-7
        jac[:, j] = (core.evaluate(p, laws, y + e, 0.0)[0]
                     - core.evaluate(p, laws, y - e, 0.0)[0]) / 2e-7  # fmt: skip
    stiffest = np.sort(np.linalg.eigvals(jac).real)[:2]
    np.testing.assert_allclose(stiffest, -3.5 * 0.15 * 9.81 / 0.01, rtol=1e-3)


def test_unstable_step_refused_with_a_useful_message(en02_problem: SphereProblem) -> None:
    limit = stability_limit(en02_problem)
    with pytest.raises(UnstableStepError) as err:
        simulate(en02_problem.replace(dt=0.005, t_end=1.0))
    message = str(err.value)
    for word in ("mu = 0.15", "eps = 0.01", "dt = 0.005", f"{limit:.6g}"):
        assert word in message
    res = simulate(en02_problem.replace(dt=0.005, t_end=1.0, allow_unstable=True))
    assert res.status == "ok" and any("allow_unstable" in w for w in res.warnings)


def test_runs_beyond_the_limit_chatter(en02_problem: SphereProblem) -> None:
    short = en02_problem.replace(t_end=24.0, interval=0.024)
    ref = simulate(short.replace(dt=0.0005))
    true_limit = stability_limit(en02_problem) * 1.25  # without the a-priori margin, N = m g
    below = simulate(short.replace(dt=0.004))  # 0.92 x stability_limit
    assert not below.warnings
    assert below.max_slip_speed == pytest.approx(ref.max_slip_speed, rel=1e-3)
    assert np.abs(below.X - ref.X).max() < 1e-10
    for dt in (0.006, 0.008):  # 1.11 and 1.48 x the limit at N = m g
        assert dt > 1.1 * true_limit
        above = simulate(short.replace(dt=dt, allow_unstable=True))
        assert above.warnings
        assert above.max_slip_speed > 100 * ref.max_slip_speed  # chatter at the eps scale
        assert np.abs(above.X - ref.X).max() > 1e-6


# ---------------------------------------------------------------- stop conditions


def _assert_stopped(res, status: str) -> None:
    assert res.status == status
    assert res.t[-1] == res.stop_time
    assert res.steps == round(res.stop_time / res.dt)
    assert res.rhs_evals == 4 * res.steps + 1


def test_stop_contact_lost_on_a_fast_cycle(en02_problem: SphereProblem) -> None:
    fast = Law.quintic(0.0, 12 * math.pi, 1.0)
    res = simulate(en02_problem.replace(phi_a=fast, t_end=1.0))
    _assert_stopped(res, "contact_lost")
    assert 0.0 < res.stop_time < 1.0 and res.N[-1] <= 0.0 and np.all(res.N[:-1] > 0.0)
    assert res.min_N <= 0.0


def test_stop_offset_singular_when_cavity_too_tight(en02_problem: SphereProblem) -> None:
    # the cavity moves inward (R_c = 0.43 -> 0), where its angular curvature A Ka^2 / rho^2
    # grows until b kappa reaches 1
    res = simulate(en02_problem.replace(phi_r=Law.quintic(0.0, math.pi, 10.0), t_end=10.0))
    _assert_stopped(res, "offset_singular")
    assert 1.0 < res.stop_time < 10.0 and 1.0 <= res.max_b_kappa < 1.01
    big = simulate(en02_problem.replace(b=0.2))  # b A Ka^2 / rho^2 = 1.05 at the start
    _assert_stopped(big, "offset_singular")
    assert big.stop_time == 0.0 and len(big.t) == 1


def test_stop_edge_crossed_and_left_annulus(en02_problem: SphereProblem) -> None:
    flat = en02_problem.replace(A=0.0, mu=0.0, t_end=1.0)  # a flat annulus: N = m g
    edge = simulate(flat.replace(R=0.501, Rdot=-1.0))
    _assert_stopped(edge, "edge_crossed")  # envelope reaches R = 0 once R < b = 0.12
    assert edge.stop_time == pytest.approx(0.382, abs=1e-9) and edge.R[-1] > 0.0
    assert edge.min_edge_clearance < 0.0
    jump = simulate(flat.replace(R=0.2, Rdot=-1.0, dt=0.25, interval=0.25))  # fmt: skip
    _assert_stopped(jump, "left_annulus")
    assert jump.stop_time == 0.25 and jump.R[-1] < 0.0
    outside = simulate(en02_problem.replace(R=1.75, mu=0.0))
    _assert_stopped(outside, "left_annulus")
    assert outside.stop_time == 0.0


def test_stop_non_finite_at_a_huge_step(en02_problem: SphereProblem) -> None:
    dt = 1e100
    p = en02_problem.replace(dt=dt, t_end=2 * dt, interval=dt, alphadot=1.0,
                             allow_unstable=True)
    res = simulate(p)
    _assert_stopped(res, "non_finite")
    assert res.stop_time == dt and res.steps == 1
    assert res.warnings and not np.all(np.isfinite(res.X[-1]))
    assert np.all(np.isfinite(res.X[0]))


def test_cosine_ramp_pattern_runs_at_the_scheme_order() -> None:
    """EN-02 with the angular phase on a cosine ramp of T = 30 s (docs/model.md s.2; config
    only: kind = cosine_ramp). The compiled core evaluates the law's value, rate and
    acceleration consistently, taking the ramp's own acceleration at t = 0 and T where it
    jumps, so RK4 keeps its order: the centre's dt - dt/2 difference falls 2^4 = 16-fold
    from dt = 4 ms to 2 ms (measured 16.2; a law taking the held side's zero acceleration
    at the ends makes it first order, ratio 2.0)."""
    from creatio.pipeline.config import resolve

    cfg = resolve("en02", ["phases.a.kind=cosine_ramp", "phases.T=30", "study.duration=30"]).obj
    assert cfg.phases.a.to_law(cfg.phases.T).kind.value == "cosine_ramp"
    runs = [simulate(cfg.sphere_problem(dt)) for dt in (0.004, 0.002, 0.001)]
    assert all(r.status == "ok" for r in runs)
    d1 = np.abs(runs[0].X - runs[1].X).max()
    d2 = np.abs(runs[1].X - runs[2].X).max()
    assert 14.0 < d1 / d2 < 18.0, d1 / d2
