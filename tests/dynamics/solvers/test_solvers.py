"""The compiled integrators (dopri5, dop853, radau5) and the scipy peer harness.

Orders are observed on a smooth (frictionless) EN-02 segment against a tight reference;
adaptive runs must meet their tolerance; radau5 must stay accurate far beyond the explicit
friction limit; the scipy harness must measure the native solution's error exactly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, UnstableStepError, simulate, stability_limit
from creatio.dynamics.peer_solvers import centre_grid, solve_peer
from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve

ORDERS = {name: m.order for name, m in METHODS.items()}


def real_stability_bound(method: str) -> float:
    """The registry's real stability interval of a method (computed from its tableau)."""
    return METHODS[method].stability_bound



@pytest.fixture(scope="module")
def en02(en02_config_problem: SphereProblem) -> SphereProblem:
    """EN-02 trajectory-only problem (mu = 0.15: rotation integrated, energy off)."""
    return en02_config_problem


@pytest.fixture(scope="module")
def smooth(en02: SphereProblem) -> SphereProblem:
    """Frictionless 20 s EN-02 segment: smooth and non-stiff, 4-component state."""
    return en02.replace(mu=0.0, t_end=20.0, interval=0.2)


def _ref(problem: SphereProblem) -> np.ndarray:
    return simulate(problem.replace(method="dop853", rtol=1e-13, atol=1e-15)).X


def _err(X: np.ndarray, ref: np.ndarray) -> float:
    assert X.shape == ref.shape
    return float(np.linalg.norm(X - ref, axis=1).max())


@pytest.mark.parametrize(
    ("method", "dts"),
    [
        ("rk4", (0.025, 0.0125)),
        ("dopri5", (0.05, 0.025)),
        ("dop853", (0.2, 0.1)),
        ("radau5", (0.1, 0.05)),
        ("rodas4", (0.05, 0.025)),
    ],
)
def test_observed_order_on_smooth_case(smooth: SphereProblem, method: str, dts) -> None:
    ref = _ref(smooth)
    errs = []
    for dt in dts:
        prob = smooth.replace(method=method, dt=dt, fixed_step=method != "rk4")
        res = simulate(prob)
        assert res.status == "ok" and res.steps == round(smooth.output.t_end / dt)
        errs.append(_err(res.X, ref))
    order = math.log2(errs[0] / errs[1])
    assert errs[1] > 1e-13, "finest error must stay above rounding for an order estimate"
    assert abs(order - ORDERS[method]) < 0.35, (method, errs, order)


@pytest.mark.parametrize(
    ("method", "dts"),
    [
        ("rk4", (0.03, 0.015)),
        ("dopri5", (0.06, 0.03)),
        ("dop853", (0.3, 0.15)),
        ("radau5", (0.12, 0.06)),
        ("rodas4", (0.12, 0.06)),
    ],
)
def test_dense_output_order_at_off_step_times(smooth: SphereProblem, method: str,
                                              dts) -> None:
    """With dense output and steps that do not divide the 0.2 s grid, the rows between steps
    converge at min(p, q + 1) for order p and interpolant order q (rk4 4, dopri5 5, dop853 8,
    radau5 4, rodas4 4): a lower-order interpolant (a linear one: 2) fails."""
    ref = _ref(smooth)
    expected = min(METHODS[method].order, METHODS[method].dense_order + 1)
    errs = []
    for dt in dts:
        assert (smooth.output.interval / dt) % 1.0 > 0.1  # most rows fall between steps
        prob = smooth.replace(method=method, dt=dt, fixed_step=method != "rk4", dense_output=True)
        res = simulate(prob)
        assert res.status == "ok" and res.steps == math.ceil(smooth.output.t_end / dt - 1e-9)
        np.testing.assert_allclose(res.t, np.arange(res.t.size) * smooth.output.interval,
                                   rtol=0.0, atol=1e-12)
        errs.append(_err(res.X, ref))
    order = math.log2(errs[0] / errs[1])
    assert errs[1] > 1e-13, "finest error must stay above rounding for an order estimate"
    assert order > expected - 0.35, (method, errs, order, expected)


@pytest.mark.parametrize("method", ["dopri5", "dop853", "radau5", "rodas4"])
def test_adaptive_dense_output_meets_the_tolerance_in_fewer_steps(en02: SphereProblem,
                                                                  method: str) -> None:
    """Steps that need not land on the grid: fewer of them than the landing run's, and the
    interpolated rows still within rtol x |X| of the reference."""
    prob = en02.replace(t_end=30.0)
    ref = _ref(prob)
    rtol = 1e-9
    landing = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100))
    dense = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100, dense_output=True))
    assert dense.status == "ok" and dense.t.size == landing.t.size
    scale = float(np.linalg.norm(ref, axis=1).max())
    assert _err(dense.X, ref) <= rtol * scale
    assert dense.steps < landing.steps


