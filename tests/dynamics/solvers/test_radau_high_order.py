"""Radau IIA of orders 9, 13 and variable order (radau9, radau13, radau) in the sphere driver.

What is checked against what: the stability functions of the registered methods against the
A- and L-stability their registry entries state (no stability limit on dt); the observed
order of radau9 and radau13 on EN-02 at fixed steps, at the steps and between them (dense
output), against a reference of a different method (dop853 at rtol 1e-13); the variable-order
method's stage counts on EN-02 at a loose and a tight tolerance; agreement with radau5 at a
common tolerance; the work counts the driver returns against the stepper's own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.dynamics.solvers import METHODS, RADAU_VO
from creatio.dynamics.solvers import radau_variable_order as vo
from creatio.dynamics.solvers.radau_coefficients import (
    coefficients,
    pade_denominator,
    stability_function,
)
from creatio.dynamics.solvers.radau_high_order import PRM_S_MAX, PRM_S_MIN, solve
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
    """Rows inside the steps come from the collocation polynomial (degree s), whose error
    there is O(h^(s + 1)) (measured: radau9 6.3, radau13 8.0)."""
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
    assert s <= observed <= s + 1.5, (errs, observed)


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
