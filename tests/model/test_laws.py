"""Time laws (docs/model.md s.2): values and derivatives against closed forms and differences."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import Polynomial

from creatio.model.cavity import pattern_angle
from creatio.model.laws import (
    KIND_CODES,
    L_AMPLITUDE,
    L_DELTA,
    L_KIND,
    L_OMEGA,
    L_PHI0,
    L_RATE,
    L_T,
    NLAW,
    QUINTIC_CODES,
    Law,
    LawKind,
    law_eval,
    quintic_step,
    trapezoid_on_grid,
    unit_coefficients,
)
from creatio.model.surface import Motion, Surface

# Quintic smooth step s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, built as a polynomial object so
# that its derivatives come from numpy's polynomial algebra, not from the code under test.
S_POLY = Polynomial([0.0, 0.0, 0.0, 10.0, -15.0, 6.0])

# One law of each kind (its special case of docs/model.md s.2), with non-trivial coefficients,
# and its closed form below: the independent check each kind needs.
# test_every_kind_has_a_closed_form fails for a kind of LawKind that has none here.
LAWS = {
    LawKind.constant: Law.constant(0.7),
    LawKind.linear: Law.linear(0.23, 0.31),
    LawKind.quintic: Law.quintic(0.5, 3.0, 2.0),
    LawKind.sinusoid: Law.sinusoid(np.pi / 4, 0.3, 0.7),
    LawKind.cosine_ramp: Law.cosine_ramp(0.5, 3.0, 2.0),
    LawKind.trapezoid: Law.trapezoid(0.5, 3.0, 2.0, 0.25),
}


def law_of(kind: LawKind) -> Law:
    """A law of kind with every term of the general form nonzero (phi0, rate, the step's
    delta over T = 2, a sinusoid; a trapezoid's ramp 1/4): built from the registry alone, so
    the tests over LawKind run a new kind with no edit here."""
    return Law(phi0=0.5, rate=0.31, delta=3.0, T=2.0, amplitude=0.3, omega=0.7, kind=kind,
               ramp=0.25)


def closed_form(kind: LawKind, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, d1, d2 of LAWS[kind] written out from docs/model.md s.2."""
    z = np.zeros_like(t)
    if kind is LawKind.constant:
        return 0.7 + z, z, z
    if kind is LawKind.linear:
        return 0.23 + 0.31 * t, 0.31 + z, z
    if kind is LawKind.quintic:
        T, D = 2.0, 3.0
        tau = t / T
        return (
            0.5 + D * S_POLY(tau),
            D * 30.0 * tau**2 * (1.0 - tau) ** 2 / T,
            D * 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / T**2,
        )
    if kind is LawKind.cosine_ramp:
        T, D = 2.0, 3.0
        w = np.pi / T
        return (0.5 + D * (1.0 - np.cos(w * t)) / 2.0, D * w * np.sin(w * t) / 2.0,
                D * w**2 * np.cos(w * t) / 2.0)
    if kind is LawKind.trapezoid:
        return trapezoid_closed_form(t, 0.5, 3.0, 2.0, 0.5)
    assert kind is LawKind.sinusoid, f"no closed form written for kind {kind.value}"
    G, Om = 0.3, 0.7
    return np.pi / 4 + G * np.sin(Om * t), G * Om * np.cos(Om * t), -G * Om**2 * np.sin(Om * t)


def d5(f, x: np.ndarray, h: float) -> np.ndarray:
    """Fourth-order 5-point central difference of f at x."""
    return (f(x - 2 * h) - 8 * f(x - h) + 8 * f(x + h) - f(x + 2 * h)) / (12 * h)


# Times strictly inside the cycle [0, 2] with room for the 5-point stencil (the clamped laws are
# only C2 (quintic) or C1 (cosine ramp) at 0 and T, so a stencil straddling them would lose
# its 4th order).
T_IN = np.linspace(0.01, 1.99, 67)


def test_every_kind_has_a_closed_form() -> None:
    """Each kind of the registry has its special case and closed form here (a new kind is
    picked up by every test over LawKind and fails this one until its closed form is
    written)."""
    assert set(LAWS) == set(LawKind)
    assert all(LAWS[kind].kind is kind for kind in LawKind)


@pytest.mark.parametrize("kind", list(LawKind))
def test_law_matches_closed_form(kind: LawKind) -> None:
    """Each kind's value, d1, d2 equal the formulas of docs/model.md (rounding-level agreement)."""
    lv = LAWS[kind](T_IN)
    v, d1, d2 = closed_form(kind, T_IN)
    for got, want in ((lv.value, v), (lv.d1, d1), (lv.d2, d2)):
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-14)


