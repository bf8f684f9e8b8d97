"""Actuation demand of a prescribed cycle (docs/model.md s.12.1): the membrane quadrature
against the flat annulus's closed form and against finite differences of its own energies,
its refinement, and the normal motion's extrema against their closed forms.

Everything here is NumPy (creatio.model.actuation); the sphere's load power against the
run's own energy bookkeeping is in test_en04.py (it needs a simulation).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.model import actuation as act
from creatio.model.laws import Law
from creatio.model.surface import Frame, Motion, Surface

SURFACE = Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=6)
T = 120.0
FLAT = Law.constant(0.0)
#: EN-02: the pattern turns -360 deg (phi_a = 12 pi s(t / T)), phi_r = 0.
EN02 = Motion(FLAT, Law.quintic(0.0, 12.0 * math.pi, T), FLAT)
#: EN-02R: phi_r = -pi s, phi_a = -12 pi s.
EN02R = Motion(Law.quintic(0.0, -math.pi, T), Law.quintic(0.0, -12.0 * math.pi, T), FLAT)
#: Both phases moving from non-zero phases (the closed form's S term sin(2 phi_r) != 0).
MIXED = Motion(Law.linear(0.4, 0.3), Law.quintic(1.1, 5.0, 30.0), FLAT)
SIGMA, G = 0.5, 9.81


def _converged(motion: Motion, t: np.ndarray) -> act.Convergence:
    return act.converge_quadrature(SURFACE, motion, t, SIGMA, 0.0, G, 9, 5)


def test_quadrature_weights_integrate_the_reference_area_and_a_harmonic() -> None:
    """sum(weight) = 2 pi (R0 dR + dR^2 / 2); a harmonic below n_alpha integrates to 0."""
    rule = act.quadrature(SURFACE, 7, 6)
    area = 2.0 * math.pi * (SURFACE.R0 * SURFACE.dR + 0.5 * SURFACE.dR**2)
    assert rule.weight.sum() == pytest.approx(area, rel=1e-15)
    f = np.cos(6.0 * rule.alpha)[:, None] * np.ones_like(rule.R)[None, :]
    assert abs(np.sum(rule.weight * f)) < 1e-14 * area
    # the trapezoid rule aliases a harmonic that is a multiple of n_alpha: a rule that can fail
    g = np.cos(7.0 * rule.alpha)[:, None] * np.ones_like(rule.R)[None, :]
    assert np.sum(rule.weight * g) == pytest.approx(area, rel=1e-14)


@pytest.mark.parametrize("motion", [EN02, EN02R, MIXED], ids=["en02", "en02r", "mixed"])
def test_kinetic_energy_quadrature_equals_the_closed_form(motion: Motion) -> None:
    """K_m by the converged quadrature equals the flat-annulus closed form to 1e-10 relative
    (it reaches rounding), at every time of a cycle; P_inertia likewise."""
    t = np.linspace(0.0, T, 241)
    conv = _converged(motion, t)
    assert conv.converged and conv.final_rel_change <= 1e-10
    mi = act.membrane_integrals(SURFACE, motion, t, conv.rule, SIGMA, 0.0, G)
    K, P = act.annulus_kinetic_energy(SURFACE, motion, t, SIGMA)
    assert np.max(K) > 1e-3  # a moving membrane, not two zeros agreeing
    assert np.max(np.abs(mi.kinetic - K)) <= 1e-10 * np.max(K)
    assert np.max(np.abs(mi.inertia - P)) <= 1e-10 * np.max(np.abs(P))
    # the flat annulus lifts nothing on balance: int W_t dA = 0 at every time
    assert np.max(np.abs(mi.gravity)) <= 1e-12 * np.max(mi.scale[:, 2])


def test_a_coarse_grid_misses_the_closed_form_and_refinement_is_monotone() -> None:
    """The first grids differ from the closed form far beyond 1e-10 (the check can fail), and
    each refinement's change falls until the last is at rounding."""
    t = np.linspace(0.0, T, 121)
    K, _ = act.annulus_kinetic_energy(SURFACE, EN02, t, SIGMA)
    coarse = act.membrane_integrals(SURFACE, EN02, t, act.quadrature(SURFACE, 9, 5), SIGMA,
                                    0.0, G)
    assert np.max(np.abs(coarse.kinetic - K)) > 1e-3 * np.max(K)
    conv = _converged(EN02, t)
    kinetic = conv.rel_change[1:, 0]
    assert np.all(np.diff(kinetic) < 0.0)
    assert len(conv.levels) >= 3


