"""EN-03 (docs/model.md s.9): the sphere on a structure free to yaw about z.

The 4 x 4 solve against a dense solve; the equations of motion of sphere and structure
against high-order differences of a lively run; H_z and the energy balance at rounding on
EN-03's defaults; the limits (I_s -> infinity is EN-02, mu = 0 leaves the spin at zero, the
point-mass estimate as the cavity shrinks and stiffens); the stability limit with the
structure's turn; every integrator on the new states.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, simulate, stability_limit
from creatio.dynamics import sphere as core
from creatio.dynamics.kinematics import centre_kinematics
from creatio.dynamics.solvers.tableaus import RK4_REAL_STABILITY
from creatio.model.laws import Law
from creatio.model.structure import free_structure_solve, point_mass_rotation
from creatio.pipeline.config import resolve
from creatio.reports.registry import writer

G = np.array([0.0, 0.0, -9.81])


@pytest.fixture(scope="module")
def en03(en02_problem: SphereProblem) -> SphereProblem:
    """EN-03's default single run (I_s = 10 kg m^2), built from the hand-made EN-02."""
    return en02_problem.replace(inertia=10.0)


@pytest.fixture(scope="module")
def en03_pair(en03: SphereProblem):
    return simulate(en03), simulate(en03.replace(dt=0.001))