def off_the_kinks(law: Law, t: np.ndarray, margin: float) -> np.ndarray:
    """The times of t farther than margin from the cycle's ends and the law's switches
    (where a step's acceleration may jump)."""
    kinks = np.array([0.0, law.T, *law.switch_times()])
    return t[np.min(np.abs(t[:, None] - kinks[None, :]), axis=1) > margin]


@pytest.mark.parametrize("kind", list(LawKind))
def test_law_derivatives_match_central_differences(kind: LawKind) -> None:
    """d1 from 5-point differences of value, d2 from 5-point differences of d1, for a law of
    each kind with every term of the general form, away from its step's kinks.

    Error of the 5-point formula: h^4/30 max|f^(5)| + ~1.5 eps max|f| / h. With h = 1e-3 the
    largest fifth derivative here is the quintic's delta 720 / T^5 = 67.5, giving 2.3e-12
    (the cosine ramp's delta (pi / T)^5 / 2 = 14.3 gives less, the trapezoid's segments are
    quadratics, the sinusoid's 0.3 0.7^5 = 0.05), and rounding (|f| <= 5) adds ~1.7e-12;
    atol 1e-10 is a safe margin over both.
    """
    law, h = law_of(kind), 1e-3
    t = off_the_kinks(law, T_IN, 3 * h)
    lv = law(t)
    np.testing.assert_allclose(d5(lambda s: law(s).value, t, h), lv.d1, rtol=0, atol=1e-10)
    np.testing.assert_allclose(d5(lambda s: law(s).d1, t, h), lv.d2, rtol=0, atol=1e-10)


@pytest.mark.parametrize("kind", list(LawKind))
def test_law_output_shape_follows_t(kind: LawKind) -> None:
    """Value and derivatives broadcast to the shape of t, even for constant parts."""
    t = np.zeros((3, 4))
    for law in (LAWS[kind], law_of(kind)):
        lv = law(t)
        assert lv.value.shape == lv.d1.shape == lv.d2.shape == (3, 4)


