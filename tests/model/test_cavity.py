"""Cavity trajectories, helical pitch, pattern angle, inclination classes (docs/model.md s.3)."""

from __future__ import annotations

import numpy as np
import pytest

from creatio.model.cavity import cavity, classify_inclination, helical_pitch, pattern_angle
from creatio.model.laws import Law
from creatio.model.surface import Frame, Motion, Surface, Wave

# Notebook geometry (docs/studies.md): R0 = 0.68, dR = 1.72, A = 0.18, Kr = 1, Ka = 6.
R0, DR, A, KR, KA = 0.68, 1.72, 0.18, 1, 6
SURF = Surface(R0=R0, dR=DR, A=A, Kr=KR, Ka=KA)
K = 2 * np.pi * KR / DR
CONE = np.deg2rad(35.0)

LIN_R, LIN_A = Law.linear(0.23, 0.31), Law.linear(0.5, 0.47)  # CT-02 check phases
CONST_GAMMA = {g: Motion(LIN_R, LIN_A, Law.constant(g)) for g in (0.0, CONE, np.pi / 2)}
VARYING = {
    # time-varying inclination with quintic phases (T = 2 s)
    "quintic": Motion(
        Law.quintic(0.2, -2.0, 2.0), Law.quintic(0.5, 3.0, 2.0), Law.sinusoid(0.2, 0.5, 1.1)
    ),
    # EN-01 law (c)
    "en01_c": Motion(Law.linear(0.0, 0.4), Law.linear(0.5, 0.5), Law.sinusoid(np.pi / 4, 0.3, 0.7)),
    # inclination sweeping the full range, quintic angular and sinusoidal radial phases
    "full_sweep": Motion(
        Law.sinusoid(0.3, 0.6, 1.3), Law.quintic(0.1, -4.0, 2.0), Law.sinusoid(0, np.pi / 2, 1.7)
    ),
}
ALL = {f"gamma={g:.3f}": m for g, m in CONST_GAMMA.items()} | VARYING

# Interior times (the quintic laws are smooth on (0, 2); stencils below span <= 4e-3 s).
T_S = np.array([0.01, 0.2, 0.5, 0.77, 1.3, 1.98])


def d5(f, t: np.ndarray, h: float) -> np.ndarray:
    """4th-order 5-point central difference of f at t."""
    return (f(t - 2 * h) - 8 * f(t - h) + 8 * f(t + h) - f(t + 2 * h)) / (12 * h)


def test_cavity_requires_amplitude() -> None:
    """With A = 0 there is no cavity: cavity() refuses."""
    flat = Surface(R0=R0, dR=DR, A=0.0, Kr=KR, Ka=KA)
    with pytest.raises(ValueError):
        cavity(flat, CONST_GAMMA[0.0], 0.0)


@pytest.mark.parametrize("mname", list(ALL))
@pytest.mark.parametrize(("n", "m"), [(0, 0), (0, 3), (-1, 5), (1, -2)])
def test_cavity_lies_on_surface_at_minimum_of_w(mname: str, n: int, m: int) -> None:
    """C = c(alpha_c, R_c, t); there W = -A, grad W = 0, Hess W = diag(A k^2, A Ka^2).

    Exact identities; rounding of sin/cos at |u|, |v| <= ~40 is ~1e-14, times A k^2 <= 2.4.
    """
    motion = ALL[mname]
    cav = cavity(SURF, motion, T_S, n=n, m=m)
    f = Frame(SURF, motion, cav.alpha, cav.R, T_S)
    np.testing.assert_allclose(cav.position, f.position, rtol=0, atol=1e-14)
    w = Wave(SURF, motion, cav.alpha, cav.R, T_S)
    np.testing.assert_allclose(w.W, -A, rtol=0, atol=1e-15)
    np.testing.assert_allclose(w.W_R, 0.0, atol=1e-14)
    np.testing.assert_allclose(w.W_a, 0.0, atol=1e-14)
    np.testing.assert_allclose(w.W_RR, A * K**2, rtol=1e-14)
    np.testing.assert_allclose(w.W_aa, A * KA**2, rtol=1e-14)
    np.testing.assert_allclose(w.W_Ra, 0.0, atol=1e-13)
    # the coordinates themselves, from docs/model.md s.3
    pr, pa = motion.phi_r(T_S), motion.phi_a(T_S)
    np.testing.assert_allclose(cav.R, (np.pi / 2 - pr.value + 2 * np.pi * n) / K, atol=1e-15)
    np.testing.assert_allclose(cav.alpha, (np.pi - pa.value + 2 * np.pi * m) / KA, atol=1e-15)
    np.testing.assert_allclose(cav.dR, -pr.d1 / K, atol=1e-16)
    np.testing.assert_allclose(cav.dalpha, -pa.d1 / KA, atol=1e-16)


