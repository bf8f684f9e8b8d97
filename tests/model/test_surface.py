"""Surface c(alpha, R, t) (docs/model.md s.1): derivatives, metric, normal, inverse, validation."""

from __future__ import annotations

import numpy as np
import pytest

from creatio.model.laws import Law
from creatio.model.surface import Frame, Motion, Surface, Wave, inverse

# Notebook geometry (docs/studies.md): R0 = 0.68, dR = 1.72, A = 0.18, Kr = 1, Ka = 6.
R0, DR, A, KR, KA = 0.68, 1.72, 0.18, 1, 6
SURF = Surface(R0=R0, dR=DR, A=A, Kr=KR, Ka=KA)
K = 2 * np.pi * KR / DR

LIN_R, LIN_A = Law.linear(0.23, 0.31), Law.linear(0.5, 0.47)  # CT-02 check phases
MOTIONS = {
    # constant inclinations: annulus, a cone, a negative cone, cylinder
    "annulus": Motion(LIN_R, LIN_A, Law.constant(0.0)),
    "cone": Motion(LIN_R, LIN_A, Law.constant(np.deg2rad(35.0))),
    "cone_negative": Motion(LIN_R, LIN_A, Law.constant(-0.6)),
    "cylinder": Motion(LIN_R, LIN_A, Law.constant(np.pi / 2)),
    # CT-02's time-varying inclination and EN-01 law (c)
    "ct02_varying": Motion(LIN_R, LIN_A, Law.sinusoid(np.pi / 4, 0.04, 0.7)),
    "en01_c": Motion(Law.linear(0.0, 0.4), Law.linear(0.5, 0.5), Law.sinusoid(np.pi / 4, 0.3, 0.7)),
    # quintic phases (cycle T = 2 s) with a sinusoidal inclination
    "quintic": Motion(
        Law.quintic(0.2, -2.0, 2.0), Law.quintic(0.5, 3.0, 2.0), Law.sinusoid(0.2, 0.5, 1.1)
    ),
    # sinusoidal phases with an inclination sweeping the whole range [-pi/2, pi/2]
    "sinusoid_full": Motion(
        Law.sinusoid(0.2, 0.8, 1.3), Law.sinusoid(0.1, 1.5, 0.9), Law.sinusoid(0.0, np.pi / 2, 1.7)
    ),
}


def sample_points(seed: int, n: int = 300) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded random (alpha, R, t): alpha in [0, 2 pi), R in [0, dR], t in [0.01, 1.99] s.

    The times keep a 5-point stencil (h = 1e-3) inside the quintic cycle (0, 2) where the laws
    are smooth; the radial ends 0 and dR are appended explicitly.
    """
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(0.0, 2 * np.pi, n)
    R = np.concatenate([rng.uniform(0.0, DR, n - 2), [0.0, DR]])
    t = rng.uniform(0.01, 1.99, n)
    return alpha, R, t


def frame(motion: Motion, alpha, R, t, surface: Surface = SURF) -> Frame:
    return Frame(surface, motion, alpha, R, t)


def d5(f, h: float):
    """4th-order 5-point central difference of f(shift) at shift 0."""
    return (f(-2 * h) - 8 * f(-h) + 8 * f(h) - f(2 * h)) / (12 * h)


def shifted(motion: Motion, attr: str, var: str, alpha, R, t):
    """f(shift) = attribute `attr` of the frame with `var` shifted by `shift`."""

    def f(s: float) -> np.ndarray:
        a2, R2, t2 = alpha + (s if var == "alpha" else 0.0), R, t
        if var == "R":
            R2 = R + s
        elif var == "t":
            t2 = t + s
        return getattr(frame(motion, a2, R2, t2), attr)

    return f


# 5-point central differences with h = 1e-3: truncation <= h^4/30 max|f^(5)| (for second
# derivatives, f^(6) of c). The worst directional derivative of c of order <= 6 is bounded by
# A (k + Ka + |phase and gamma rates| + 1)^6 + R1 ~ 0.18 * 12^6 = 5e5 at most, so truncation
# < 2e-8 in the crudest bound and ~1e-10 in practice; rounding adds 1.5 eps |f| / h ~ 1e-12.
# A wrong or missing term gives errors of order A, A k, or gamma' R, i.e. >= 1e-2.
H = 1e-3
FD_TOL = 2e-8

FIRST = [("c_R", "R"), ("c_alpha", "alpha"), ("c_t", "t")]
SECOND = [
    # (analytic second derivative, first derivative differenced, variable)
    ("c_RR", "c_R", "R"),
    ("c_Ra", "c_R", "alpha"),  # d/dalpha c_R
    ("c_Ra", "c_alpha", "R"),  # d/dR c_alpha (mixed partial the other way)
    ("c_aa", "c_alpha", "alpha"),
    ("c_Rt", "c_R", "t"),
    ("c_Rt", "c_t", "R"),
    ("c_at", "c_alpha", "t"),
    ("c_at", "c_t", "alpha"),
    ("c_tt", "c_t", "t"),
]


@pytest.mark.parametrize("mname", list(MOTIONS))
@pytest.mark.parametrize(("attr", "var"), FIRST)
def test_first_derivatives_against_central_differences(mname: str, attr: str, var: str) -> None:
    """c_R, c_alpha, c_t equal 5-point central differences of the position."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(1)
    fd = d5(shifted(motion, "position", var, alpha, R, t), H)
    got = getattr(frame(motion, alpha, R, t), attr)
    err = np.max(np.linalg.norm(got - fd, axis=-1))
    assert err < FD_TOL, f"{attr} vs FD in {var}: max error {err:.3e}"