def test_closed_form_power_is_the_derivative_of_the_closed_form_energy() -> None:
    """P_inertia = dK_m/dt in closed form against 4th-order central differences of K_m (the
    S' term of a moving radial phase included)."""
    t = np.linspace(1.0, 25.0, 13)
    h = 1e-3
    K = [act.annulus_kinetic_energy(SURFACE, MIXED, t + k * h, SIGMA)[0] for k in (-2, -1, 1, 2)]
    fd = (K[0] - 8.0 * K[1] + 8.0 * K[2] - K[3]) / (12.0 * h)
    _, P = act.annulus_kinetic_energy(SURFACE, MIXED, t, SIGMA)
    assert np.max(np.abs(P - fd)) <= 1e-9 * np.max(np.abs(P))


def test_inclined_membrane_powers_are_derivatives_of_its_energies() -> None:
    """On a cone whose inclination oscillates (no closed form), the quadrature's P_inertia is
    dK_m/dt and P_gravity is the rate of the membrane's potential energy sigma g int z dA
    (c_z by the same rule), both against 4th-order central differences."""
    motion = Motion(Law.linear(0.2, 0.5), Law.quintic(0.3, 6.0, 20.0),
                    Law.sinusoid(0.4, 0.3, 0.8))
    rule = act.quadrature(SURFACE, 41, 25)
    t = np.linspace(2.0, 18.0, 9)
    h = 1e-3

    def integrals(x: np.ndarray) -> act.MembraneIntegrals:
        return act.membrane_integrals(SURFACE, motion, x, rule, SIGMA, 0.0, G)

    def potential(x: np.ndarray) -> np.ndarray:
        z = Frame(SURFACE, motion, rule.alpha[None, :, None], rule.R[None, None, :],
                  x[:, None, None]).position[..., 2]
        return SIGMA * G * np.sum(rule.weight[None] * z, axis=(1, 2))

    def d(f) -> np.ndarray:
        v = [f(t + k * h) for k in (-2, -1, 1, 2)]
        return (v[0] - 8.0 * v[1] + 8.0 * v[2] - v[3]) / (12.0 * h)

    mi = integrals(t)
    assert np.max(np.abs(mi.gravity)) > 1e-2  # the cone lifts and lowers the membrane
    assert np.max(np.abs(mi.inertia - d(lambda x: integrals(x).kinetic))) \
        <= 1e-8 * np.max(np.abs(mi.inertia))
    assert np.max(np.abs(mi.gravity - d(potential))) <= 1e-8 * np.max(np.abs(mi.gravity))


def test_closed_form_refuses_an_inclined_surface() -> None:
    motion = Motion(FLAT, Law.quintic(0.0, 1.0, T), Law.constant(0.1))
    with pytest.raises(ValueError, match="flat annulus"):
        act.annulus_kinetic_energy(SURFACE, motion, [1.0], SIGMA)


