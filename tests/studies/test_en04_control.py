"""EN-04's closed loop (docs/studies.md, docs/model.md s.12.2): refused settings one line each
with exit 2, the arrival rule against the recorded histories, the open-loop comparisons.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.studies import en04
from creatio.studies.en04_control import ControllerPoint, controller, measure


@pytest.mark.parametrize(("override", "key", "rule"), [
    ("study.control.omega_c=[-2.0]", "study.control.omega_c[0]", "> 0"),
    ("study.control.omega_n=[10.0,-1.0]", "study.control.omega_n[1]", "> 0"),
    ("study.control.zeta=-0.5", "study.control.zeta", ">= 0"),
    ("study.control.zeta_c=0", "study.control.zeta_c", "> 0"),
    ("study.control.delta_max_deg=[30.0]", "study.control.delta_max_deg[0]", "180 / Ka = 30"),
    ("study.control.delta_max_deg=[-1.0]", "study.control.delta_max_deg[0]", "[0, 180 / Ka"),
    ("study.control.default.delta_max_deg=45", "study.control.default.delta_max_deg",
     "180 / Ka"),
    ("study.control.u_max=0", "study.control.u_max", "> 0"),
    ("study.control.u_max=-3", "study.control.u_max", "> 0"),
    ("study.control.duration=15.0005", "study.control.duration", "multiple"),
    ("bases.en02.solver.method=radau5", "bases.en02.solver.method", "explicit"),
    ("study.control.extrema.n_R=2", "study.control.extrema.n_R", ">= 3"),
])
def test_refused_settings(override: str, key: str, rule: str) -> None:
    with pytest.raises(ConfigError) as e:
        resolve("en04", [override])
    assert e.value.key == key
    assert rule in str(e.value) and "\n" not in str(e.value)


def test_refusal_is_one_line_exit_2() -> None:
    """The CLI refuses a negative gain, a lead at half a cavity and u_max <= 0 in one line."""
    for override in ("study.control.omega_c=[-2.0]", "study.control.delta_max_deg=[30.0]",
                     "study.control.u_max=0"):
        proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en04",
                               override], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and override.split("=")[0] in lines[0]


@pytest.fixture(scope="module")
def cfg():
    return resolve("en04").obj


def test_arrival_rule_on_the_histories(cfg) -> None:
    """Arrival is the first recorded time within the band, settling the first time after the
    last one outside it, the overshoot the largest excursion past the goal; u recomputed from
    the histories never exceeds what the servo could ask at the recorded states."""
    c, base, nominal, ctl, res = _controlled_run(cfg)
    goal, tol = math.radians(c.theta_goal_deg), math.radians(c.arrival_tol_deg)
    m = measure(res, goal, tol, float(base.geometry.Ka), ctl)
    theta = res.histories.alpha - res.histories.alpha[0]
    inside = np.abs(theta - goal) <= tol
    first = np.flatnonzero(inside)[0]
    assert m.arrival == res.histories.t[first] and not inside[first - 1]
    last_out = np.flatnonzero(~inside)[-1]
    assert m.settling == res.histories.t[last_out + 1]
    assert m.overshoot == pytest.approx(math.degrees(max(0.0, np.max(goal - theta))), rel=1e-12)
    assert m.carried and m.status == "ok"
    assert m.final_error == pytest.approx(math.degrees(theta[-1] - goal), rel=1e-12)
    # the pattern's rate never exceeds what the lead limit and the speed limit allow by much:
    # the servo follows -Ka alphadot, so |phidot_a| <= Ka (Omega_max + a margin)
    assert m.max_phidot < 6.0 * 2.0 * 1.5


def test_controller_beats_the_quintic_boundary(cfg) -> None:
    """On EN-02's sphere the quintic cycle is carried at T = 7 s and lost at 6.5 s (EN-02F's
    boundary, 6.86 s there); the fastest grid controller of the default config arrives in
    under 4.5 s (4.14 s measured) and stays in its cavity."""
    c = cfg.study.control
    base = cfg.bases[c.base]
    nominal = base.sphere_problem().replace(t_end=c.duration, interval=0.01)
    from creatio.model.laws import Law
    from creatio.model.surface import Motion

    motion = nominal.model.motion

    def quintic(T: float):
        law = Law.quintic(motion.phi_a.phi0, motion.phi_a.delta, T)
        return simulate(nominal.replace(motion=Motion(motion.phi_r, law, motion.gamma)))

    assert quintic(7.0).carried and quintic(7.0).counts.status == "ok"
    lost = quintic(6.5)
    assert not (lost.carried and lost.counts.status == "ok")
    ctl = controller(c, nominal, en04.closed_forms(base).roll_alpha ** 2,
                     ControllerPoint(2.0, 20.0, 4.0, 20.0))
    res = simulate(nominal.replace(control=ctl))
    m = measure(res, math.radians(c.theta_goal_deg), math.radians(c.arrival_tol_deg),
                float(base.geometry.Ka), ctl)
    assert m.carried and m.arrival < 4.5


def test_mass_does_not_change_the_closed_loop(cfg) -> None:
    """Every force scales with m (gravity, N, friction, I = 2 m b^2 / 5), so the robustness
    runs' mass factors give the same controlled path to rounding (docs/model.md s.12.2)."""
    c = cfg.study.control
    base = cfg.bases[c.base]
    nominal = base.sphere_problem().replace(t_end=5.0, interval=0.01)
    ctl = controller(c, nominal, en04.closed_forms(base).roll_alpha ** 2, c.default)
    runs = [simulate(nominal.replace(control=ctl, m=nominal.model.sphere.m * f))
            for f in (0.5, 1.0, 2.0)]
    for r in runs[::2]:
        assert np.max(np.abs(r.histories.alpha - runs[1].histories.alpha)) < 1e-10
        assert np.max(np.abs(r.histories.phi_a - runs[1].histories.phi_a)) < 1e-9
    assert runs[2].extrema.min_N == pytest.approx(4.0 * runs[0].extrema.min_N, rel=1e-9)


