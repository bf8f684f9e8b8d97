"""Membrane strain, curvature change, stresses and the maximum over the membrane (EN-06,
docs/materials.md): each against finite differences of the surface position or a closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from creatio.model import strain as S
from creatio.model.laws import Law
from creatio.model.surface import Frame, Motion, Surface

# EN-02's geometry (docs/studies.md): R0 = 0.68, dR = 1.72, A = 0.18, Kr = 1, Ka = 6.
R0, DR, A, KA = 0.68, 1.72, 0.18, 6
K = 2.0 * math.pi / DR
SURF = Surface(R0=R0, dR=DR, A=A, Kr=1, Ka=KA)
FLAT = Surface(R0=R0, dR=DR, A=0.0, Kr=1, Ka=KA)
EN02 = Motion(Law.constant(0.0), Law.quintic(0.0, 12.0 * math.pi, 120.0), Law.constant(0.0))
MOVING = {
    "annulus": Motion(Law.linear(0.23, 0.31), Law.linear(0.5, 0.47), Law.constant(0.0)),
    "cone": Motion(Law.linear(0.23, 0.31), Law.linear(0.5, 0.47), Law.constant(0.6)),
    "varying": Motion(Law.sinusoid(0.2, 0.8, 1.3), Law.linear(0.1, 0.9),
                      Law.sinusoid(0.3, 0.5, 1.7)),
    "cylinder": Motion(Law.linear(0.23, 0.31), Law.linear(0.5, 0.47), Law.constant(np.pi / 2)),
}
STEP = 1e-4


def points(seed: int, n: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded random (alpha, R, t) over the membrane and a few seconds."""
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 2 * np.pi, n), rng.uniform(0, DR, n), rng.uniform(0.1, 3.0, n)


def fd_derivatives(surface: Surface, motion: Motion, a: np.ndarray, r: np.ndarray,
                   t: np.ndarray) -> dict[str, np.ndarray]:
    """c_R, c_a, c_RR, c_Ra, c_aa by central differences of the position alone."""
    def c(da: float, dr: float) -> np.ndarray:
        return Frame(surface, motion, a + da, r + dr, t).position

    h = STEP
    return {
        "R": (c(0, h) - c(0, -h)) / (2 * h),
        "a": (c(h, 0) - c(-h, 0)) / (2 * h),
        "RR": (c(0, h) - 2 * c(0, 0) + c(0, -h)) / h**2,
        "aa": (c(h, 0) - 2 * c(0, 0) + c(-h, 0)) / h**2,
        "Ra": (c(h, h) - c(h, -h) - c(-h, h) + c(-h, -h)) / (4 * h**2),
    }


def fd_forms(surface: Surface, motion: Motion, a: np.ndarray, r: np.ndarray, t: np.ndarray
             ) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    """First (E, F, G) and second (L, M, N) forms from finite-difference derivatives."""
    d = fd_derivatives(surface, motion, a, r, t)
    n = np.cross(d["R"], d["a"])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)

    def dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.sum(x * y, axis=-1)

    first = (dot(d["R"], d["R"]), dot(d["R"], d["a"]), dot(d["a"], d["a"]))
    second = (dot(d["RR"], n), dot(d["Ra"], n), dot(d["aa"], n))
    return first, second


@pytest.mark.parametrize("seed", [1, 2])
def test_rank_one_strain_at_zero_inclination_matches_the_metric_by_differences(seed: int) -> None:
    """At gamma = 0, eps = 1/2 g g^T with g = (W_R, W_alpha / rho): both the module's strain
    and g are checked against the metric of central differences of the position."""
    a, r, t = points(seed)
    motion = MOVING["annulus"]
    (E, F, G), _ = fd_forms(SURF, motion, a, r, t)
    rho0 = R0 + r
    eps = S.strains(SURF, motion, a, r, t).membrane
    np.testing.assert_allclose(eps.rr, 0.5 * (E - 1), atol=1e-7)
    np.testing.assert_allclose(eps.ra, 0.5 * F / rho0, atol=1e-7)
    np.testing.assert_allclose(eps.aa, 0.5 * (G / rho0**2 - 1), atol=1e-7)
    # rank one: the FD metric's own determinant vanishes in this frame (eps = g g^T / 2)
    det = 0.25 * ((E - 1) * (G / rho0**2 - 1) - (F / rho0) ** 2)
    np.testing.assert_allclose(det, 0.0, atol=1e-7)
    np.testing.assert_allclose(eps.rr * eps.aa - eps.ra**2, 0.0, atol=1e-15)
    assert np.max(eps.rr + eps.aa) > 0.1


