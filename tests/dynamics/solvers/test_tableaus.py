"""The tableaus (creatio.dynamics.solvers.tableaus), written as rationals, closed forms and
published decimals, evaluate to the very doubles of an independent implementation: scipy's
Dormand-Prince, DOP853 and Radau IIA constants, bit for bit (the doubles the integrators ran
with before the coefficients were written this way, which equalled scipy's too)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate._ivp import dop853_coefficients as d8
from scipy.integrate._ivp import radau as scipy_radau
from scipy.integrate._ivp.rk import RK45

from creatio.dynamics.solvers import METHODS
from creatio.dynamics.solvers import tableaus as tb


def same_bits(a, b) -> bool:
    """Equal as IEEE doubles, bit for bit (so -0.0 != 0.0 and every last bit counts)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


@pytest.mark.parametrize(("ours", "theirs"), [
    (tb.DP5_C, RK45.C), (tb.DP5_A, RK45.A), (tb.DP5_B, RK45.B), (tb.DP5_E, RK45.E),
    (tb.DP5_P, RK45.P),
    (tb.DOP853_C, d8.C[:d8.N_STAGES]), (tb.DOP853_A, d8.A[:d8.N_STAGES, :d8.N_STAGES]),
    (tb.DOP853_B, d8.B), (tb.DOP853_E5, d8.E5), (tb.DOP853_E3, d8.E3),
    (tb.DOP853_C_EXTRA, d8.C[d8.N_STAGES + 1:]), (tb.DOP853_A_EXTRA, d8.A[d8.N_STAGES + 1:]),
    (tb.DOP853_D, d8.D),
    (tb.RADAU_C, scipy_radau.C), (tb.RADAU_E, scipy_radau.E), (tb.RADAU_T, scipy_radau.T),
    (tb.RADAU_TI, scipy_radau.TI), (tb.RADAU_P, scipy_radau.P),
    (tb.RADAU_MU_REAL, scipy_radau.MU_REAL), (tb.RADAU_MU_COMPLEX_RE, scipy_radau.MU_COMPLEX.real),
    (tb.RADAU_MU_COMPLEX_IM, scipy_radau.MU_COMPLEX.imag),
], ids=lambda x: "" if isinstance(x, np.ndarray | float) else str(x))
def test_coefficients_are_scipys_doubles(ours, theirs) -> None:
    assert same_bits(ours, theirs)


def test_rationals_are_exact_where_a_double_can_be() -> None:
    """The classical RK4 and the dyadic DOP853 entries are exact; 2/9-like fractions round
    to the nearest double, as the published decimals do (Dormand-Prince c5 = 8/9)."""
    np.testing.assert_array_equal(tb.RK4_C, [0.0, 0.5, 0.5, 1.0])
    assert tb.DOP853_A[6, 0] == 0.037109375 and tb.DOP853_A[6, 5] == -0.017578125
    assert tb.DP5_C[4] == float("0.888888888888888888888888888889")
    assert tb.DOP853_C[5] == float("0.333333333333333333333333333333")


def test_radau_collocation_constants_are_consistent() -> None:
    """The closed forms hold together: the nodes are the roots of the Radau polynomial
    10 x^3 - 18 x^2 + 9 x - 1, the inverse of the Radau IIA matrix built from them has the
    eigenvalues mu_real and mu_complex with its conjugate, and TI inverts T (to rounding)."""
    c = tb.RADAU_C
    np.testing.assert_allclose(np.polyval([10, -18, 9, -1], c), 0.0, atol=1e-15)
    # the Radau IIA matrix from its nodes: a_ij = integral from 0 to c_i of l_j
    powers = np.array([[ci ** (k + 1) / (k + 1) for k in range(3)] for ci in c])
    a = powers @ np.linalg.inv(np.vander(c, 3, increasing=True))
    ev = np.sort_complex(np.linalg.eigvals(np.linalg.inv(a)))
    mu_c = tb.RADAU_MU_COMPLEX_RE + 1j * tb.RADAU_MU_COMPLEX_IM
    np.testing.assert_allclose(ev, np.sort_complex([tb.RADAU_MU_REAL, mu_c, mu_c.conjugate()]),
                               rtol=1e-13)
    np.testing.assert_allclose(tb.RADAU_T @ tb.RADAU_TI, np.eye(3), atol=1e-15)


@pytest.mark.parametrize("name", list(METHODS))
def test_every_method_meets_its_order_on_the_linear_test(name: str) -> None:
    """Every method of the registry: an explicit tableau's rows sum to its nodes (A 1 = c)
    and its weights meet the linear-test conditions b A^(k-1) 1 = 1 / k! for k <= its order
    (its stability polynomial agrees with exp(z) to that order, as an order-p method's must),
    its error weights vanish on a constant (sum e = 0) and its real stability interval is
    finite; an implicit method (no tableau) is L-stable, with no limit on dt."""
    m = METHODS[name]
    if m.tableau is None:
        assert m.l_stable and math.isinf(m.stability_bound)
        return
    b, c, s = m.tableau.weights(), np.asarray(m.tableau.c), m.tableau.stages
    given = np.asarray(m.tableau.a, float)
    a = np.zeros((s, s))  # A as stored may leave out its zero last column
    a[:, :given.shape[1]] = given[:s, :s]
    np.testing.assert_allclose(a.sum(axis=1), c[:s], rtol=0, atol=1e-15)
    v = np.ones(s)
    for k in range(1, m.order + 1):
        assert b @ v == pytest.approx(1.0 / math.factorial(k), rel=1e-12, abs=1e-17), k
        v = a @ v
    for e in (m.tableau.e, m.tableau.e3):
        if e is not None:
            assert abs(float(np.sum(e))) < 1e-15
    assert 0.0 < m.stability_bound < math.inf and not m.l_stable
