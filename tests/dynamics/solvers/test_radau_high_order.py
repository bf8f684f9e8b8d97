"""Radau IIA of orders 9, 13 and variable order (radau9, radau13, radau) in the sphere driver.

What is checked against what: the stability functions of the registered methods against the
A- and L-stability their registry entries state (no stability limit on dt); the observed
order of radau9 and radau13 on EN-02 at fixed steps, at the steps and between them (dense
output), against a reference of a different method (dop853 at rtol 1e-13); the dense output's
order against the collocation polynomial's on an oscillator with a known solution; the
variable-order method's stage counts on EN-02 at a loose and a tight tolerance; agreement
with radau5 at a common tolerance; the work counts the driver returns against the stepper's
own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit
from oscillator import osc_rhs

from creatio.dynamics import simulate
from creatio.dynamics.solvers import METHODS, RADAU_VO
from creatio.dynamics.solvers import radau_variable_order as vo
from creatio.dynamics.solvers.explicit import ACCEPTED
from creatio.dynamics.solvers.radau_coefficients import (
    coefficients,
    pade_denominator,
    stability_function,
)
from creatio.dynamics.solvers.radau_high_order import (
    PRM_S_MAX,
    PRM_S_MIN,
    defect_shapes,
    dense,
    dense_step,
    solve,
)
from creatio.pipeline.config import resolve

NEW = ("radau9", "radau13", "radau")


def _stages(name: str) -> list[int]:
    params = METHODS[name].params
    return list(range(int(params[PRM_S_MIN]), int(params[PRM_S_MAX]) + 1, 2))


@pytest.mark.parametrize("name", NEW)
def test_registry_states_l_stability_and_the_stability_functions_have_it(name: str) -> None:
    """The registry says: no stability limit on dt (bound inf, L-stable). Each stage count
    the method runs has |R(z)| <= 1 on the imaginary axis and its denominator's zeros (the
    poles) in the right half plane (A-stable: R is analytic in the left half plane, so the
    maximum principle gives |R| <= 1 there), |R| <= 1 on the negative real axis out to
    -1e12, and R(z) -> 0 as z -> -inf (L-stable); R is the (s-1, s) Pade approximant."""
    m = METHODS[name]
    assert m.stepper == RADAU_VO and m.l_stable and m.stability_bound == math.inf
    for s in _stages(name):
        coef = coefficients(s)
        y = np.concatenate([-np.logspace(-3, 6, 600), np.logspace(-3, 6, 600)])
        assert np.max(np.abs(stability_function(coef, 1j * y))) <= 1.0 + 1e-12
        poles = np.roots([float(q) for q in reversed(pade_denominator(s))])
        assert poles.size == s and np.all(poles.real > 0.0)
        x = -np.logspace(-6, 12, 500)
        r = np.abs(stability_function(coef, x))
        assert np.all(r <= 1.0 + 1e-12)
        # R(x) ~ C / x for large |x| (numerator degree s - 1, denominator s)
        assert r[-1] < 1e-9
        assert abs(stability_function(coef, complex(-np.inf))[0]) < 1e-12
        # a left half-plane sample away from both axes
        zz = (-np.logspace(-2, 4, 40)[:, None] + 1j * np.logspace(-2, 4, 40)[None, :]).ravel()
        assert np.max(np.abs(stability_function(coef, zz))) <= 1.0 + 1e-12


@pytest.fixture(scope="module")
def en02():
    """EN-02 over its first 2 s, trajectory only (the benchmark's state)."""
    prob = resolve("en02", []).obj.sphere_problem().replace(energy=False, t_end=2.0)
    assert prob.rotation_integrated and not prob.structure_free
    return prob


@pytest.fixture(scope="module")
def en02_reference(en02):
    """dop853 at rtol 1e-13: a reference of a different method (explicit, not collocation)."""
    res = simulate(en02.replace(method="dop853", rtol=1e-13, atol=1e-15, fixed_step=False,
                                interval=0.025))
    assert res.counts.status == "ok"
    return res


def _fixed(en02, name: str, dt: float, dense: bool):
    """A fixed-step run of dt with Newton converged to rtol 1e-14, rows every 0.025 s."""
    res = simulate(en02.replace(method=name, dt=dt, fixed_step=True, rtol=1e-14, atol=1e-16,
                                interval=0.025 if dense else dt, dense_output=dense))
    assert res.counts.status == "ok"
    return res


#: Fixed steps that converge on EN-02's first 2 s (radau9 at 0.4 s and radau13 at 0.5 s lose
#: Newton convergence near t = 1 s) with errors above the reference's own (about 4e-16 m).
STEPS = {"radau9": (0.25, 0.125), "radau13": (0.4, 0.25)}


def _observed(errs: list[float], dts: tuple[float, float]) -> float:
    return math.log(errs[0] / errs[1]) / math.log(dts[0] / dts[1])


@pytest.mark.parametrize(("name", "order"), [("radau9", 9), ("radau13", 13)])
def test_observed_order_at_fixed_steps_on_en02(en02, en02_reference, name, order) -> None:
    """Refining a fixed step divides the error at the steps by about (dt ratio)^order
    (measured: radau9 8.86, radau13 12.6)."""
    ref = en02_reference
    errs = []
    for dt in STEPS[name]:
        res = _fixed(en02, name, dt, False)
        idx = np.searchsorted(ref.histories.t, res.histories.t - 1e-9)
        np.testing.assert_allclose(ref.histories.t[idx], res.histories.t, atol=1e-9)
        errs.append(np.abs(res.histories.X - ref.histories.X[idx]).max())
    observed = _observed(errs, STEPS[name])
    assert errs[1] > 1e-15, errs  # above the reference's own error
    assert order - 1.0 <= observed <= order + 1.5, (errs, observed)


@pytest.mark.parametrize(("name", "s"), [("radau9", 5), ("radau13", 7)])
def test_dense_output_order_between_steps_on_en02(en02, en02_reference, name, s) -> None:
    """Rows inside the steps come from the collocation polynomial corrected by its defect at
    the step's start (degree s + 1), whose error there is O(h^(s + 2)) (measured: radau9
    7.4, radau13 9.5), an order above the collocation polynomial's O(h^(s + 1)) (measured
    before the correction: 6.3, 8.0, which this bound refuses)."""
    ref = en02_reference
    errs = []
    for dt in STEPS[name]:
        res = _fixed(en02, name, dt, True)
        steps = np.arange(0.0, 2.0 + 1e-9, dt)
        off = np.min(np.abs(res.histories.t[:, None] - steps[None, :]), axis=1) > 1e-9
        assert off.sum() >= 40
        idx = np.searchsorted(ref.histories.t, res.histories.t - 1e-9)
        errs.append(np.abs(res.histories.X[off] - ref.histories.X[idx][off]).max())
    observed = _observed(errs, STEPS[name])
    assert s + 1.5 <= observed <= s + 3.0, (errs, observed)


def test_order_switch_raises_the_order_at_tighter_tolerance_on_en02(en02) -> None:
    """Hairer's order selection, counted over EN-02's first 20 s with free steps: at rtol
    1e-12 the variable-order method takes a larger share of its steps at 7 stages than at
    1e-6 (measured: 66 of 85 against 15 of 41), and more at 7 stages than at 3."""
    prob = en02.replace(t_end=20.0)
    y0 = prob.initial_state(True, False)
    p, lawc = prob.parameter_vector(), prob.law_matrix()
    share = {}
    for rtol in (1e-6, 1e-12):
        ok, _, _, cnt, *_ = solve(p, lawc, y0, 20.0, 1e-3, rtol, rtol * 1e-2, 3, 7, 3, False,
                                  100000, np.zeros(0), vo.THET)
        assert ok
        steps = {s: int(cnt[vo.CNT_STEPS[s]]) for s in (3, 5, 7)}
        share[rtol] = steps[7] / sum(steps.values())
        if rtol == 1e-12:
            assert cnt[vo.CNT_CHANGES] >= 1 and steps[7] > steps[3], steps
    assert share[1e-12] > share[1e-6], share


@pytest.mark.parametrize("name", NEW)
def test_agrees_with_radau5_at_a_common_tolerance(en02, en02_reference, name) -> None:
    """At rtol 1e-10 every Radau IIA method lands within 1e-9 m of radau5's trajectory, and
    within 1e-9 m of the reference (radau5 itself: measured 4e-13 m over 120 s)."""
    run = {m: simulate(en02.replace(method=m, rtol=1e-10, atol=1e-12, fixed_step=False,
                                    interval=0.025)) for m in ("radau5", name)}
    assert all(r.counts.status == "ok" for r in run.values())
    assert np.abs(run[name].histories.X - run["radau5"].histories.X).max() < 1e-9
    assert np.abs(run[name].histories.X - en02_reference.histories.X).max() < 1e-9


def test_driver_counts_match_the_stepper(en02) -> None:
    """The driver's counts are the stepper's: radau_high_order.solve runs the same stepper with
    free steps, so its Newton iterations per step and Jacobians are of the same size; every
    count is positive and a fixed radau9 step of 0.2 s needs no rejection."""
    res = simulate(en02.replace(method="radau9", rtol=1e-10, atol=1e-12, fixed_step=False))
    c = res.counts
    assert c.status == "ok"
    assert c.newton_iterations >= c.steps  # one Newton iteration at least per try
    assert 0 < c.jacobians <= c.steps + c.rejected_steps
    assert c.lu_factorisations >= c.jacobians
    # rhs: 5 per Newton iteration, the Jacobian's columns, one per step for f(t, y)
    n_cols = 7  # R, alpha and their rates, omega (creatio.dynamics.solvers.radau5.jacobian)
    assert c.rhs_evals >= 5 * c.newton_iterations + n_cols * c.jacobians + c.steps
    fixed = simulate(en02.replace(method="radau9", dt=0.2, fixed_step=True, rtol=1e-12,
                                  atol=1e-14, interval=0.2))
    f = fixed.counts
    assert f.status == "ok" and f.rejected_steps == 0 and f.steps == 10
    r5 = simulate(en02.replace(method="radau5", rtol=1e-8, atol=1e-10, fixed_step=False))
    assert r5.counts.newton_iterations >= r5.counts.steps


@njit(cache=True)
def _both_dense(ctx, y0, t_end, h, s, td, coll, corrected):
    """Fixed steps of h at s stages (Newton to rtol 1e-14) with the driver's contract: at
    each time of td inside a step, the collocation polynomial (radau_high_order.dense) into
    coll and the corrected one (radau_high_order.dense_step) into corrected."""
    ws = vo.workspace(2, s, s, s, 60, vo.THET)
    y = y0.copy()
    f = np.empty(2)
    ynew = np.empty(2)
    osc_rhs(0.0, y, f, ctx)
    t = 0.0
    jd = 0
    while t < t_end - 1e-12:
        outcome, _, _, _, _, _ = vo.step(osc_rhs, None, ctx, t, t + h, h, y, f, ynew, ws,
                                         (1e-14, 1e-14), True, False)
        if outcome != ACCEPTED:
            return False
        while jd < td.size and td[jd] <= t + h:
            dense(ws, td[jd], coll[jd])
            dense_step(ws, td[jd], corrected[jd], t, y, f, t + h, ynew, ynew)
            jd += 1
        t += h
        y[:] = ynew
        osc_rhs(t, y, f, ctx)
    return True


@pytest.mark.parametrize(("s", "hs"), [(3, (0.04, 0.02, 0.01)), (5, (0.16, 0.1, 0.0625)),
                                       (7, (0.4, 0.25, 0.16))])
def test_corrected_dense_output_gains_an_order_on_the_collocation_polynomial(
        s: int, hs: tuple) -> None:
    """Dense output between steps (radau_high_order.dense_step): the collocation polynomial
    corrected by its defect at the step's start. At 200 random off-step times of the damped
    oscillator (w = 10) at fixed steps, its error falls as h^(s+2) (measured 5.0, 7.0, 9.0)
    where the collocation polynomial's falls as h^(s+1) (4.1-4.3, 5.9-6.0, 7.9), and it is
    the smaller at every h (by 2.4-15x, more at smaller h)."""
    w = 10.0
    ctx = (1.0, 0.05, w)
    td = np.sort(np.random.default_rng(1).uniform(1.0, 10.0, 200))
    errs = []
    for h in hs:
        coll = np.full((td.size, 2), np.nan)
        corrected = np.full((td.size, 2), np.nan)
        y0 = np.array([0.0, 1.0])
        assert _both_dense(ctx, y0, 10.0, h, s, td, coll, corrected)
        x = np.modf(td / h)[0]
        off = (x > 0.05) & (x < 0.95)
        assert off.sum() > 150
        exact = np.stack([np.sin(w * td), np.cos(w * td)], axis=-1)
        errs.append([np.max(np.abs(v[off] - exact[off])) for v in (coll, corrected)])
    errs = np.array(errs)
    ratios = np.asarray(hs[:-1]) / np.asarray(hs[1:])
    slopes = np.log(errs[:-1] / errs[1:]) / np.log(ratios)[:, None]
    assert np.all(np.abs(slopes[:, 0] - (s + 1)) < 0.35), slopes
    assert np.all(np.abs(slopes[:, 1] - (s + 2)) < 0.35), slopes
    assert np.all(errs[:, 1] < errs[:, 0] / 2.0), errs


def test_defect_shapes_vanish_at_both_ends_with_unit_start_slope() -> None:
    """The correction's shape per stage count: W(0) = W(1) = 0 (so dense output keeps the
    step's ends), W'(0) = 1 and W'(c_i) = 0 at every stage (so its derivative keeps the
    collocation polynomial's at the stages), each to the rounding of its coefficients (a few
    eps times their sum: the coefficients reach 1e3 at 7 stages, where prod c_i is small)."""
    from creatio.dynamics.solvers.radau_coefficients import STAGES

    shapes = defect_shapes()
    for k, s in enumerate(STAGES):
        poly = np.polynomial.Polynomial(shapes[k])
        assert poly.trim().degree() == s + 1
        c = coefficients(s).c
        rounding = 8.0 * np.finfo(float).eps * np.abs(poly.deriv().coef).sum()
        np.testing.assert_allclose([poly(0.0), poly(1.0)], 0.0, atol=rounding)
        np.testing.assert_allclose(poly.deriv()(0.0), 1.0, rtol=0, atol=rounding)
        np.testing.assert_allclose(poly.deriv()(c), 0.0, atol=rounding)


def test_jacobians_ahead_cut_the_newton_iterations_of_long_free_steps() -> None:
    """Free steps at 7 stages over EN-02's first 60 s (rtol 1e-11, steps of 0.3-0.6 s): with
    the Jacobian at the stages' centroid (what the driver's dense runs do), the Newton
    iterations per try fall to at most 0.85 of radau.f's Jacobian at the step's start
    (measured 4.8 against 6.3, with Newton's tolerance FNEWT_AHEAD times radau.f's), and
    both runs keep their rows every second within 100 rtol of a reference of a different
    method (dop853 at rtol 1e-13) in R and in R alpha (measured 1.4e-12 and 4.8e-12 m,
    3.8e-11 and 1.2e-10 m)."""
    prob = resolve("en02", []).obj.sphere_problem().replace(energy=False, t_end=60.0)
    ref = simulate(prob.replace(method="dop853", rtol=1e-13, atol=1e-15, fixed_step=False,
                                interval=1.0))
    assert ref.counts.status == "ok"
    y0 = prob.initial_state(True, False)
    p, lawc = prob.parameter_vector(), prob.law_matrix()
    td = np.arange(1.0, 61.0)
    rtol = 1e-11
    per_try = {}
    for ahead in (False, True):
        ok, _, out, cnt, _, steps, _, _ = solve(p, lawc, y0, 60.0, 1e-3, rtol, rtol * 1e-2, 7,
                                                7, 7, False, 100000, td, vo.THET, ahead)
        assert ok
        tries = steps + cnt[vo.CNT_REJECTED_ERROR] + cnt[vo.CNT_REJECTED_NEWTON]
        per_try[ahead] = cnt[vo.CNT_NEWTON] / tries
        R, alpha = ref.histories.R[1:], ref.histories.alpha[1:]
        assert np.abs(out[:, 0] - R).max() < 100 * rtol
        assert np.abs(R * (out[:, 1] - alpha)).max() < 100 * rtol
    assert per_try[True] <= 0.85 * per_try[False], per_try