def _controlled_run(cfg):
    """EN-02 under one controller (omega_max 2 rad/s, delta_max 20 deg, omega_c 4 rad/s,
    omega_n 20 rad/s) over the control part's duration, recorded at every step: the config's
    parts, the controller and the run."""
    c = cfg.study.control
    base = cfg.bases[c.base]
    nominal = base.sphere_problem().replace(t_end=c.duration, interval=base.solver.dt)
    ctl = controller(c, nominal, en04.closed_forms(base).roll_alpha ** 2,
                     ControllerPoint(2.0, 20.0, 4.0, 20.0))
    return c, base, nominal, ctl, simulate(nominal.replace(control=ctl))


def test_actuation_figures_along_a_controlled_run_against_its_closed_forms(cfg) -> None:
    """The actuation figures along a controlled EN-02 run (flat annulus, phi_r = 0) against
    what its own histories give in closed form (docs/model.md s.12.1): K_m = sigma pi A^2 M
    phidot_a^2 / 4, max |W_t| = A max |phidot_a|, max |W_tt| = A max sqrt(phidot_a^4 + u^2),
    the bandwidth max |phidot_a| / (2 pi) (maxima refined between the steps), the stroke 2 A
    (the phase sweeps 12 pi); the peak
    of P_actuator equals the largest over every recorded step (the quadrature at each), and
    E_actuator the run's own surface work plus K_m(end) - K_m(0) to the scheme's truncation
    (the load energy from the recorded contact against the integrator's bookkeeping)."""
    from creatio.model import actuation as act
    from creatio.studies.en04_control import DemandSettings, demand_figures

    c, base, nominal, ctl, res = _controlled_run(cfg)
    Ka = float(base.geometry.Ka)
    h = res.histories
    surface = base.geometry.surface()
    rule = act.quadrature(surface, 23, 15)
    settings = DemandSettings()
    g = base.sphere.g
    d = demand_figures(res, surface, nominal.model.motion, ctl, rule, settings, g,
                       c.path_interval)
    f = d.figures
    A, R0, dR = surface.A, surface.R0, surface.dR
    u, _, _ = ctl.acceleration(Ka, h.alpha, h.alphadot, h.phi_a, h.phi_a_rate)
    rate = h.phi_a_rate
    K = settings.sigma * math.pi * A * A * (R0 * dR + 0.5 * dR * dR) * rate**2 / 4.0
    # the maxima lie between the 2-ms steps: refined there, they are the maxima over the same
    # run recorded every 0.5 ms to 5e-6 (what those samples still miss, 1/16 of the 2-ms
    # samples' 4e-5, plus the runs' truncation difference, ~1e-9)
    quarter = simulate(nominal.replace(control=ctl, dt=base.solver.dt / 4.0,
                                       interval=base.solver.dt / 4.0))
    q = quarter.histories
    r4 = q.phi_a_rate
    u4, _, _ = ctl.acceleration(Ka, q.alpha, q.alphadot, q.phi_a, r4)
    c_K = np.max(K) / np.max(rate**2)
    assert f["K_m_max"] == pytest.approx(c_K * np.max(r4**2), rel=5e-6)
    assert abs(np.max(K) / (c_K * np.max(r4**2)) - 1.0) > 2e-5  # the 2-ms samples miss it
    assert f["max_W_t"] == pytest.approx(A * np.max(np.abs(r4)), rel=5e-6)
    assert f["max_W_tt"] == pytest.approx(A * np.max(np.sqrt(r4**4 + u4**2)), rel=5e-6)
    assert f["bandwidth"] == pytest.approx(np.max(np.abs(r4)) / (2.0 * math.pi), rel=5e-6)
    assert f["stroke"] == pytest.approx(2.0 * A, rel=1e-6)
    motion = act.sampled_motion(nominal.model.motion, h.t, h.phi_a, rate, u)
    mi = act.membrane_integrals(surface, motion, h.t, rule, settings.sigma, settings.c_d, g)
    P = (act.load_power(surface, motion, h.t, h.R, h.alpha, h.N, h.f) + mi.inertia
         + mi.gravity + mi.damping)
    assert f["P_actuator_peak"] == pytest.approx(np.max(np.abs(P)), rel=1e-12)
    work = h.surface_work[-1] - h.surface_work[0] + K[-1] - K[0]
    assert f["E_actuator"] == pytest.approx(work, rel=5e-5)
    assert f["K_m_closed_form_rel_error"] < 1e-12


