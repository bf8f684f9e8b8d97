"""The rib skin (creatio.model.ribs): a periodic quintic spline through the ribs, C4 at the
ribs, its aliased-harmonic series and its order-6 shape error (docs/model.md s.14)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline

from creatio.model import ribs
from creatio.model.laws import Law
from creatio.model.surface import Motion, Surface, Wave

KA = 6


@pytest.mark.parametrize("N", [13, 18, 24, 72])
def test_spline_takes_the_rib_values_exactly(N: int) -> None:
    c, s = ribs.Ribs(N).samples(KA)
    table = ribs.skin_table(c, s)
    alpha_j = 2.0 * np.pi * np.arange(N) / N
    assert np.max(np.abs(ribs.spline_eval(table[:, :6], alpha_j) - c)) < 1e-14
    assert np.max(np.abs(ribs.spline_eval(table[:, 6:], alpha_j) - s)) < 1e-14


def test_spline_is_scipy_periodic_quintic() -> None:
    N = 18
    y = np.random.default_rng(1).normal(size=N)
    coef = ribs.periodic_quintic(y)
    knots = 2.0 * np.pi * np.arange(N + 1) / N
    ref = make_interp_spline(knots, np.append(y, y[0]), k=5, bc_type="periodic")
    alpha = np.linspace(0.0, 2.0 * np.pi, 997)
    for order in range(5):
        scale = np.max(np.abs(ref(alpha, nu=order)))
        assert np.max(np.abs(ribs.spline_eval(coef, alpha, order) - ref(alpha, nu=order))) \
            < 1e-12 * scale


def test_c4_at_the_knots_and_periodic() -> None:
    N = 20
    coef = ribs.periodic_quintic(np.random.default_rng(2).normal(size=N))
    h = 2.0 * np.pi / N
    # derivative n of interval j at x = 1 against interval j + 1 at x = 0 (cyclic: periodic)
    for n in range(6):
        left = np.array([sum(math.perm(p, n) * coef[j, p] for p in range(n, 6))
                         for j in range(N)]) / h**n
        right = math.factorial(n) * np.roll(coef[:, n], -1) / h**n
        gap = np.max(np.abs(left - right))
        if n <= 4:
            assert gap < 1e-9 * max(1.0, np.max(np.abs(right)))
        else:
            assert gap > 1e-6 * np.max(np.abs(right))  # the fifth derivative jumps
    alpha = np.linspace(-3.0, 3.0, 101)
    assert np.max(np.abs(ribs.spline_eval(coef, alpha)
                         - ribs.spline_eval(coef, alpha + 4.0 * np.pi))) < 1e-12


@pytest.mark.parametrize("N", [18, 24, 48])
def test_spline_equals_aliased_harmonic_series(N: int) -> None:
    table = ribs.Ribs(N).table(KA)
    alpha = np.linspace(0.0, 2.0 * np.pi, 1001)
    phi = 0.7
    m = np.arange(-400, 401)
    h = ribs.alias_amplitudes(N, KA, m)
    series = np.sum(h[:, None] * np.cos((KA + m[:, None] * N) * alpha + phi), axis=0)
    assert np.max(np.abs(ribs.skin(table, phi, alpha) - series)) < 1e-12
    fft = ribs.alias_spectrum(table, KA, M=2)
    assert np.max(np.abs(fft - h[398:403])) < 1e-12


def test_h0_tends_to_one_and_shape_error_falls_at_order_six() -> None:
    Ns = np.array([96, 144, 192, 288])
    h0 = [float(ribs.alias_amplitudes(int(N), KA, 0)) for N in Ns]
    assert all(0.0 < 1.0 - a for a in h0) and np.all(np.diff(1.0 - np.array(h0)) < 0)
    measured = []
    for N in Ns:
        table = ribs.Ribs(int(N)).table(KA)
        alpha = np.linspace(0.0, 2.0 * np.pi, 64 * int(N), endpoint=False)
        err = ribs.skin(table, 0.3, alpha) - np.cos(KA * alpha + 0.3)
        measured.append(math.sqrt(np.mean(err**2) / 0.5))
        assert measured[-1] == pytest.approx(ribs.shape_error(int(N), KA), rel=1e-6)
    slope = np.polyfit(np.log(Ns), np.log(measured), 1)[0]
    assert abs(slope + 6.0) < 0.3


def test_samples_of_sin_vanish_at_two_ka_and_it_is_refused() -> None:
    _, s = ribs.Ribs(2 * KA).samples(KA)
    assert np.max(np.abs(s)) < 1e-14
    with pytest.raises(ValueError, match=r"N must be > 2 Ka = 12"):
        ribs.check_rib_count(2 * KA, KA)
    with pytest.raises(ValueError, match=r"2 Ka = 12"):
        Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=KA, ribs=ribs.Ribs(12))
    ribs.check_rib_count(2 * KA + 1, KA)


def test_rib_errors_enter_the_samples() -> None:
    e, d = ribs.rib_errors(24, 0.01, math.radians(1.0), seed=5)
    e2, d2 = ribs.rib_errors(24, 0.01, math.radians(1.0), seed=5)
    assert np.array_equal(e, e2) and np.array_equal(d, d2) and np.std(e) > 0.0
    c, s = ribs.Ribs(24, tuple(e), tuple(d)).samples(KA)
    alpha_j = 2.0 * np.pi * np.arange(24) / 24
    assert np.allclose(np.hypot(c, s), 1.0 + e, rtol=0, atol=1e-15)
    assert np.allclose(np.arctan2(s, c), np.angle(np.exp(1j * (KA * alpha_j + d))), atol=1e-13)


def test_wave_on_ribs_matches_its_derivatives_by_differences() -> None:
    surf = Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=KA, ribs=ribs.Ribs(18))
    motion = Motion(phi_r=Law.quintic(0.0, -math.pi, 120.0),
                    phi_a=Law.quintic(0.0, 12.0 * math.pi, 120.0), gamma=Law.constant(0.0))
    rng = np.random.default_rng(3)
    a, R, t = rng.uniform(0, 2 * np.pi, 20), rng.uniform(0, 1.72, 20), rng.uniform(1, 119, 20)
    w = Wave(surf, motion, a, R, t)
    d = 1e-5

    def W(da=0.0, dR=0.0, dt=0.0):
        return Wave(surf, motion, a + da, R + dR, t + dt).W

    assert np.allclose(w.W_a, (W(da=d) - W(da=-d)) / (2 * d), atol=1e-8)
    assert np.allclose(w.W_R, (W(dR=d) - W(dR=-d)) / (2 * d), atol=1e-8)
    assert np.allclose(w.W_t, (W(dt=d) - W(dt=-d)) / (2 * d), atol=1e-8)
    assert np.allclose(w.W_aa, (W(da=d) - 2 * w.W + W(da=-d)) / d**2, atol=1e-4)
    ideal = Wave(Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=KA), motion, a, R, t)
    big = Wave(Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=KA, ribs=ribs.Ribs(600)), motion,
               a, R, t)
    # the spline's k-th derivative converges as h^(6 - k): bound A Ka^6 h^(6 - k)
    h = 2.0 * np.pi / 600
    for name, k in (("W", 0), ("W_t", 0), ("W_tt", 0), ("W_Rt", 0), ("W_a", 1), ("W_at", 1),
                    ("W_aa", 2)):
        bound = 0.18 * KA**6 * h ** (6 - k)
        assert np.max(np.abs(getattr(big, name) - getattr(ideal, name))) < bound, name
