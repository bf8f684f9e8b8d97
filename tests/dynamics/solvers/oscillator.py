"""The forced oscillator that the Radau steppers' tests integrate (test_radau_coefficients,
test_radau_high_order), written once: a weak quadratic nonlinearity whose exact solution is
y = (sin w t, cos w t),
  y1' = w y2 - k (y1 - sin wt) + e (y2^2 - cos^2 wt),
  y2' = -w y1 - k (y2 - cos wt) + e (y1^2 - sin^2 wt),
ctx = (k, e, w); undamped (k = 0) its global error grows with t, damped (k = 1) a dense
output's own error shows. Found by name through pytest's pythonpath (pyproject.toml)."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def osc_rhs(t, y, out, ctx):  # type: ignore[no-untyped-def]
    """The right-hand side into out (the steppers' rhs signature)."""
    k, e, w = ctx
    s = math.sin(w * t)
    c = math.cos(w * t)
    out[0] = w * y[1] - k * (y[0] - s) + e * (y[1] * y[1] - c * c)
    out[1] = -w * y[0] - k * (y[1] - c) + e * (y[0] * y[0] - s * s)


@njit(cache=True)
def osc_jac(t, y, f, jac, work, tmp, ctx):  # type: ignore[no-untyped-def]
    """Its exact Jacobian into jac (the steppers' jac signature); no evaluation spent."""
    k, e, w = ctx
    jac[0, 0] = -k
    jac[0, 1] = w + 2.0 * e * y[1]
    jac[1, 0] = -w + 2.0 * e * y[0]
    jac[1, 1] = -k
    return 0