def _rz(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_structure_solve_matches_a_dense_4x4_solve() -> None:
    """theta'' and N by elimination equal the dense solve of the 4 x 4 system, and the
    tangential rows then give qddot (random tangent frames, slip directions, preload)."""
    rng = np.random.default_rng(7)
    for _ in range(50):
        m, inv_Is, P = rng.uniform(0.5, 2.0), rng.uniform(0.0, 2.0), rng.uniform(0.0, 5.0)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        J = rng.normal(size=(3, 2))
        J -= np.outer(n, n @ J)  # columns tangent: n . J = 0
        phi = rng.normal(size=3) * 0.3
        phi -= n * (n @ phi)  # tangential friction direction
        X = rng.normal(size=3)
        rho_c = rng.uniform(0.5, 2.0)
        c = np.array([rho_c, 0.0, rng.normal()])  # the contact point (rotating frame)
        g = rng.normal(size=3)  # g - a0 - 2 Theta z x V - Theta^2 z x (z x X)
        zx = np.array([-X[1], X[0], 0.0])
        b = g - (P / m) * n
        A = np.zeros((4, 4))
        A[:3, :2] = m * J
        A[:3, 2] = m * zx
        A[:3, 3] = -(n + phi)
        A[3, 2] = 1.0
        A[3, 3] = inv_Is * np.cross(c, n + phi)[2]
        rhs = np.r_[m * b, inv_Is * P * np.cross(c, n)[2]]
        qdd1, qdd2, thdd, N = np.linalg.solve(A, rhs)
        thdd_c, N_c = free_structure_solve(m, inv_Is, P, *n, phi[0], phi[1], X[0], X[1], rho_c,
                                           float(n @ b))
        assert thdd_c == pytest.approx(thdd, rel=1e-10, abs=1e-12)
        assert N_c == pytest.approx(N, rel=1e-10, abs=1e-12)
        r = b - thdd_c * zx + N_c * phi / m
        qdd = np.linalg.solve(J.T @ J, J.T @ r)
        np.testing.assert_allclose(qdd, [qdd1, qdd2], rtol=1e-9, atol=1e-12)


def test_equations_of_motion_against_high_order_differences(en02_problem) -> None:
    """A lively free-structure run with a normal preload and gravity: m A = m g - P n + N n + f
    in the world (A from 5-point differences of the world-frame centre), I_s Theta' =
    -[c x (N n + f - P n)] . z, I omega' = (-b n) x f, H_z constant."""
    I_s, P = 0.7, 3.0
    h = 2.5e-4
    p = en02_problem.replace(
        inertia=I_s, confinement="normal", force=P, mu=0.3,
        phi_r=Law(0.1, 0.02, 0.1, 2.0, 0.02, 1.3), phi_a=Law(0.0, 0.05, 0.1, 1.5, 0.02, 0.9),
        gamma=Law(0.2, 0.0, 0.05, 2.0, 0.02, 1.7), R=0.45, alpha=0.5, Rdot=0.02, alphadot=0.03,
        omega=(0.5, -1.0, 0.5), t_end=2.0, dt=h, interval=h)
    res = simulate(p)
    r = res.histories
    assert res.counts.status == "ok" and res.extrema.max_slip_speed > 0.1
    assert np.abs(r.theta_rate).max() > 0.01  # the structure really turns
    inertia = p.model.sphere.inertia
    W = np.stack([_rz(th) @ x for th, x in zip(r.theta, r.X, strict=True)])
    # the 5-point stencils' truncation error is largest in the early slip transient (the slip
    # relaxes at ~1000 1/s, h = 0.25 ms): a few 1e-7 relative there
    for i in (20, 2800, 6000):
        n_s = centre_kinematics(p.model.surface, p.model.motion, p.model.sphere.b, r.R[i],
                                r.alpha[i], r.t[i])["n"]
        Rz = _rz(r.theta[i])
        n, f = Rz @ n_s, Rz @ r.f[i]
        acc = (-W[i - 2] + 16 * W[i - 1] - 30 * W[i] + 16 * W[i + 1] - W[i + 2]) / (12 * h * h)
        m = p.model.sphere.m
        np.testing.assert_allclose(m * acc, m * G - P * n + r.N[i] * n + f, atol=2e-6)
        dTh = (r.theta_rate[i - 2] - 8 * r.theta_rate[i - 1] + 8 * r.theta_rate[i + 1]
               - r.theta_rate[i + 2]) / (12 * h)
        c = r.X[i] - p.model.sphere.b * n_s  # contact point, structure frame
        torque = -np.cross(c, r.N[i] * n_s + r.f[i] - P * n_s)[2]
        assert I_s * dTh == pytest.approx(torque, rel=1e-5)
        dw = (r.omega[i - 2] - 8 * r.omega[i - 1] + 8 * r.omega[i + 1]
              - r.omega[i + 2]) / (12 * h)
        np.testing.assert_allclose(inertia * dw, np.cross(-p.model.sphere.b * n, f), rtol=1e-5,
                                   atol=1e-9)
    hz = r.hz_structure + r.hz_orbital + r.hz_spin
    assert np.abs(hz - hz[0]).max() == pytest.approx(res.extrema.max_hz_drift, rel=0.5, abs=1e-15)
    assert res.extrema.max_hz_drift < 1e-12 * max(1.0, res.extrema.max_structure_momentum * 1e3)


def test_en03_defaults_conserve_hz_and_energy_to_rounding(en03_pair) -> None:
    res, half = en03_pair
    h = res.histories
    assert res.counts.status == "ok" and res.carried
    assert res.extrema.max_structure_momentum == pytest.approx(0.1078, rel=1e-3)
    assert res.extrema.max_hz_drift < 2e-14  # 4.4e-15 measured: rounding, scale 0.108 kg m^2/s
    assert res.extrema.max_energy_residual < 2e-14  # 4.1e-15 J
    assert half.extrema.max_hz_drift < 2e-14 and half.extrema.max_energy_residual < 2e-14
    assert np.abs(h.X - half.histories.X).max() < 1e-12  # timestep difference 6.6e-14 m
    # the structure turns against the sphere; the point-mass estimate (centre radius 1.11 m)
    relative = h.azimuth[-1] - h.azimuth[0]
    assert math.degrees(relative) == pytest.approx(-360.0, abs=1e-5)
    estimate = point_mass_rotation(1.0, float(np.hypot(*h.X[0, :2])), 10.0, relative)
    assert math.degrees(estimate) == pytest.approx(39.49, abs=0.01)
    assert math.degrees(h.theta[-1]) == pytest.approx(math.degrees(estimate), abs=0.03)
    world = h.world_azimuth[-1] - h.world_azimuth[0]
    assert world == pytest.approx(relative + h.theta[-1], abs=1e-12)


def test_large_inertia_is_en02_to_its_timestep_difference(en02_problem, en03_pair) -> None:
    fixed = simulate(en02_problem)
    hf = fixed.histories
    fixed_half = simulate(en02_problem.replace(dt=0.001))
    step_difference = np.abs(hf.X - fixed_half.histories.X).max()
    big = simulate(en02_problem.replace(inertia=1e12))
    assert np.abs(big.histories.X - hf.X).max() <= step_difference  # 1.2e-14 vs 7.1e-14 m
    assert abs(big.histories.theta[-1]) < 1e-11
    # the structure path on a fixed structure (1 / I_s = 0 exactly) with a zero preload
    # differs from the fixed path only by the order of its operations
    same = simulate(en02_problem.replace(confinement="normal", force=0.0))
    assert same.counts.structure_free and np.all(same.histories.theta == 0.0)
    assert np.abs(same.histories.X - hf.X).max() < 1e-13


def test_frictionless_leaves_the_spin_at_zero(en03) -> None:
    res = simulate(en03.replace(mu=0.0, rotation=True, t_end=30.0))
    h = res.histories
    assert res.counts.rotation_integrated and res.counts.structure_free
    assert np.all(h.omega == 0.0) and np.all(h.cumulative_spin == 0.0)
    assert np.all(h.hz_spin == 0.0)
    assert np.abs(h.theta).max() > 1e-3  # the normal force alone turns the structure
    assert res.extrema.max_hz_drift < 1e-14 and res.extrema.max_energy_residual < 1e-13


def test_point_mass_estimate_approached_as_the_cavity_shrinks_and_stiffens(en03) -> None:
    """A -> 0 and b -> 0 together (b / A fixed, so b kappa is fixed) with g ~ 1 / A^2 (the
    cavity's restoring stiffness g A k^2 grows like 1 / A), frictionless (no spin): the
    centre's radial excursion, which alone separates the simulated turn from the point-mass
    estimate, shrinks like A, and so does the difference."""
    diffs, excursions = [], []
    for s in (1.0, 1 / 3, 1 / 9):
        p = en03.replace(A=0.18 * s, b=0.12 * s, g=9.81 / s**2, mu=0.0)
        res = simulate(p)
        h = res.histories
        assert res.counts.status == "ok" and res.carried
        relative = h.azimuth[-1] - h.azimuth[0]
        rho = np.hypot(h.X[:, 0], h.X[:, 1])
        estimate = point_mass_rotation(p.model.sphere.m, float(rho[0]), p.model.structure.inertia,
                                       relative)
        diffs.append(abs(h.theta[-1] - estimate) / abs(estimate))
        excursions.append(np.abs(rho - rho[0]).max())
    assert diffs[0] < 3e-4  # 2.6e-4 at the notebook's cavity
    for k in (1, 2):
        assert 2.0 < diffs[k - 1] / diffs[k] < 3.5  # ~3 per factor 3 in A: linear
        assert 2.0 < excursions[k - 1] / excursions[k] < 3.5


def test_stability_limit_gains_the_structure_turn(en03) -> None:
    """Slip relaxes at mu N (1/m + b^2/I + rho_c^2/I_s) / eps along the azimuth: the
    linearised free-structure dynamics at rest has that eigenvalue, the radial slip keeps
    3.5 mu N / (m eps), and the RK4 limit follows the faster one."""
    I_s = 2.0
    p = en03.replace(inertia=I_s)
    rho_c = 0.68 + 0.43
    rate = 0.15 * 9.81 * (3.5 + rho_c**2 / I_s) / 0.01
    assert stability_limit(p) == pytest.approx(RK4_REAL_STABILITY / (1.25 * rate), rel=1e-12)
    y = p.initial_state(True, True)
    prm, laws = p.parameter_vector(), p.law_matrix()
    jac = np.empty((y.size, y.size))
    for j in range(y.size):
        e = np.zeros(y.size)
        e[j] = 1e-7
        jac[:, j] = (core.evaluate_structure(prm, laws, y + e, 0.0)[0]
                     - core.evaluate_structure(prm, laws, y - e, 0.0)[0]) / 2e-7
    ev = np.sort(np.linalg.eigvals(jac).real)
    np.testing.assert_allclose(ev[0], -rate, rtol=1e-3)
    np.testing.assert_allclose(ev[1], -3.5 * 0.15 * 9.81 / 0.01, rtol=1e-3)


@pytest.mark.parametrize("method", ["dopri5", "dop853", "radau5"])
def test_every_integrator_runs_the_structure(en03, method) -> None:
    """Adaptive and implicit methods on the structure path (Radau's Jacobian differences the
    theta and Theta columns) agree with RK4 on a 20 s EN-03 segment."""
    short = en03.replace(inertia=1.0, t_end=20.0)
    ref = simulate(short.replace(dt=0.001))
    res = simulate(short.replace(method=method, rtol=1e-10, atol=1e-12))
    assert res.counts.status == "ok" and res.histories.t.size == ref.histories.t.size
    np.testing.assert_allclose(res.histories.theta, ref.histories.theta, rtol=0, atol=1e-8)
    assert np.abs(res.histories.X - ref.histories.X).max() < 1e-8
    assert res.extrema.max_hz_drift < 1e-9
    if method == "radau5":
        assert res.counts.jacobians >= 1 and res.counts.steps < ref.counts.steps / 10


def test_en03_study_dataset_and_report(tmp_path) -> None:
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    cfg = resolve("en03", ["study.inertia_sweep=[1.0,100.0]", "phases.T=30.0"])
    parts = cfg.entry.parts(cfg.obj)
    assert [q.name for q in parts] == ["en03_dt0.002", "en03_dt0.001", "en03_inertia_dt0.002",
                                       "en03_inertia_dt0.001"]
    paths = [write_dataset(run_study(cfg, q.name), tmp_path / f"{q.name}.nc") for q in parts]
    files = writer(cfg.entry.id)(paths, tmp_path)
    report = json.loads(files["json"].read_text())
    for key in ("status", "timestep_difference_m", "energy_residual_J", "structure_rotation_deg",
                "structure_rotation_point_mass_deg", "angular_momentum_drift",
                "angular_momentum_scale", "angular_displacement_deg",
                "world_angular_displacement_deg", "structure_inertia_kg_m2"):
        assert key in report
    assert report["status"] == "ok" and report["structure_inertia_kg_m2"] == 10.0
    assert list(report["inertia_sweep"]) == ["1", "100"]
    assert report["limit_check"]["difference_from_fixed_m"] < 1e-12
    assert report["world_angular_displacement_deg"] == pytest.approx(
        report["angular_displacement_deg"] + report["structure_rotation_deg"], abs=1e-9)
