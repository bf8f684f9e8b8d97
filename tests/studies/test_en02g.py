"""EN-02G (docs/model.md s.8): the static equilibrium start, the cavity-cell check, and the
study across the inclination family.

The equilibrium solves J(q, 0)^T g = 0 with exact derivatives of the centre's height; it
must satisfy the equation to rounding, be a minimum, agree with high-order differences, and
vanish past the inclination where the cavity's meridional slope can no longer hold the
sphere (arctan(A k)). At gamma = 0 it is EN-02's start, bit for bit.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, simulate
from creatio.dynamics.kinematics import centre_kinematics
from creatio.model.cavity import cavity_cell_offsets, in_cavity_cell
from creatio.model.equilibrium import equilibrium_limit, height_derivatives, static_equilibrium
from creatio.model.laws import Law
from creatio.pipeline.config import resolve
from creatio.reports.registry import writer

K = 2.0 * math.pi / 1.72  # notebook geometry: Kr = 1, dR = 1.72


def _inclined(p: SphereProblem, gamma_deg: float) -> SphereProblem:
    law = Law.constant(math.radians(gamma_deg))
    return p.replace(gamma=law, equilibrium=True)


def _eq(gamma_deg: float, b: float = 0.12):
    return static_equilibrium(0.68, K, 0.18, 6.0, b, 0.0, 0.0, math.radians(gamma_deg), 0, 0)


@pytest.mark.parametrize("gamma_deg", [5.0, 15.0, 25.0, 30.0])
def test_equilibrium_solves_jt_g_to_rounding_and_is_a_minimum(en02_problem, gamma_deg) -> None:
    eq = _eq(gamma_deg)
    assert eq.acceptable and eq.converged and eq.minimum and eq.in_cell
    assert eq.iterations <= 8  # quadratic convergence from the cavity bottom
    # J^T g in the world frame from the exact centre kinematics of the dynamics layer
    p = _inclined(en02_problem, gamma_deg)
    kin = centre_kinematics(p.model.surface, p.model.motion, p.model.sphere.b,
                            eq.R, eq.alpha, 0.0)
    jtg = kin["X_q"].T @ np.array([0.0, 0.0, -9.81])
    assert np.abs(jtg).max() < 1e-14  # rounding (g = 9.81, slopes of order 1)
    # a minimum of the potential m g X_z: positive definite Hessian
    hRR, hRa, haa = eq.hessian
    assert hRR > 0.0 and hRR * haa - hRa**2 > 0.0
    # by symmetry of the cavity in v about its bottom, alpha stays at alpha_c = pi / 6
    assert eq.alpha == pytest.approx(math.pi / 6, abs=1e-15)
    # on the cone gravity pulls the contact inward: R below the bottom's 0.43
    assert 0.0 < eq.R < 0.43


def test_height_derivatives_are_exact_against_eighth_order_differences() -> None:
    """The gradient and Hessian Newton uses (jets) against 8th-order central differences of
    the height X_z itself, at points off the equilibrium on a cone."""
    args = (0.68, K, 0.18, 6.0, 0.12, 0.23, 0.41, math.radians(17.0))
    c8 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
    d2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315,
                   -1 / 560])
    steps = np.arange(-4, 5)
    for R, a in ((0.31, 0.47), (0.6, 0.2), (1.2, -0.3)):
        z, gR, ga, hRR, hRa, haa = height_derivatives(R, a, *args)
        h = 1e-3

        def Z(dR: float, da: float, R: float = R, a: float = a) -> float:
            return height_derivatives(R + dR, a + da, *args)[0]

        fR = sum(c * Z(s * h, 0.0) for c, s in zip(c8, steps, strict=True)) / h
        fa = sum(c * Z(0.0, s * h) for c, s in zip(c8, steps, strict=True)) / h
        fRR = sum(c * Z(s * h, 0.0) for c, s in zip(d2, steps, strict=True)) / h**2
        faa = sum(c * Z(0.0, s * h) for c, s in zip(d2, steps, strict=True)) / h**2
        fRa = sum(ci * cj * Z(si * h, sj * h) for ci, si in zip(c8, steps, strict=True)
                  for cj, sj in zip(c8, steps, strict=True)) / h**2
        np.testing.assert_allclose([gR, ga], [fR, fa], rtol=0, atol=1e-11)
        np.testing.assert_allclose([hRR, hRa, haa], [fRR, fRa, faa], rtol=0, atol=1e-7)


def test_equilibrium_limit_is_the_steepest_meridional_slope() -> None:
    """No equilibrium past the limit, which is where the cavity's steepest meridional slope
    A k equals tan(gamma), for any sphere: the minimum meets the cell's inner edge u = 0
    there, where W = W_RR = W_Ralpha = 0, so n does not turn along R and X_R = c_R."""
    expected = math.degrees(math.atan(0.18 * K))
    for b in (0.12, 1e-6):
        limit = math.degrees(equilibrium_limit(0.68, K, 0.18, 6.0, b, 0.0, 0.0, 0, 0))
        assert limit == pytest.approx(expected, abs=1e-7)
        assert _eq(limit - 1e-3, b).acceptable and not _eq(limit + 1e-3, b).acceptable


@pytest.mark.parametrize("gamma_deg", [40.0, 90.0])
def test_no_equilibrium_is_a_status_and_nothing_runs(en02_problem, gamma_deg) -> None:
    eq = _eq(gamma_deg)
    assert not eq.acceptable and eq.reason
    res = simulate(_inclined(en02_problem, gamma_deg))
    assert res.counts.status == "no_equilibrium" and res.counts.steps == 0
    assert res.histories.t.size == 0
    assert res.counts.equilibrium_message == eq.reason and not res.carried
    assert math.isnan(res.extrema.min_N) and math.isnan(res.extrema.max_energy_residual)


def test_en02g_at_zero_inclination_is_en02_bit_for_bit(en02_problem) -> None:
    eq = _eq(0.0)
    assert (eq.R, eq.alpha) == (0.43, math.radians(30.0))  # the bottom, kept as is
    a = simulate(en02_problem)
    b = simulate(_inclined(en02_problem, 0.0))
    for name in ("X", "R", "alpha", "V", "N", "f", "omega", "Q", "energy_residual"):
        np.testing.assert_array_equal(getattr(a.histories, name), getattr(b.histories, name))
    assert a.extrema.min_N == b.extrema.min_N
    assert a.extrema.max_slip_speed == b.extrema.max_slip_speed


def test_cell_offsets_follow_the_moving_cavity() -> None:
    # the bottom of cavity (0, 0) at any phases, and the cell's edges
    for pr, pa in ((0.0, 0.0), (0.3, -2.0), (-1.1, 7.5)):
        R = (math.pi / 2 - pr) / K
        a = (math.pi - pa) / 6.0
        assert cavity_cell_offsets(R, a, pr, pa, K, 6.0, 0, 0) == pytest.approx((0.0, 0.0),
                                                                                 abs=1e-14)
        du, dv = cavity_cell_offsets(R, a + math.pi / 12 * 0.999, pr, pa, K, 6.0, 0, 0)
        assert in_cavity_cell(du, dv)
        du, dv = cavity_cell_offsets(R, a + math.pi / 12 * 1.001, pr, pa, K, 6.0, 0, 0)
        assert not in_cavity_cell(du, dv)  # past the zero line of W through the saddles
    # alpha is continuous: a full turn later it is another cavity's cell
    du, dv = cavity_cell_offsets(0.43, math.pi / 6 + 2 * math.pi, 0.0, 0.0, K, 6.0, 0, 0)
    assert not in_cavity_cell(du, dv)


def test_a_short_cycle_leaves_its_cavity_yet_ends_ok(en02_problem) -> None:
    """The gap the cell check closes: at T = 6.9 s the run completes ("ok") but the contact
    point crossed the cell's outer edge (the zero line of W past the radial wall) at
    t = 4.272 s, for about 0.15 s, before falling back; EN-02 itself is carried."""
    assert simulate(en02_problem).carried
    fast = en02_problem.replace(phi_a=Law(0.0, 0.0, 12 * math.pi, 6.9, 0.0, 0.0), t_end=6.9)
    res = simulate(fast)
    h = res.histories
    assert res.counts.status == "ok" and not res.carried
    assert res.events.left_cavity_time == pytest.approx(4.272, abs=1e-9)
    inside = (np.abs(h.cell_u) < math.pi / 2) & (np.abs(h.cell_v) < math.pi / 2)
    assert inside[h.t < 4.272].all() and not inside[(h.t > 4.25) & (h.t < 4.45)].any()
    assert np.abs(h.cell_u[~inside]).min() >= math.pi / 2  # out over the radial edge
    stop = simulate(fast.replace(stop_on_leaving_cavity=True))
    assert stop.counts.status == "left_cavity"
    assert stop.counts.stop_time == res.events.left_cavity_time
    np.testing.assert_array_equal(stop.histories.X[:-1], h.X[:len(stop.histories.t) - 1])


def test_en02g_study_dataset_and_report(tmp_path) -> None:
    """A small EN-02G through the study's run function and report writer."""
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    cfg = resolve("en02g", ["study.inclinations_deg=[0,20,40]", "study.oscillation.gamma0_deg=[10]",
                            "phases.T=30.0"])
    paths = []
    for part in cfg.entry.parts(cfg.obj):
        ds = run_study(cfg, part.name)
        paths.append(write_dataset(ds, tmp_path / f"{part.name}.nc"))
    assert ds.sizes["inclination"] == 3 and ds.sizes["gamma0"] == 1
    assert list(ds.status.values) == ["ok", "ok", "no_equilibrium"]
    assert np.isnan(ds.centre.values[2]).all()  # no run, no history
    assert ds.start_R.values[0] == 0.43 and ds.start_R.values[1] < 0.43
    files = writer(cfg.entry.id)(paths, tmp_path)
    report = json.loads(files["json"].read_text())
    for key in ("status", "timestep_difference_m", "energy_residual_J",
                "max_carried_inclination_deg", "per_inclination"):
        assert key in report
    row = report["per_inclination"]["20"]
    for key in ("carried", "left_cavity_time_s", "min_normal_reaction_N"):
        assert key in row
    assert report["per_inclination"]["40"]["status"] == "no_equilibrium"
    # constant inclinations: near EN-02's level (a 30 s cycle); the oscillating law starts
    # with a slip transient
    # (the normal turns at gamma'(0) != 0 under a sphere at rest), RK4's error is larger
    assert max(report["per_inclination"][g]["timestep_difference_m"] for g in ("0", "20")) < 1e-10
    assert report["timestep_difference_m"] < 1e-7
    for f in files.values():
        assert f.exists() and f.stat().st_size > 0