@pytest.mark.parametrize("mname", list(MOTIONS))
@pytest.mark.parametrize(("attr", "first", "var"), SECOND)
def test_second_derivatives_against_central_differences(
    mname: str, attr: str, first: str, var: str
) -> None:
    """Each second derivative equals 5-point differences of an analytic first derivative."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(2)
    fd = d5(shifted(motion, first, var, alpha, R, t), H)
    got = getattr(frame(motion, alpha, R, t), attr)
    err = np.max(np.linalg.norm(got - fd, axis=-1))
    assert err < FD_TOL, f"{attr} vs d/d{var} {first}: max error {err:.3e}"


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_wave_derivatives_against_central_differences(mname: str) -> None:
    """W_R, W_a, W_t from differences of W; second derivatives of W from differences of those."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(3)

    def wave_f(attr: str, var: str):
        def f(s: float) -> np.ndarray:
            a2 = alpha + (s if var == "alpha" else 0.0)
            R2 = R + (s if var == "R" else 0.0)
            t2 = t + (s if var == "t" else 0.0)
            return getattr(Wave(SURF, motion, a2, R2, t2), attr)

        return f

    w = Wave(SURF, motion, alpha, R, t)
    pairs = [
        ("W_R", "W", "R"), ("W_a", "W", "alpha"), ("W_t", "W", "t"),
        ("W_RR", "W_R", "R"), ("W_aa", "W_a", "alpha"), ("W_Ra", "W_R", "alpha"),
        ("W_Ra", "W_a", "R"), ("W_Rt", "W_R", "t"), ("W_Rt", "W_t", "R"),
        ("W_at", "W_a", "t"), ("W_at", "W_t", "alpha"), ("W_tt", "W_t", "t"),
    ]  # fmt: skip
    for attr, base, var in pairs:
        err = np.max(np.abs(getattr(w, attr) - d5(wave_f(base, var), H)))
        assert err < FD_TOL, f"{attr} vs d/d{var} {base}: {err:.3e}"


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_position_matches_model_formula(mname: str) -> None:
    """position restates c = (rho cos a, rho sin a, R sin g + W cos g) with W = A sin u cos v."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(4)
    g = motion.gamma(t).value
    W = A * np.sin(K * R + motion.phi_r(t).value) * np.cos(KA * alpha + motion.phi_a(t).value)
    rho = R0 + R * np.cos(g) - W * np.sin(g)
    want = np.stack([rho * np.cos(alpha), rho * np.sin(alpha), R * np.sin(g) + W * np.cos(g)], -1)
    np.testing.assert_allclose(frame(motion, alpha, R, t).position, want, rtol=0, atol=1e-15)


def test_special_inclinations_reduce_to_annulus_and_cylinder() -> None:
    """gamma = 0: rho = R0 + R, z = W; gamma = pi/2: rho = R0 - W, z = R."""
    alpha, R, t = sample_points(5)
    for mname, expect in (
        ("annulus", lambda W: (R0 + R, W)),
        ("cylinder", lambda W: (R0 - W, R)),
    ):
        f = frame(MOTIONS[mname], alpha, R, t)
        rho_want, z_want = expect(f.w.W)
        c = f.position
        np.testing.assert_allclose(np.hypot(c[..., 0], c[..., 1]), rho_want, atol=1e-15)
        np.testing.assert_allclose(c[..., 2], z_want, atol=1e-15)


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_metric_is_dot_products_of_tangents(mname: str) -> None:
    """(E, F, G) = (c_R.c_R, c_R.c_alpha, c_alpha.c_alpha) and E G - F^2 = J^2 (rounding)."""
    f = frame(MOTIONS[mname], *sample_points(6))
    E, F, G = f.metric()
    cR, ca = f.c_R, f.c_alpha
    np.testing.assert_allclose(E, np.sum(cR * cR, -1), rtol=1e-14, atol=0)
    np.testing.assert_allclose(F, np.sum(cR * ca, -1), rtol=0, atol=1e-14)
    np.testing.assert_allclose(G, np.sum(ca * ca, -1), rtol=1e-14, atol=0)
    np.testing.assert_allclose(E * G - F**2, f.J**2, rtol=1e-13, atol=0)


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_jacobian_identity_and_normal(mname: str) -> None:
    """J = |c_R x c_alpha|; n is unit, orthogonal to c_R and c_alpha, and = (c_R x c_alpha)/J.

    All of these are exact identities, so only rounding (a few 1e-16 relative) is allowed.
    """
    f = frame(MOTIONS[mname], *sample_points(7))
    cross = np.cross(f.c_R, f.c_alpha)
    jx = np.linalg.norm(cross, axis=-1)
    np.testing.assert_allclose(f.J, jx, rtol=1e-14, atol=0)
    n = f.normal
    assert np.max(np.abs(np.linalg.norm(n, axis=-1) - 1.0)) < 1e-15 * 4
    for tang in (f.c_R, f.c_alpha):
        dot = np.sum(n * tang, -1) / np.linalg.norm(tang, axis=-1)
        assert np.max(np.abs(dot)) < 1e-15
    np.testing.assert_allclose(n, cross / jx[..., None], rtol=0, atol=1e-15)


def test_normal_orientation_flat_surface() -> None:
    """With A = 0: n = +e_z on the annulus (gamma = 0) and n = -e_rho on the cylinder."""
    flat = Surface(R0=R0, dR=DR, A=0.0, Kr=KR, Ka=KA)
    alpha, R, t = sample_points(8)
    n0 = frame(MOTIONS["annulus"], alpha, R, t, flat).normal
    np.testing.assert_allclose(n0, np.broadcast_to([0.0, 0.0, 1.0], n0.shape), atol=1e-15)
    n1 = frame(MOTIONS["cylinder"], alpha, R, t, flat).normal
    e_rho = np.stack([np.cos(alpha), np.sin(alpha), 0 * alpha], -1)
    np.testing.assert_allclose(n1, -e_rho, atol=1e-15)


def test_normal_points_up_on_corrugated_annulus() -> None:
    """gamma = 0, A > 0: n_z = rho / J > 0 everywhere, and n = +e_z where grad W = 0."""
    alpha, R, t = sample_points(9, 2000)
    f = frame(MOTIONS["annulus"], alpha, R, t)
    nz = f.normal[..., 2]
    assert np.all(nz > 0.0)
    np.testing.assert_allclose(nz, f.rho / f.J, rtol=1e-14)
    # stationary points of W at t = 0: cos u = 0 and sin v = 0
    motion = MOTIONS["annulus"]
    Rs = (np.pi / 2 - 0.23) / K
    alphas = (np.arange(12) * np.pi - 0.5) / KA
    n = frame(motion, alphas, Rs, 0.0).normal
    # sin v at v = j pi is only zero to eps * |v| ~ 8e-15, times A Ka = 1.08 in W_alpha
    np.testing.assert_allclose(n, np.broadcast_to([0.0, 0.0, 1.0], n.shape), atol=2e-14)


def test_normal_points_inward_on_cylinder_where_w_vanishes() -> None:
    """gamma = pi/2, at W = 0 (sin u = 0): n . e_rho = -rho / J < 0 (pointing to the axis)."""
    motion = Motion(Law.constant(0.23), Law.constant(0.5), Law.constant(np.pi / 2))
    Rw = (np.array([1.0, 2.0]) * np.pi - 0.23) / K  # 0.80 and 1.66, both inside [0, dR]
    alpha = np.linspace(0.0, 2 * np.pi, 72, endpoint=False)
    aa, RR = np.meshgrid(alpha, Rw)
    f = frame(motion, aa, RR, 0.0)
    assert np.max(np.abs(f.w.W)) < 1e-15
    e_rho = np.stack([np.cos(aa), np.sin(aa), 0 * aa], -1)
    radial = np.sum(f.normal * e_rho, -1)
    assert np.all(radial < 0.0)
    np.testing.assert_allclose(radial, -(R0 / f.J), rtol=1e-14)  # rho = R0 - W = R0 there


def test_jacobian_lower_bound_over_all_inclinations() -> None:
    """J >= rho >= R0 - A = 0.50 for |gamma| <= pi/2, at 200,000 random points.

    gamma(t) = (pi/2) sin(t) with random t in [0, 1000] s covers the whole range; the phases
    move linearly with incommensurate rates so (u, v) cover their torus too.
    """
    rng = np.random.default_rng(10)
    n = 200_000
    gamma = Law.sinusoid(0.0, np.pi / 2, 1.0)
    motion = Motion(Law.linear(0.1, 1.0), Law.linear(0.3, np.sqrt(2)), gamma)
    f = frame(motion, rng.uniform(0, 2 * np.pi, n), rng.uniform(0, DR, n), rng.uniform(0, 1e3, n))
    assert SURF.j_lower_bound == pytest.approx(0.50, abs=1e-15)
    assert np.all(f.J >= f.rho - 1e-15)
    assert np.all(f.rho >= R0 - A - 1e-15)
    assert f.J.min() >= 0.50 - 1e-15
    assert f.J.min() < 0.53  # the sample does get close to the bound


def test_jacobian_lower_bound_is_attained() -> None:
    """The bound is sharp: gamma = pi/2, R = 0, W = A with grad W = 0 gives J = R0 - A."""
    motion = Motion(Law.constant(np.pi / 2), Law.constant(0.0), Law.constant(np.pi / 2))
    f = frame(motion, 0.0, 0.0, 0.0)
    assert float(f.J) == pytest.approx(R0 - A, abs=1e-15)


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_inverse_round_trip(mname: str) -> None:
    """inverse(c(alpha, R, t)) returns (alpha, R, W) up to rounding (rho > 0 everywhere)."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(11, 1000)
    f = frame(motion, alpha, R, t)
    a2, R2, W2 = inverse(SURF, motion, f.position, t)
    assert np.all((a2 >= 0.0) & (a2 < 2 * np.pi))
    wrapped = np.angle(np.exp(1j * (a2 - alpha)))
    assert np.max(np.abs(wrapped)) < 1e-14
    np.testing.assert_allclose(R2, R, rtol=0, atol=1e-14)
    np.testing.assert_allclose(W2, f.w.W, rtol=0, atol=1e-14)