@pytest.mark.parametrize("kind", list(LawKind))
def test_every_step_rises_from_0_to_1_and_holds(kind: LawKind) -> None:
    """The step a kind's delta travels starts at 0 and ends at 1 at rest, holds outside
    [0, 1], rises monotonically, and its s' and s'' are the derivatives of s and s': their
    trapezoidal integrals over [0, 1] are s(1) - s(0) = 1 and s'(1) - s'(0) = 0, to the
    rule's error h^2 max|s^(3)| / 12 = 5e-10 (h = 1e-5, |s^(3)| <= 60: the quintic's) and,
    where s'' jumps (the trapezoid's switches, the cosine's ends), a cell's jump times h,
    below 1e-4."""
    law = Law(delta=1.0, T=1.0, kind=kind, ramp=0.25)
    outside = np.array([-3.0, -1e-3, 1.0 + 1e-3, 4.0])
    s, ds, dds = law.step(outside)
    np.testing.assert_array_equal(s, [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_array_equal(ds, 0.0)
    np.testing.assert_array_equal(dds, 0.0)
    tau = np.linspace(0.0, 1.0, 100001)
    s, ds, dds = law.step(tau)
    assert s[0] == 0.0 and s[-1] == 1.0
    assert abs(ds[0]) < 1e-15 and abs(ds[-1]) < 1e-15
    assert np.all(np.diff(s) >= 0.0) and np.all(ds >= -1e-15)
    assert np.trapezoid(ds, tau) == pytest.approx(1.0, abs=1e-8)
    assert np.trapezoid(dds, tau) == pytest.approx(0.0, abs=1e-4)


def test_quintic_step_endpoints_and_midpoint() -> None:
    """s, s', s'' at tau = 0 and 1 are (0, 0, 0) and (1, 0, 0); at 1/2: (1/2, 15/8, 0)."""
    s, ds, dds = quintic_step(np.array([0.0, 0.5, 1.0]))
    np.testing.assert_array_equal(s[[0, 2]], [0.0, 1.0])
    np.testing.assert_array_equal(ds[[0, 2]], [0.0, 0.0])
    np.testing.assert_array_equal(dds[[0, 2]], [0.0, 0.0])
    np.testing.assert_allclose([s[1], ds[1], dds[1]], [0.5, 1.875, 0.0], atol=1e-15)


def test_quintic_step_against_polynomial_derivatives() -> None:
    """Inside (0, 1) s, ds/dtau, d2s/dtau2 equal the polynomial and its exact derivatives."""
    tau = np.linspace(0.0, 1.0, 101)
    s, ds, dds = quintic_step(tau)
    np.testing.assert_allclose(s, S_POLY(tau), atol=1e-15)
    np.testing.assert_allclose(ds, S_POLY.deriv(1)(tau), atol=1e-14)
    np.testing.assert_allclose(dds, S_POLY.deriv(2)(tau), atol=1e-13)


def test_quintic_step_clamped_outside_unit_interval() -> None:
    """Outside [0, 1] the step holds its end value with zero slope and curvature."""
    s, ds, dds = quintic_step(np.array([-5.0, -1e-3, 1.0 + 1e-3, 7.0]))
    np.testing.assert_array_equal(s, [0.0, 0.0, 1.0, 1.0])
    np.testing.assert_array_equal(ds, 0.0)
    np.testing.assert_array_equal(dds, 0.0)


@pytest.mark.parametrize("edge", [0.0, 2.0])
def test_quintic_law_is_c2_across_cycle_ends(edge: float) -> None:
    """Value, d1, d2 of the clamped quintic law are continuous across t = 0 and t = T.

    Near an end, d2 = delta 60 tau (1 - tau)(1 - 2 tau) / T^2 is Lipschitz with constant
    60 delta / T^3 = 22.5, d1 and value vanish even faster; so the jump over [edge - e,
    edge + e] must be below 22.5 * e (plus rounding), while a C1-only law would jump by O(1).
    """
    law = Law.quintic(0.5, 3.0, 2.0)
    for e in (1e-4, 1e-6, 1e-8):
        lo, hi = law(edge - e), law(edge + e)
        for a, b in ((lo.value, hi.value), (lo.d1, hi.d1), (lo.d2, hi.d2)):
            assert abs(float(b) - float(a)) <= 22.5 * 2 * e + 1e-15
    before, after = law(-3.0), law(5.0)
    assert float(before.value) == 0.5 and float(after.value) == 3.5
    for lv in (before, after):
        assert float(lv.d1) == 0.0 and float(lv.d2) == 0.0


def test_constructors_set_kind_and_coefficients() -> None:
    """coefficients() lays out (phi0, rate, delta, T, amplitude, omega) and the kind's code
    at the named positions, for each constructor."""
    cases = [
        (Law.constant(0.7), LawKind.constant, [0.7, 0, 0, 1, 0, 0]),
        (Law.linear(0.23, 0.31), LawKind.linear, [0.23, 0.31, 0, 1, 0, 0]),
        (Law.quintic(0.5, 3.0, 2.0), LawKind.quintic, [0.5, 0, 3.0, 2.0, 0, 0]),
        (Law.sinusoid(0.1, 0.3, 0.7), LawKind.sinusoid, [0.1, 0, 0, 1, 0.3, 0.7]),
    ]
    for law, kind, coeffs in cases:
        assert law.kind is kind
        c = law.coefficients()
        assert c.dtype == np.float64 and c.shape == (NLAW,)
        named = [c[i] for i in (L_PHI0, L_RATE, L_DELTA, L_T, L_AMPLITUDE, L_OMEGA)]
        np.testing.assert_array_equal(named, coeffs)
        assert c[L_KIND] == KIND_CODES[kind]


@pytest.mark.parametrize("T", [0.0, -1.0])
def test_nonpositive_cycle_length_raises(T: float) -> None:
    """A quintic cycle length T <= 0 is refused."""
    with pytest.raises(ValueError):
        Law.quintic(0.0, 1.0, T)


def test_bounds_exact_for_bounded_kinds() -> None:
    """bounds() is the exact range over t >= 0 for constant, quintic, sinusoid kinds."""
    assert Law.constant(0.7).bounds() == (0.7, 0.7)
    assert Law.linear(0.3, 0.0).bounds() == (0.3, 0.3)
    assert Law.quintic(0.5, 3.0, 2.0).bounds() == (0.5, 3.5)
    assert Law.quintic(0.5, -3.0, 2.0).bounds() == (-2.5, 0.5)
    lo, hi = Law.sinusoid(np.pi / 4, 0.3, 0.7).bounds()
    assert lo == pytest.approx(np.pi / 4 - 0.3, abs=1e-15)
    assert hi == pytest.approx(np.pi / 4 + 0.3, abs=1e-15)
    # The range is attained: sample densely and compare extremes.
    for law in (Law.quintic(0.5, -3.0, 2.0), Law.sinusoid(np.pi / 4, 0.3, 0.7)):
        v = law(np.linspace(0.0, 20.0, 200001)).value
        lo, hi = law.bounds()
        assert v.min() >= lo - 1e-15 and v.max() <= hi + 1e-15
        assert v.min() == pytest.approx(lo, abs=1e-9) and v.max() == pytest.approx(hi, abs=1e-9)


@pytest.mark.parametrize("rate", [0.31, -0.31])
def test_bounds_unbounded_for_moving_linear_law(rate: float) -> None:
    """A linear law with rate != 0 is unbounded in the direction it moves."""
    lo, hi = Law.linear(0.23, rate).bounds()
    if rate > 0:
        assert hi == np.inf and lo <= 0.23
    else:
        assert lo == -np.inf and hi >= 0.23


# EN-01 pattern velocity over the EN-02 cycle: phi_a = 12 pi s(t / 120), Ka = 6.
EN01_SURFACE = Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=6)
EN01_MOTION = Motion(
    phi_r=Law.constant(0.0), phi_a=Law.quintic(0.0, 12 * np.pi, 120.0), gamma=Law.constant(0.0)
)


def test_en01_pattern_rate_figures() -> None:
    """alpha_p' = -phi_a'/6 peaks at t = 60 s with |alpha_p'| = pi/32 = 0.09817477 rad/s.

    Closed form: -(12 pi / 6) 30 tau^2 (1 - tau)^2 / 120 with tau = t / 120; at tau = 1/2 this
    is pi/32 = 5.625 deg/s. The published 0.09817477 is rounded to 8 decimals (<= 5e-9).
    """
    t = np.linspace(0.0, 120.0, 120001)  # 1 ms grid, includes t = 60 exactly
    ang, rate, _ = pattern_angle(EN01_SURFACE, EN01_MOTION, t)
    tau = t / 120.0
    np.testing.assert_allclose(rate, -2 * np.pi * 30 * tau**2 * (1 - tau) ** 2 / 120, atol=1e-17)
    i = int(np.argmax(np.abs(rate)))
    assert t[i] == 60.0
    assert abs(rate[i]) == pytest.approx(np.pi / 32, rel=1e-15)
    assert abs(abs(rate[i]) - 0.09817477) < 5e-9
    assert np.rad2deg(abs(rate[i])) == pytest.approx(5.625, rel=1e-15)
    assert rate[0] == 0.0 and rate[-1] == 0.0
    assert np.rad2deg(ang[-1] - ang[0]) == pytest.approx(-360.0, rel=1e-14)
    assert np.all(rate <= 0.0)  # the pattern turns one way only (clockwise seen from +z)


def test_en01_pattern_rate_against_central_differences() -> None:
    """Central differences with step 0.001 s agree with alpha_p' to better than 7.95e-11 rad/s.

    The 2-point error is h^2/6 max|alpha_p'''| = 1e-6/6 * 2 pi 60 / 120^3 = 3.6e-11 plus
    rounding ~ eps * 2 pi / h = 1.4e-12, inside the published bound 7.95e-11.
    """
    h = 1e-3
    t = np.linspace(0.0, 120.0, 2401)

    def ang(s):
        return pattern_angle(EN01_SURFACE, EN01_MOTION, s)[0]

    _, rate, acc = pattern_angle(EN01_SURFACE, EN01_MOTION, t)
    fd = (ang(t + h) - ang(t - h)) / (2 * h)
    assert np.max(np.abs(fd - rate)) < 7.95e-11
    # and the pattern acceleration is -phi_a''/6 (5-point differences of the rate; the rate's
    # fifth derivative is <= 2 pi 720 / 120^5 ~ 2e-7, so the error is rounding ~ 1e-14)
    fd2 = d5(lambda s: pattern_angle(EN01_SURFACE, EN01_MOTION, s)[1], t[1:-1], h)
    np.testing.assert_allclose(fd2, acc[1:-1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("edge", [0.0, 2.0])
def test_cosine_ramp_is_c1_with_the_acceleration_jump_of_its_closed_form(edge: float) -> None:
    """Across t = 0 and t = T the cosine ramp's value and rate are continuous (the rate is
    D pi / (2 T) sin(pi t / T), Lipschitz with constant D pi^2 / (2 T^2) = 3.70), while its
    acceleration jumps by D pi^2 / (2 T^2): from 0 up at t = 0 (cos 0 = 1), from -jump to 0 at
    T (cos pi = -1). At the ends themselves it takes the ramp's one-sided value (the closed
    interval [0, T] of docs/model.md s.2), which a step landing there needs."""
    law = Law.cosine_ramp(0.5, 3.0, 2.0)
    jump = 3.0 * np.pi**2 / (2 * 2.0**2)
    for e in (1e-4, 1e-6, 1e-8):
        lo, hi = law(edge - e), law(edge + e)
        assert abs(float(hi.value - lo.value)) <= jump * 2 * e + 1e-15
        assert abs(float(hi.d1 - lo.d1)) <= jump * 2 * e + 1e-15
        assert float(hi.d2 - lo.d2) == pytest.approx(jump, rel=1e-6)
    at = law(edge)
    assert float(at.d2) == pytest.approx(jump if edge == 0.0 else -jump, rel=1e-15)
    assert float(at.value) == (0.5 if edge == 0.0 else 3.5)
    before, after = law(-3.0), law(5.0)
    assert float(before.value) == 0.5 and float(after.value) == 3.5
    for lv in (before, after):
        assert float(lv.d1) == 0.0 and float(lv.d2) == 0.0
    assert law.bounds() == (0.5, 3.5)


def test_cosine_ramp_peak_rate_and_midpoint() -> None:
    """At t = T / 2 the ramp is halfway, at its peak rate D pi / (2 T) and zero acceleration."""
    law = Law.cosine_ramp(0.0, 3.0, 2.0)
    mid = law(1.0)
    assert float(mid.value) == pytest.approx(1.5, abs=1e-15)
    assert float(mid.d1) == pytest.approx(3.0 * np.pi / 4.0, rel=1e-15)
    assert float(mid.d2) == pytest.approx(0.0, abs=1e-15)
    t = np.linspace(0.0, 2.0, 20001)
    assert float(np.max(law(t).d1)) == pytest.approx(3.0 * np.pi / 4.0, rel=1e-12)


@pytest.mark.parametrize("kind", list(LawKind))
def test_compiled_law_eval_matches_the_law(kind: LawKind) -> None:
    """law_eval compiled by numba (as the dynamics core compiles it) agrees with the NumPy
    law at times before, inside and after the cycle and on its switches, to rounding; every
    step but the quintic's (constant, linear and sinusoid laws' delta travels it too) is that
    same formula applied element by element, bit for bit."""
    from numba import njit

    import creatio.dynamics.jit  # noqa: F401  (registers the kernels law_eval calls)

    compiled = njit(law_eval)
    times = np.array([-0.5, 0.0, 0.37, 0.5, 1.0, 1.11, 1.5, 1.99, 2.0, 2.5, 7.0])
    for law in (LAWS[kind], law_of(kind)):
        lv = law(times)
        got = np.array([compiled(law.coefficients(), float(t)) for t in times])
        np.testing.assert_allclose(got, np.stack([lv.value, lv.d1, lv.d2], axis=1),
                                   rtol=1e-13, atol=1e-14)
        if KIND_CODES[kind] not in QUINTIC_CODES:
            tau = np.linspace(-0.5, 1.5, 2001)
            step = np.stack(law.step(tau), axis=1)
            unit = np.array([compiled(unit_coefficients(kind, law.ramp), float(x)) for x in tau])
            assert np.array_equal(step.view(np.uint64), unit.view(np.uint64))


# ------------------------------------------------------------------------------ trapezoid
def trapezoid_closed_form(t: np.ndarray, phi0: float, D: float, T: float, ta: float):
    """Value, rate and acceleration of the trapezoid written out from its kinematics: a
    constant acceleration a = W / ta for ta seconds up to the cruise rate W = D / (T - ta),
    the cruise, the mirror deceleration, held at phi0 + D after T."""
    W = D / (T - ta)
    a = W / ta
    v = np.empty_like(t)
    x = np.empty_like(t)
    acc = np.empty_like(t)
    for i, s in enumerate(t):
        if s <= 0.0:
            x[i], v[i], acc[i] = 0.0, 0.0, 0.0
        elif s < ta:
            x[i], v[i], acc[i] = 0.5 * a * s * s, a * s, a
        elif s <= T - ta:
            x[i], v[i], acc[i] = 0.5 * a * ta * ta + W * (s - ta), W, 0.0
        elif s < T:
            r = T - s
            x[i], v[i], acc[i] = D - 0.5 * a * r * r, a * r, -a
        else:
            x[i], v[i], acc[i] = D, 0.0, 0.0
    return phi0 + x, v, acc


@pytest.mark.parametrize(("T", "ramp"), [(2.0, 0.25), (3.0, 0.5), (10.0, 0.1)])
def test_trapezoid_against_its_kinematics(T: float, ramp: float) -> None:
    """Phase, rate and acceleration away from the switches equal the constant-acceleration
    kinematics; the cruise rate is D / (T - ta); the compiled law_eval equals the NumPy law."""
    from numba import njit

    import creatio.dynamics.jit  # noqa: F401  (registers the kernels law_eval calls)

    phi0, D = 0.3, -4.0
    law = Law.trapezoid(phi0, D, T, ramp)
    ta = ramp * T
    t = np.linspace(-0.5, T + 0.5, 997)
    t = t[np.min(np.abs(t[:, None] - np.array([0.0, ta, T - ta, T])[None, :]), axis=1) > 1e-6]
    lv = law(t)
    x, v, a = trapezoid_closed_form(t, phi0, D, T, ta)
    np.testing.assert_allclose(lv.value, x, rtol=0, atol=1e-13)
    np.testing.assert_allclose(lv.d1, v, rtol=0, atol=1e-13)
    np.testing.assert_allclose(lv.d2, a, rtol=0, atol=1e-12)
    assert abs(law.scalar(0.5 * T)[1]) == pytest.approx(abs(D) / (T - ta), rel=1e-12)
    assert np.max(np.abs(lv.d1)) <= abs(D) / (T - ta) * (1 + 1e-12)
    compiled = njit(law_eval)
    for s in (*t[::50], 0.0, ta, T - ta, T):
        np.testing.assert_allclose(compiled(law.coefficients(), float(s)),
                                   [float(q) for q in law.scalar(float(s))], rtol=1e-14,
                                   atol=1e-15)
    # the rate is the phase's derivative (5-point differences inside each segment)
    inside = t[(t > 0.01) & (t < ta - 0.01)]
    np.testing.assert_allclose(d5(lambda s: law(s).value, inside, 1e-3), law(inside).d1,
                               rtol=0, atol=1e-10)


def test_trapezoid_switches_take_the_mean_acceleration() -> None:
    """On a switch the acceleration is the mean of its two sides (the ramp's own value at
    t = 0): a step ending on it and the next starting on it err by opposite amounts."""
    law = Law.trapezoid(0.0, 2.0, 4.0, 0.25)
    a = law(np.array([0.5])).d2[0]  # inside the ramp
    got = [law.scalar(s)[2] for s in (0.0, 1.0, 3.0, 4.0)]
    assert got == pytest.approx([a, a / 2, -a / 2, -a / 2], rel=1e-14)
    tri = Law.trapezoid(0.0, 2.0, 4.0, 0.5)
    assert tri.scalar(2.0)[2] == 0.0


@pytest.mark.parametrize(("peak", "accel", "dt"), [
    (1.0 * 6, 0.5 * 6, 0.002), (3.0 * 6, 1.5 * 6, 0.002), (2.5 * 6, 3.0 * 6, 0.001),
    (3.0 * 6, 0.5 * 6, 0.002),
])
def test_trapezoid_on_grid_lands_on_steps(peak: float, accel: float, dt: float) -> None:
    """Switch times rounded to the step grid; the law then travels delta exactly, with
    rate and acceleration within one step's rounding of the ones asked for."""
    D = 12.0 * np.pi
    T, ramp, W, a = trapezoid_on_grid(D, peak, accel, dt)
    law = Law.trapezoid(0.0, D, T, ramp)
    for s in law.switch_times():
        assert abs(s / dt - round(s / dt)) < 1e-6
    assert law.scalar(T)[0] == pytest.approx(D, rel=1e-14)
    assert law.scalar(0.5 * T)[1] == pytest.approx(W, rel=1e-12)
    assert W == pytest.approx(min(peak, np.sqrt(D * accel)), rel=2 * dt * accel / W + 1e-3)
    assert W / (ramp * T) == pytest.approx(a, rel=1e-12)


def test_trapezoid_config_refusals() -> None:
    """A cruise rate outside (D / T, 2 D / T] and switch times off the step grid are refused
    by key (docs/model.md s.2)."""
    from creatio.errors import ConfigError
    from creatio.pipeline.config import resolve

    ok = resolve("en02", ["phases.T=30", "phases.a.kind=trapezoid", "phases.a.rate=115.2"])
    assert ok.obj.phases.laws()[1].switch_times() == (11.25, 18.75, 30.0)
    with pytest.raises(ConfigError, match=r"phases.a.rate.*\(72, 144\]"):
        resolve("en02", ["phases.T=30", "phases.a.kind=trapezoid", "phases.a.rate=150"])
    with pytest.raises(ConfigError, match="phases.a.*multiples of solver.dt"):
        resolve("en02", ["phases.T=30", "phases.a.kind=trapezoid", "phases.a.rate=97"])
