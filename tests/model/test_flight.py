"""Separation, flight and impact (docs/model.md s.11): closed forms and the hybrid loop.

The drop test on a flat, still surface has closed forms (first impact at sqrt(2 h / g),
apex ratio e^2, no spin, no loss at e = 1 with mu = 0); on the moving membrane the event
times converge with dt at RK4's order, the energy balance closes with the impact losses,
and a run that never separates is the driver's run bit for bit.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from creatio.dynamics import Model, Sphere, SphereProblem, Start, simulate
from creatio.dynamics.layout import EV_HEIGHT, EV_IMPACT, EV_KIND, EV_LOSS, EV_T
from creatio.model.flight import _foot_terms, foot_point
from creatio.model.laws import Law
from creatio.model.surface import Motion, Surface

FLAT = Law.constant(0.0)


def drop(e: float, h: float = 0.1, mu: float = 0.0, **kw) -> SphereProblem:
    """A sphere dropped at rest from gap h onto the flat, still surface (A = 0)."""
    flat = SphereProblem(
        model=Model(Surface(R0=0.68, dR=1.72, A=0.0, Kr=1, Ka=6), Motion(FLAT, FLAT, FLAT),
                    Sphere(m=1.0, b=0.12, g=9.81, mu=mu, eps=0.01)),
        start=Start(R=0.86, alpha=0.5),
    )
    return flat.replace(t_end=kw.pop("t_end", 1.0), dt=kw.pop("dt", 1e-3), interval=0.01,
                        flight=True, restitution=e, height=h, **kw)


def impacts(res) -> np.ndarray:
    return res.events.table[res.events.table[:, EV_KIND] == EV_IMPACT]


@pytest.fixture(scope="module")
def bouncing():
    return simulate(drop(0.5, mu=0.3))


def test_first_impact_time_and_apex_ratio(bouncing) -> None:
    imp = impacts(bouncing)
    assert bouncing.counts.status == "ok"
    assert abs(imp[0, EV_T] - math.sqrt(2 * 0.1 / 9.81)) < 1e-9
    heights = imp[:6, EV_HEIGHT]
    assert np.allclose(heights[1:] / heights[:-1], 0.25, rtol=1e-8, atol=0.0)
    # the sequence ends in contact once the rebound is below the resumption speed
    assert bouncing.events.table[-1, EV_KIND] == 2
    assert not bouncing.events.ends_in_flight


def test_drop_has_no_spin_and_balance_closes(bouncing) -> None:
    assert np.abs(bouncing.histories.omega).max() < 1e-12  # rounding of v_s in the final contact
    assert bouncing.extrema.max_energy_residual < 1e-12
    # the losses: (1 - e^2) of the kinetic energy at each impact, m g h in total at the end
    total = impacts(bouncing)[:, EV_LOSS].sum()
    assert total == pytest.approx(9.81 * 0.1, rel=1e-6)


def test_elastic_frictionless_drop_loses_nothing() -> None:
    res = simulate(drop(1.0, h=0.05, t_end=0.5))
    imp = impacts(res)
    assert len(imp) >= 2
    assert np.abs(res.events.table[:, EV_LOSS]).max() < 1e-12
    assert np.allclose(imp[:, EV_HEIGHT], 0.05, rtol=1e-9)
    assert res.extrema.max_energy_residual < 1e-12


@pytest.mark.parametrize("X, guess", [
    ((0.9 * math.cos(0.6), 0.9 * math.sin(0.6), 0.35), (0.3, 0.55)),
    # above a cavity wall, guessed from the cavity bottom across it
    ((1.1 * math.cos(0.8), 1.1 * math.sin(0.8), 0.25), (0.43, math.pi / 6)),
])
def test_foot_point_is_the_perpendicular_foot(X, guess) -> None:
    """Newton returns the foot: X - c(q*) is along n, |X - c| = gap + b, from any guess."""
    args = (0.68, 2 * math.pi / 1.72, 0.18, 6.0, 0.12, 0.0, 0.0, 0.0, 0.3, 0.5, 0.0, 0.0,
            0.0, 0.0)
    found, R, a, gap, *_ = foot_point(*X, *guess, *args)
    assert found
    terms = _foot_terms(*X, R, a, *args)
    assert math.hypot(terms[8], terms[9], terms[10]) == pytest.approx(gap + 0.12, abs=1e-12)
    assert math.hypot(terms[1] / math.sqrt(terms[6]), terms[2] / math.sqrt(terms[7])) < 1e-12
    _, R2, a2, gap2, *_ = foot_point(*X, R + 0.05, a - 0.05, *args)
    assert R2 == pytest.approx(R, abs=1e-10) and a2 == pytest.approx(a, abs=1e-10)
    assert gap2 == pytest.approx(gap, abs=1e-12)


@pytest.fixture(scope="module")
def fling(en02_problem: SphereProblem) -> SphereProblem:
    """EN-02 with a 4 s cycle: the sphere separates (the boundary is near 6.9 s); dt = 1 ms
    keeps RK4 inside the friction stability limit at the normal reactions after impacts."""
    return en02_problem.replace(phi_a=Law.quintic(0.0, 12.0 * math.pi, 4.0), t_end=1.7,
                                interval=0.1, dt=0.001)


def test_contact_lost_without_flight_and_ok_with(fling: SphereProblem) -> None:
    """Flight takes the run past the contact_lost stop: separation, impact, contact."""
    off = simulate(fling)
    on = simulate(fling.replace(flight=True))
    assert off.counts.status == "contact_lost"
    assert on.counts.status == "ok" and on.counts.stop_time == fling.output.t_end
    assert list(on.events.table[:, EV_KIND]) == [0, 1, 2]
    assert on.events.table[0, EV_T] == pytest.approx(off.counts.stop_time, abs=fling.solver.dt)
    # before the first separation the hybrid loop is the driver, bit for bit
    n = int(np.searchsorted(off.histories.t, on.events.table[0, EV_T]))
    assert n > 10
    assert np.array_equal(on.histories.X[:n], off.histories.X[:n])
    assert np.array_equal(on.histories.omega[:n], off.histories.omega[:n])
    assert np.array_equal(on.histories.energy_residual[:n], off.histories.energy_residual[:n])


def test_flight_energy_balance_closes_with_losses(fling: SphereProblem) -> None:
    """With bounces (e = 0.5) the residual including the impact losses is the contact
    phases' RK4 error: it falls by more than 2^3 when dt halves, to 1e-7 J."""
    res = []
    for dt in (0.001, 0.0005):
        on = simulate(fling.replace(flight=True, restitution=0.5, dt=dt))
        assert on.counts.status == "ok"
        assert np.sum(on.events.table[:, EV_KIND] == EV_IMPACT) > 5
        res.append(on.extrema.max_energy_residual)
    assert res[1] < res[0] / 8 and res[1] < 1e-7