def test_dense_output_frees_a_fixed_step_from_the_grid() -> None:
    """solver.dt = 3 ms does not divide the 0.1 s grid: refused by name, accepted with
    solver.dense_output=true."""
    with pytest.raises(ConfigError, match="solver.output_interval"):
        resolve("en02", ["solver.dt=0.003"])
    prob = resolve("en02", ["solver.dt=0.003", "solver.dense_output=true"]).obj.sphere_problem()
    assert prob.solver.dense_output and prob.solver.dt == 0.003
    with pytest.raises(ConfigError, match="solver.dense_output"):
        resolve("en02f", ["solver.dense_output=true", "flight.contact_loss=flight"])


@pytest.mark.parametrize("method", ["dopri5", "dop853", "radau5", "rodas4"])
@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_adaptive_methods_meet_their_tolerance(en02: SphereProblem, method: str,
                                               rtol: float) -> None:
    """Global centre error <= rtol x |X| (the local control keeps every step within it)."""
    prob = en02.replace(t_end=30.0)
    ref = _ref(prob)
    res = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100))
    assert res.status == "ok"
    scale = float(np.linalg.norm(ref, axis=1).max())
    assert _err(res.X, ref) <= rtol * scale
    # and the control works: a looser tolerance takes fewer steps
    loose = simulate(prob.replace(method=method, rtol=rtol * 100, atol=rtol))
    assert loose.steps < res.steps


def test_radau5_accurate_far_beyond_the_explicit_limit(en02: SphereProblem) -> None:
    prob = en02.replace(t_end=30.0)
    limit = stability_limit(prob)
    dt = 0.05
    assert dt > 10 * limit  # 11.6 x RK4's limit (4.33 ms)
    ref = _ref(prob)
    stiff = simulate(prob.replace(method="radau5", dt=dt, fixed_step=True))
    assert stiff.status == "ok" and _err(stiff.X, ref) < 1e-9
    # RODAS4, L-stable too, is as stable there; order 4 against 5 costs it accuracy
    ros = simulate(prob.replace(method="rodas4", dt=dt, fixed_step=True))
    assert ros.status == "ok" and _err(stiff.X, ref) < _err(ros.X, ref) < 1e-8
    assert math.isinf(stability_limit(prob.replace(method="radau5", dt=dt)))
    # the explicit scheme at the same step is refused, and breaks down when forced
    with pytest.raises(UnstableStepError, match="stability limit"):
        simulate(prob.replace(dt=dt))
    # forced, it does not blow up (|f| <= mu N saturates the slip): it chatters, its slip
    # and its error orders of magnitude above the stiff scheme's at the same step
    forced = simulate(prob.replace(dt=dt, allow_unstable=True))
    assert forced.warnings and _err(forced.X, ref) > 1e4 * _err(stiff.X, ref)
    assert forced.max_slip_speed > 10 * stiff.max_slip_speed


def test_dormand_prince_stability_interval_matches_its_polynomial() -> None:
    """DP5's stability function is 1 + z + ... + z^5/120 + z^6/600 (Hairer-Wanner I, II.10)."""
    poly = np.polynomial.Polynomial([1, 1, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600])
    # |R(-x)| first returns to 1 at R(-x) = +1 (R(-x) = -1 has no real root)
    assert not any(abs(r.imag) < 1e-9 for r in (poly + 1).roots())
    roots = (poly - 1).roots()
    edge = min(-r.real for r in roots if abs(r.imag) < 1e-9 and r.real < -1e-9)
    assert real_stability_bound("dopri5") == pytest.approx(edge, rel=1e-9)
    # DOP853's real interval (tests/studies/test_stability_map.py derives it again from
    # scipy's tableau)
    assert real_stability_bound("dop853") == pytest.approx(6.3937, abs=1e-4)
    assert math.isinf(real_stability_bound("radau5"))