@pytest.mark.parametrize("mname", list(MOTIONS))
def test_seam_closure(mname: str) -> None:
    """c(alpha + 2 pi) = c(alpha) (integer Ka); only the rounding of sin/cos at larger arguments
    (eps * Ka * 4 pi * A k ~ 1e-14) separates them. Tangents and normal close too."""
    motion = MOTIONS[mname]
    alpha, R, t = sample_points(12)
    f0, f1 = frame(motion, alpha, R, t), frame(motion, alpha + 2 * np.pi, R, t)
    for attr in ("position", "c_R", "c_alpha", "normal"):
        np.testing.assert_allclose(getattr(f1, attr), getattr(f0, attr), rtol=0, atol=1e-13)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"R0": 0.0},
        {"R0": -0.68},
        {"dR": 0.0},
        {"dR": -1.72},
        {"A": 0.68},  # A = R0
        {"A": 0.9},  # A > R0
        {"A": -0.1},
    ],
)
def test_surface_validation(kwargs: dict) -> None:
    """R0 <= 0, dR <= 0, A >= R0 (and A < 0) are refused."""
    params = {"R0": R0, "dR": DR, "A": A, "Kr": KR, "Ka": KA} | kwargs
    with pytest.raises(ValueError):
        Surface(**params)


def test_surface_derived_quantities() -> None:
    """k = 2 pi Kr / dR, R1 = R0 + dR = 2.40, J bound R0 - A = 0.50; A = 0 is valid."""
    assert SURF.k == pytest.approx(2 * np.pi / 1.72, rel=1e-15)
    assert SURF.R1 == pytest.approx(2.40, rel=1e-15)
    assert Surface(R0=R0, dR=DR, A=0.0, Kr=2, Ka=3).k == pytest.approx(4 * np.pi / 1.72)
