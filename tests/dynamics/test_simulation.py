"""Sphere dynamics: EN-02 figures, physics identities, stability limit and stop conditions."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, UnstableStepError, simulate, stability_limit
from creatio.dynamics import sphere as core
from creatio.dynamics.kinematics import centre_kinematics
from creatio.dynamics.layout import NEV
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
    c = res.counts
    assert c.status == "ok" and c.stop_time == 120.0 and c.steps == 60_000
    assert c.rhs_evals == 4 * 60_000 + 1
    h = res.histories
    assert len(h.t) == 1201 and h.t[-1] == pytest.approx(120.0, abs=1e-12)
    displacement = math.degrees(h.azimuth[-1] - h.azimuth[0])
    assert displacement == pytest.approx(-360.0, abs=1e-3)
    assert round(float(np.hypot(*res.histories.X[-1, :2])), 3) == 1.110
    assert round(res.extrema.min_N, 3) == 9.810
    timestep_difference = np.abs(res.histories.X - half.histories.X).max()
    assert timestep_difference <= 6.04e-11  # published upper bound
    assert timestep_difference < 1e-12  # exact derivatives: ~1e-13
    assert res.extrema.max_energy_residual <= 1.48e-7
    assert res.extrema.max_energy_residual < 1e-12
    assert res.extrema.min_edge_clearance > 0.3 and res.extrema.max_b_kappa < 1.0
    np.testing.assert_allclose(res.histories.cavity_R, 0.43, atol=1e-12)


def test_en02r_transport(en02r_pair) -> None:
    res, half = en02r_pair
    h = res.histories
    assert res.counts.status == "ok"
    assert math.degrees(h.azimuth[-1] - h.azimuth[0]) == pytest.approx(360.0, abs=1e-3)
    assert np.hypot(*h.X[0, :2]) == pytest.approx(1.11, abs=1e-12)
    assert np.hypot(*h.X[-1, :2]) == pytest.approx(1.97, abs=1e-4)
    s = h.t / 120.0
    np.testing.assert_allclose(h.cavity_R, 0.43 + 0.86 * s**3 * (10 - 15 * s + 6 * s**2))
    assert res.extrema.max_cavity_tracking_error < 2e-3
    assert np.abs(h.R - h.cavity_R).max() <= res.extrema.max_cavity_tracking_error
    assert 0.0 < res.extrema.min_edge_clearance <= 0.31
    assert np.abs(h.X - half.histories.X).max() < 1e-12
    assert res.extrema.max_energy_residual < 1e-12


def test_extrema_cover_every_step(en02_pair) -> None:
    res, _ = en02_pair
    h = res.histories
    assert res.extrema.min_N <= h.N.min() and res.extrema.max_N >= h.N.max()
    assert res.extrema.max_slip_speed >= h.slip_speed.max()
    assert res.extrema.max_energy_residual >= np.abs(h.energy_residual).max()


def test_result_records_hold_every_history_row_for_row(en02_pair) -> None:
    """Every history has one row per output time at its width (vectors 3, the quaternion 4);
    off the structure path its histories are NaN and the world azimuth is the structure
    frame's; a run without flight has an empty event table and never left its cavity."""
    res, _ = en02_pair
    h = res.histories
    n = h.t.size
    widths = {"X": 3, "V": 3, "f": 3, "omega": 3, "marker": 3, "Q": 4}
    for f in dataclasses.fields(h):
        shape = (n, widths[f.name]) if f.name in widths else (n,)
        assert getattr(h, f.name).shape == shape, f.name
    for name in ("theta", "theta_rate", "hz_structure", "hz_orbital", "hz_spin",
                 "confinement_work"):  # fmt: skip
        assert np.isnan(getattr(h, name)).all(), name
    np.testing.assert_array_equal(h.world_azimuth, h.azimuth)
    assert not res.counts.structure_free and np.isnan(res.extrema.max_hz_drift)
    assert res.events.table.shape == (0, NEV) and not res.events.flight
    assert math.isnan(res.events.left_cavity_time) and res.carried


