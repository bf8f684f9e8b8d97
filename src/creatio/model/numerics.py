"""Numerical closed forms shared by the model, the integrators and the checks.

* :func:`steps_in`: how many steps of dt make up a span (the "dt divides the interval" rule
  of fixed-step runs and their output grid);
* :func:`observed_order`: the convergence order between successive steps of a check;
* :func:`rk_stability_polynomial` and :func:`real_stability_bound`: the linear stability
  function R(z) = 1 + z b^T (I - z A)^-1 1 of an explicit Runge-Kutta tableau and the length
  of the negative real axis inside |R| <= 1 (docs/model.md s.6).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["observed_order", "real_stability_bound", "rk_stability_polynomial", "steps_in"]

#: Relative tolerance of "an integer multiple" (a span written in decimal, like 120 s at
#: dt = 0.002 s, is a multiple only up to rounding).
MULTIPLE_RTOL = 1e-9


def steps_in(span: float, dt: float) -> int | None:
    """n with span = n dt to a relative 1e-9 (n >= 1), or None if dt does not divide span."""
    if not (dt > 0.0 and span > 0.0):
        return None
    ratio = span / dt
    n = round(ratio)
    if n < 1 or abs(ratio - n) > MULTIPLE_RTOL * ratio:
        return None
    return n


def observed_order(hs: Sequence[float], errors: ArrayLike) -> NDArray[np.float64]:
    """log(e_i / e_{i+1}) / log(h_i / h_{i+1}) along the last axis."""
    h = np.asarray(hs, float)
    e = np.asarray(errors, float)
    return np.log(e[..., :-1] / e[..., 1:]) / np.log(h[:-1] / h[1:])


def rk_stability_polynomial(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Ascending coefficients of R(z) = 1 + sum_j z^j b^T A^(j-1) 1 for an explicit tableau
    (A strictly lower triangular, so the series ends at z^s)."""
    b = np.asarray(b, float)
    s = b.size
    A = np.zeros((s, s))
    a = np.asarray(a, float)
    A[:, : min(a.shape[1], s)] = a[:s, : min(a.shape[1], s)]
    coeffs = [1.0]
    v = np.ones(s)
    for _ in range(s):
        coeffs.append(float(b @ v))
        v = A @ v
    return np.array(coeffs)


def real_stability_bound(coefficients: ArrayLike, search: float = 20.0) -> float:
    """Largest x with |R(-y)| <= 1 for every y in [0, x]: scan, then bisect to rounding."""
    poly = np.polynomial.Polynomial(np.asarray(coefficients, float))
    ys = np.linspace(0.0, search, 200001)
    bad = np.nonzero(np.abs(poly(-ys)) > 1.0 + 1e-12)[0]
    if bad.size == 0:
        return float("inf")
    lo, hi = ys[bad[0] - 1], ys[bad[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if abs(poly(-mid)) > 1.0:
            hi = mid
        else:
            lo = mid
    return float(lo)