@pytest.mark.parametrize("mname", list(ALL))
def test_cavity_velocity_and_acceleration_against_differences(mname: str) -> None:
    """C' from 5-point differences of C(t); C'' from 5-point differences of C'(t) and from the
    5-point second difference of C(t).

    h = 1e-3: truncation h^4/30 |C^(5)|; the fastest case (gamma' up to (pi/2) 1.7 = 2.7/s
    on |R_c| <= 2) has |C^(5)|, |C^(6)| of order 1e3, i.e. <= ~3e-11, and rounding
    1.5 eps |C| / h ~ 1e-12, so 1e-9. The 5-point second difference (h = 2e-3) has truncation
    h^4/90 |C^(6)| ~ 2e-10 and rounding (64/12) eps |C| / h^2 ~ 1e-9, so 1e-8.
    """
    motion = ALL[mname]
    cav = cavity(SURF, motion, T_S)

    def pos(t):
        return cavity(SURF, motion, t).position

    def vel(t):
        return cavity(SURF, motion, t).velocity

    def err(a, b):
        return np.max(np.linalg.norm(a - b, axis=-1))

    assert err(cav.velocity, d5(pos, T_S, 1e-3)) < 1e-9
    assert err(cav.acceleration, d5(vel, T_S, 1e-3)) < 1e-9
    h, t = 2e-3, T_S
    sec = (-pos(t + 2 * h) + 16 * pos(t + h) - 30 * pos(t) + 16 * pos(t - h) - pos(t - 2 * h)) / (
        12 * h**2
    )
    assert err(cav.acceleration, sec) < 1e-8


@pytest.mark.parametrize("gamma", list(CONST_GAMMA))
def test_ct02_cavity_differences_at_published_times(gamma: float) -> None:
    """CT-02 item 3: t = 0, 0.2, 0.5 s, h = 1e-4, 2-point differences of C for C' and C''.

    Errors: C' has h^2/6 |C'''| ~ 2e-10 (|C'''| ~ 1e-1) plus eps |C| / h ~ 7e-12; the 3-point
    second difference has h^2/12 |C''''| ~ 1e-11 plus 4 eps |C| / h^2 ~ 3e-7. Bounds 1e-8 and
    1e-6 leave a factor 3-50 while a wrong term is >= 1e-3 (e.g. rho_c alpha_c'^2 = 6e-3).
    """
    motion, h = CONST_GAMMA[gamma], 1e-4
    t = np.array([0.0, 0.2, 0.5])

    def pos(s):
        return cavity(SURF, motion, s).position

    cav = cavity(SURF, motion, t)
    v_fd = (pos(t + h) - pos(t - h)) / (2 * h)
    a_fd = (pos(t + h) + pos(t - h) - 2 * pos(t)) / h**2
    assert np.max(np.linalg.norm(cav.velocity - v_fd, axis=-1)) < 1e-8
    assert np.max(np.linalg.norm(cav.acceleration - a_fd, axis=-1)) < 1e-6