@pytest.mark.parametrize("motion", [EN02, EN02R, MIXED], ids=["en02", "en02r", "mixed"])
def test_normal_rate_closed_forms_equal_the_numeric_maxima(motion: Motion) -> None:
    """max |W_t| and max |W_tt| over the surface and the cycle: the spatial closed forms
    (largest singular values) maximised in time against a search over (alpha, R, t) that
    does not use them (grid, then Nelder-Mead); equal to 1e-9."""
    end = motion.phi_a.T
    t = np.linspace(0.0, end, 601)
    ex = act.normal_rate_maxima(SURFACE, motion, t, 48, 33)
    _, wt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, motion, x)[0], 0, end)
    _, wtt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, motion, x)[1], 0, end)
    assert ex.max_W_t == pytest.approx(wt, rel=1e-9)
    assert ex.max_W_tt == pytest.approx(wtt, rel=1e-9)
    # the bounds are maxima: no sample of the surface exceeds them
    assert ex.max_W_t <= wt * (1 + 1e-12) and ex.max_W_tt <= wtt * (1 + 1e-12)


def test_angular_law_closed_forms() -> None:
    """EN-02's angular law: max |W_t| = A 1.875 |delta| / T (the quintic's peak rate), the
    stroke 2 A, max |W_tt| = A max sqrt(phi'^4 + phi''^2) from polynomial roots; all equal to
    the spatial closed forms maximised in time, and the stroke to the numeric one."""
    delta = 12.0 * math.pi
    ang = act.angular_law_bounds(SURFACE, EN02)
    assert ang["max_W_t"] == pytest.approx(SURFACE.A * 1.875 * delta / T, rel=1e-14)
    assert ang["stroke"] == pytest.approx(2.0 * SURFACE.A, rel=1e-15)
    _, wtt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, EN02, x)[1], 0, T)
    assert ang["max_W_tt"] == pytest.approx(wtt, rel=1e-12)
    t = np.linspace(0.0, T, 12001)
    ex = act.normal_rate_maxima(SURFACE, EN02, t, 48, 33)
    # the stroke's extremes over t come from the samples: cos v misses its extreme by at most
    # (phi_a' dt)^2 / 8 relative, 5e-6 at dt = 0.01 s and phi_a' <= 0.59 rad/s
    assert ex.stroke == pytest.approx(ang["stroke"], rel=5e-6)
    assert act.angular_law_bounds(SURFACE, EN02R)["stroke"] != act.angular_law_bounds(
        SURFACE, EN02R)["stroke"]  # NaN: phi_r moves, no angular-law closed form


def test_stroke_of_a_partial_sweep() -> None:
    """A sweep of width w < pi strokes 2 A sin(w / 2) at the worst point (numeric search)."""
    w = math.pi / 3
    motion = Motion(FLAT, Law.quintic(0.2, w, 10.0), FLAT)
    ang = act.angular_law_bounds(SURFACE, motion)
    assert ang["stroke"] == pytest.approx(2.0 * SURFACE.A * math.sin(w / 2), rel=1e-15)
    ex = act.normal_rate_maxima(SURFACE, motion, np.linspace(0.0, 10.0, 2001), 48, 33)
    assert ex.stroke == pytest.approx(ang["stroke"], rel=1e-7)


def test_bandwidth_of_a_steady_pattern_is_its_phase_rate() -> None:
    """A pattern turning at a constant rate w makes every point oscillate at w / (2 pi): the
    local frequency says so, and half of W_t's energy at a point lies below it (to a
    spectral bin)."""
    w = 2.0 * math.pi * 0.5  # 0.5 Hz
    motion = Motion(FLAT, Law.linear(0.0, w), FLAT)
    duration, dt = 40.0, 0.01
    t = np.arange(0.0, duration + dt / 2, dt)
    assert np.all(act.local_frequency(motion, t) == pytest.approx(0.5, rel=1e-15))
    from creatio.model.surface import Wave

    W_t = Wave(SURFACE, motion, 0.3, 0.43, t).W_t
    assert act.energy_frequency(W_t, dt, 0.5) == pytest.approx(0.5, abs=1.0 / duration)
    # the radial phase adds its rate: |phi_r'| + |phi_a'|
    both = Motion(Law.linear(0.0, -1.0), Law.linear(0.0, w), FLAT)
    assert act.local_frequency(both, [3.0])[0] == pytest.approx((w + 1.0) / (2 * math.pi))