def _fake_runs(boundary):
    """run(T, dt) of a search whose carried set is T >= boundary(dt): no integration."""
    from types import SimpleNamespace

    def run(T: float, dt: float):
        return SimpleNamespace(carried=T >= boundary(dt), counts=SimpleNamespace(status="ok"))
    return run


def _grid_end(b: float, lo: float = 4.0, hi: float = 14.0, halvings: int = 10) -> float:
    """The upper end of the bisection bracket of [lo, hi] halved ``halvings`` times that holds
    b (b off the grid): ceil((b - lo) / w) w + lo with w = (hi - lo) / 2^halvings."""
    w = (hi - lo) / 2**halvings
    return lo + math.ceil((b - lo) / w) * w


def test_bisection_budget_holds_when_the_step_barely_moves_the_boundary() -> None:
    """A boundary that moves by 1e-6 s between dt and dt / 4 stays in its final bracket: the
    reported T is the bracket's end above it (10 halvings of [4, 14] to 0.01 s), error 0."""
    from creatio.studies.en04_control import BisectionConfig, budgeted_bisection

    q = BisectionConfig(4.0, 14.0, 0.01)
    bisection, check = budgeted_bisection(q, _fake_runs(lambda dt: 6.9 + 5e-4 * dt), 0.002)
    tried, lo, hi, _, found = bisection
    assert found and hi == _grid_end(6.9 + 1e-6) and hi - lo == 10.0 / 1024
    assert len(tried) == 12
    assert check.ok and check.observed == 0.0 and check.points == 2
    assert check.budget == pytest.approx(1e-4) and check.reference_dt == 0.0005
    assert check.line() == "numerical error <= 0 s (budget 0.0001 s, checked on 2 points)"


def test_bisection_budget_broken_by_a_loose_step_is_detected_and_tightened() -> None:
    """A deliberately loose step (boundary 6.9 + 50 dt: 7.0 s at 2 ms, 6.925 s at 0.5 ms)
    flips an end of the final bracket at dt / 4: the error is the bracket's width, the
    bisection is redone at 1 ms, then 0.5 ms, and still broken it says so."""
    from creatio.studies.en04_control import BisectionConfig, budgeted_bisection

    q = BisectionConfig(4.0, 14.0, 0.01)
    bisection, check = budgeted_bisection(q, _fake_runs(lambda dt: 6.9 + 50.0 * dt), 0.002)
    _, lo, hi, _, _ = bisection
    assert check.tightened == 2 and check.dt == 0.0005 and not check.ok
    assert hi == _grid_end(6.925) and check.observed == hi - lo
    assert "broken at first, the bisection redone 2 time(s)" in check.line()
    # one tightening is enough when the boundary settles: 6.9 + 50 dt above 1 ms, fixed below
    settle = _fake_runs(lambda dt: 6.9 + 50.0 * dt if dt > 1e-3 else 6.9031)
    bisection, check = budgeted_bisection(q, settle, 0.002)
    assert check.ok and check.tightened == 1 and bisection[2] == _grid_end(6.9031)