@pytest.mark.parametrize("mname", list(ALL))
def test_cavity_motion_obeys_surface_chain_rule(mname: str) -> None:
    """C' = c_t + c_R R_c' + c_a alpha_c' and C'' = c_tt + 2 c_tR R' + 2 c_ta a' + c_RR R'^2
    + 2 c_Ra R' a' + c_aa a'^2 + c_R R'' + c_a a'' (docs/model.md s.1; exact, rounding only)."""
    motion = ALL[mname]
    cav = cavity(SURF, motion, T_S)
    f = Frame(SURF, motion, cav.alpha, cav.R, T_S)
    r1, a1 = cav.dR[:, None], cav.dalpha[:, None]
    r2 = (-motion.phi_r(T_S).d2 / K)[:, None]
    a2 = (-motion.phi_a(T_S).d2 / KA)[:, None]
    v = f.c_t + f.c_R * r1 + f.c_alpha * a1
    acc = (
        f.c_tt + 2 * f.c_Rt * r1 + 2 * f.c_at * a1 + f.c_RR * r1**2 + 2 * f.c_Ra * r1 * a1
        + f.c_aa * a1**2 + f.c_R * r2 + f.c_alpha * a2
    )  # fmt: skip
    np.testing.assert_allclose(cav.velocity, v, rtol=0, atol=1e-13)
    np.testing.assert_allclose(cav.acceleration, acc, rtol=0, atol=1e-12)


@pytest.mark.parametrize("gamma", [0.0, CONE, np.pi / 2, -0.4])
def test_constant_gamma_closed_forms(gamma: float) -> None:
    """Constant gamma: |C'|^2 = R_c'^2 + rho_c^2 alpha_c'^2, and C', C'' in the (e_rho, e_alpha,
    e_z) basis as written in docs/model.md s.3 (quintic phases exercise R_c'', alpha_c'')."""
    motion = Motion(Law.quintic(0.2, -2.0, 2.0), Law.quintic(0.5, 3.0, 2.0), Law.constant(gamma))
    cav = cavity(SURF, motion, T_S)
    r1, a1 = -motion.phi_r(T_S).d1 / K, -motion.phi_a(T_S).d1 / KA
    r2, a2 = -motion.phi_r(T_S).d2 / K, -motion.phi_a(T_S).d2 / KA
    sg, cg = np.sin(gamma), np.cos(gamma)
    rho = R0 + cav.R * cg + A * sg
    pos = cav.position
    np.testing.assert_allclose(np.hypot(pos[:, 0], pos[:, 1]), rho, rtol=1e-15)
    np.testing.assert_allclose(pos[:, 2], cav.R * sg - A * cg, atol=1e-15)
    speed2 = np.sum(cav.velocity**2, -1)
    np.testing.assert_allclose(speed2, r1**2 + rho**2 * a1**2, rtol=1e-14)
    ac = cav.alpha
    e_rho = np.stack([np.cos(ac), np.sin(ac), 0 * ac], -1)
    e_al = np.stack([-np.sin(ac), np.cos(ac), 0 * ac], -1)
    e_z = np.array([0.0, 0.0, 1.0])
    v = (r1 * cg)[:, None] * e_rho + (rho * a1)[:, None] * e_al + (r1 * sg)[:, None] * e_z
    acc = (
        (r2 * cg - rho * a1**2)[:, None] * e_rho
        + (2 * r1 * cg * a1 + rho * a2)[:, None] * e_al
        + (r2 * sg)[:, None] * e_z
    )
    np.testing.assert_allclose(cav.velocity, v, rtol=0, atol=1e-15)
    np.testing.assert_allclose(cav.acceleration, acc, rtol=0, atol=1e-14)


def test_cavity_turns_with_the_pattern() -> None:
    """alpha_c' = alpha_p' = -phi_a'/Ka: the cavity azimuth and the pattern angle move together."""
    motion = VARYING["quintic"]
    cav = cavity(SURF, motion, T_S)
    a0 = float(cavity(SURF, motion, 0.0).alpha)
    ang, rate, acc = pattern_angle(SURF, motion, T_S, alpha0=a0)
    np.testing.assert_allclose(rate, cav.dalpha, atol=1e-16)
    np.testing.assert_allclose(acc, -motion.phi_a(T_S).d2 / KA, atol=1e-16)
    # alpha0 is the pattern angle at t = 0: started on the cavity, the pattern stays on it
    np.testing.assert_allclose(ang, cav.alpha, atol=1e-15)
    assert float(pattern_angle(SURF, motion, 0.0, alpha0=a0)[0]) == a0


