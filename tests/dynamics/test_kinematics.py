"""Compiled laws and exact offset-surface kinematics of the sphere centre against references."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics.kinematics import centre_kinematics
from creatio.model.laws import Law, LawKind, law_eval
from creatio.model.surface import Motion, Surface

# Notebook geometry (docs/studies.md): R0 = 0.68, dR = 1.72, A = 0.18, Kr = 1, Ka = 6.
GEOM = {"R0": 0.68, "dR": 1.72, "A": 0.18, "Kr": 1, "Ka": 6}
B = 0.12

LAWS = [
    Law.constant(0.3),
    Law.linear(0.5, 0.47),
    Law.quintic(0.0, 12.0 * math.pi, 120.0),
    Law.quintic(0.2, -math.pi, 3.0),
    Law.sinusoid(math.pi / 4, 0.3, 0.7),
    Law(phi0=0.23, rate=0.31, delta=0.4, T=3.0, amplitude=0.1, omega=1.3),
]


@pytest.mark.parametrize("law", LAWS, ids=[f"law{i}" for i in range(len(LAWS))])
def test_law_eval_matches_creatio_laws(law: Law) -> None:
    times = np.array([-0.5, 0.0, 0.37, 1.11, 2.96, 3.0, 59.3, 60.0, 119.9, 120.0, 130.0])
    expected = law(times)
    for i, t in enumerate(times):
        value, d1, d2 = law_eval(law.coefficients(), float(t))
        assert value == pytest.approx(expected.value[i], rel=1e-14, abs=1e-14)
        assert d1 == pytest.approx(expected.d1[i], rel=1e-13, abs=1e-15)
        assert d2 == pytest.approx(expected.d2[i], rel=1e-13, abs=1e-15)


def _law_value(law: Law, t: float) -> float:
    return float(law(t).value)


def centre_reference(case: dict, R: float, alpha: float, t: float) -> np.ndarray:
    """X = c + b n written directly from docs/model.md s.1 formulas (independent of the jets)."""
    R0, dR, A, Kr, Ka = (GEOM[k] for k in ("R0", "dR", "A", "Kr", "Ka"))
    k = 2.0 * math.pi * Kr / dR
    u = k * R + _law_value(case["law_r"], t)
    v = Ka * alpha + _law_value(case["law_a"], t)
    gm = _law_value(case["law_gamma"], t)
    W = A * math.sin(u) * math.cos(v)
    W_R = A * k * math.cos(u) * math.cos(v)
    W_a = -A * Ka * math.sin(u) * math.sin(v)
    rho = R0 + R * math.cos(gm) - W * math.sin(gm)
    e_rho = np.array([math.cos(alpha), math.sin(alpha), 0.0])
    e_alpha = np.array([-math.sin(alpha), math.cos(alpha), 0.0])
    e_z = np.array([0.0, 0.0, 1.0])
    e_g = math.cos(gm) * e_rho + math.sin(gm) * e_z
    e_n = -math.sin(gm) * e_rho + math.cos(gm) * e_z
    J = math.sqrt(rho**2 * (1.0 + W_R**2) + W_a**2)
    n = (rho * (e_n - W_R * e_g) - W_a * e_alpha) / J
    c = rho * e_rho + (R * math.sin(gm) + W * math.cos(gm)) * e_z
    return c + B * n


CASES = {
    # both phases and the inclination time-varying (all three law terms active)
    "gamma_varying": {
        "law_r": Law(0.23, 0.31, 0.4, 3.0, 0.1, 1.3),
        "law_a": Law(0.5, 0.47, -0.7, 2.0, 0.2, 0.9),
        "law_gamma": Law(math.pi / 4, 0.02, 0.1, 4.0, 0.3, 0.7),
    },
    # near-cylinder: gamma = pi/2 - 0.02 + 0.015 sin(1.1 t) stays below pi/2
    "gamma_near_half_pi": {
        "law_r": Law(0.1, -0.4, 0.0, 1.0, 0.0, 0.0),
        "law_a": Law(0.5, 0.5, 0.3, 5.0, 0.0, 0.0),
        "law_gamma": Law(math.pi / 2 - 0.02, 0.0, 0.0, 1.0, 0.015, 1.1),
    },
    # EN-02 laws (gamma = 0, phi_a = 12 pi s(t/120)) at mid-cycle
    "en02": {
        "law_r": Law(0.0, 0.0, 0.0, 120.0, 0.0, 0.0),
        "law_a": Law(0.0, 0.0, 12.0 * math.pi, 120.0, 0.0, 0.0),
        "law_gamma": Law(0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
    },
}
POINTS = [(0.3, 0.4, 0.37), (1.2, 2.5, 1.11), (1.7, 5.0, 2.9), (0.43, math.pi / 6, 60.0)]


def _kin(case: dict, R: float, alpha: float, t: float) -> dict[str, np.ndarray]:
    motion = Motion(case["law_r"], case["law_a"], case["law_gamma"])
    return centre_kinematics(Surface(**GEOM), motion, B, R, alpha, t)


def _d(f, i: int, h: float):
    """4th-order central difference of f(x) (x = (R, alpha, t)) along coordinate i."""
    e = np.zeros(3)
    e[i] = h

    def df(x: np.ndarray) -> np.ndarray:
        return (-f(x + 2 * e) + 8 * f(x + e) - 8 * f(x - e) + f(x - 2 * e)) / (12 * h)

    return df


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
@pytest.mark.parametrize("point", POINTS)
def test_centre_derivatives_match_central_differences(case: str, point: tuple) -> None:
    check_against_differences(CASES[case], point)


@pytest.mark.parametrize("kind", list(LawKind))
def test_centre_kinematics_follow_a_phase_law_of_every_kind(kind: LawKind) -> None:
    """The compiled kinematics read a phase law of each kind of the registry (every term of
    the general form on, the step the kind's; a trapezoid's ramp 1/4): X and its derivatives
    against central differences of the closed-form centre, at times inside the cycle away
    from the step's kinks (0.5, 1.5, 2 s) and after it."""
    laws = dict(CASES["gamma_varying"])
    laws["law_a"] = Law(0.5, 0.47, -0.7, 2.0, 0.2, 0.9, kind=kind, ramp=0.25)
    for point in ((0.3, 0.4, 0.37), (1.2, 2.5, 1.11), (1.7, 5.0, 1.7), (0.43, 0.5, 2.9)):
        check_against_differences(laws, point)