def test_separation_time_converges_at_fourth_order(fling: SphereProblem) -> None:
    times = []
    for dt in (0.004, 0.002, 0.001):
        res = simulate(fling.replace(flight=True, dt=dt, t_end=1.6))
        times.append(res.events.table[0, EV_T])
    d1 = abs(times[0] - times[1])
    d2 = abs(times[1] - times[2])
    assert d2 < d1
    assert math.log2(d1 / d2) > 3.3


#: EN-02 as release 0.1.0 holds it: computed by the code before flight existed.
RELEASED_EN02 = (Path(__file__).resolve().parents[2] / "data" / "releases" / "0.1.0" / "studies"
                 / "en02" / "en02_dt0.002.nc")


def test_flight_disabled_is_the_released_en02(en02_problem: SphereProblem) -> None:
    """flight=False (whatever the other flight settings) never enters the hybrid loop: no
    events, and EN-02's 120 s history equals release 0.1.0's, made before flight existed (0
    on the machine that made it; 1e-12 m is the release diff's tolerance across machines)."""
    from creatio.store.netcdf import read_dataset

    a = simulate(en02_problem)
    assert a.events.table.shape == (0, 11) and not a.events.flight
    released, _ = read_dataset(RELEASED_EN02)
    centre = released["centre"].values
    assert centre.shape == a.histories.X.shape
    assert np.max(np.abs(centre - a.histories.X)) <= 1e-12
    assert np.max(np.abs(released["omega"].values - a.histories.omega)) <= 1e-12
    b = simulate(en02_problem.replace(restitution=0.7, impact_cap=5.0))
    ha, hb = a.histories, b.histories
    assert np.array_equal(ha.X, hb.X) and np.array_equal(ha.energy_residual, hb.energy_residual)