def test_harness_measures_the_native_error_on_the_same_solution(en02: SphereProblem) -> None:
    """States of a native run pushed through the peer harness give the native X exactly."""
    prob = en02.replace(t_end=20.0)
    native = simulate(prob.replace(method="dop853", rtol=1e-8, atol=1e-10))
    states = np.zeros((native.t.size, prob.initial_state(True, False).size))
    states[:, 0] = native.R
    states[:, 1] = native.alpha
    X = centre_grid(prob, native.t, states, False)
    np.testing.assert_allclose(X, native.X, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("native", "peer", "rtol", "compare_errors"),
    [
        ("dopri5", "RK45", 1e-8, True),
        ("dop853", "DOP853", 1e-8, False),
        ("radau5", "Radau", 1e-8, True),
    ],
)
def test_scipy_peer_agrees_with_the_native_port(en02: SphereProblem, native: str, peer: str,
                                                rtol: float, compare_errors: bool) -> None:
    """Each native method ports scipy's pair, controller (and Newton for Radau): on the same
    problem they take about the same number of steps and reach errors within a small
    factor of each other, as measured by the same harness. (DOP853's errors are not
    compared: native 2e-14 m is far below the ~5e-12 m of scipy's dense-output
    interpolation at the t_eval grid, which native steps never need.)"""
    prob = en02.replace(t_end=10.0)
    ref = _ref(prob)
    theirs = solve_peer(prob, peer, rtol, rtol / 100)
    ours = simulate(prob.replace(method=native, rtol=rtol, atol=rtol / 100))
    assert theirs.status == "ok" and ours.status == "ok"
    np.testing.assert_array_equal(theirs.t, ours.t)
    e_peer = _err(centre_grid(prob, theirs.t, theirs.y, False), ref)
    e_native = _err(ours.X, ref)
    assert e_peer < 1e2 * rtol and e_native < 1e2 * rtol
    if compare_errors:
        assert 1 / 5 < e_peer / e_native < 5
    assert abs(ours.steps / theirs.steps - 1) < 0.15, (ours.steps, theirs.steps)


def test_solver_group_selects_a_method() -> None:
    cfg = resolve("en02", ["solver=radau5"]).obj
    prob = cfg.sphere_problem()
    assert prob.solver.method == "radau5" and prob.adaptive and math.isinf(cfg.step_limit())
    fine = cfg.sphere_problem(cfg.solver.dt / cfg.solver.refine)
    assert fine.solver.rtol == pytest.approx(prob.solver.rtol / 2**5)
    assert resolve("en02").obj.solver.method == "rk4"  # the published studies stay on RK4
    with pytest.raises(ConfigError, match="solver.rtol"):
        resolve("en02", ["solver=radau5", "solver.rtol=0"])
    with pytest.raises(ConfigError, match="solver.method"):
        resolve("en02", ["solver.method=euler"])


def test_radau5_step_is_set_by_the_slow_dynamics_at_large_mu(en02: SphereProblem) -> None:
    """At mu = 50 the slip relaxes at ~1.7e5 /s (RK4 limit 13 us): radau5's steps stay
    near the mu = 0.15 count, and it agrees with RK4 run inside its limit."""
    prob = en02.replace(mu=50.0, t_end=5.0)
    limit = stability_limit(prob)
    assert limit < 2e-5
    rk4 = simulate(prob.replace(dt=1e-5))
    stiff = simulate(prob.replace(method="radau5", rtol=1e-8, atol=1e-10))
    assert rk4.status == "ok" and stiff.status == "ok"
    assert stiff.steps < 400 and 1000 * stiff.steps < 5.0 / limit  # explicit: >= 5 s / limit
    assert _err(stiff.X, rk4.X) < 1e-8


def test_a_step_the_integrator_cannot_take_stops_cleanly(en02: SphereProblem) -> None:
    """radau5 at a fixed 1 s step cannot solve its stage equations: status step_failed at
    the start, finite histories, no exception."""
    res = simulate(en02.replace(method="radau5", fixed_step=True, dt=1.0, interval=1.0))
    assert res.status == "step_failed" and res.stop_time == 0.0
    assert np.all(np.isfinite(res.X)) and res.t.size >= 1


@pytest.mark.parametrize("name", list(METHODS))
def test_flight_accepts_exactly_the_methods_the_registry_marks(en02: SphereProblem,
                                                                name: str) -> None:
    """Which methods flight's event loop runs is the registry's word (Method.flight), not a
    list in a message: each method is accepted or refused by the problem accordingly, and a
    refusal names the methods that would do (a new explicit method is accepted unedited)."""
    method = METHODS[name]
    changes = {"method": name, "flight": True, "energy": True, "rotation": None}
    if method.adaptive:
        changes.update(rtol=1e-8, atol=1e-10)
    if method.flight:
        assert en02.replace(**changes).events.flight
    else:
        with pytest.raises(ValueError) as err:
            en02.replace(**changes)
        able = [m for m, x in METHODS.items() if x.flight]
        assert all(m in str(err.value) for m in able) and name in str(err.value)