def check_against_differences(laws: dict, point: tuple) -> None:
    """X, its first and second derivatives at point = (R, alpha, t) against 4th-order central
    differences of :func:`centre_reference`, and n unit and normal to X_R and X_alpha."""
    R, alpha, t = point
    kin = _kin(laws, R, alpha, t)

    def X(x: np.ndarray) -> np.ndarray:
        return centre_reference(laws, *x)

    x0 = np.array(point, dtype=float)
    np.testing.assert_allclose(kin["X"], X(x0), rtol=0, atol=1e-14)
    hs = (1e-3, 1e-3 / GEOM["Ka"], 1e-3)  # alpha derivatives carry factors of Ka
    first = [_d(X, i, hs[i]) for i in range(3)]
    for i in range(2):
        np.testing.assert_allclose(kin["X_q"][:, i], first[i](x0), rtol=0, atol=1e-8)
    np.testing.assert_allclose(kin["X_t"], first[2](x0), rtol=0, atol=1e-8)
    for i in range(3):
        for j in range(i, 3):
            fd = _d(first[i], j, hs[j])(x0)
            if j < 2:
                exact = kin["X_qq"][:, i, j]
            elif i < 2:
                exact = kin["X_qt"][:, i]
            else:
                exact = kin["X_tt"]
            np.testing.assert_allclose(exact, fd, rtol=0, atol=1e-6 * (1.0 + np.abs(fd).max()))
    # the offset surface shares the normal of c: unit, orthogonal to X_R and X_alpha
    assert np.linalg.norm(kin["n"]) == pytest.approx(1.0, abs=1e-15)
    assert np.abs(kin["n"] @ kin["X_q"]).max() < 1e-14


def test_normal_points_up_on_annulus() -> None:
    kin = _kin(CASES["en02"], 0.43, math.pi / 6, 0.0)  # EN-02 start: a cavity bottom
    np.testing.assert_allclose(kin["n"], [0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(kin["X"], kin["c"] + [0.0, 0.0, B], atol=1e-15)
