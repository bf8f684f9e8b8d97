"""The compiled integrators (dopri5, dop853, radau5) and the scipy peer harness.

Orders are observed on a smooth (frictionless) EN-02 segment against a tight reference;
adaptive runs must meet their tolerance; radau5 must stay accurate far beyond the explicit
friction limit; the scipy harness must measure the native solution's error exactly.
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, UnstableStepError, simulate, stability_limit
from creatio.dynamics.peer_solvers import centre_grid, solve_peer
from creatio.dynamics.solvers import EXPLICIT, METHODS, RADAU_VO, STEPPERS
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve

ORDERS = {name: m.order for name, m in METHODS.items()}
#: The adaptive methods of the registry whose local error control is to rtol itself (an
#: error estimate: they choose their own step). The radau_high_order kind (RADAU_VO) follows
#: radau.f instead: its estimate is held to a transformed tolerance (0.1 rtol^((s+1)/(2s)))
#: and its high order carries the global error to about rtol (here radau9 and radau13 reach
#: 1.6e-9 m at rtol 1e-9, 1.5 rtol |X|), with steps as long as the 0.1 s output grid allows at
#: rtol 1e-6 and 1e-4 alike (302 on 30 s); tests/dynamics/solvers/test_radau_high_order.py
#: holds those methods to radau5 at a common tolerance.
ADAPTIVE = [name for name, m in METHODS.items() if m.adaptive and m.stepper != RADAU_VO]

#: Fixed-step pairs measured on the smooth case: each in the asymptotic range, its finer
#: error above rounding (1e-13 m). A method not named here takes :func:`order_steps`.
SMOOTH_STEPS = {"rk4": (0.025, 0.0125), "dopri5": (0.05, 0.025), "dop853": (0.2, 0.1),
                "radau5": (0.1, 0.05), "rodas4": (0.05, 0.025)}
#: The same for the dense output, steps that do not divide the 0.2 s grid.
DENSE_STEPS = {"rk4": (0.03, 0.015), "dopri5": (0.06, 0.03), "dop853": (0.3, 0.15),
               "radau5": (0.12, 0.06), "rodas4": (0.12, 0.06), "radau": (0.15, 0.075)}


def order_steps(method: str, dense: bool) -> tuple[float, float]:
    """The fixed-step pair (h, h / 2) of a method the tables above do not name: h the
    largest step dividing the 0.2 s grid (dense: 1.5 times it, between the rows) with
    h^order <= 1e-6, where the measured pairs lie."""
    order = METHODS[method].order
    h = next(h for h in (0.2, 0.1, 0.05, 0.025, 0.0125) if h ** order <= 1e-6 or h == 0.0125)
    return (1.5 * h, 0.75 * h) if dense else (h, h / 2)


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
    return simulate(problem.replace(method="dop853", rtol=1e-13, atol=1e-15)).histories.X


def _err(X: np.ndarray, ref: np.ndarray) -> float:
    assert X.shape == ref.shape
    return float(np.linalg.norm(X - ref, axis=1).max())


#: The highest order this smooth case shows: its dop853 reference is good to ~1e-13 m, and
#: at steps dividing its 0.2 s grid an order-9 method is already at ~2e-12 m at 0.1 s
#: (radau9: 1.4e-10, 1.9e-12, 1.4e-13 m at 0.2, 0.1, 0.05 s), radau13 at 6e-13 at 0.2 s
#: (its dense rows: 1e-11, 1.8e-12, 5.4e-14 m at 0.3, 0.15, 0.075 s, orders 2.5 and 5).
#: Higher orders are observed on EN-02's first 2 s at a tight Newton tolerance instead
#: (tests/dynamics/solvers/test_radau_high_order.py).
SMOOTH_MAX_ORDER = 8


@pytest.mark.parametrize("method", list(METHODS))
def test_observed_order_on_smooth_case(smooth: SphereProblem, method: str) -> None:
    """Every method of the registry at a fixed step: halving it divides the error by about
    2^order (the registry's order, within 0.35; a variable-order method's at least its
    lowest: radau 5.3), up to the orders this case can show."""
    if ORDERS[method] > SMOOTH_MAX_ORDER:
        pytest.skip(f"order {ORDERS[method]} is beyond what the smooth case shows above its "
                    f"reference's error (SMOOTH_MAX_ORDER = {SMOOTH_MAX_ORDER})")
    dts = SMOOTH_STEPS.get(method) or order_steps(method, dense=False)
    ref = _ref(smooth)
    errs = []
    for dt in dts:
        prob = smooth.replace(method=method, dt=dt, fixed_step=method != "rk4")
        res = simulate(prob)
        assert res.counts.status == "ok" and res.counts.steps == round(smooth.output.t_end / dt)
        errs.append(_err(res.histories.X, ref))
    order = math.log2(errs[0] / errs[1])
    assert errs[1] > 1e-13, "finest error must stay above rounding for an order estimate"
    if METHODS[method].variable_order:  # it may raise its order: at least its lowest
        assert order > ORDERS[method] - 0.35, (method, errs, order)
    else:
        assert abs(order - ORDERS[method]) < 0.35, (method, errs, order)


@pytest.mark.parametrize("method", list(METHODS))
def test_dense_output_order_at_off_step_times(smooth: SphereProblem, method: str) -> None:
    """With dense output and steps that do not divide the 0.2 s grid, the rows between steps
    converge at min(p, q + 1) for order p and interpolant order q (rk4 4, dopri5 5, dop853 8,
    radau5 4, rodas4 4, radau 5: its defect-corrected quartic at 3 stages, whose own order
    test_radau_high_order measures; here 5.8 at 0.15 / 0.075 s, the steps' order, as with
    the collocation cubic): a lower-order interpolant (a linear one: 2) fails."""
    if ORDERS[method] > SMOOTH_MAX_ORDER:
        pytest.skip(f"order {ORDERS[method]} is beyond what the smooth case shows above its "
                    f"reference's error (SMOOTH_MAX_ORDER = {SMOOTH_MAX_ORDER})")
    dts = DENSE_STEPS.get(method) or order_steps(method, dense=True)
    ref = _ref(smooth)
    expected = min(METHODS[method].order, METHODS[method].dense_order + 1)
    errs = []
    for dt in dts:
        assert (smooth.output.interval / dt) % 1.0 > 0.1  # most rows fall between steps
        prob = smooth.replace(method=method, dt=dt, fixed_step=method != "rk4", dense_output=True)
        res = simulate(prob)
        assert res.counts.status == "ok"
        assert res.counts.steps == math.ceil(smooth.output.t_end / dt - 1e-9)
        t = res.histories.t
        np.testing.assert_allclose(t, np.arange(t.size) * smooth.output.interval,
                                   rtol=0.0, atol=1e-12)
        errs.append(_err(res.histories.X, ref))
    order = math.log2(errs[0] / errs[1])
    assert errs[1] > 1e-13, "finest error must stay above rounding for an order estimate"
    assert order > expected - 0.35, (method, errs, order, expected)


@pytest.mark.parametrize("method", ADAPTIVE)
def test_adaptive_dense_output_meets_the_tolerance_in_fewer_steps(en02: SphereProblem,
                                                                  method: str) -> None:
    """Steps that need not land on the grid: fewer of them than the landing run's, and the
    interpolated rows still within rtol x |X| of the reference."""
    prob = en02.replace(t_end=30.0)
    ref = _ref(prob)
    rtol = 1e-9
    landing = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100))
    dense = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100, dense_output=True))
    assert dense.counts.status == "ok" and dense.histories.t.size == landing.histories.t.size
    scale = float(np.linalg.norm(ref, axis=1).max())
    assert _err(dense.histories.X, ref) <= rtol * scale
    assert dense.counts.steps < landing.counts.steps


def test_dense_output_frees_a_fixed_step_from_the_grid() -> None:
    """solver.dt = 3 ms does not divide the 0.1 s grid: refused by name, accepted with
    solver.dense_output=true."""
    with pytest.raises(ConfigError, match="solver.output_interval"):
        resolve("en02", ["solver.dt=0.003"])
    prob = resolve("en02", ["solver.dt=0.003", "solver.dense_output=true"]).obj.sphere_problem()
    assert prob.solver.dense_output and prob.solver.dt == 0.003
    with pytest.raises(ConfigError, match="solver.dense_output"):
        resolve("en02f", ["solver.dense_output=true", "flight.contact_loss=flight"])


@pytest.mark.parametrize("method", ADAPTIVE)
@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_adaptive_methods_meet_their_tolerance(en02: SphereProblem, method: str,
                                               rtol: float) -> None:
    """Global centre error <= rtol x |X| (the local control keeps every step within it)."""
    prob = en02.replace(t_end=30.0)
    ref = _ref(prob)
    res = simulate(prob.replace(method=method, rtol=rtol, atol=rtol / 100))
    assert res.counts.status == "ok"
    scale = float(np.linalg.norm(ref, axis=1).max())
    assert _err(res.histories.X, ref) <= rtol * scale
    # and the control works: a looser tolerance takes fewer steps
    loose = simulate(prob.replace(method=method, rtol=rtol * 100, atol=rtol))
    assert loose.counts.steps < res.counts.steps


def test_radau5_accurate_far_beyond_the_explicit_limit(en02: SphereProblem) -> None:
    prob = en02.replace(t_end=30.0)
    limit = stability_limit(prob)
    dt = 0.05
    assert dt > 10 * limit  # 11.6 x RK4's limit (4.33 ms)
    ref = _ref(prob)
    stiff = simulate(prob.replace(method="radau5", dt=dt, fixed_step=True))
    assert stiff.counts.status == "ok" and _err(stiff.histories.X, ref) < 1e-9
    # RODAS4, L-stable too, is as stable there; order 4 against 5 costs it accuracy
    ros = simulate(prob.replace(method="rodas4", dt=dt, fixed_step=True))
    assert ros.counts.status == "ok"
    assert _err(stiff.histories.X, ref) < _err(ros.histories.X, ref) < 1e-8
    assert math.isinf(stability_limit(prob.replace(method="radau5", dt=dt)))
    # the explicit scheme at the same step is refused, and breaks down when forced
    with pytest.raises(UnstableStepError, match="stability limit"):
        simulate(prob.replace(dt=dt))
    # forced, it does not blow up (|f| <= mu N saturates the slip): it chatters, its slip
    # and its error orders of magnitude above the stiff scheme's at the same step
    forced = simulate(prob.replace(dt=dt, allow_unstable=True))
    assert forced.counts.warnings
    assert _err(forced.histories.X, ref) > 1e4 * _err(stiff.histories.X, ref)
    assert forced.extrema.max_slip_speed > 10 * stiff.extrema.max_slip_speed


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
    states = np.zeros((native.histories.t.size, prob.initial_state(True, False).size))
    states[:, 0] = native.histories.R
    states[:, 1] = native.histories.alpha
    X = centre_grid(prob, native.histories.t, states, False)
    np.testing.assert_allclose(X, native.histories.X, rtol=0, atol=1e-15)


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
    assert theirs.status == "ok" and ours.counts.status == "ok"
    np.testing.assert_array_equal(theirs.t, ours.histories.t)
    e_peer = _err(centre_grid(prob, theirs.t, theirs.y, False), ref)
    e_native = _err(ours.histories.X, ref)
    assert e_peer < 1e2 * rtol and e_native < 1e2 * rtol
    if compare_errors:
        assert 1 / 5 < e_peer / e_native < 5
    assert abs(ours.counts.steps / theirs.steps - 1) < 0.15, (ours.counts.steps, theirs.steps)


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
    assert rk4.counts.status == "ok" and stiff.counts.status == "ok"
    steps = stiff.counts.steps
    assert steps < 400 and 1000 * steps < 5.0 / limit  # explicit: >= 5 s / limit
    assert _err(stiff.histories.X, rk4.histories.X) < 1e-8


def test_a_step_the_integrator_cannot_take_stops_cleanly(en02: SphereProblem) -> None:
    """radau5 at a fixed 1 s step cannot solve its stage equations: status step_failed at
    the start, finite histories, no exception."""
    res = simulate(en02.replace(method="radau5", fixed_step=True, dt=1.0, interval=1.0))
    assert res.counts.status == "step_failed" and res.counts.stop_time == 0.0
    assert np.all(np.isfinite(res.histories.X)) and res.histories.t.size >= 1


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


#: The implicit stepper kinds' modules, from the registry (every method that is not explicit).
IMPLICIT_MODULES = sorted({STEPPERS[m.stepper] for m in METHODS.values() if m.stepper != EXPLICIT})


@pytest.mark.parametrize("module_name", IMPLICIT_MODULES)
def test_implicit_workspaces_are_laid_out_by_their_slot_names(module_name: str) -> None:
    """Each implicit stepper's workspace (creatio.dynamics.solvers.<kind>.workspace, for each
    method of its kind) holds NWS slots, and the module that lays it out names every slot
    once (WS_* = 0 .. NWS - 1): the carried state WS_RS a float vector, the Jacobian WS_JAC
    an n x n matrix, the work vectors WS_WORK and WS_TMP of the state's size n."""
    module = importlib.import_module(f"creatio.dynamics.solvers.{module_name}")
    layout = importlib.import_module("creatio.dynamics.solvers.radau_variable_order"
                                     if module_name == "radau_high_order" else module.__name__)
    slots = {k: v for k, v in vars(layout).items() if k.startswith("WS_")}
    assert sorted(slots.values()) == list(range(module.NWS)) == list(range(layout.NWS))
    n = 9
    for m in (x for x in METHODS.values() if STEPPERS[x.stepper] == module_name):
        ws = module.workspace(n, m.driver_tableau.c)
        assert len(ws) == module.NWS
        assert ws[layout.WS_RS].ndim == 1 and ws[layout.WS_RS].dtype == np.float64
        assert ws[layout.WS_JAC].shape == (n, n)
        assert ws[layout.WS_WORK].shape == ws[layout.WS_TMP].shape == (n,)