def test_flight_settings_refused() -> None:
    with pytest.raises(ValueError, match="restitution"):
        drop(1.5)
    with pytest.raises(ValueError, match="a method its event loop runs"):
        drop(0.5, method="radau5")
    with pytest.raises(ValueError, match="needs flight"):
        drop(0.5).replace(flight=False)


def test_adaptive_method_locates_the_same_events(fling: SphereProblem) -> None:
    """dopri5 under error control: the drop test's closed form, and EN-02's separation and
    impact times within 1e-7 s of RK4 at dt = 0.5 ms."""
    d = simulate(drop(0.5, method="dopri5", t_end=0.3))
    assert abs(impacts(d)[0, EV_T] - math.sqrt(2 * 0.1 / 9.81)) < 1e-9
    rk = simulate(fling.replace(flight=True, dt=0.0005))
    dp = simulate(fling.replace(flight=True, method="dopri5", rtol=1e-10, atol=1e-12))
    assert dp.counts.status == "ok"
    assert list(dp.events.table[:, EV_KIND]) == list(rk.events.table[:, EV_KIND])
    assert np.abs(dp.events.table[:, EV_T] - rk.events.table[:, EV_T]).max() < 1e-7


def test_impact_cap_turns_bounces_into_contact() -> None:
    """With e = 0.9 the bounces shorten geometrically; a cap of 5 per second ends them."""
    free = simulate(drop(0.9, h=0.02))
    capped = simulate(drop(0.9, h=0.02, impact_cap=5.0))
    assert len(impacts(capped)) < len(impacts(free))
    assert capped.events.table[-1, EV_KIND] == 2 and abs(capped.events.table[-1, 2]) > 1e-4
    assert capped.extrema.max_energy_residual < 1e-12


def test_en02f_builds_its_datasets_and_report(tmp_path) -> None:
    """EN-02F through its study function and report writer, on a short sweep."""
    from creatio.pipeline.config import resolve
    from creatio.reports.en02f import write_en02f
    from creatio.store.netcdf import write_dataset
    from creatio.studies import en02f
    from creatio.studies.schema import vary

    cfg = vary(resolve("en02f").obj, {"study.cycles_s": [8.0, 6.0], "study.restitutions": [0.0],
                                     "phases.T": 6.0, "study.duration": 6.0})
    paths = [write_dataset(en02f.run(cfg, dt), tmp_path / f"en02f_dt{dt!r}.nc")
             for dt in cfg.solver.timesteps()]
    paths.append(write_dataset(en02f.run(cfg, drop=True), tmp_path / "en02f_drop.nc"))
    out = write_en02f(paths, tmp_path / "reports")
    s = json.loads(out["json"].read_text())
    for key in ("status", "flights", "impacts", "flight_time_s", "max_flight_height_m",
                "impact_loss_J", "energy_residual_J", "ends_in_cavity",
                "timestep_difference_m"):
        assert key in s
    assert s["drop_test"]["first_impact_time_error_s"] < 1e-9
    assert s["drop_test"]["apex_ratio_error"] < 1e-8
    assert s["cases"]["8_0"]["ends_in_cavity"] and s["cases"]["8_0"]["flights"] == 0
    assert s["flights"] >= 1
    lo, hi = s["boundary"]["with_flight"]["0"]
    assert 6.0 <= lo < hi <= 8.0
    assert all(p.is_file() for p in out.values())


def test_events_that_do_not_advance_the_clock_end_the_run() -> None:
    """A phase of 1e12 rad leaves the radial law's value a rounding staircase (its ulp is
    1.2e-4 rad), and at T = 3 s contact and flight then flip with no time passing: found by
    a fuzz of the configs, the run looped for ever. It now ends step_failed where it stalls."""
    from creatio.pipeline.config import resolve

    cfg = resolve("en02f", ["phases.r.phi0=1e12"]).obj
    T, _, prob = next(c for c in cfg.run_problems(0.001) if c[0] == 3.0 and c[1] == 0.0)
    res = simulate(prob)
    assert res.counts.status == "step_failed"
    assert 0.0 < res.counts.stop_time < T
    tail = res.events.table[-100:, EV_T]
    assert np.ptp(tail) < 1e-6  # the stop is where the events piled up