def _ramp(dt: float, rate: float = -0.5, carried: bool = True, t_end: float = 15.0):
    """A fake run whose contact angle turns at a constant rate, recorded every dt."""
    from types import SimpleNamespace

    t = np.arange(0.0, t_end + 0.5 * dt, dt)
    return SimpleNamespace(histories=SimpleNamespace(t=t, alpha=0.3 + rate * t),
                           carried=carried, counts=SimpleNamespace(status="ok"))


def test_crossing_is_the_arrival_between_steps() -> None:
    """On a constant turn the band |theta - goal| <= tol is reached at (|goal| - tol) / rate,
    whatever the step (linear between steps is exact); measure's arrival is the step after."""
    from creatio.studies.en04_control import crossing

    goal, tol = -2.0 * math.pi, math.radians(2.0)
    exact = (2.0 * math.pi - tol) / 0.5
    for dt in (0.002, 0.01, 0.1):
        assert crossing(_ramp(dt), goal, tol) == pytest.approx(exact, abs=1e-12)
    assert math.isnan(crossing(_ramp(0.01, rate=-0.1), goal, tol))


def test_arrival_budget_detects_a_lost_case_and_a_late_arrival() -> None:
    """The grid's check (16 seeded cases of 40 rerun at dt / 4): the same runs give error 0;
    reruns 1 ms later (rate changed by 1e-4 relative) give that delay, over the 2e-5 s budget;
    a rerun that is lost where the run carried gives inf."""
    from creatio.studies.en04_control import check_arrivals

    goal, tol = -2.0 * math.pi, math.radians(2.0)
    runs = [_ramp(0.002, rate=-0.5 - 0.01 * i) for i in range(40)]
    same = check_arrivals(runs, lambda i, dt: _ramp(dt, rate=-0.5 - 0.01 * i), goal, tol, 0.002)
    assert same.ok and same.points == 16 and same.observed < 1e-12
    assert same.budget == pytest.approx(2e-5) and same.reference_dt == 0.0005
    late = check_arrivals(runs, lambda i, dt: _ramp(dt, rate=(-0.5 - 0.01 * i) / (1 + 1e-4)),
                          goal, tol, 0.002)
    worst = max((2.0 * math.pi - tol) / (0.5 + 0.01 * i) * 1e-4 for i in range(40))
    assert not late.ok and 0.5 * worst < late.observed <= worst * (1 + 1e-9)
    lost = check_arrivals(runs, lambda i, dt: _ramp(dt, carried=False), goal, tol, 0.002)
    assert not lost.ok and lost.observed == math.inf


def test_the_compiled_servo_and_the_skipped_search_change_no_figure(cfg, monkeypatch) -> None:
    """Along a controlled EN-02 run: servo_along's (u, delta) are the controller's scalar
    formula per step (Controller.acceleration) bit for bit, and the figures with only the
    searches they use (DEMAND_POLISHED) equal, exactly, those with every search polished."""
    from creatio.model import actuation as act
    from creatio.studies import en04_control as ec

    c, base, nominal, ctl, res = _controlled_run(cfg)
    Ka = float(base.geometry.Ka)
    h = res.histories
    u, delta = ec.servo_along(res, ctl, Ka)
    want = ctl.acceleration(Ka, h.alpha, h.alphadot, h.phi_a, h.phi_a_rate)
    assert np.array_equal(u, want[0]) and np.array_equal(delta, want[1])
    assert np.max(np.abs(u)) > 0.0 and u.size == h.t.size
    surface = base.geometry.surface()
    rule = act.quadrature(surface, 23, 15)
    args = (res, surface, nominal.model.motion, ctl, rule, ec.DemandSettings(), base.sphere.g,
            c.path_interval, u)
    some = ec.demand_figures(*args)
    monkeypatch.setattr(ec, "DEMAND_POLISHED", True)
    every = ec.demand_figures(*args)
    assert some.figures.keys() == every.figures.keys()
    for key, value in every.figures.items():
        assert np.array_equal(some.figures[key], value, equal_nan=True), key
    assert np.array_equal(some.t, every.t)