def _turn_displacement(Wr: float, Wa: float, gamma: float, phi_r0: float, t0: float):
    """Displacement of C over the time alpha_c takes to change by +2 pi (linear phases)."""
    motion = Motion(Law.linear(phi_r0, Wr), Law.linear(0.5, Wa), Law.constant(gamma))
    dt = 2 * np.pi / (-Wa / KA)  # alpha_c' = -Wa / Ka; dt < 0 when Wa > 0 (go back in time)
    c0, c1 = cavity(SURF, motion, t0), cavity(SURF, motion, t0 + dt)
    assert float(c1.alpha - c0.alpha) == pytest.approx(2 * np.pi, rel=1e-13)
    return c0, c1


@pytest.mark.parametrize("gamma", [0.0, CONE, np.pi / 2])
@pytest.mark.parametrize(
    ("Wr", "Wa"), [(0.05, -0.47), (-0.05, -0.47), (0.05, 0.47), (0.31, 0.47)]
)
def test_helical_pitch_matches_displacement_over_one_turn(
    gamma: float, Wr: float, Wa: float
) -> None:
    """p_R = dR (Ka/Kr)(Wr/Wa), p_z, p_rho equal the change of R_c, z_c, rho_c over one +2 pi
    turn of alpha_c; since alpha_c returns to the same direction, C(t1) - C(t0) = p_rho e_rho
    + p_z e_z. Linear laws: the identity is exact up to rounding (~1e-14 on |p| ~ 1)."""
    # (the closed form extends past [0, dR], so large pitches are checked as identities too)
    pR, pz, prho = helical_pitch(SURF, Wr, Wa, gamma)
    assert pR == pytest.approx(DR * (KA / KR) * (Wr / Wa), rel=1e-15)
    phi_r0 = np.pi / 2 - K * 0.86
    c0, c1 = _turn_displacement(Wr, Wa, gamma, phi_r0, t0=3.0)
    assert float(c1.R - c0.R) == pytest.approx(pR, rel=1e-12)
    disp = (c1.position - c0.position).ravel()
    rho0 = np.hypot(*c0.position.ravel()[:2])
    rho1 = np.hypot(*c1.position.ravel()[:2])
    assert rho1 - rho0 == pytest.approx(prho, abs=1e-13)
    assert disp[2] == pytest.approx(pz, abs=1e-13)
    a = float(c0.alpha)
    want = prho * np.array([np.cos(a), np.sin(a), 0.0]) + np.array([0.0, 0.0, pz])
    np.testing.assert_allclose(disp, want, rtol=0, atol=1e-13)


def test_helical_pitch_zero_radial_rate_is_a_circle() -> None:
    """Wr = 0: zero pitch, and C returns to the same point after one turn."""
    assert helical_pitch(SURF, 0.0, 0.47, CONE) == (0.0, 0.0, 0.0)
    c0, c1 = _turn_displacement(0.0, 0.47, CONE, 0.23, t0=1.0)
    np.testing.assert_allclose(c1.position, c0.position, rtol=0, atol=1e-14)


def test_helical_pitch_notebook_numbers() -> None:
    """CT-02 phases Wr = 0.31, Wa = 0.47 at gamma = 30 deg: p_R = 1.72*6*0.31/0.47 = 6.8068..."""
    pR, pz, prho = helical_pitch(SURF, 0.31, 0.47, np.pi / 6)
    assert pR == pytest.approx(6.806808510638298, rel=1e-14)
    assert pz == pytest.approx(pR / 2, rel=1e-14)
    assert prho == pytest.approx(pR * np.sqrt(3) / 2, rel=1e-14)


def test_helical_pitch_undefined_for_zero_angular_rate() -> None:
    """Wa = 0 (motion along a meridian): the pitch is undefined and helical_pitch raises."""
    with pytest.raises(ValueError):
        helical_pitch(SURF, 0.31, 0.0, CONE)


def test_classify_inclination() -> None:
    """0 -> annulus, +-pi/2 -> cylinder, anything in between -> cone (CT-02's 19 inclinations)."""
    assert classify_inclination(0.0) == "annulus"
    assert classify_inclination(np.pi / 2) == "cylinder"
    assert classify_inclination(-np.pi / 2) == "cylinder"
    for g in (1e-6, -0.3, CONE, np.pi / 2 - 1e-6):
        assert classify_inclination(g) == "cone"
    names = [classify_inclination(np.deg2rad(d)) for d in range(0, 91, 5)]
    assert names == ["annulus"] + ["cone"] * 17 + ["cylinder"]