def test_energy_frequency_of_a_gaussian_pulse() -> None:
    """x = exp(-(t - t0)^2 / (2 s^2)) sin(2 pi f0 t) has the energy spectrum of a Gaussian of
    standard deviation 1 / (2 sqrt(2) pi s) about f0 (f0 >> it): 99 % of its energy lies
    below f0 + 2.3263 sigma_f, 50 % below f0; to the zero-padded bin 1 / (8 x duration)."""
    duration, dt, s, f0 = 40.0, 0.01, 4.0, 0.8
    t = np.arange(0.0, duration + dt / 2, dt)
    x = np.exp(-((t - 20.0) ** 2) / (2 * s * s)) * np.sin(2 * math.pi * f0 * t)
    sigma_f = 1.0 / (2.0 * math.sqrt(2.0) * math.pi * s)
    bin_ = 1.0 / (8 * (t.size * dt))
    assert act.energy_frequency(x, dt, 0.99) == pytest.approx(f0 + 2.3263 * sigma_f,
                                                              abs=1.5 * bin_)
    assert act.energy_frequency(x, dt, 0.5) == pytest.approx(f0, abs=1.5 * bin_)


def test_en02_bandwidth_closed_form() -> None:
    """EN-02's highest local frequency: 1.875 x 12 pi / (2 pi T) = 0.09375 Hz at T / 2."""
    tmax, f = act.time_maximum(lambda x: act.local_frequency(EN02, x), 0.0, T)
    assert f == pytest.approx(1.875 * 6.0 / T, rel=1e-14)
    assert tmax == pytest.approx(T / 2, abs=1e-6)


def test_load_power_is_zero_on_a_still_membrane_and_follows_c_t() -> None:
    """P_surface = (N n + f) . c_t: zero where the membrane is still, and for a pure normal
    push on the flat annulus N n_z W_t (c_t = W_t e_z)."""
    still = Motion(FLAT, Law.constant(0.3), FLAT)
    p = act.load_power(SURFACE, still, [1.0], [0.5], [0.2], [9.81], [[0.1, -0.2, 0.05]])
    assert p[0] == 0.0
    fr = Frame(SURFACE, EN02, 0.2, 0.5, 40.0)
    p = act.load_power(SURFACE, EN02, [40.0], [0.5], [0.2], [2.0], [[0.0, 0.0, 0.0]])
    assert p[0] == pytest.approx(2.0 * fr.normal[2] * fr.w.W_t, rel=1e-14)
    assert abs(p[0]) > 1e-3