def test_newton_identity_on_running_state(lively: SphereProblem) -> None:
    """m (X'' - g) = N n + f, I omega' = (-b n) x f, m' = omega x m, from differences."""
    h = 2.5e-4
    res = simulate(lively.replace(dt=h, interval=h))
    r = res.histories
    assert res.counts.status == "ok" and res.extrema.max_slip_speed > 0.1
    assert not res.counts.warnings
    assert r.slip_speed[20] > 0.05 and r.slip_speed[2800] < 0.01
    sphere = lively.model.sphere
    inertia = 0.4 * sphere.m * sphere.b**2
    for i in (20, 2800, 6000):  # sliding (|v_s| >> eps) at 5 ms, then near rolling
        acc = (-r.X[i - 2] + 16 * r.X[i - 1] - 30 * r.X[i] + 16 * r.X[i + 1]
               - r.X[i + 2]) / (12 * h * h)  # fmt: skip
        n = _kin(lively, r.R[i], r.alpha[i], r.t[i])["n"]
        np.testing.assert_allclose(sphere.m * (acc - GRAVITY), r.N[i] * n + r.f[i], atol=1e-6)
        dw = (r.omega[i - 2] - 8 * r.omega[i - 1] + 8 * r.omega[i + 1]
              - r.omega[i + 2]) / (12 * h)  # fmt: skip
        np.testing.assert_allclose(inertia * dw, np.cross(-sphere.b * n, r.f[i]), atol=1e-7)
        # the body marker turns with the world-frame omega: dm/dt = omega x m
        dm = (r.marker[i - 2] - 8 * r.marker[i - 1] + 8 * r.marker[i + 1]
              - r.marker[i + 2]) / (12 * h)  # fmt: skip
        np.testing.assert_allclose(dm, np.cross(r.omega[i], r.marker[i]), atol=1e-8)
        # friction is tangential, bounded by mu N, and opposes the slip
        assert abs(r.f[i] @ n) < 1e-12
        assert np.linalg.norm(r.f[i]) <= sphere.mu * r.N[i]
        vel = (r.X[i - 2] - 8 * r.X[i - 1] + 8 * r.X[i + 1] - r.X[i + 2]) / (12 * h)
        np.testing.assert_allclose(r.V[i], vel, atol=1e-9)


def test_energy_balance_converges_at_fourth_order(lively: SphereProblem) -> None:
    coarse = simulate(lively.replace(dt=2e-3, interval=2e-3))
    hc = coarse.histories
    fine = simulate(lively)
    assert hc.friction_dissipation[-1] > 1e-3 and abs(hc.surface_work[-1]) > 1e-2
    np.testing.assert_allclose(
        hc.energy_residual,
        hc.energy - hc.energy[0] - hc.surface_work + hc.friction_dissipation,
        atol=1e-15,
    )
    np.testing.assert_allclose(hc.energy, hc.kinetic + hc.potential)
    assert fine.extrema.max_energy_residual < 1e-6
    assert coarse.extrema.max_energy_residual / fine.extrema.max_energy_residual > 10.0  # ~2^4