@pytest.mark.parametrize("name", ["cone", "varying", "cylinder"])
def test_general_strain_at_nonzero_inclination_matches_differences(name: str) -> None:
    """At gamma != 0, the strain against the FD metric of the surface and of the uncorrugated
    reference (whose G0 is checked to be (R0 + R cos gamma)^2)."""
    a, r, t = points(3)
    motion = MOVING[name]
    (E, F, G), _ = fd_forms(SURF, motion, a, r, t)
    (E0, F0, G0), _ = fd_forms(FLAT, motion, a, r, t)
    gamma = motion.gamma(t).value
    np.testing.assert_allclose(E0, 1.0, atol=1e-7)
    np.testing.assert_allclose(F0, 0.0, atol=1e-7)
    np.testing.assert_allclose(G0, (R0 + r * np.cos(gamma)) ** 2, rtol=1e-7)
    eps = S.strains(SURF, motion, a, r, t).membrane
    rho0 = R0 + r * np.cos(gamma)
    np.testing.assert_allclose(eps.rr, 0.5 * (E - 1), atol=1e-7)
    np.testing.assert_allclose(eps.ra, 0.5 * F / rho0, atol=1e-7)
    np.testing.assert_allclose(eps.aa, 0.5 * (G / rho0**2 - 1), atol=1e-7)
    assert np.max(np.abs(eps.aa)) > 1e-3  # the inclined case strains across the slope too


@pytest.mark.parametrize("name", ["annulus", "cone", "varying"])
def test_curvature_change_matches_second_differences(name: str) -> None:
    """dkappa = (II - II0) in the reference orthonormal frame, II from second differences
    of the position and the normal of the FD tangents."""
    a, r, t = points(4, 100)
    motion = MOVING[name]
    _, (L, M, N) = fd_forms(SURF, motion, a, r, t)
    _, (L0, M0, N0) = fd_forms(FLAT, motion, a, r, t)
    rho0 = R0 + r * np.cos(motion.gamma(t).value)
    dk = S.strains(SURF, motion, a, r, t).dkappa
    np.testing.assert_allclose(dk.rr, L - L0, atol=2e-5)
    np.testing.assert_allclose(dk.ra, (M - M0) / rho0, atol=2e-5)
    np.testing.assert_allclose(dk.aa, (N - N0) / rho0**2, atol=2e-5)


def test_upper_face_strain_is_the_offset_surface_strain_to_first_order() -> None:
    """The face at +z n has strain eps - z dkappa: the z-derivative at z = 0 of the
    Green-Lagrange strain of the offset sheet c + z n relative to c0 + z n0, in the
    mid-surface reference frame (thin sheet; central differences in z and in (alpha, R)),
    is -dkappa, and the faces follow it."""
    a, r, t = points(5, 50)
    motion = MOVING["cone"]
    h = 2e-3
    z = h / 2

    def offset_strain(zz: float) -> np.ndarray:
        def metric(surface: Surface, zz: float) -> tuple[np.ndarray, ...]:
            def x(da: float, dr: float) -> np.ndarray:
                f = Frame(surface, motion, a + da, r + dr, t)
                return f.position + zz * f.normal
            s = STEP
            xr = (x(0, s) - x(0, -s)) / (2 * s)
            xa = (x(s, 0) - x(-s, 0)) / (2 * s)
            return (np.sum(xr * xr, -1), np.sum(xr * xa, -1), np.sum(xa * xa, -1))
        (E, F, G), (E0, F0, G0), (M0, _, N0) = metric(SURF, zz), metric(FLAT, zz), metric(FLAT, 0)
        return np.stack([0.5 * (E - E0) / M0, 0.5 * (F - F0) / np.sqrt(M0 * N0),
                         0.5 * (G - G0) / N0])

    st = S.strains(SURF, motion, a, r, t, h=h)
    slope = (offset_strain(z) - offset_strain(-z)) / (2 * z)
    dk = np.stack([st.dkappa.rr, st.dkappa.ra, st.dkappa.aa])
    np.testing.assert_allclose(slope, -dk, atol=1e-4 * np.max(np.abs(dk)))
    up = st.upper
    np.testing.assert_allclose(np.stack([up.rr, up.ra, up.aa]),
                               offset_strain(0.0) + z * slope, atol=1e-7)
    low = st.lower
    np.testing.assert_allclose(np.stack([low.rr, low.ra, low.aa]),
                               offset_strain(0.0) - z * slope, atol=1e-7)


