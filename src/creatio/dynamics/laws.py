"""Compiled scalar evaluation of the general time law of :mod:`creatio.laws`.

phi(t) = phi0 + rate t + delta s(clip(t / T, 0, 1)) + amplitude sin(omega t),
s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (quintic smooth step, MODEL.md section 2).
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["law_eval"]


@njit(cache=True)
def law_eval(
    phi0: float, rate: float, delta: float, T: float, amplitude: float, omega: float, t: float
) -> tuple[float, float, float]:
    """Value, first and second time derivative of the general law at time t.

    Scalar and compiled so the integrator can call it in its inner loop; terms with a zero
    coefficient are skipped (no trigonometry for a law without a sinusoid).
    """
    value = phi0 + rate * t
    d1 = rate
    d2 = 0.0
    if delta != 0.0:
        tau = t / T
        if tau <= 0.0:
            s = 0.0
            ds = 0.0
            dds = 0.0
        elif tau >= 1.0:
            s = 1.0
            ds = 0.0
            dds = 0.0
        else:
            s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau)
            om = 1.0 - tau
            ds = 30.0 * tau * tau * om * om
            dds = 60.0 * tau * om * (1.0 - 2.0 * tau)
        value += delta * s
        d1 += delta * ds / T
        d2 += delta * dds / (T * T)
    if amplitude != 0.0:
        sw = math.sin(omega * t)
        cw = math.cos(omega * t)
        value += amplitude * sw
        d1 += amplitude * omega * cw
        d2 -= amplitude * omega * omega * sw
    return value, d1, d2
