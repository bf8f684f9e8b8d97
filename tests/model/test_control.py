"""The controlled phase (docs/model.md s.12.2): the lead and the cascade against their
definitions, the energy identity on the controlled path at RK4's truncation level, a lead
limit of zero holding the sphere in its cavity, the adaptive methods, refused settings.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.model.cavity import cavity_angle
from creatio.model.control import Controller, lead, outer_gains, servo
from creatio.pipeline.config import resolve
from creatio.studies import en04


@pytest.fixture(scope="module")
def base():
    return resolve("en04").obj.bases["en02"]


def _controller(base, omega_max: float, delta_max_deg: float, omega_c: float = 3.0,
                omega_n: float = 20.0) -> Controller:
    k_theta, k_omega = outer_gains(omega_c, 1.0, en04.closed_forms(base).roll_alpha ** 2)
    return Controller(goal=-2.0 * math.pi, alpha0=base.sphere_problem().start_point[1],
                      k_theta=k_theta, k_omega=k_omega, omega_max=omega_max,
                      delta_max=math.radians(delta_max_deg), omega_n=omega_n, zeta=1.0)


def _run(base, ctl: Controller, dt: float, t_end: float = 6.0, **changes):
    prob = base.sphere_problem().replace(control=ctl, t_end=t_end, interval=0.02, dt=dt,
                                         **changes)
    return simulate(prob)


@pytest.mark.parametrize("phi_a", [0.0, 0.3, -2.0, 7.5, 40.0])
@pytest.mark.parametrize("alpha", [0.52, -1.3, 3.0])
def test_lead_is_the_nearest_cavity(alpha: float, phi_a: float) -> None:
    Ka = 6
    d = lead(alpha, phi_a, Ka)
    assert -math.pi / Ka < d <= math.pi / Ka + 1e-15
    # alpha + d is a cavity angle of some branch m, and no branch is nearer
    m = round((Ka * (alpha + d) - math.pi + phi_a) / (2.0 * math.pi))
    assert alpha + d == pytest.approx(cavity_angle(phi_a, Ka, m), abs=1e-12)
    others = [abs(cavity_angle(phi_a, Ka, j) - alpha) for j in range(m - 3, m + 4)]
    assert abs(d) <= min(others) + 1e-12


def test_servo_unsaturated_is_the_pd_law() -> None:
    """Far from its limits the outer loop is delta_cmd = K_theta (goal - theta) - K_omega
    alphadot, and u drives phi_a toward the phase whose cavity sits at alpha + delta_cmd."""
    Ka, goal, a0, kt, ko, wn, z = 6.0, -1.0, 0.4, 0.09, 0.06, 20.0, 0.7
    alpha, ad, pa, pad = 0.35, -0.1, 0.2, 0.05
    u, d, dc, v = servo(alpha, ad, pa, pad, Ka, goal, a0, kt, ko, 10.0, 1.0, wn, z, math.inf)
    theta = alpha - a0
    assert dc == pytest.approx(kt * (goal - theta) - ko * ad, rel=1e-14)
    assert v == pytest.approx(kt / ko * (goal - theta), rel=1e-14)
    assert u == pytest.approx(wn**2 * Ka * (d - dc) + 2 * z * wn * (-Ka * ad - pad), rel=1e-14)
    # limits clip each stage
    u2, _, dc2, v2 = servo(alpha, ad, pa, pad, Ka, goal, a0, kt, ko, 0.2, 0.001, wn, z, 5.0)
    assert v2 == -0.2 and abs(dc2) == 0.001 and abs(u2) == 5.0


def test_outer_gains_place_the_poles() -> None:
    """thetaddot = k delta with delta = delta_cmd gives s^2 + k K_omega s + k K_theta."""
    k, wc, zc = 99.9, 3.0, 0.8
    kt, ko = outer_gains(wc, zc, k)
    roots = np.roots([1.0, k * ko, k * kt])
    assert np.allclose(np.abs(roots), wc, rtol=1e-12)
    assert -roots[0].real / wc == pytest.approx(zc, rel=1e-12)


def test_energy_residual_rk4_order(base) -> None:
    """The sphere's energy balance (docs/model.md s.5, W_surface now the actuator's work on
    it) closes at RK4's truncation level on the controlled path: the residual shrinks by
    2^4 = 16 when dt halves (measured 18.2, 16.7, 16.3 from dt = 4 ms down)."""
    ctl = _controller(base, 0.5, 20.0)
    coarse = _run(base, ctl, 0.002)
    fine = _run(base, ctl, 0.001)
    assert coarse.counts.status == fine.counts.status == "ok"
    assert abs(coarse.histories.alpha[-1] - ctl.alpha0) > 1.0  # it travelled
    ratio = coarse.extrema.max_energy_residual / fine.extrema.max_energy_residual
    assert 14.0 < ratio < 19.0
    assert coarse.extrema.max_energy_residual < 1e-8
    # the recorded phase rate is the state's, and the work is not zero: the actuator works
    assert np.all(np.isfinite(coarse.histories.phi_a_rate))
    assert abs(coarse.histories.surface_work[-1]) > 1e-4


def test_zero_lead_limit_keeps_the_sphere_at_its_bottom(base) -> None:
    """delta_max = 0 commands the cavity onto the sphere: it never leaves the bottom it
    starts at (the start is the cavity bottom, at rest)."""
    res = _run(base, _controller(base, 3.0, 0.0), 0.002)
    assert res.counts.status == "ok" and res.carried
    assert np.max(np.abs(res.histories.alpha - res.histories.alpha[0])) < 1e-9
    assert np.max(np.abs(res.histories.R - res.histories.R[0])) < 1e-9


@pytest.mark.parametrize("method", ["dopri5", "dop853"])
def test_adaptive_methods_agree_with_rk4(base, method: str) -> None:
    ctl = _controller(base, 1.5, 10.0)
    ref = _run(base, ctl, 0.0005, t_end=4.0)
    res = _run(base, ctl, 0.001, t_end=4.0, method=method, rtol=1e-10, atol=1e-12)
    assert res.counts.status == ref.counts.status == "ok"
    assert np.max(np.abs(res.histories.alpha - ref.histories.alpha)) < 1e-7
    assert np.max(np.abs(res.histories.phi_a - ref.histories.phi_a)) < 1e-6
    assert res.extrema.max_energy_residual < 1e-8


@pytest.mark.parametrize(("field", "value"), [
    ("k_theta", -0.1), ("k_omega", 0.0), ("omega_n", -1.0), ("u_max", 0.0),
    ("delta_max", -0.01), ("omega_max", 0.0),
])
def test_controller_refuses(field: str, value: float) -> None:
    good = dict(goal=-1.0, alpha0=0.0, k_theta=0.1, k_omega=0.1, omega_max=1.0,
                delta_max=0.1, omega_n=10.0, zeta=1.0)
    with pytest.raises(ValueError, match=field):
        Controller(**{**good, field: value})


def test_controlled_path_refuses_the_free_structure(base) -> None:
    """The control block sits after the fixed structure's state (the structure path has no
    columns for it); the implicit methods are accepted (tests/dynamics/solvers/test_radau5.py)."""
    ctl = _controller(base, 1.0, 10.0)
    with pytest.raises(ValueError, match="fixed structure"):
        base.sphere_problem().replace(control=ctl, inertia=2.0)
    assert base.sphere_problem().replace(control=ctl, method="radau5").controlled


def test_trapezoid_law_converges_at_rk4_order() -> None:
    """EN-02 under a trapezoidal angular law whose switch times land on steps: the centre's
    dt - dt/2 differences shrink 16x per halving (measured 16.0 from 1 ms to 0.5 ms; the
    mean acceleration on a switch keeps the steps on both sides consistent)."""
    cfg = resolve("en02", ["phases.T=30", "phases.a.kind=trapezoid",
                           "phases.a.rate=115.2"]).obj
    prob = cfg.sphere_problem()
    X = {dt: simulate(prob.replace(dt=dt, interval=0.1, t_end=30.0)).histories.X
         for dt in (0.002, 0.001, 0.0005)}
    d1 = np.max(np.linalg.norm(X[0.002] - X[0.001], axis=1))
    d2 = np.max(np.linalg.norm(X[0.001] - X[0.0005], axis=1))
    assert d1 < 1e-9
    assert 12.0 < d1 / d2 < 20.0