def test_principal_strain_and_stretch_at_zero_inclination() -> None:
    """eps1 = |g|^2 / 2, eps2 = 0 along and across the slope g; lambda1 = sqrt(1 + |g|^2)."""
    a, r, t = points(6, 500)
    st = S.strains(SURF, MOVING["annulus"], a, r, t)
    u = K * r + MOVING["annulus"].phi_r(t).value
    v = KA * a + MOVING["annulus"].phi_a(t).value
    g = np.stack([A * K * np.cos(u) * np.cos(v), -A * KA * np.sin(u) * np.sin(v) / (R0 + r)])
    e1, e2, angle = st.membrane.principal()
    np.testing.assert_allclose(e1, 0.5 * np.sum(g**2, 0), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(e2, 0.0, atol=1e-15)
    direction = np.stack([np.cos(angle), np.sin(angle)])
    cross = direction[0] * g[1] - direction[1] * g[0]
    np.testing.assert_allclose(cross, 0.0, atol=1e-12)
    l1, l2 = st.membrane_stretches()
    np.testing.assert_allclose(l1, np.sqrt(1 + np.sum(g**2, 0)), rtol=1e-12)
    np.testing.assert_allclose(l2, 1.0, atol=1e-12)


def test_neo_hookean_stress_is_the_energy_derivative() -> None:
    """sigma_i = lambda_i dW/dlambda_i for W = mu/2 (l1^2 + l2^2 + (l1 l2)^-2 - 3)."""
    mu = 4e5
    l1, l2 = np.array([1.0, 1.3, 2.1]), np.array([1.0, 0.9, 1.4])

    def W(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return 0.5 * mu * (x**2 + y**2 + (x * y) ** -2 - 3)

    d = 1e-6
    s1 = l1 * (W(l1 + d, l2) - W(l1 - d, l2)) / (2 * d)
    s2 = l2 * (W(l1, l2 + d) - W(l1, l2 - d)) / (2 * d)
    got1, got2 = S.neo_hookean_stress(l1, l2, mu)
    np.testing.assert_allclose(got1, s1, rtol=1e-7, atol=1e-3)
    np.testing.assert_allclose(got2, s2, rtol=1e-7, atol=1e-3)
    assert got1[0] == 0.0 and got2[0] == 0.0


def test_svk_stress_is_the_energy_derivative() -> None:
    """S = dW/deps for W = E / (2 (1 - nu^2)) [(1 - nu) eps:eps + nu tr(eps)^2]."""
    E, nu = 1e9, 0.3
    eps = S.Sym2(np.array([0.01, -0.002]), np.array([0.004, 0.001]), np.array([0.003, 0.02]))

    def W(rr: np.ndarray, ra: np.ndarray, aa: np.ndarray) -> np.ndarray:
        c = E / (2 * (1 - nu**2))
        return c * ((1 - nu) * (rr**2 + 2 * ra**2 + aa**2) + nu * (rr + aa) ** 2)

    d = 1e-7
    s = S.svk_stress(eps, E, nu)
    np.testing.assert_allclose(s.rr, (W(eps.rr + d, eps.ra, eps.aa)
                                      - W(eps.rr - d, eps.ra, eps.aa)) / (2 * d), rtol=1e-6)
    np.testing.assert_allclose(2 * s.ra, (W(eps.rr, eps.ra + d, eps.aa)
                                          - W(eps.rr, eps.ra - d, eps.aa)) / (2 * d), rtol=1e-6)
    np.testing.assert_allclose(s.aa, (W(eps.rr, eps.ra, eps.aa + d)
                                      - W(eps.rr, eps.ra, eps.aa - d)) / (2 * d), rtol=1e-6)


def en02_peak() -> tuple[float, float]:
    """EN-02's largest membrane strain by the closed form: max over R of
    A^2 / 2 max(k^2 cos^2 kR, (Ka / (R0 + R))^2 sin^2 kR) (every v is reached)."""
    def minus(r: float) -> float:
        return -0.5 * A**2 * max(K**2 * math.cos(K * r) ** 2,
                                 (KA / (R0 + r)) ** 2 * math.sin(K * r) ** 2)
    res = minimize_scalar(minus, bounds=(0.2, 0.6), method="bounded",
                          options={"xatol": 1e-12})
    return -float(res.fun), float(res.x)


@pytest.mark.parametrize(("n_t", "refine_time"), [(5, False), (49, True)])
def test_maximum_over_the_membrane_reaches_the_closed_form_to_1e_6(n_t: int,
                                                                   refine_time: bool) -> None:
    """The refined grid finds EN-02's maximum strain and its radius, and says how fine."""
    value, r_star = en02_peak()
    times = np.linspace(0, 120, n_t)
    best = S.maximum(S.largest_face_strain(SURF, EN02), DR, times, n_alpha=96, n_R=17,
                     refine_time=refine_time)
    assert best.value == pytest.approx(value, rel=1e-6)
    assert best.value <= value * (1 + 1e-12)
    assert best.R == pytest.approx(r_star, abs=2e-3)
    assert math.sin(KA * best.alpha + EN02.phi_a(best.t).value) ** 2 == pytest.approx(1, abs=1e-5)
    assert best.drop <= 1e-6 and best.levels >= 2
    assert (best.n_alpha, best.n_R, best.n_t) == (96, 17, n_t)
    assert best.d_R == pytest.approx(DR / 16 / 2**best.levels)
    assert best.d_alpha == pytest.approx(2 * np.pi / 96 / 2**best.levels)
    if refine_time:
        assert best.d_t == pytest.approx(2.5 / 2**best.levels)
    else:
        assert best.d_t == 0.0 and best.t in times


def test_area_beyond_a_limit_matches_the_closed_form_annulus() -> None:
    """At t = 0 (v = Ka alpha), the area fraction where eps1 > limit, against the closed form
    on a four times finer midpoint grid."""
    limit = 0.2
    got = S.area_beyond(S.largest_face_strain(SURF, EN02), SURF, EN02, limit, [0.0],
                        n_alpha=192, n_R=96)
    n_a, n_r = 4 * 192, 4 * 96
    al = 2 * np.pi * (np.arange(n_a) + 0.5) / n_a
    rr = DR * (np.arange(n_r) + 0.5) / n_r
    u, v = K * rr[None, :], KA * al[:, None]
    e1 = 0.5 * A**2 * (K**2 * np.cos(u) ** 2 * np.cos(v) ** 2
                       + (KA / (R0 + rr)) ** 2 * np.sin(u) ** 2 * np.sin(v) ** 2)
    w = np.broadcast_to(R0 + rr, e1.shape)
    expected = float(np.sum(w * (e1 > limit)) / np.sum(w))
    assert 0.05 < expected < 0.5
    assert got.fraction == pytest.approx(expected, abs=5e-3)
    assert got.per_time[0] == got.fraction
    assert S.area_beyond(S.largest_face_strain(SURF, EN02), SURF, EN02, 1.0, [0.0, 60.0],
                         n_alpha=32, n_R=16).fraction == 0.0