# ------------------------------------------------ a phase given as samples (s.12.2's phi_a)
def _history(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A closed-loop-like angular phase that is no law of s.2: a critically damped approach
    to 12 pi (time constant 0.8 s) with a servo-like ripple, and its exact derivatives."""
    tau, w, a = 0.8, 7.0, 0.3
    e = np.exp(-t / tau)
    p = 12.0 * math.pi * (1.0 - e * (1.0 + t / tau)) + a * e * np.sin(w * t)
    d1 = 12.0 * math.pi * e * t / tau**2 + a * e * (w * np.cos(w * t) - np.sin(w * t) / tau)
    d2 = (12.0 * math.pi * e * (1.0 - t / tau) / tau**2
          + a * e * (np.sin(w * t) / tau**2 - 2.0 * w * np.cos(w * t) / tau
                     - w * w * np.sin(w * t)))
    return p, d1, d2


def test_sampled_law_returns_its_samples_and_interpolates_between() -> None:
    """At a sample time the samples come back bit for bit; halfway between, the cubic
    Hermite value and rate are within h^4 / 384 max|4th derivative| of the exact history."""
    t = np.linspace(0.0, 6.0, 601)
    p, d1, d2 = _history(t)
    law = act.SampledLaw(t, p, d1, d2)
    v = law(t)
    assert np.array_equal(v.value, p) and np.array_equal(v.d1, d1) and np.array_equal(v.d2, d2)
    mid = 0.5 * (t[1:] + t[:-1])
    q, q1, _ = _history(mid)
    m = law(mid)
    assert np.max(np.abs(m.value - q)) < 1e-7 and np.max(np.abs(m.d1 - q1)) < 1e-5
    assert np.max(np.abs(m.value - q)) > 1e-12  # interpolated, not the formula
    with pytest.raises(ValueError, match="increasing"):
        act.SampledLaw(t[::-1], p, d1, d2)


def test_sampled_path_fed_a_laws_own_samples_equals_the_law_path() -> None:
    """Every figure of actuation_demand from a law's own samples equals the law's: the powers
    at the samples bit for bit (the same formula at the same numbers), the maxima refined
    between samples (K_m, |W_t|, |W_tt|, local frequency, the local searches of the stroke
    and the worst point) to the interpolation's error at h = 0.01 s."""
    motion = MIXED
    t = np.linspace(0.0, 30.0, 3001)
    v = motion.phi_a(t)
    sampled = act.sampled_motion(motion, t, v.value, v.d1, v.d2)
    rule = act.quadrature(SURFACE, 23, 15)
    P_s = 1e-3 * np.sin(0.7 * t)  # any load: it is added, not recomputed
    kw = {"extrema": (24, 9), "polish": True}
    a = act.actuation_demand(SURFACE, motion, t, P_s, rule, SIGMA, 0.2, G, **kw)
    b = act.actuation_demand(SURFACE, sampled, t, P_s, rule, SIGMA, 0.2, G, **kw)
    for key, y in a.powers().items():
        assert np.array_equal(y, b.powers()[key]), key
    assert np.array_equal(a.integrals.kinetic, b.integrals.kinetic)
    # the worst point is where the local search stops on a flat maximum: located to about
    # the square root of its 1e-15 stopping rule, so W_t there agrees to ~1e-8, not 1e-9
    assert np.max(np.abs(a.W_t_worst - b.W_t_worst)) <= 1e-7 * np.max(np.abs(a.W_t_worst))
    assert b.bandwidth99 == pytest.approx(a.bandwidth99, rel=1e-9)
    for name in ("K_m_max", "max_W_t_closed_form", "bandwidth"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-9), name
    # |W_tt| reads the acceleration, linear between samples: off by at most h^2 / 8 times
    # the largest 4th derivative of phi_a (2.2e-3 rad/s^4), A x 2.8e-8 = 1.5e-7 of the
    # maximum (3.6e-9 measured: the maximum sits near a sample)
    assert b.max_W_tt_closed_form == pytest.approx(a.max_W_tt_closed_form, rel=1.5e-7)
    assert b.extrema.max_W_tt == pytest.approx(a.extrema.max_W_tt, rel=1.5e-7)
    for name in ("stroke", "max_W_t"):
        assert getattr(b.extrema, name) == pytest.approx(getattr(a.extrema, name), rel=1e-9)
    assert a.K_m_max > 1e-3 and a.max_W_tt_closed_form > 0.0


def test_separable_closed_form_on_a_closed_loop_like_history() -> None:
    """gamma = 0: K_m and P_inertia by the converged quadrature along a sampled phase (no law
    of s.2) and a moving radial phase equal the separable closed form of docs/model.md s.12.1,
    written out here from the history's exact derivatives, to 1e-10 relative."""
    t = np.linspace(0.0, 6.0, 301)
    p, d1, d2 = _history(t)
    radial = Law.linear(0.4, 0.3)
    motion = act.sampled_motion(Motion(radial, FLAT, FLAT), t, p, d1, d2)
    conv = act.converge_quadrature(SURFACE, motion, t, SIGMA, 0.0, G, 9, 5)
    assert conv.converged
    mi = act.membrane_integrals(SURFACE, motion, t, conv.rule, SIGMA, 0.0, G)
    A, k, R0, dR = SURFACE.A, SURFACE.k, SURFACE.R0, SURFACE.dR
    pr, r1 = 0.4 + 0.3 * t, 0.3
    M = R0 * dR + 0.5 * dR**2
    S = dR * np.sin(2.0 * pr) / (4.0 * k)
    dS = dR * r1 * np.cos(2.0 * pr) / (2.0 * k)
    c = 0.5 * SIGMA * math.pi * A * A
    K = c * (r1**2 * (0.5 * M + S) + d1**2 * (0.5 * M - S))
    P = c * (2.0 * d1 * d2 * (0.5 * M - S) + (r1**2 - d1**2) * dS)
    assert np.max(K) > 1.0  # the fast approach moves the membrane hard
    assert np.max(np.abs(mi.kinetic - K)) <= 1e-10 * np.max(K)
    assert np.max(np.abs(mi.inertia - P)) <= 1e-10 * np.max(np.abs(P))


def test_inertia_power_is_the_derivative_of_k_m_along_a_history() -> None:
    """Along a sampled phase on an oscillating cone, P_inertia at the samples equals the
    4th-order central difference of K_m at the samples (h = 1e-3 s) to 1e-7 relative; with
    the acceleration samples zeroed (a history that forgets u) it misses by far more."""
    t = np.linspace(0.0, 4.0, 4001)
    p, d1, d2 = _history(t)
    base = Motion(Law.linear(0.2, 0.5), FLAT, Law.sinusoid(0.4, 0.3, 0.8))
    rule = act.quadrature(SURFACE, 41, 25)

    def fd_error(acc: np.ndarray) -> float:
        mi = act.membrane_integrals(SURFACE, act.sampled_motion(base, t, p, d1, acc), t, rule,
                                    SIGMA, 0.0, G)
        K, h = mi.kinetic, t[1] - t[0]
        fd = (K[:-4] - 8.0 * K[1:-3] + 8.0 * K[3:-1] - K[4:]) / (12.0 * h)
        return float(np.max(np.abs(mi.inertia[2:-2] - fd)) / np.max(np.abs(mi.inertia)))

    assert fd_error(d2) <= 1e-7
    assert fd_error(np.zeros_like(d2)) > 1e-2


def test_polishing_some_maxima_leaves_the_others_as_the_full_search_does() -> None:
    """The three local searches are independent: polishing the stroke and max |W_t| only
    gives them (and the worst point) exactly as polishing all three does, and max |W_tt| as
    the grid left it, which is below the polished one and the closed form."""
    t = np.linspace(0.0, 30.0, 601)
    full = act.normal_rate_maxima(SURFACE, MIXED, t, 24, 9)
    grid = act.normal_rate_maxima(SURFACE, MIXED, t, 24, 9, polish=False)
    some = act.normal_rate_maxima(SURFACE, MIXED, t, 24, 9, polish=("stroke", "max_W_t"))
    assert (some.stroke, some.stroke_point) == (full.stroke, full.stroke_point)
    assert (some.max_W_t, some.worst) == (full.max_W_t, full.worst)
    assert some.max_W_tt == grid.max_W_tt < full.max_W_tt
    _, wtt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, MIXED, x)[1], 0, 30)
    assert full.max_W_tt == pytest.approx(wtt, rel=1e-9)
    with pytest.raises(ValueError, match=r"\['W_tt'\] are not maxima"):
        act.normal_rate_maxima(SURFACE, MIXED, t, 24, 9, polish=("W_tt",))