def test_frictionless_no_spin_and_auto_rotation_off(en02_problem: SphereProblem) -> None:
    p = en02_problem.replace(mu=0.0, t_end=20.0)
    auto = simulate(p)
    h = auto.histories
    assert not auto.counts.rotation_integrated and auto.counts.energy_integrated
    assert np.all(h.omega == 0.0) and np.all(h.cumulative_spin == 0.0)
    np.testing.assert_array_equal(h.Q, np.tile([1.0, 0.0, 0.0, 0.0], (len(h.t), 1)))
    np.testing.assert_array_equal(h.marker, np.tile([0.0, 0.0, 1.0], (len(h.t), 1)))
    forced = simulate(p.replace(rotation=True))
    assert forced.counts.rotation_integrated
    assert np.all(forced.histories.omega == 0.0) and np.all(forced.histories.cumulative_spin == 0.0)
    np.testing.assert_array_equal(forced.histories.marker[-1], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(forced.histories.X, h.X, rtol=0, atol=1e-15)
    assert np.all(forced.histories.slip_speed[1:] > 0.0)  # it slides: the pattern moves under it
    assert forced.extrema.max_energy_residual < 1e-12


def test_trajectory_only_matches_full_run_when_frictionless(en02_problem: SphereProblem) -> None:
    p = en02_problem.replace(mu=0.0, t_end=30.0)
    full = simulate(p.replace(rotation=True, energy=True))
    bare = simulate(p.replace(rotation=False, energy=False))
    assert not bare.counts.rotation_integrated and not bare.counts.energy_integrated
    np.testing.assert_allclose(bare.histories.X, full.histories.X, rtol=0, atol=1e-15)
    np.testing.assert_allclose(bare.histories.N, full.histories.N, rtol=0, atol=1e-13)
    assert np.isnan(bare.extrema.max_energy_residual)
    for name in ("kinetic", "potential", "energy", "surface_work", "friction_dissipation",
                 "energy_residual"):  # fmt: skip
        assert np.all(np.isnan(getattr(bare.histories, name)))


def test_rotation_false_refused_with_friction(en02_problem: SphereProblem) -> None:
    with pytest.raises(ValueError, match="rotation=False"):
        en02_problem.replace(rotation=False)


def test_quaternion_and_marker_follow_a_free_spin(en02_problem: SphereProblem) -> None:
    """Frictionless, spin w about x: Q = (cos wt/2, sin wt/2, 0, 0), marker (0, -sin wt, cos wt)."""
    w = 3.0
    p = en02_problem.replace(mu=0.0, omega=(w, 0.0, 0.0), t_end=10.0)
    res = simulate(p)
    h = res.histories
    assert res.counts.rotation_integrated
    half = 0.5 * w * h.t
    zero = np.zeros_like(half)
    np.testing.assert_allclose(h.Q, np.stack([np.cos(half), np.sin(half), zero, zero], 1),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(h.marker, np.stack([zero, -np.sin(2 * half), np.cos(2 * half)], 1),
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(h.cumulative_spin, w * h.t, rtol=1e-12)


def test_quaternion_stays_unit(en02_pair) -> None:
    res, _ = en02_pair
    h = res.histories
    np.testing.assert_allclose(np.linalg.norm(h.Q, axis=1), 1.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(h.marker, axis=1), 1.0, atol=1e-14)
    assert h.cumulative_spin[-1] > 10.0 and np.all(np.diff(h.cumulative_spin) >= 0.0)


def test_output_sampling_and_interval_validation(en02_problem: SphereProblem) -> None:
    res = simulate(en02_problem.replace(t_end=1.05, interval=0.1))
    np.testing.assert_allclose(res.histories.t, np.r_[np.arange(11) * 0.1, 1.05], atol=1e-12)
    with pytest.raises(ValueError, match=r"interval = 0\.101 s is not .* dt = 0\.002"):
        en02_problem.replace(interval=0.101)
    with pytest.raises(ValueError, match="t_end"):
        en02_problem.replace(t_end=1.0001)


# ---------------------------------------------------------------- first step (solver.h0)


@pytest.mark.parametrize(("dt", "h0", "first"), [
    (0.002, None, 0.002),      # h0 null: the run's dt, as before h0 existed
    (0.001, None, 0.001),      # ... the convergence partner's dt
    (0.002, 1e-3, 1e-3),       # h0 divides the output interval: the first step is h0
    (0.001, 1e-3, 1e-3),       # ... whatever dt names the run
    (0.002, 1.5e-3, 0.1 / 67),  # it does not: the interval in ceil(0.1 / h0) = 67 steps
])
def test_an_adaptive_run_takes_h0_as_its_first_step(en02_problem: SphereProblem, dt: float,
                                                    h0: float | None, first: float) -> None:
    """radau5 with a budget of 2 evaluations (the start's, then the first try's) stops
    before its second try: its stop time is where the first step landed."""
    res = simulate(en02_problem.replace(method="radau5", dt=dt, h0=h0, max_rhs_evals=2))
    c = res.counts
    assert (c.status, c.steps, c.rejected_steps) == ("budget_exceeded", 1, 0)
    assert c.stop_time == pytest.approx(first, rel=1e-15)


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
    assert res.counts.status == "ok" and any("allow_unstable" in w for w in res.counts.warnings)


def test_runs_beyond_the_limit_chatter(en02_problem: SphereProblem) -> None:
    short = en02_problem.replace(t_end=24.0, interval=0.024)
    ref = simulate(short.replace(dt=0.0005))
    true_limit = stability_limit(en02_problem) * 1.25  # without the a-priori margin, N = m g
    below = simulate(short.replace(dt=0.004))  # 0.92 x stability_limit
    assert not below.counts.warnings
    assert below.extrema.max_slip_speed == pytest.approx(ref.extrema.max_slip_speed, rel=1e-3)
    assert np.abs(below.histories.X - ref.histories.X).max() < 1e-10
    for dt in (0.006, 0.008):  # 1.11 and 1.48 x the limit at N = m g
        assert dt > 1.1 * true_limit
        above = simulate(short.replace(dt=dt, allow_unstable=True))
        assert above.counts.warnings
        # chatter at the eps scale
        assert above.extrema.max_slip_speed > 100 * ref.extrema.max_slip_speed
        assert np.abs(above.histories.X - ref.histories.X).max() > 1e-6


# ---------------------------------------------------------------- stop conditions


def _assert_stopped(res, status: str) -> None:
    assert res.counts.status == status
    assert res.histories.t[-1] == res.counts.stop_time
    assert res.counts.steps == round(res.counts.stop_time / res.counts.dt)
    assert res.counts.rhs_evals == 4 * res.counts.steps + 1


def test_stop_contact_lost_on_a_fast_cycle(en02_problem: SphereProblem) -> None:
    fast = Law.quintic(0.0, 12 * math.pi, 1.0)
    res = simulate(en02_problem.replace(phi_a=fast, t_end=1.0))
    h = res.histories
    _assert_stopped(res, "contact_lost")
    assert 0.0 < res.counts.stop_time < 1.0 and h.N[-1] <= 0.0 and np.all(h.N[:-1] > 0.0)
    assert res.extrema.min_N <= 0.0


def test_stop_offset_singular_when_cavity_too_tight(en02_problem: SphereProblem) -> None:
    # the cavity moves inward (R_c = 0.43 -> 0), where its angular curvature A Ka^2 / rho^2
    # grows until b kappa reaches 1
    res = simulate(en02_problem.replace(phi_r=Law.quintic(0.0, math.pi, 10.0), t_end=10.0))
    _assert_stopped(res, "offset_singular")
    assert 1.0 < res.counts.stop_time < 10.0 and 1.0 <= res.extrema.max_b_kappa < 1.01
    big = simulate(en02_problem.replace(b=0.2))  # b A Ka^2 / rho^2 = 1.05 at the start
    _assert_stopped(big, "offset_singular")
    assert big.counts.stop_time == 0.0 and len(big.histories.t) == 1


def test_stop_edge_crossed_and_left_annulus(en02_problem: SphereProblem) -> None:
    flat = en02_problem.replace(A=0.0, mu=0.0, t_end=1.0)  # a flat annulus: N = m g
    edge = simulate(flat.replace(R=0.501, Rdot=-1.0))
    _assert_stopped(edge, "edge_crossed")  # envelope reaches R = 0 once R < b = 0.12
    assert edge.counts.stop_time == pytest.approx(0.382, abs=1e-9) and edge.histories.R[-1] > 0.0
    assert edge.extrema.min_edge_clearance < 0.0
    jump = simulate(flat.replace(R=0.2, Rdot=-1.0, dt=0.25, interval=0.25))  # fmt: skip
    _assert_stopped(jump, "left_annulus")
    assert jump.counts.stop_time == 0.25 and jump.histories.R[-1] < 0.0
    outside = simulate(en02_problem.replace(R=1.75, mu=0.0))
    _assert_stopped(outside, "left_annulus")
    assert outside.counts.stop_time == 0.0


def test_stop_non_finite_at_a_huge_step(en02_problem: SphereProblem) -> None:
    dt = 1e100
    p = en02_problem.replace(dt=dt, t_end=2 * dt, interval=dt, alphadot=1.0,
                             allow_unstable=True)
    res = simulate(p)
    _assert_stopped(res, "non_finite")
    assert res.counts.stop_time == dt and res.counts.steps == 1
    assert res.counts.warnings and not np.all(np.isfinite(res.histories.X[-1]))
    assert np.all(np.isfinite(res.histories.X[0]))


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
    assert all(r.counts.status == "ok" for r in runs)
    d1 = np.abs(runs[0].histories.X - runs[1].histories.X).max()
    d2 = np.abs(runs[1].histories.X - runs[2].histories.X).max()
    assert 14.0 < d1 / d2 < 18.0, d1 / d2
