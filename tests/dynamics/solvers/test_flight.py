"""The controlled phase (docs/model.md s.12.2) with flight (s.11) on: the controller's
measurement in flight continues the contact's (the same u on both sides of a separation), a
run that never separates is the flight-off run bit for bit, and a servo stiff enough to
throw the sphere flies, lands and carries it on, its energy balance (impact loss included)
converging as dt halves."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numba import njit

from creatio.dynamics import simulate
from creatio.dynamics.layout import (
    CT_PHI,
    CT_RATE,
    EV_CONTACT,
    EV_IMPACT,
    EV_KIND,
    EV_SEPARATION,
    NF,
)
from creatio.dynamics.solvers.flight import FLIGHT, NC, _f, _to_flight
from creatio.dynamics.sphere import pack_controlled, rhs
from creatio.pipeline.config import resolve


@pytest.fixture(scope="module")
def problem():
    return resolve("en02", ["control=pd", "phases.T=8"]).obj.sphere_problem()


@njit
def _both_sides(t, yc, p, lawc):
    """(contact rates, flight rates) of a contact state and of its flight image."""
    pp, lc = pack_controlled(p, lawc)
    dc = np.empty(yc.size)
    rhs(t, yc, dc, pp, lc, True, True, False)
    yf = np.zeros(NF + yc.size - NC)
    _to_flight(t, yc, yf, pp, lc)
    df = np.empty(yf.size)
    _f(FLIGHT, t, yf, df, pp, lc, True, True, False)
    return dc, df


def test_flight_measurement_continues_the_contact(problem) -> None:
    """At any contact state the centre's foot point is the contact point and the projected
    rate is alphadot, so u in flight equals u in contact (to the foot point's iteration
    tolerance); the phase and its rate carry over unchanged."""
    p, lawc = problem.run_parameters(), problem.law_matrix()
    for shift, rate, Rdot, alphadot in ((0.0, 0.0, 0.0, 0.0), (0.15, 1.2, 0.04, -0.3),
                                        (-0.3, -2.0, -0.1, 0.5)):
        yc = problem.initial_state(True, True)
        yc[2], yc[3] = Rdot, alphadot
        yc[NC + CT_PHI] += shift
        yc[NC + CT_RATE] = rate
        dc, df = _both_sides(0.4, yc, p, lawc)
        assert df[NF + CT_PHI] == dc[NC + CT_PHI] == rate
        assert df[NF + CT_RATE] == pytest.approx(dc[NC + CT_RATE], rel=1e-9, abs=1e-9)
        if shift or rate:
            assert abs(dc[NC + CT_RATE]) > 1.0  # u is at work, not trivially 0


def test_a_run_that_never_separates_is_the_flight_off_run(problem) -> None:
    a = simulate(problem)
    b = simulate(problem.replace(flight=True))
    assert a.counts.status == b.counts.status == "ok" and b.events.table.shape[0] == 0
    for name in ("t", "X", "alpha", "phi_a", "phi_a_rate", "energy_residual", "omega"):
        assert np.array_equal(getattr(a.histories, name), getattr(b.histories, name)), name


def test_a_thrown_sphere_lands_and_is_carried(problem) -> None:
    """omega_n = 40 rad/s snaps the surface down faster than gravity pulls the sphere: without
    flight the run ends contact_lost at 0.046 s; with it the sphere separates at 0.0445 s,
    flies 1.8 mm high, lands at 0.117 s (e = 0: contact resumes at the impact) and is carried
    to its goal. Halving dt from 1 ms the energy residual (the impact's loss accounted)
    falls 54-fold then 25-fold (RK4's 16 once the located events' errors are resolved), the
    impact time and the centre converge."""
    ctl = dataclasses.replace(problem.model.control, omega_n=40.0)
    off = simulate(problem.replace(control=ctl))
    assert off.counts.status == "contact_lost" and off.counts.stop_time < 0.1
    runs = [simulate(problem.replace(control=ctl, flight=True, dt=dt))
            for dt in (0.001, 0.0005, 0.00025)]
    for r in runs:
        assert r.counts.status == "ok" and r.carried
        kinds = r.events.table[:, EV_KIND].astype(int).tolist()
        assert kinds == [EV_SEPARATION, EV_IMPACT, EV_CONTACT]
        assert 1e-3 < r.events.max_flight_height < 3e-3
        alpha = r.histories.alpha
        assert math.degrees(alpha[-1] - alpha[0]) == pytest.approx(-360.0, abs=2.0)
    residual = [r.extrema.max_energy_residual for r in runs]
    assert residual[0] / residual[1] > 16.0 and residual[1] / residual[2] > 16.0
    assert residual[2] < 1e-9
    t_impact = [r.events.table[1, 0] for r in runs]
    assert abs(t_impact[1] - t_impact[2]) < abs(t_impact[0] - t_impact[1]) + 1e-9
    assert abs(t_impact[1] - t_impact[2]) < 2e-5
    dX = [np.max(np.abs(a.X - b.X[: a.t.size]))
          for a, b in zip([r.histories for r in runs[:-1]], [r.histories for r in runs[1:]],
                          strict=True)]
    assert dX[1] < dX[0] / 4.0 and dX[1] < 1e-6