def test_a_looser_polish_tolerance_stops_earlier_near_the_same_maximum(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """ftol is the Nelder-Mead stop: at 1e-6 the search evaluates W fewer times than at the
    default 1e-15 and still lands within 1e-5 of the closed-form max |W_t| (the default
    within 1e-9, as test_normal_rate_closed_forms_equal_the_numeric_maxima)."""
    t = np.linspace(0.0, 30.0, 601)
    _, wt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, MIXED, x)[0], 0, 30)
    calls = []
    normal = act._normal

    def counted(*args: object, **kwargs: object) -> object:
        calls.append(1)
        return normal(*args, **kwargs)

    monkeypatch.setattr(act, "_normal", counted)
    counts, values = [], []
    for ftol in (act.NM_FTOL, 1e-6):
        calls.clear()
        values.append(act.normal_rate_maxima(SURFACE, MIXED, t, 48, 33, polish=("max_W_t",),
                                             ftol=ftol).max_W_t)
        counts.append(len(calls))
    assert counts[1] < counts[0]
    assert values[0] == pytest.approx(wt, rel=1e-9)
    assert values[1] == pytest.approx(wt, rel=1e-5) and values[1] <= values[0]


#: An inclined membrane (gamma' and gamma'' nonzero) with both phases moving, one of them
#: sampled: every term of Frame's c_t and c_tt is exercised.
_TS = np.linspace(0.0, 30.0, 301)
INCLINED = Motion(Law.linear(0.4, 0.3),
                  act.SampledLaw(_TS, 1.1 + 0.2 * _TS + 0.01 * _TS**2, 0.2 + 0.02 * _TS,
                                 np.full(_TS.size, 0.02)),
                  Law.quintic(0.05, 0.3, 30.0))


@pytest.mark.parametrize("motion", [MIXED, INCLINED], ids=["flat", "inclined"])
def test_membrane_integrals_are_frames_numbers_bit_for_bit(motion: Motion) -> None:
    """The integrals (computed without Frame on the ideal surface: the frame vectors on
    (alpha, t), the sines on (R, t)) are exactly those of Frame's c_t and c_tt reduced as
    the docstring says, at many times and at one, and K_m alone (the search's) likewise."""
    rule = act.quadrature(SURFACE, 23, 15)
    t = np.linspace(0.3, 29.7, 377)
    a, R, w = rule.alpha[None, :, None], rule.R[None, None, :], rule.weight[None, :, :]
    frame = Frame(SURFACE, motion, a, R, t[:, None, None])
    ct, ctt = frame.c_t, frame.c_tt
    speed2 = np.einsum("...i,...i->...", ct, ct)
    power = np.einsum("...i,...i->...", ct, ctt)
    mi = act.membrane_integrals(SURFACE, motion, t, rule, SIGMA, 0.7, G)
    assert np.array_equal(mi.kinetic, 0.5 * SIGMA * np.sum(w * speed2, axis=(1, 2)))
    assert np.array_equal(mi.inertia, SIGMA * np.sum(w * power, axis=(1, 2)))
    assert np.array_equal(mi.gravity, SIGMA * np.sum(w * (G * ct[..., 2]), axis=(1, 2)))
    assert np.array_equal(mi.damping, 0.7 * np.sum(w * speed2, axis=(1, 2)))
    assert np.max(np.abs(mi.inertia)) > 0.0 and np.max(np.abs(mi.gravity)) > 0.0
    one = act.membrane_integrals(SURFACE, motion, t[5:6], rule, SIGMA, 0.0, G)
    assert np.array_equal(one.kinetic, mi.kinetic[5:6])
    assert np.array_equal(act._kinetic_energy(SURFACE, motion, t, rule, SIGMA), mi.kinetic)


@pytest.mark.parametrize("motion", [MIXED, INCLINED], ids=["flat", "inclined"])
def test_normal_motion_is_waves_numbers_bit_for_bit(motion: Motion) -> None:
    """W, W_t, W_tt of the extrema's evaluator equal Wave's exactly: on a (t, alpha, R)
    grid, along the times at one point (with the phases evaluated beforehand) and at one
    point and time."""
    rng = np.random.default_rng(7)
    alpha = rng.uniform(0.0, 2.0 * math.pi, 11)[None, :, None]
    R = rng.uniform(0.0, SURFACE.dR, 7)[None, None, :]
    t = rng.uniform(0.0, 30.0, 13)
    cases = [(alpha, R, t[:, None, None], False), (0.4, 1.1, t, True),
             (np.float64(2.5), np.float64(0.3), np.float64(17.2), False)]
    for a, r, s, given in cases:
        wave = act.Wave(SURFACE, motion, a, r, s)
        fast = act._normal(SURFACE, motion, a, r, s,
                           act._laws_at(motion, s, gamma=False) if given else None)
        for name in ("W", "W_t", "W_tt"):
            assert np.array_equal(getattr(fast, name), getattr(wave, name)), name


def _hermite_reference(law: act.SampledLaw, t: float) -> tuple[float, float, float]:
    """SampledLaw's definition at one time through NumPy's clip and searchsorted on a 0-d
    array (the array machinery the one-time path skips)."""
    ts = law.t
    x = np.clip(np.asarray(t, float), ts[0], ts[-1])
    i = np.clip(np.searchsorted(ts, x, side="right") - 1, 0, ts.size - 2)
    h = ts[i + 1] - ts[i]
    s = (x - ts[i]) / h
    h00, h10 = (1.0 + 2.0 * s) * (1.0 - s) ** 2, s * (1.0 - s) ** 2
    h01, h11 = s * s * (3.0 - 2.0 * s), s * s * (s - 1.0)
    v, d1, d2 = law.value, law.d1, law.d2
    return (h00 * v[i] + h10 * h * d1[i] + h01 * v[i + 1] + h11 * h * d1[i + 1],
            h00 * d1[i] + h10 * h * d2[i] + h01 * d1[i + 1] + h11 * h * d2[i + 1],
            (1.0 - s) * d2[i] + s * d2[i + 1])


def test_sampled_law_at_one_time_is_the_array_definition() -> None:
    """At one time (a local search's), the sampled law gives exactly the numbers of its
    definition through np.clip and np.searchsorted: between samples, at them, at the ends,
    outside them (clamped), at -0.0; a 1-element array still takes the array path."""
    rng = np.random.default_rng(11)
    ts = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 1e-2, 400))])
    law = act.SampledLaw(ts, rng.normal(size=ts.size), rng.normal(size=ts.size),
                         rng.normal(size=ts.size))
    times = [*rng.uniform(-0.5, ts[-1] + 0.5, 2000), *ts[:50], ts[-1], -0.0, 0.0]
    for t in times:
        got = law(t)
        want = _hermite_reference(law, t)
        for x, y in zip((got.value, got.d1, got.d2), want, strict=True):
            assert x == y and np.signbit(x) == np.signbit(y) and np.ndim(x) == 0, t
    assert law(ts[7]).value == law.value[7] and law(ts[-1] + 3.0).d1 == law.d1[-1]
    assert law(np.array([ts[3]])).value.shape == (1,)


def test_demands_shared_time_samplings_give_time_maximums_numbers() -> None:
    """actuation_demand's closed-form maxima and bandwidth (the phases evaluated once on the
    common sampling) are exactly time_maximum's, each on its own sampling."""
    t = np.linspace(0.0, 30.0, 301)
    rule = act.quadrature(SURFACE, 9, 5)
    d = act.actuation_demand(SURFACE, INCLINED, t, np.zeros(t.size), rule, SIGMA, 0.0, G,
                             extrema=(8, 5), polish=False)
    _, wt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, INCLINED, x)[0], 0, 30)
    _, wtt = act.time_maximum(lambda x: act.normal_rate_bounds(SURFACE, INCLINED, x)[1], 0, 30)
    _, f = act.time_maximum(lambda x: act.local_frequency(INCLINED, x), 0, 30)
    assert (d.max_W_t_closed_form, d.max_W_tt_closed_form, d.bandwidth) == (wt, wtt, f)
    assert wt > 0.0 and wtt > 0.0 and f > 0.0
